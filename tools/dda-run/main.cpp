// dda-run: Monte-Carlo rockfall runs of a scene (terrain file, block file, release,
// engine and stochastic settings) to a run file; `dda-run merge` joins shards.
// See docs/dda-run.md.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iterator>
#include <string>

#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/timer.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/run_file.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/xdmf.hpp"
#include "talus/mc/runner.hpp"
#include "talus/mc/scene.hpp"

#ifdef TALUS_WITH_MPI
#include <mpi.h>
#endif

namespace {

using namespace talus;

// "done/total, rate, ETA": a refreshing line on a terminal, plain lines (with -v) in logs.
class Progress {
 public:
  Progress(std::size_t total, std::size_t already) : total_(total), done_(already), start_done_(already) {
    tty_ = ::isatty(STDERR_FILENO) == 1 && core::log_level() >= core::LogLevel::warn;
  }
  void advance() {
    ++done_;
    const double t = clock_.seconds();
    const bool last = done_ == total_;
    if (tty_) {
      if (t - shown_ < 0.25 && !last) return;
      std::fprintf(stderr, "\r%s", line(t).c_str());
      if (last) std::fputc('\n', stderr);
    } else {
      if (t - shown_ < 10.0 && !last) return;
      core::log_info(line(t));
    }
    shown_ = t;
  }

 private:
  std::string line(double t) const {
    const double rate = t > 0.0 ? static_cast<double>(done_ - start_done_) / t : 0.0;
    const double eta = rate > 0.0 ? static_cast<double>(total_ - done_) / rate : 0.0;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%zu/%zu realizations, %.1f/s, ETA %.0f s   ", done_, total_, rate, eta);
    return buf;
  }
  std::size_t total_, done_, start_done_;
  bool tty_ = false;
  double shown_ = 0.0;
  core::Stopwatch clock_;
};

unsigned parse_threads(const std::string& text) {
  if (text.empty()) return 0;
  unsigned value = 0;
  const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (err != std::errc() || end != text.data() + text.size() || value > 4096)
    throw core::UsageError("--threads expects a count (0 = all cores), got '" + text + "'");
  return value;
}

// Test hook: exit abruptly (as if killed) after this many chunks reached the journal.
std::size_t abort_after_chunks() {
  const char* text = std::getenv("TALUS_DDA_RUN_ABORT_AFTER_CHUNKS");
  return text ? static_cast<std::size_t>(std::strtoull(text, nullptr, 10)) : 0;
}

struct Options {
  std::string threads;
  std::string shard;
  bool resume = false;
};

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

// Runs the shard of the scene into `output` through its journal; with `report_ends`,
// warns about realizations that did not end at rest.
void run_scene(const mc::SceneSettings& settings, const cli::Invocation& inv, const Options& opt,
               const mc::Shard& shard, const std::string& output, bool report_ends) {
  const std::string source = inv.config_path.empty() ? "scene" : inv.config_path;
  if (settings.terrain.empty()) throw core::InputError(source, "no terrain file given (key 'terrain')");
  if (settings.block_file.empty()) throw core::InputError(source, "no block file given (key 'block_file')");
  core::Stopwatch clock;
  terrain::Terrain terrain = io::read_terrain_file(settings.terrain);
  const auto library = io::read_block_file(settings.block_file);
  const mc::Scene scene = mc::Scene::build(settings, std::move(terrain), library, source);

  io::Provenance provenance = inv.provenance("dda-run", settings.seed);
  provenance.inputs = settings.terrain + "\n" + settings.block_file + "\n";
  const io::RunInfo info = io::make_run_info(scene, provenance, shard);
  const std::string journal_path = io::run_journal_path(output);
  const bool journal_exists = std::filesystem::exists(journal_path);
  if (opt.resume && !journal_exists)
    throw core::InputError(journal_path, "no journal of an interrupted run to resume");
  if (!opt.resume && journal_exists)
    throw core::InputError(journal_path, "a journal of an interrupted run exists: add --resume to complete it, "
                                         "or delete it to start afresh");
  const std::vector<std::uint32_t> all = shard.indices(scene.realizations());
  // A block released into the ground is refused before any work (and before a journal
  // exists, which the corrected scene could not resume).
  if (!opt.resume) mc::check_releases(scene, all, parse_threads(opt.threads));
  io::RunJournal journal = opt.resume ? io::RunJournal::resume(journal_path, info)
                                      : io::RunJournal::create(journal_path, info);

  const std::vector<std::uint32_t> done = journal.finished();
  std::vector<std::uint32_t> pending;
  std::set_difference(all.begin(), all.end(), done.begin(), done.end(), std::back_inserter(pending));
  core::log_info("scene ready in " + core::format_number(clock.seconds()) + " s: " + std::to_string(pending.size()) +
                 " realizations to run (" + std::to_string(done.size()) + " already done), shard " + shard.text());

  const auto chunk = static_cast<std::size_t>(settings.outputs.chunk);
  const std::size_t abort_after = abort_after_chunks();
  std::size_t chunks = 0;
  std::vector<mc::RealizationResult> buffer;
  Progress progress(all.size(), done.size());
  clock.restart();
  mc::run_realizations(scene, pending, parse_threads(opt.threads), [&](mc::RealizationResult&& r) {
    buffer.push_back(std::move(r));
    if (buffer.size() >= chunk) {
      journal.append(buffer);
      buffer.clear();
      if (++chunks == abort_after) std::_Exit(137);
    }
    progress.advance();
  });
  journal.append(buffer);
  const double seconds = clock.seconds();

  const mc::RunData data = journal.read();
  io::write_run_file(output, info, data);
  std::filesystem::remove(journal_path);
  core::log_info("ran " + std::to_string(pending.size()) + " realizations in " + core::format_number(seconds) +
                 " s (" + core::format_number(seconds > 0 ? static_cast<double>(pending.size()) / seconds : 0.0) +
                 "/s); wrote " + output);
  if (report_ends) warn_unrested(output, data.records);
}

// The shard file of MPI rank r: "run.h5" → "run.rank1.h5" (its own .xmf sidecar name).
[[maybe_unused]] std::string rank_part(const std::string& output, int rank) {
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
  if (argc > 1 && std::string(argv[1]) == "merge") return merge_main(argc - 1, argv + 1);

  [[maybe_unused]] int rank = 0;
  int ranks = 1;
#ifdef TALUS_WITH_MPI
  // MPI only under a launcher (mpirun sets these): a plain start stays a one-process run
  // without the cost of a singleton MPI start.
  const bool mpi = std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
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
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.flags = {{"--resume", "complete an interrupted run from its journal (OUTPUT.journal)", &opt.resume}};
  spec.options = {{"--threads", "worker threads (default 0 = one per core)", &opt.threads},
                  {"--shard", "run only realizations i = K (mod N), K/N; join the shards with 'dda-run merge'",
                   &opt.shard}};
  spec.check = [&](const cli::Invocation& inv) {
    if (inv.output.empty()) throw core::UsageError("no output file given (-o FILE)");
    parse_threads(opt.threads);
    if (!opt.shard.empty()) mc::Shard::parse(opt.shard);
    if (!opt.shard.empty() && ranks > 1) throw core::UsageError("--shard cannot be combined with MPI ranks");
    io::AtomicOutput probe(inv.output);  // fails now if the output directory is missing
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
