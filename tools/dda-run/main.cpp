// dda-run: Monte-Carlo rockfall runs of a scene (terrain file, block file, release,
// engine and stochastic settings) to a run file; `dda-run merge` joins shards.
// See docs/dda-run.md.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iterator>
#include <string>

#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/threads.hpp"
#include "talus/core/timer.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/run_file.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/vector.hpp"
#include "talus/io/xdmf.hpp"
#include "talus/mc/runner.hpp"
#include "talus/mc/scene.hpp"

#ifdef TALUS_WITH_MPI
#include <mpi.h>
#endif

namespace {

using namespace talus;

// "LABEL: done/total (percent), elapsed, rate, ETA" at the default log level (-q hides
// it): on a terminal one refreshing line; in logs (make | tee, Slurm) a plain line every
// `interval` seconds. The label names the output and shard, so that the lines of
// processes sharing one log or terminal tell apart. Processes that likely share the
// terminal (shards, jobs of a parallel make) print whole lines there too, every 10 s:
// one refreshing line would be overwritten by the others'.
class Progress {
 public:
  Progress(std::string label, std::size_t total, std::size_t already, bool sharded)
      : label_(std::move(label)), total_(total), done_(already), start_done_(already) {
    enabled_ = core::log_level() >= core::LogLevel::warn;
    const bool tty = enabled_ && ::isatty(STDERR_FILENO) == 1;
    refresh_ = tty && !sharded && !under_parallel_make();
    interval_ = cli::progress_interval(tty);
  }
  void advance() {
    ++done_;
    if (!enabled_) return;
    const double t = clock_.seconds();
    const bool last = done_ == total_;
    if (refresh_) {
      if (t - shown_ < 0.25 && !last) return;
      std::fprintf(stderr, "\r%s\033[K", line(t).c_str());
      if (last) std::fputc('\n', stderr);
      std::fflush(stderr);
    } else {
      if (t - shown_ < interval_ || last) return;  // the summary reports the end
      core::log_notice(line(t));
    }
    shown_ = t;
  }
  // Ends a refreshing line before other messages.
  void finish() {
    if (refresh_ && done_ != total_) std::fputc('\n', stderr);
  }

 private:
  // GNU make passes -j (and its jobserver) to the jobs it runs in parallel.
  static bool under_parallel_make() {
    const char* flags = std::getenv("MAKEFLAGS");
    if (flags == nullptr) return false;
    const std::string f = flags;
    return f.find("--jobserver") != std::string::npos || f.rfind("-j", 0) == 0 || f.find(" -j") != std::string::npos;
  }

  std::string line(double t) const {
    const double rate = t > 0.0 ? static_cast<double>(done_ - start_done_) / t : 0.0;
    const double eta = rate > 0.0 ? static_cast<double>(total_ - done_) / rate : 0.0;
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s: %zu/%zu realizations (%.0f%%), elapsed %.0f s, %.2f/s, ETA %.0f s",
                  label_.c_str(), done_, total_, total_ ? 100.0 * static_cast<double>(done_) / static_cast<double>(total_) : 100.0,
                  t, rate, eta);
    return buf;
  }
  std::string label_;
  std::size_t total_, done_, start_done_;
  bool enabled_ = true;
  bool refresh_ = false;
  double interval_ = 30.0;
  double shown_ = 0.0;
  core::Stopwatch clock_;
};

// SIGINT and SIGTERM ask the run to stop: the realizations handed over so far are written
// to the journal and the run ends with a message saying how to resume.
volatile std::sig_atomic_t g_stop_signal = 0;

// A second signal ends the process at once (the journal's chunk files stay complete).
extern "C" void request_stop(int signal) {
  if (g_stop_signal != 0) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
    return;
  }
  g_stop_signal = signal;
}

// Run from .preinit_array: the first code after the dynamic loader's relocation, before the
// libraries' initializers and main (docs/errors.md says what window is left). SA_RESTART
// keeps a signal from failing their system calls with EINTR.
extern "C" void install_stop_handlers(int, char**, char**) {
  struct sigaction action{};
  action.sa_handler = request_stop;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}
