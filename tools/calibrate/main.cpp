// calibrate: fits ground-material parameters to observed stops by approximate Bayesian
// computation, and predicts other cases with the posterior. See docs/calibration.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <sstream>

#include <unistd.h>

#include "calibration.hpp"
#include "settings.hpp"
#include "talus/cli/plot_helper.hpp"
#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/random.hpp"
#include "talus/core/threads.hpp"
#include "talus/core/timer.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/file_header.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/settings_yaml.hpp"
#include "talus/stats/sample.hpp"
#include "talus/stats/summary.hpp"

#ifdef TALUS_WITH_MPI
#include <mpi.h>
#endif

namespace {

using namespace talus;
namespace fs = std::filesystem;
using calibrate::Problem;
using calibrate::Settings;
using stats::AbcGeneration;

constexpr io::SchemaVersion kCalibrationSchema{1, 0};
constexpr const char* kPosterior = "posterior.h5";
const std::vector<double> kQuantiles = {0.05, 0.10, 0.25, 0.50, 0.75, 0.90, 0.95};

std::string num(double x) { return core::format_number(x); }
// x to `n` significant digits, for progress lines.
std::string digits(double x, int n) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*g", n, x);
  return text;
}

// Test hook: exit abruptly after writing the checkpoint of this generation (0 = never), as
// a killed job would (tests/tools/calibration_recovery.py).
std::int64_t abort_after_generation() {
  const char* text = std::getenv("TALUS_CALIBRATE_ABORT_AFTER_GENERATION");
  return text ? std::strtoll(text, nullptr, 10) : 0;
}

std::string generation_name(std::int64_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "%03lld", static_cast<long long>(index));
  return name;
}

// ------------------------------------------------------------------ the posterior file

struct Checkpoint {
  std::vector<AbcGeneration> generations;
  std::int64_t realizations = 0;
  std::int64_t failures = 0;
  bool finished = false;
};

// The fit at the posterior medians: each case's simulated stops, or its summaries' comparisons.
struct Fit {
  std::vector<std::vector<std::vector<double>>> values;
  std::vector<std::vector<stats::SummaryComparison>> summaries;
};

std::vector<std::string> summary_labels(const calibrate::Case& c) {
  std::vector<std::string> labels;
  for (const auto& s : c.summaries) labels.push_back(s.label);
  return labels;
}

// Per case: its observed stops and, at the posterior medians, its simulated ones.
void write_stop_cases(const io::h5::Group& cases, const Problem& problem,
                      const std::vector<std::vector<std::vector<double>>>& fit) {
  cases.write_strings("variables", problem.variables());
  cases.write("scale", problem.scale().data(), {problem.scale().size()}, "m");
  for (std::size_t c = 0; c < problem.cases().size(); ++c) {
    const io::h5::Group cg = cases.create_group(std::to_string(c));
    const auto& obs = problem.cases()[c].observed;
    std::vector<double> flat;
    for (const auto& o : obs) flat.insert(flat.end(), o.begin(), o.end());
    cg.write("observed", flat.data(), {obs.size(), problem.variables().size()}, "m");
    if (c < fit.size() && !fit[c].empty()) {
      flat.clear();
      for (const auto& o : fit[c]) flat.insert(flat.end(), o.begin(), o.end());
      cg.write("fitted", flat.data(), {fit[c].size(), problem.variables().size()}, "m");
    }
  }
}

// Per case: each summary's label, published value and sd, and at the posterior medians
// the simulated counterpart, the combined sd and z.
void write_summary_cases(const io::h5::Group& cases, const Problem& problem,
                         const std::vector<std::vector<stats::SummaryComparison>>& fit) {
  for (std::size_t c = 0; c < problem.cases().size(); ++c) {
    const auto& cs = problem.cases()[c];
    const io::h5::Group cg = cases.create_group(std::to_string(c));
    cg.write_strings("statistic", summary_labels(cs));
    std::vector<double> value, sd;
    for (const auto& x : cs.summaries) {
      value.push_back(x.target.value);
      sd.push_back(x.target.sd);
    }
    cg.write("observed", value.data(), {value.size()}, "per statistic");
    cg.write("observed_sd", sd.data(), {sd.size()}, "per statistic");
    if (c < fit.size() && !fit[c].empty()) {
      std::vector<double> sim, sim_sd, z;
      for (const auto& x : fit[c]) {
        sim.push_back(x.simulated);
        sim_sd.push_back(x.sd);
        z.push_back(x.z);
      }
      cg.write("fitted", sim.data(), {sim.size()}, "per statistic");
      cg.write("fitted_sd", sim_sd.data(), {sim_sd.size()}, "per statistic");
      cg.write("fitted_z", z.data(), {z.size()}, "-");
    }
  }
}