[[gnu::section(".preinit_array"), gnu::used]] void (*g_install_stop_handlers)(int, char**, char**) =
    install_stop_handlers;

// `dda-run merge` keeps the default actions (it leaves at most a temporary, which the next
// writer removes); a signal that came before is acted on now.
void restore_default_signals() {
  const int early = g_stop_signal;
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (early != 0) std::raise(early);
}

// The run stopped on a signal: exit code 128 + signal, as a shell reports a killed job.
class Interrupted : public core::Error {
 public:
  Interrupted(int signal, const std::string& message)
      : core::Error(static_cast<core::ExitCode>(128 + signal), message) {}
};
struct StopRequested {};

// Test hook: exit abruptly (as if killed) after this many chunks reached the journal.
std::size_t abort_after_chunks() {
  const char* text = std::getenv("TALUS_DDA_RUN_ABORT_AFTER_CHUNKS");
  return text ? static_cast<std::size_t>(std::strtoull(text, nullptr, 10)) : 0;
}

// The rank count an MPI launcher (Open MPI, MPICH/Hydra, Slurm's srun with PMI) gives
// this process, or 0 outside one.
[[maybe_unused]] int mpi_launcher_ranks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    if (const char* text = std::getenv(name)) {
      const int n = std::atoi(text);
      if (n > 0) return n;
    }
  }
  return 0;
}

struct Options {
  std::string threads;
  std::string shard;
  bool resume = false;
};

// "N realizations: a rest, b out_of_domain, ..." — the ends of a run by reason.
std::string ends_by_reason(const std::vector<mc::Record>& records) {
  constexpr int kReasons = static_cast<int>(dda::EndReason::penetration) + 1;
  std::array<std::size_t, kReasons> count{};
  for (const auto& r : records)
    if (static_cast<std::size_t>(r.end) < count.size()) ++count[static_cast<std::size_t>(r.end)];
  std::string text;
  for (int k = 0; k < kReasons; ++k)
    if (count[static_cast<std::size_t>(k)] > 0)
      text += (text.empty() ? "" : ", ") + std::to_string(count[static_cast<std::size_t>(k)]) + " " +
              std::string(dda::to_string(static_cast<dda::EndReason>(k)));
  return text.empty() ? "none" : text;
}

// One warning line when realizations of the run file `path` did not end at rest: their
// count by end reason (a run of blocks that did not stop is not a finished study).
void warn_unrested(const std::string& path, const std::vector<mc::Record>& records) {
  constexpr int kReasons = static_cast<int>(dda::EndReason::penetration) + 1;
  std::array<std::size_t, kReasons> count{};
  std::size_t unknown = 0;
  for (const auto& r : records) {
    const auto k = static_cast<std::size_t>(r.end);
    if (k < count.size())
      ++count[k];
    else
      ++unknown;
  }
  const std::size_t unrested = records.size() - count[static_cast<std::size_t>(dda::EndReason::rest)];
  if (unrested == 0) return;
  std::string reasons;
  for (int k = 0; k < kReasons; ++k) {
    const auto reason = static_cast<dda::EndReason>(k);
    if (reason == dda::EndReason::rest || count[static_cast<std::size_t>(k)] == 0) continue;
    reasons += (reasons.empty() ? "" : ", ") + std::to_string(count[static_cast<std::size_t>(k)]) + " " +
               std::string(dda::to_string(reason));
  }
  if (unknown > 0) reasons += (reasons.empty() ? "" : ", ") + std::to_string(unknown) + " unknown";
  core::log_warn(path + ": " + std::to_string(unrested) + " of " + std::to_string(records.size()) +
                 " realizations did not end at rest: " + reasons);
}

// How far a block may move in one step at its fastest before the step costs it rebound:
// the measured share the scene's step rule keeps to by default (dda::kMaxStepTravel).
constexpr double kCoarseStepRatio = dda::kMaxStepTravel;

// One warning line when realizations of the run moved faster than the step resolves for
// their block: max speed × the block's time_step over its diameter above kCoarseStepRatio
// (the scene shortens the step of blocks that could, unless engine.max_step_travel is 0 or
// the stiffness is given in N/m).
void warn_coarse_step(const std::string& path, const mc::Scene& scene, const std::vector<mc::Record>& records) {
  std::size_t coarse = 0;
  double worst = 0.0;
  for (const auto& r : records) {
    const auto b = static_cast<std::size_t>(r.block);
    if (b >= scene.blocks().size()) continue;
    const dda::Model& model = scene.blocks()[b].model;
    const double ratio = r.max_speed * model.settings.time_step / (2.0 * model.radius);
    if (ratio > kCoarseStepRatio) ++coarse;
    worst = std::max(worst, ratio);
  }
  if (coarse == 0) return;
  char share[32], text[64];
  std::snprintf(share, sizeof share, "%g %%", 100.0 * kCoarseStepRatio);
  std::snprintf(text, sizeof text, "%.2f", worst);
  core::log_warn(path + ": " + std::to_string(coarse) + " of " + std::to_string(records.size()) +
                 " realizations moved more than " + share +
                 " of their block's diameter in one time step at their fastest "
                 "(up to " + text + "): the step may cost their impacts rebound; compare with a finer "
                 "engine.time_step (engine.preset=research) before relying on jump heights and energies");
}