void write_posterior(const std::string& path, const Problem& problem, const Checkpoint& cp,
                     const io::Provenance& provenance, const Fit& fit) {
  io::AtomicOutput out(path);
  {
    io::h5::File f = io::h5::File::create(out.temp_path(), path);
    const io::h5::Group root = f.root();
    io::write_header(root, "calibration", kCalibrationSchema, provenance);
    const Settings& s = problem.settings();
    root.set_attr("finished", static_cast<std::int64_t>(cp.finished ? 1 : 0));
    root.set_attr("realizations_run", cp.realizations);
    root.set_attr("numerical_failures", cp.failures);
    const io::h5::Group p = root.create_group("parameters");
    std::vector<std::string> labels, priors;
    std::vector<double> lo, hi;
    for (const auto& fp : s.parameters) {
      labels.push_back(fp.label());
      priors.push_back(fp.prior);
      lo.push_back(fp.min);
      hi.push_back(fp.max);
    }
    p.write_strings("name", labels);
    p.write_strings("prior", priors);
    p.write("min", lo.data(), {lo.size()});
    p.write("max", hi.data(), {hi.size()});
    const std::size_t dim = labels.size();
    const io::h5::Group gens = root.create_group("generations");
    for (const AbcGeneration& g : cp.generations) {
      const io::h5::Group gg = gens.create_group(generation_name(g.index));
      std::vector<double> theta;
      for (const auto& t : g.theta) theta.insert(theta.end(), t.begin(), t.end());
      gg.write("theta", theta.data(), {g.theta.size(), dim});
      gg.write("weight", g.weight.data(), {g.weight.size()}, "-");
      gg.write("distance", g.distance.data(), {g.distance.size()}, "-");
      gg.set_attr("index", g.index);
      gg.set_attr("tolerance", g.tolerance);
      gg.set_attr("proposed", g.proposed);
    }
    const io::h5::Group cases = root.create_group("cases");
    std::vector<std::string> names;
    for (const auto& c : problem.cases()) names.push_back(c.name);
    cases.write_strings("name", names);
    cases.set_attr("kind", problem.summaries() ? "summaries" : "stops");
    if (problem.summaries()) write_summary_cases(cases, problem, fit.summaries);
    else write_stop_cases(cases, problem, fit.values);
    f.close();
  }
  out.commit();
}