// Runs the shard of the scene into `output` through its journal; with `report_ends`,
// warns about realizations that did not end at rest.
void run_scene(const mc::SceneSettings& settings, const cli::Invocation& inv, const Options& opt,
               const mc::Shard& shard, const std::string& output, bool report_ends) {
  if (settings.terrain.empty())
    throw core::InputError(inv.origins.of("terrain"), "no terrain file given (key 'terrain')");
  if (settings.block_file.empty())
    throw core::InputError(inv.origins.of("block_file"), "no block file given (key 'block_file')");
  core::Stopwatch clock;
  terrain::Terrain terrain = io::read_terrain_file(settings.terrain);
  const std::string fingerprint = io::terrain_fingerprint(terrain);
  const auto library = io::read_block_file(settings.block_file);
  // A block name is refused where it was given (the scene file or --set blocks).
  for (const auto& name : settings.blocks)
    if (std::none_of(library.begin(), library.end(), [&](const block::Block& b) { return b.name == name; })) {
      std::string names;
      for (const auto& b : library) names += (names.empty() ? "" : ", ") + b.name;
      throw core::InputError(inv.origins.of("blocks"), "block '" + name + "' is not in the block file " +
                                                           settings.block_file + " (it has: " + names + ")");
    }
  // Release zones and barrier lines from vector files, checked against the terrain's CRS.
  const mc::SceneVectors vectors = io::read_scene_vectors(settings, terrain);
  const mc::Scene scene = mc::Scene::build(settings, std::move(terrain), library, inv.origins, vectors);

  io::Provenance provenance = inv.provenance("dda-run", settings.seed);
  provenance.inputs = settings.terrain + "\n" + settings.block_file + "\n" + vectors.inputs;
  io::RunInfo info = io::make_run_info(scene, provenance, shard);
  info.terrain_fingerprint = fingerprint;
  info.terrain_file = std::filesystem::absolute(settings.terrain).lexically_normal().string();
  const std::string journal_path = io::run_journal_path(output);
  // Held until the run file is written: a second dda-run on this output is refused
  // instead of sharing (or being told to delete) the journal.
  const io::OutputLock lock(output);
  const bool journal_exists = std::filesystem::exists(journal_path);
  if (!opt.resume && journal_exists)
    throw core::InputError(journal_path, "a journal of an interrupted run exists: add --resume to complete it, "
                                         "or delete it to start afresh");
  // --resume without a journal is a fresh run, so a Makefile rule can always pass it.
  const bool resume = opt.resume && journal_exists;
  if (opt.resume && !journal_exists) core::log_info("no journal to resume (" + journal_path + "): starting afresh");
  const std::vector<std::uint32_t> all = shard.indices(scene.realizations());
  // A block released into the ground is refused before any work (and before a journal
  // exists, which the corrected scene could not resume).
  if (!resume) mc::check_releases(scene, all, cli::parse_threads(opt.threads));
  io::RunJournal journal = resume ? io::RunJournal::resume(journal_path, info)
                                  : io::RunJournal::create(journal_path, info);

  // A failed write (a full disk) leaves the journal as it was before that write.
  const std::string resumable = "; the journal " + journal_path +
                                " keeps the realizations written so far: run the same command with --resume once "
                                "there is room";
  const auto append = [&](const std::vector<mc::RealizationResult>& results) {
    try {
      journal.append(results);
    } catch (const core::RuntimeError& e) {
      throw core::RuntimeError(e.what() + resumable);
    }
  };
  const std::vector<std::uint32_t> done = journal.finished();
  std::vector<std::uint32_t> pending;
  std::set_difference(all.begin(), all.end(), done.begin(), done.end(), std::back_inserter(pending));
  core::log_info("scene ready in " + core::format_number(clock.seconds()) + " s: " + std::to_string(pending.size()) +
                 " realizations to run (" + std::to_string(done.size()) + " already done), shard " + shard.text());

  const auto chunk = static_cast<std::size_t>(settings.outputs.chunk);
  const std::size_t abort_after = abort_after_chunks();
  std::size_t chunks = 0;
  std::vector<mc::RealizationResult> buffer;
  const std::string label = output + (shard.count > 1 ? " [shard " + shard.text() + "]" : "");
  Progress progress(label, all.size(), done.size(), shard.count > 1);
  clock.restart();
  std::size_t ran = 0;
  {
    try {
      mc::run_realizations(scene, pending, cli::parse_threads(opt.threads), [&](mc::RealizationResult&& r) {
        buffer.push_back(std::move(r));
        ++ran;
        if (buffer.size() >= chunk) {
          append(buffer);
          buffer.clear();
          if (++chunks == abort_after) std::_Exit(137);
        }
        progress.advance();
        if (g_stop_signal != 0) throw StopRequested{};
      }, [] { return g_stop_signal != 0; });
      if (g_stop_signal != 0) throw StopRequested{};
    } catch (const StopRequested&) {
      // Realizations handed over are kept; those still running on workers are abandoned
      // within a few hundred steps and redone by the resume.
      append(buffer);
      progress.finish();
      const int signal = g_stop_signal;
      throw Interrupted(signal, std::string(signal == SIGINT ? "interrupted (SIGINT)" : "stopped (SIGTERM)") + ": " +
                                    std::to_string(done.size() + ran) + " of " + std::to_string(all.size()) +
                                    " realizations are in the journal " + journal_path +
                                    "; run the same command with --resume to complete it");
    }
  }
  append(buffer);
  progress.finish();
  const double seconds = clock.seconds();

  const mc::RunData data = journal.read();
  try {
    io::write_run_file(output, info, data);
  } catch (const core::RuntimeError& e) {
    throw core::RuntimeError(e.what() + resumable);
  }
  journal.remove();
  if (g_stop_signal != 0) {
    // The signal came during the final write, which the handler let finish.
    const int signal = g_stop_signal;
    throw Interrupted(signal, std::string(signal == SIGINT ? "interrupted (SIGINT)" : "stopped (SIGTERM)") +
                                  " during the final write: " + output + " is complete");
  }
  const unsigned thread_count = cli::parse_threads(opt.threads) == 0 ? core::default_thread_count() : cli::parse_threads(opt.threads);
  const std::string threads = std::to_string(thread_count) + (thread_count == 1 ? " thread" : " threads") +
                              (cli::parse_threads(opt.threads) == 0 ? " (" + core::default_thread_source() + ")" : "");
  char timing[96];
  std::snprintf(timing, sizeof timing, " realizations in %.1f s (%.2f/s, ", seconds,
                seconds > 0 ? static_cast<double>(ran) / seconds : 0.0);
  core::log_notice(label + ": " + std::to_string(ran) + timing + threads +
                   (done.empty() ? std::string() : ", " + std::to_string(done.size()) + " resumed from the journal") +
                   "); ends: " + ends_by_reason(data.records));
  if (report_ends) warn_unrested(output, data.records);
  warn_coarse_step(output, scene, data.records);
}

// The shard file of MPI rank r: "run.h5" → "run.rank1.h5" (its own .xmf sidecar name).
std::string rank_part(const std::string& output, int rank) {
  std::filesystem::path p(output);
  const std::string ext = p.extension().string();
  return p.replace_extension().string() + ".rank" + std::to_string(rank) + ext;
}

int merge_main(int argc, char** argv) {
  cli::ToolSpec spec;
  spec.name = "dda-run merge";
  spec.summary = "Join shards of one dda-run run (--shard K/N or MPI ranks) into one run file";
  spec.inputs_doc = "run files, shards of one run";
  spec.min_inputs = 1;
  spec.settings = [](core::SettingsVisitor&) {};
  spec.check = [](const cli::Invocation& inv) {
    if (inv.output.empty()) throw core::UsageError("no output file given (-o FILE)");
    io::AtomicOutput probe(inv.output);  // fails now if the output directory is missing
    io::check_outputs_distinct(inv.named_inputs(),
                               {{"-o", inv.output}, {"XDMF sidecar of -o", io::xdmf_sidecar_path(inv.output)}});
  };
  spec.run = [](const cli::Invocation& inv) {
    std::vector<io::RunFile> files;
    for (const auto& path : inv.inputs) files.push_back(io::read_run_file(path));
    io::RunFile merged = io::merge_run_files(files, inv.inputs);
    if (merged.info.shard != "0/1")
      core::log_warn("the shards hold " + std::to_string(merged.data.records.size()) + " of " +
                     std::to_string(merged.info.realizations) + " realizations");
    io::write_run_file(inv.output, merged.info, merged.data);
    warn_unrested(inv.output, merged.data.records);
  };
  return cli::run_tool(argc, argv, spec);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "merge") {
    restore_default_signals();
    return merge_main(argc - 1, argv + 1);
  }
  // The handlers are in place (install_stop_handlers): a signal while the scene is read
  // stops the run at its first check with the one-line message.

  [[maybe_unused]] int rank = 0;
  int ranks = 1;
#ifdef TALUS_WITH_MPI
  // MPI only under a launcher (mpirun sets these): a plain start stays a one-process run
  // without the cost of a singleton MPI start.
  const bool mpi = cli::started_by_mpi_launcher();
  if (mpi) {
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  }
#endif

  mc::SceneSettings settings;
  Options opt;
  cli::ToolSpec spec;
  spec.name = "dda-run";
  spec.summary = "Run Monte-Carlo rockfall realizations of a scene (3-D DDA) into a run file";
  spec.inputs_doc = "none (the scene names the terrain and block files); 'dda-run merge A.h5 B.h5 -o ALL.h5' joins shards";
  spec.max_inputs = 0;
  spec.set_example = "realizations=100";
#ifdef TALUS_WITH_MPI
  spec.build_notes = "MPI: yes (under mpirun each rank runs one shard; rank 0 merges)";
#else
  spec.build_notes = "MPI: no (build with -DTALUS_WITH_MPI=ON to run under mpirun; or use --shard K/N)";