Checkpoint read_checkpoint(const std::string& path, const Problem& problem, const std::string& settings_yaml) {
  const io::h5::File f = io::h5::File::open(path);
  const io::h5::Group root = f.root();
  io::check_header(root, "calibration", kCalibrationSchema);
  if (io::read_provenance(root).settings_yaml != settings_yaml)
    throw core::InputError(path, "was written with other settings: run with the settings it was started with, or "
                                 "delete it (or choose another -o) to start afresh");
  Checkpoint cp;
  cp.finished = root.attr_int("finished") != 0;
  cp.realizations = root.attr_int("realizations_run");
  cp.failures = root.attr_int("numerical_failures");
  const std::size_t dim = problem.priors().size();
  const io::h5::Group gens = root.open_group("generations");
  for (const std::string& name : gens.children()) {
    const io::h5::Group gg = gens.open_group(name);
    AbcGeneration g;
    g.index = gg.attr_int("index");
    g.tolerance = gg.attr_double("tolerance");
    g.proposed = gg.attr_int("proposed");
    const auto theta = gg.read_doubles("theta");
    g.weight = gg.read_doubles("weight");
    g.distance = gg.read_doubles("distance");
    for (std::size_t i = 0; i < g.weight.size(); ++i)
      g.theta.emplace_back(theta.begin() + static_cast<std::ptrdiff_t>(i * dim),
                           theta.begin() + static_cast<std::ptrdiff_t>((i + 1) * dim));
    cp.generations.push_back(std::move(g));
  }
  std::sort(cp.generations.begin(), cp.generations.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
  return cp;
}

// ------------------------------------------------------------------ text outputs

std::string csv_posterior(const Problem& problem, const AbcGeneration& g) {
  std::ostringstream out;
  out << "particle,weight,distance";
  for (const auto& p : problem.settings().parameters) out << "," << p.label();
  out << "\n";
  for (std::size_t i = 0; i < g.theta.size(); ++i) {
    out << i << "," << num(g.weight[i]) << "," << num(g.distance[i]);
    for (double t : g.theta[i]) out << "," << num(t);
    out << "\n";
  }
  return out.str();
}

std::string csv_generations(const std::vector<AbcGeneration>& gens) {
  std::ostringstream out;
  out << "generation,tolerance,proposed,accepted,acceptance\n";
  for (const auto& g : gens)
    out << g.index << "," << num(g.tolerance) << "," << g.proposed << "," << g.theta.size() << "," << num(g.acceptance())
        << "\n";
  return out.str();
}

const char* unit_of(const std::string& parameter) {
  if (parameter == "restitution_scale") return "m/s";
  if (parameter == "roughness_sigma") return "m";
  if (parameter == "friction_angle_mean_deg" || parameter == "lateral_tilt_sd_deg") return "deg";
  return "-";
}

std::string csv_summary(const Problem& problem, const AbcGeneration& g) {
  const auto summary = calibrate::summarize(g);
  std::ostringstream out;
  out << "parameter,unit,prior,min,max,mean,sd,P5,P50,P95\n";
  for (std::size_t k = 0; k < summary.size(); ++k) {
    const auto& p = problem.settings().parameters[k];
    const auto& s = summary[k];
    out << p.label() << "," << unit_of(p.parameter) << "," << p.prior << "," << num(p.min) << "," << num(p.max) << ","
        << num(s.mean) << "," << num(s.sd) << "," << num(s.p05) << "," << num(s.p50) << "," << num(s.p95) << "\n";
  }
  return out.str();
}

std::string table(const Problem& problem, const AbcGeneration& g) {
  const auto summary = calibrate::summarize(g);
  std::ostringstream out;
  out << "parameter                          P5          P50         P95         mean        sd\n";
  for (std::size_t k = 0; k < summary.size(); ++k) {
    char line[256];
    const auto& s = summary[k];
    std::snprintf(line, sizeof line, "%-32s %-11.4g %-11.4g %-11.4g %-11.4g %.4g\n",
                  problem.settings().parameters[k].label().c_str(), s.p05, s.p50, s.p95, s.mean, s.sd);
    out << line;
  }
  return out.str();
}

std::vector<double> medians(const AbcGeneration& g) {
  std::vector<double> m;
  for (const auto& s : calibrate::summarize(g)) m.push_back(s.p50);
  return m;
}

// ------------------------------------------------------------------ prediction

// Draws k particles of g by systematic resampling (one uniform of the calibration stream),
// so heavy particles are drawn in proportion to their weight.
std::vector<std::size_t> resample(const AbcGeneration& g, std::size_t k, std::uint64_t seed) {
  const core::RandomStream stream(seed, core::Stream::calibration, 0xffffffffu);
  const double u0 = stream.uniform(0);
  std::vector<std::size_t> picks;
  double cumulative = 0.0;
  std::size_t i = 0;
  for (std::size_t j = 0; j < k; ++j) {
    const double target = (static_cast<double>(j) + u0) / static_cast<double>(k);
    while (i + 1 < g.weight.size() && cumulative + g.weight[i] < target) cumulative += g.weight[i++];
    picks.push_back(i);
  }
  return picks;
}

// The last generation of a calibration's posterior file, checked against the parameters
// the settings name (the same ones, in the same order).
AbcGeneration read_posterior(const Problem& problem, const std::string& posterior_path) {
  const io::h5::File f = io::h5::File::open(posterior_path);
  const io::h5::Group root = f.root();
  io::check_header(root, "calibration", kCalibrationSchema);
  const auto labels = root.open_group("parameters").read_strings("name");
  std::vector<std::string> wanted;
  for (const auto& p : problem.settings().parameters) wanted.push_back(p.label());
  if (labels != wanted)
    throw core::InputError(posterior_path, "fits other parameters than the settings name (its parameters must be "
                                           "listed, in the same order)");
  const io::h5::Group gens = root.open_group("generations");
  const auto names = gens.children();
  if (names.empty()) throw core::InputError(posterior_path, "holds no generation");
  const io::h5::Group last = gens.open_group(*std::max_element(names.begin(), names.end()));
  if (last.attr_int("index") == 0)
    throw core::InputError(posterior_path, "holds generation 0 only (the prior's sample): its calibration completed no "
                                           "generation after the prior, so there is no posterior to predict with");
  // A calibration stopped before its end (killed, out of time) left its last complete
  // generation as a checkpoint: a stage of the fit, not its posterior.
  if (root.attr_int("finished") == 0)
    throw core::InputError(posterior_path, "is the checkpoint of a calibration that did not finish (its last complete "
                                           "generation is " + std::to_string(last.attr_int("index")) +
                                           "): complete it with calibrate --resume and the same settings and OUTDIR "
                                           "before predicting with it");
  AbcGeneration g;
  g.weight = last.read_doubles("weight");
  const auto theta = last.read_doubles("theta");
  const std::size_t dim = labels.size();
  if (theta.size() != g.weight.size() * dim)
    throw core::InputError(posterior_path, "generation " + *std::max_element(names.begin(), names.end()) +
                                           " has particles of the wrong size");
  for (std::size_t i = 0; i < g.weight.size(); ++i)
    g.theta.emplace_back(theta.begin() + static_cast<std::ptrdiff_t>(i * dim),
                         theta.begin() + static_cast<std::ptrdiff_t>((i + 1) * dim));
  return g;
}

// Cases of summaries: each posterior draw is simulated with `realizations` realizations and
// each statistic computed as its publisher did (the share, the quantile, the extreme of the
// first n blocks), so the spread over the draws holds both the parameters' uncertainty and
// the statistic's own sampling scatter. The band is its P5, P50 and P95.
void predict_summaries(const Problem& problem, const std::vector<std::size_t>& picks, const AbcGeneration& g,
                       const std::string& dir, const io::Provenance& provenance) {
  std::ostringstream csv;
  csv << "case,statistic,observed,observed_sd,band_low,band_median,band_high,inside,share_of_draws_below\n";
  io::AtomicOutput h5out((fs::path(dir) / "predictive.h5").string());
  {
    io::h5::File out = io::h5::File::create(h5out.temp_path(), h5out.final_path());
    io::write_header(out.root(), "calibration-prediction", kCalibrationSchema, provenance);
    out.root().set_attr("kind", "summaries");
    for (std::size_t c = 0; c < problem.cases().size(); ++c) {
      const auto& cs = problem.cases()[c];
      const std::size_t k = cs.summaries.size();
      std::vector<std::vector<double>> per(k);
      for (std::size_t d = 0; d < picks.size(); ++d) {
        const calibrate::Simulated sim = problem.simulate(g.theta[picks[d]], c, d + 1);
        if (sim.blocks[0].empty())
          throw core::RuntimeError("case '" + cs.name + "': every realization of posterior draw " + std::to_string(d) +
                                   " ended in a numerical failure: no statistic to compute");
        for (std::size_t j = 0; j < k; ++j)
          per[j].push_back(stats::summary_statistic(sim.blocks[static_cast<std::size_t>(cs.summaries[j].variable)],
                                                    cs.summaries[j].target));
      }
      const io::h5::Group cg = out.root().create_group(std::to_string(c));
      cg.set_attr("name", cs.name);
      cg.write_strings("statistic", summary_labels(cs));
      std::vector<double> observed, sd, draws(picks.size() * k);
      for (std::size_t j = 0; j < k; ++j) {
        const auto& t = cs.summaries[j].target;
        observed.push_back(t.value);
        sd.push_back(t.sd);
        for (std::size_t d = 0; d < picks.size(); ++d) draws[d * k + j] = per[j][d];
        const stats::Sample band(per[j]);
        const double lo = band.quantile(0.05), hi = band.quantile(0.95);
        const auto below = std::count_if(per[j].begin(), per[j].end(), [&](double x) { return x < t.value; });
        csv << cs.name << "," << cs.summaries[j].label << "," << num(t.value) << "," << num(t.sd) << "," << num(lo)
            << "," << num(band.quantile(0.5)) << "," << num(hi) << "," << (t.value >= lo && t.value <= hi ? 1 : 0) << ","
            << num(static_cast<double>(below) / static_cast<double>(per[j].size())) << "\n";
      }
      cg.write("observed", observed.data(), {k}, "per statistic");
      cg.write("observed_sd", sd.data(), {k}, "per statistic");
      cg.write("draws", draws.data(), {picks.size(), k}, "per statistic");
    }
    out.close();
  }
  h5out.commit();
  io::write_text_file((fs::path(dir) / "predictive.csv").string(), csv.str());
  std::fputs(csv.str().c_str(), stdout);
}

void predict(const Problem& problem, const AbcGeneration& g, const std::string& dir, const io::Provenance& provenance) {
  const Settings& s = problem.settings();
  const auto picks = resample(g, static_cast<std::size_t>(s.predictive_draws), s.seed);
  if (problem.summaries()) {
    predict_summaries(problem, picks, g, dir, provenance);
    return;
  }
  std::ostringstream csv;
  csv << "case,variable,p,predicted,band_low,band_median,band_high,observed,inside\n";
  std::ostringstream ks;
  ks << "case,variable,n_observed,n_predicted,ks_distance,ks_p_value\n";
  io::AtomicOutput h5out((fs::path(dir) / "predictive.h5").string());
  {
    io::h5::File out = io::h5::File::create(h5out.temp_path(), h5out.final_path());
    io::write_header(out.root(), "calibration-prediction", kCalibrationSchema, provenance);
    out.root().write_strings("variables", problem.variables());
    for (std::size_t c = 0; c < problem.cases().size(); ++c) {
      const auto& cs = problem.cases()[c];
      std::vector<std::vector<std::vector<double>>> per_draw;
      std::vector<double> pooled_flat;
      for (std::size_t d = 0; d < picks.size(); ++d) {
        const calibrate::Simulated sim = problem.simulate(g.theta[picks[d]], c, d + 1);
        per_draw.push_back(sim.values);
        for (const auto& v : sim.values) pooled_flat.insert(pooled_flat.end(), v.begin(), v.end());
      }
      const std::size_t nv = problem.variables().size();
      const io::h5::Group cg = out.root().create_group(std::to_string(c));
      cg.set_attr("name", cs.name);
      cg.write("predicted", pooled_flat.data(), {pooled_flat.size() / nv, nv}, "m");
      std::vector<double> obs_flat;
      for (const auto& o : cs.observed) obs_flat.insert(obs_flat.end(), o.begin(), o.end());
      cg.write("observed", obs_flat.data(), {cs.observed.size(), nv}, "m");
      for (std::size_t v = 0; v < nv; ++v) {
        std::vector<double> pooled, observed;
        for (const auto& draw : per_draw)
          for (const auto& x : draw) pooled.push_back(x[v]);
        for (const auto& o : cs.observed) observed.push_back(o[v]);
        if (pooled.size() < 2)
          throw core::RuntimeError("case '" + cs.name + "': fewer than 2 of the predicted realizations came to rest "
                                   "(the scene's blocks leave the terrain or reach the step limit)");
        const stats::Sample ps(pooled), os(observed);
        for (double p : kQuantiles) {
          std::vector<double> per;
          for (const auto& draw : per_draw) {
            std::vector<double> x;
            for (const auto& r : draw) x.push_back(r[v]);
            if (!x.empty()) per.push_back(stats::Sample(x).quantile(p));
          }
          const stats::Sample band(per);
          const double q_obs = os.quantile(p);
          const double lo = band.quantile(0.05), hi = band.quantile(0.95);
          csv << cs.name << "," << problem.variables()[v] << "," << num(p) << "," << num(ps.quantile(p)) << ","
              << num(lo) << "," << num(band.quantile(0.5)) << "," << num(hi) << "," << num(q_obs) << ","
              << (q_obs >= lo && q_obs <= hi ? 1 : 0) << "\n";
        }
        const double d = stats::ks_distance(ps, os);
        ks << cs.name << "," << problem.variables()[v] << "," << os.size() << "," << ps.size() << "," << num(d) << ","
           << num(stats::ks_p_value(d, os.size(), ps.size())) << "\n";
      }
    }
    out.close();
  }
  h5out.commit();
  io::write_text_file((fs::path(dir) / "predictive.csv").string(), csv.str());
  io::write_text_file((fs::path(dir) / "predictive-ks.csv").string(), ks.str());
  std::fputs(csv.str().c_str(), stdout);
}

// The MPI ranks of this run (one process without a launcher).
struct Ranks {
  int rank = 0;
  int count = 1;
  bool writer() const { return rank == 0; }
};

// Sums an int64 over the ranks.
std::int64_t sum_over(const Ranks& ranks, std::int64_t value) {
#ifdef TALUS_WITH_MPI
  if (ranks.count > 1) {
    long long total = 0;
    const long long mine = value;
    MPI_Allreduce(&mine, &total, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    return static_cast<std::int64_t>(total);
  }
#endif
  (void)ranks;
  return value;
}

// A generation's progress at the default log level (-q hides it): a line every 30 s, 10 s
// on a terminal (TALUS_PROGRESS_INTERVAL sets the seconds), with the simulations of the
// batch, the particles accepted and when the batch ends. A generation proposes in
// batches sized from the last acceptance; another batch follows only when one falls short.
class GenerationProgress {
 public:
  GenerationProgress() : interval_(cli::progress_interval(::isatty(STDERR_FILENO) == 1)) {}
  // A generation begins: its index, the particles it needs and the tolerance they meet.
  void begin(std::int64_t index, std::int64_t particles, double tolerance) {
    index_ = index;
    particles_ = particles;
    tolerance_ = tolerance;
    accepted_ = 0;
    clock_ = core::Stopwatch{};
    shown_ = 0.0;
  }
  void batch(std::size_t size, int ranks) {
    batch_ = size;
    batch_done_ = 0;
    ranks_ = ranks;
    batch_clock_ = core::Stopwatch{};
  }
  // One simulation of this rank done, at distance d.
  void simulated(double d, bool writer) {
    ++batch_done_;
    if (d <= tolerance_) ++accepted_;
    const double t = clock_.seconds();
    if (!writer || t - shown_ < interval_) return;
    shown_ = t;
    // This rank runs one of every `ranks` simulations of the batch.
    const auto done = std::min(batch_, batch_done_ * static_cast<std::size_t>(ranks_));
    const double eta = batch_clock_.seconds() / static_cast<double>(done) * static_cast<double>(batch_ - done);
    std::string line = "generation " + std::to_string(index_) + (index_ == 0 ? " (prior)" : "") + ": " +
                       std::to_string(done) + " of " + std::to_string(batch_) + " simulations";
    if (index_ > 0)
      line += ", " + std::to_string(std::min(accepted_ * ranks_, particles_)) + " of " + std::to_string(particles_) + " particles accepted";
    line += ", elapsed " + std::to_string(std::lround(t)) + " s, ETA " + std::to_string(std::lround(eta)) + " s" +
            (index_ > 0 ? " (this batch)" : "");
    core::log_notice(line);
  }

 private:
  double interval_ = 30.0, tolerance_ = 0.0, shown_ = 0.0;
  std::int64_t index_ = 0, particles_ = 0, accepted_ = 0;
  std::size_t batch_ = 0, batch_done_ = 0;
  int ranks_ = 1;
  core::Stopwatch clock_, batch_clock_;
};

// The distances of a batch: rank r simulates candidates r, r + n, … and every rank gets
// all of them. A distance is a pure function of its parameters, so the split changes no
// value. A rank that fails makes every rank fail (none waits for it).
std::vector<double> distances(const Problem& problem, const Ranks& ranks, const std::vector<std::vector<double>>& batch,
                              GenerationProgress& progress) {
  std::vector<double> d(batch.size(), -1.0);
  int ok = 1;
  std::exception_ptr failure;
  progress.batch(batch.size(), ranks.count);
  try {
    for (std::size_t k = 0; k < batch.size(); ++k)
      if (static_cast<int>(k % static_cast<std::size_t>(ranks.count)) == ranks.rank) {
        d[k] = problem.distance(batch[k]);
        progress.simulated(d[k], ranks.writer());
      }
  } catch (...) {
    ok = 0;
    failure = std::current_exception();
  }
#ifdef TALUS_WITH_MPI
  if (ranks.count > 1) {
    int all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (failure) std::rethrow_exception(failure);
    if (!all_ok) throw core::RuntimeError("another MPI rank failed (its error is on its standard error)");
    MPI_Allreduce(MPI_IN_PLACE, d.data(), static_cast<int>(d.size()), MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  }
#endif
  (void)ok;
  if (failure) std::rethrow_exception(failure);
  return d;
}

}  // namespace

int main(int argc, char** argv) {
  Ranks ranks;
#ifdef TALUS_WITH_MPI
  // MPI only under a launcher (mpirun sets these), as dda-run.
  const bool mpi = cli::started_by_mpi_launcher();
  if (mpi) {
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &ranks.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks.count);
  }
#endif
  Settings settings;
  std::string threads_text, predict_path;
  bool resume = false;

  cli::ToolSpec spec;
  spec.name = "calibrate";
  spec.summary = "Fit ground-material parameters to observed stops (ABC-SMC) and predict other cases with the posterior";
  spec.inputs_doc = "none: the settings name the scene and the observed stops";
  spec.max_inputs = 0;
  spec.set_example = "particles=200";
#ifdef TALUS_WITH_MPI
  spec.build_notes = "MPI: yes (under mpirun the ranks share each generation's simulations; rank 0 writes)";
#else
  spec.build_notes = "MPI: no (build with -DTALUS_WITH_MPI=ON to share the simulations over MPI ranks)";
#endif
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.flags = {{"--resume", "continue the calibration in OUTDIR from its last complete generation", &resume}};
  spec.options = {{"--threads", "worker threads of the simulations (default 0 = every available core)", &threads_text, "N"},
                  {"--predict", "predict the settings' cases with the posterior of an earlier calibration", &predict_path,
                   "POSTERIOR.h5"}};
  spec.check = [&](const cli::Invocation& inv) {
    if (inv.output.empty()) throw core::UsageError("no output directory given (-o DIR)");
    io::check_outputs_distinct(inv.named_inputs(), {{"-o", inv.output}});
    std::error_code ec;
    if (fs::exists(inv.output, ec) && !fs::is_directory(inv.output, ec))
      throw core::UsageError("-o " + inv.output + ": is a file; calibrate writes into a directory (choose another -o)");
    cli::parse_threads(threads_text);
    if (resume && !predict_path.empty()) throw core::UsageError("--resume and --predict exclude each other");
    if (!predict_path.empty() && !fs::exists(predict_path))
      throw core::InputError(predict_path, "no such file (--predict takes the posterior.h5 of a calibration)");
  };
  spec.run = [&](const cli::Invocation& inv) {
    if (settings.plots && ranks.writer()) cli::check_plotting();
    core::Stopwatch clock;
    const Problem problem(settings, inv.origins, cli::parse_threads(threads_text));
    // A bad posterior is refused before anything is written.
    const AbcGeneration posterior = predict_path.empty() ? AbcGeneration{} : read_posterior(problem, predict_path);
    // Rank 0 writes; the others simulate their share of each batch.
    std::optional<io::OutputLock> lock;
    if (ranks.writer()) {
      fs::create_directories(inv.output);
      lock.emplace((fs::path(inv.output) / kPosterior).string());
    }
    io::Provenance provenance = inv.provenance("calibrate", settings.seed);
    if (!predict_path.empty()) {
      if (!ranks.writer()) return;  // a prediction runs on rank 0
      predict(problem, posterior, inv.output, provenance);
      if (settings.plots) cli::run_plot_helper("--calibration-prediction " + cli::shell_quote((fs::path(inv.output) / "predictive.h5").string()) + " " + cli::shell_quote(inv.output));
      core::log_info("predicted " + std::to_string(problem.cases().size()) + " case(s) in " + num(clock.seconds()) + " s");
      return;
    }

    const std::string posterior_path = (fs::path(inv.output) / kPosterior).string();
    stats::AbcSettings abc_settings;
    abc_settings.particles = settings.particles;
    abc_settings.generations = settings.generations;
    abc_settings.quantile = settings.quantile;
    abc_settings.min_acceptance = settings.min_acceptance;
    abc_settings.max_simulations = settings.max_simulations;
    abc_settings.seed = settings.seed;
    const stats::AbcSmc abc(problem.priors(), abc_settings);
    GenerationProgress progress;
    const stats::AbcSimulator simulate = [&](const std::vector<std::vector<double>>& batch) {
      return distances(problem, ranks, batch, progress);
    };

    Checkpoint cp;
    if (resume && fs::exists(posterior_path)) {
      cp = read_checkpoint(posterior_path, problem, inv.settings_yaml);
      if (ranks.writer()) core::log_info("resuming after generation " + std::to_string(cp.generations.back().index));
    } else if (fs::exists(posterior_path) && !resume) {
      throw core::InputError(posterior_path, "exists: add --resume to continue that calibration, or choose another -o");
    }
    auto simulations = [&] {
      std::int64_t n = 0;
      for (const auto& g : cp.generations) n += g.proposed;
      return n;
    };
    // Realizations and failures of every rank (a collective call: every rank checkpoints).
    const std::int64_t realizations_before = cp.realizations, failures_before = cp.failures;
    auto count_all = [&] {
      cp.realizations = realizations_before + sum_over(ranks, problem.realizations_run());
      cp.failures = failures_before + sum_over(ranks, problem.failures());
    };
    auto checkpoint = [&](bool finished) {
      count_all();
      cp.finished = finished;
      if (ranks.writer()) write_posterior(posterior_path, problem, cp, provenance, Fit{});
    };
    if (cp.generations.empty()) {
      core::Stopwatch g_clock;
      progress.begin(0, settings.particles, std::numeric_limits<double>::infinity());
      cp.generations.push_back(abc.first(simulate));
      checkpoint(false);
      if (ranks.writer())
        core::log_notice("generation 0 (prior): " + std::to_string(cp.generations.back().proposed) + " simulations in " +
                         digits(g_clock.seconds(), 3) + " s");
    }
    while (!cp.finished && !abc.finished(cp.generations.back())) {
      core::Stopwatch g_clock;
      std::int64_t budget = 0;
      if (settings.max_simulations > 0) {
        budget = settings.max_simulations - simulations();
        if (budget <= 0) break;
      }
      // A distance is infinite when a case had fewer than 2 realizations at rest: with more
      // than `quantile` of them so, no tolerance can choose among the particles.
      const AbcGeneration& prev = cp.generations.back();
      if (!std::isfinite(abc.tolerance(prev))) {
        const auto infinite = std::count_if(prev.distance.begin(), prev.distance.end(),
                                            [](double d) { return std::isinf(d); });
        throw core::RuntimeError(
            "generation " + std::to_string(prev.index) + ": " + std::to_string(infinite) + " of its " +
            std::to_string(prev.distance.size()) + " simulations had fewer than 2 realizations at rest in a case "
            "(nothing to compare), more than the quantile " + num(settings.quantile) + ": no tolerance can be set; "
            "the scene's blocks leave the terrain or reach the step limit over much of the prior (check the "
            "terrain's extent, engine.max_time and the priors)");
      }
      progress.begin(prev.index + 1, settings.particles, abc.tolerance(prev));
      AbcGeneration g = abc.next(prev, simulate, budget);
      if (static_cast<std::int64_t>(g.theta.size()) < settings.particles) {
        // Generation 0 is the prior's sample: returned as the posterior, it would say the
        // stops taught nothing when the budget only stopped the fit.
        if (cp.generations.back().index == 0)
          throw core::RuntimeError("the simulation budget (max_simulations " + std::to_string(settings.max_simulations) +
                                   ") ran out during generation 1, which accepted " + std::to_string(g.theta.size()) +
                                   " of its " + std::to_string(settings.particles) + " particles in " +
                                   std::to_string(g.proposed) + " simulations: there is no posterior, only the prior's "
                                   "sample (" + posterior_path + "); raise max_simulations and start afresh");
        if (ranks.writer())
          core::log_warn("the simulation budget (max_simulations) ran out during generation " + std::to_string(g.index) +
                       ": the posterior is generation " + std::to_string(cp.generations.back().index));
        break;
      }
      cp.generations.push_back(std::move(g));
      checkpoint(false);
      if (cp.generations.back().index == abort_after_generation()) std::_Exit(137);
      const auto& last = cp.generations.back();
      if (ranks.writer())
        core::log_notice("generation " + std::to_string(last.index) + ": tolerance " + digits(last.tolerance, 4) + ", " +
                         std::to_string(last.proposed) + " simulations (acceptance " + digits(last.acceptance(), 3) +
                         ") in " + digits(g_clock.seconds(), 3) + " s");
    }

    count_all();
    const std::int64_t not_at_rest = sum_over(ranks, problem.not_at_rest());
    if (!ranks.writer()) return;
    const AbcGeneration& post = cp.generations.back();
    // The fit: every case simulated at the posterior medians.
    const std::vector<double> best = medians(post);
    Fit fit;
    for (std::size_t c = 0; c < problem.cases().size(); ++c) {
      const calibrate::Simulated sim = problem.simulate(best, c);
      fit.values.push_back(sim.values);
      if (problem.summaries())
        fit.summaries.push_back(sim.blocks[0].size() < 2 ? std::vector<stats::SummaryComparison>{}
                                                         : problem.compare(c, sim));
      cp.realizations += static_cast<std::int64_t>(settings.realizations);
      cp.failures += sim.failures;
    }
    cp.finished = true;
    write_posterior(posterior_path, problem, cp, provenance, fit);
    io::write_text_file((fs::path(inv.output) / "posterior.csv").string(), csv_posterior(problem, post));
    io::write_text_file((fs::path(inv.output) / "generations.csv").string(), csv_generations(cp.generations));
    io::write_text_file((fs::path(inv.output) / "summary.csv").string(), csv_summary(problem, post));
    mc::SceneSettings calibrated = problem.with_parameters(problem.base_scene(), best);
    std::string roughness_note;
    for (std::size_t k = 0; k < settings.parameters.size(); ++k)
      if (settings.parameters[k].is_roughness())
        roughness_note = "# The calibrated roughness is the terrain's: rebuild it with terrain-gen --set roughness.sigma=" +
                         num(best[k]) + " (m).\n";
    io::write_text_file((fs::path(inv.output) / "calibrated-scene.yaml").string(),
               "# " + settings.scene + " with the calibrated materials (posterior medians; " + kPosterior +
                   " holds the whole posterior). Written by calibrate.\n" + roughness_note +
                   io::write_settings([&calibrated](core::SettingsVisitor& v) { calibrated.visit(v); }, true));
    if (settings.plots) cli::run_plot_helper("--calibration " + cli::shell_quote(posterior_path) + " " + cli::shell_quote(inv.output));
    std::fputs(table(problem, post).c_str(), stdout);
    if (not_at_rest > 0)
      core::log_info(std::to_string(not_at_rest) + " realizations of this invocation did not come to rest (left the "
                     "terrain or reached the step limit) and were " +
                     (problem.summaries() || settings.unstopped == "count" ? "compared at their final position"
                                                                           : "not compared (unstopped: drop)"));
    if (cp.failures > 0)
      core::log_warn(std::to_string(cp.failures) + " of " + std::to_string(cp.realizations) +
                     " realizations ended in a numerical failure and were left out of the comparison");
    core::log_info("calibrated in " + num(clock.seconds()) + " s: " + std::to_string(simulations()) + " simulations of " +
                   std::to_string(settings.realizations) + " realizations per case, " +
                   std::to_string(cp.generations.size() - 1) + " generation(s) after the prior");
  };
  const int code = cli::run_tool(argc, argv, spec);
#ifdef TALUS_WITH_MPI
  if (mpi) MPI_Finalize();
#endif
  return code;
}