#endif
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.flags = {{"--resume",
                 "complete an interrupted run from its journal (OUTPUT.journal); without a journal, a fresh run",
                 &opt.resume}};
  spec.options = {{"--threads",
                   "worker threads (default 0 = SLURM_CPUS_PER_TASK, else the CPUs of the affinity mask)",
                   &opt.threads},
                  {"--shard", "run only realizations i = K (mod N), K/N; join the shards with 'dda-run merge'",
                   &opt.shard}};
  spec.check = [&](const cli::Invocation& inv) {
    if (inv.output.empty()) throw core::UsageError("no output file given (-o FILE)");
    cli::parse_threads(opt.threads);
#ifndef TALUS_WITH_MPI
    // Every rank of a launcher would run the whole job into one output.
    if (const int launched = mpi_launcher_ranks(); launched > 1)
      throw core::UsageError("this dda-run is built without MPI but runs under an MPI launcher with " +
                             std::to_string(launched) + " ranks: rebuild with -DTALUS_WITH_MPI=ON, or run " +
                             std::to_string(launched) + " processes with --shard K/" + std::to_string(launched) +
                             " and join them with 'dda-run merge'");
#endif
    if (!opt.shard.empty()) mc::Shard::parse(opt.shard);
    if (!opt.shard.empty() && ranks > 1) throw core::UsageError("--shard cannot be combined with MPI ranks");
    io::AtomicOutput probe(inv.output);  // fails now if the output directory is missing
    std::vector<io::NamedPath> inputs = inv.named_inputs();
    inputs.push_back({"terrain file (key terrain)", settings.terrain});
    inputs.push_back({"block file (key block_file)", settings.block_file});
    if (!settings.release.file.empty()) inputs.push_back({"vector file (key release.file)", settings.release.file});
    for (std::size_t k = 0; k < settings.outputs.barriers.size(); ++k)
      if (!settings.outputs.barriers[k].file.empty())
        inputs.push_back({"vector file (key outputs.barriers[" + std::to_string(k) + "].file)",
                          settings.outputs.barriers[k].file});
    std::vector<io::NamedPath> outputs = {{"-o", inv.output},
                                          {"journal of -o", io::run_journal_path(inv.output)},
                                          {"lock file of -o", io::lock_path(inv.output)},
                                          {"XDMF sidecar of -o", io::xdmf_sidecar_path(inv.output)}};
    for (int r = 0; r < ranks; ++r) outputs.push_back({"shard file of MPI rank " + std::to_string(r), rank_part(inv.output, r)});
    io::check_outputs_distinct(inputs, outputs);
  };
  spec.run = [&](const cli::Invocation& inv) {
    if (ranks == 1) {
      run_scene(settings, inv, opt, opt.shard.empty() ? mc::Shard{} : mc::Shard::parse(opt.shard), inv.output,
                true);
      return;
    }
#ifdef TALUS_WITH_MPI
    // Rank r runs shard r/n into its own file; rank 0 merges them (needs a file system
    // all ranks share, as on clusters).
    const std::string part = rank_part(inv.output, rank);
    int ok = 1;
    std::exception_ptr failure;
    try {
      run_scene(settings, inv, opt, mc::Shard{static_cast<std::uint32_t>(rank), static_cast<std::uint32_t>(ranks)},
                part, false);
    } catch (...) {
      ok = 0;
      failure = std::current_exception();
    }
    // Every rank reaches this point, so a failing rank never leaves the others waiting.
    int all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (rank != 0) return;  // rank 0 reports
    if (failure) std::rethrow_exception(failure);
    if (!all_ok) throw core::RuntimeError("a rank failed; its shard file is missing");
    std::vector<io::RunFile> files;
    std::vector<std::string> names;
    for (int r = 0; r < ranks; ++r) {
      names.push_back(rank_part(inv.output, r));
      files.push_back(io::read_run_file(names.back()));
    }
    const io::RunFile merged = io::merge_run_files(files, names);
    io::write_run_file(inv.output, merged.info, merged.data);
    warn_unrested(inv.output, merged.data.records);
    for (const auto& n : names) {
      std::filesystem::remove(n);
      std::filesystem::remove(io::xdmf_sidecar_path(n));  // written when trajectories are on
    }
#endif
  };
  const int code = cli::run_tool(argc, argv, spec);
#ifdef TALUS_WITH_MPI
  if (mpi) MPI_Finalize();
#endif
  return code;
}
