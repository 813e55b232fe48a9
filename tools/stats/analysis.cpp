#include "analysis.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/threads.hpp"
#include "talus/dda/state.hpp"
#include "talus/io/observed.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/vector.hpp"
#include "talus/mc/scene.hpp"

namespace talus::stats_tool {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Above this censored share stats warns that the stop-position quantiles are biased.
constexpr double kCensoredWarning = 0.10;

// A shard's name without its shard number ("run-2" → "run"), for a joined run.
std::string run_name_of_shards(const std::string& path) {
  std::string stem = std::filesystem::path(path).stem().string();
  const auto end = stem.find_last_not_of("0123456789");
  if (end != std::string::npos && end + 1 < stem.size() && end > 0 &&
      (stem[end] == '-' || stem[end] == '_' || stem[end] == '.'))
    stem.resize(end);
  return stem;
}

// A run name that cannot name output files and table cells (empty, or holding a path
// separator, a line break, a comma or a quote).
bool unusable_run_name(const std::string& name) {
  return name.empty() || name.find_first_of("/\\\n,\"") != std::string::npos;
}


}  // namespace

std::vector<Run> load_runs(const std::vector<std::string>& paths, const Settings& settings,
                           const core::SettingsOrigins& origins) {
  std::vector<Run> runs;
  std::map<std::string, std::size_t> shard_group;  // run key → index in `runs`
  std::vector<std::vector<io::RunFile>> shards;    // parallel to `runs` (shards only)
  for (const auto& path : paths) {
    io::RunFile file = io::read_run_file(path);
    if (file.info.shard == "0/1") {
      if (file.data.records.empty()) throw core::InputError(path, "run file holds no realizations");
      runs.push_back({std::filesystem::path(path).stem().string(), {path}, std::move(file)});
      shards.emplace_back();
      continue;
    }
    const auto [it, fresh] = shard_group.try_emplace(io::run_identity(file.info), runs.size());
    if (fresh) {
      runs.push_back({run_name_of_shards(path), {}, {}});
      shards.emplace_back();
    }
    runs[it->second].files.push_back(path);
    shards[it->second].push_back(std::move(file));
  }
  std::vector<std::size_t> partial;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (shards[r].empty()) continue;
    // Checks that the shards belong together and no realization repeats.
    runs[r].file = io::merge_run_files(shards[r], runs[r].files);
    // A shard may hold none (a run of fewer realizations than shards); the run may not.
    if (runs[r].file.data.records.empty())
      throw core::InputError(runs[r].files.front(), "the shards given hold no realizations");
    if (runs[r].file.info.shard != "0/1") partial.push_back(r);
  }
  for (std::size_t r : partial) {
    const std::string held = "the shards given hold " + std::to_string(runs[r].file.data.records.size()) + " of " +
                             std::to_string(runs[r].file.info.realizations) + " realizations";
    if (settings.allow_partial) {
      core::log_warn("run '" + runs[r].name + "': " + held);
      continue;
    }
    // Two incomplete groups are most often shards of different runs given together.
    const std::size_t other = partial.front() == r ? partial.back() : partial.front();
    throw core::InputError(runs[r].files.front(),
                           held + (other != r ? "; " + runs[other].files.front() +
                                                    " is a shard of another run (settings, inputs or "
                                                    "realization count differ)"
                                              : " (a shard is missing)") +
                               "; set allow_partial=true to use them anyway");
  }
  if (!settings.names.empty()) {
    if (settings.names.size() != runs.size())
      throw core::InputError(origins.of("names"), "names: " + std::to_string(settings.names.size()) + " names for " +
                                                      std::to_string(runs.size()) + " runs");
    for (std::size_t r = 0; r < runs.size(); ++r) runs[r].name = settings.names[r];
  }
  if (!settings.release_frequencies.empty() && settings.release_frequencies.size() != runs.size())
    throw core::InputError(origins.of("release_frequencies"),
                           "release_frequencies: " + std::to_string(settings.release_frequencies.size()) +
                               " frequencies for " + std::to_string(runs.size()) +
                               " runs (one per run after shards are joined)");
  std::set<std::string> seen;
  for (const auto& run : runs) {
    if (unusable_run_name(run.name))
      throw core::InputError(origins.of("names"),
                             "run name '" + run.name + "' is empty or holds one of / \\ , \"");
    if (!seen.insert(run.name).second)
      throw core::InputError(run.files.front(), "two runs are named '" + run.name +
                                                    "': give distinct names with --set names=[a,b,...]");
  }
  return runs;
}

namespace {

// Index of `name` in `names`, appended if absent.
std::int32_t index_of(std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it != names.end()) return static_cast<std::int32_t>(it - names.begin());
  names.push_back(name);
  return static_cast<std::int32_t>(names.size() - 1);
}

// Maps an index into one run's name list to the pooled list (−1 and out-of-range kept
// as they are: invalid indices are reported where they are used).
std::int32_t remap(std::int32_t index, const std::vector<std::string>& from, std::vector<std::string>& to) {
  if (index < 0 || static_cast<std::size_t>(index) >= from.size()) return index;
  return index_of(to, from[static_cast<std::size_t>(index)]);
}

}  // namespace

void pool_runs(std::vector<Run>& runs, const Settings& settings, const core::SettingsOrigins& origins) {
  const std::size_t given = runs.size();
  for (std::size_t p = 0; p < settings.pools.size(); ++p) {
    const Pool& pool = settings.pools[p];
    const std::string item = "pools[" + std::to_string(p) + "]";
    if (unusable_run_name(pool.name))
      throw core::InputError(origins.of(item + ".name"),
                             "pools: name '" + pool.name + "' is empty or holds one of / \\ , \"");
    if (std::any_of(runs.begin(), runs.end(), [&](const Run& r) { return r.name == pool.name; }))
      throw core::InputError(origins.of(item + ".name"), "pools: '" + pool.name + "' is already the name of a run");
    std::vector<const Run*> members;
    if (pool.runs.empty()) {
      for (std::size_t r = 0; r < given; ++r) members.push_back(&runs[r]);
    } else {
      for (const std::string& name : pool.runs) {
        const auto it = std::find_if(runs.begin(), runs.begin() + static_cast<std::ptrdiff_t>(given),
                                     [&](const Run& r) { return r.name == name; });
        if (it == runs.begin() + static_cast<std::ptrdiff_t>(given)) {
          std::string known;
          for (std::size_t r = 0; r < given; ++r) known += (r ? ", " : "") + runs[r].name;
          throw core::InputError(origins.of(item + ".runs"), "pools: '" + pool.name + "' names run '" + name +
                                                                  "', which is not among the runs (" + known + ")");
        }
        members.push_back(&*it);
      }
    }
    Run pooled;
    pooled.name = pool.name;
    io::RunInfo& info = pooled.file.info;
    info = members.front()->file.info;
    info.blocks.clear();
    info.stop_classes.clear();
    info.barriers.clear();
    info.barrier_lines.clear();
    info.hazard = mc::HazardGridSpec{};
    info.shard = "0/1";
    info.release.clear();
    mc::RunData& data = pooled.file.data;
    std::uint32_t offset = 0;
    for (const Run* m : members) {
      const io::RunInfo& mi = m->file.info;
      if (mi.origin_shift != info.origin_shift)
        throw core::InputError(m->files.front(), "pools: run '" + m->name + "' is on a terrain with another origin shift than run '" +
                                                     members.front()->name + "': pooled runs must share the coordinates");
      pooled.files.insert(pooled.files.end(), m->files.begin(), m->files.end());
      for (std::size_t b = 0; b < mi.barriers.size(); ++b) {
        const std::size_t before = info.barriers.size();
        index_of(info.barriers, mi.barriers[b]);
        if (info.barriers.size() > before) info.barrier_lines.push_back(b < mi.barrier_lines.size() ? mi.barrier_lines[b] : decltype(mi.barrier_lines)::value_type{});
      }
      std::uint32_t count = 0;
      for (mc::Record rec : m->file.data.records) {
        rec.realization += offset;
        rec.block = remap(rec.block, mi.blocks, info.blocks);
        rec.stop_class = remap(rec.stop_class, mi.stop_classes, info.stop_classes);
        data.records.push_back(rec);
        count = std::max(count, rec.realization - offset + 1);
      }
      for (mc::Crossing c : m->file.data.crossings) {
        c.realization += offset;
        c.barrier = remap(c.barrier, mi.barriers, info.barriers);
        data.crossings.push_back(c);
      }
      for (mc::TrajectoryPoint t : m->file.data.trajectories) {
        t.realization += offset;
        data.trajectories.push_back(t);
      }
      // A member's release features, weighted by its share of the pool's realizations;
      // members released from zones of another kind (points and polygons) have no one layer.
      if (mi.release_kind != info.release_kind) info.release_kind.clear();
      for (io::ReleaseArea area : mi.release) {
        area.probability *= count;
        info.release.push_back(std::move(area));
      }
      offset += count;
    }
    info.realizations = offset;
    if (info.release_kind.empty()) info.release.clear();
    for (io::ReleaseArea& area : info.release) area.probability /= std::max<std::uint32_t>(offset, 1);
    runs.push_back(std::move(pooled));
  }
}

namespace {

// Bootstrap plans by sample size: the resampled indices depend only on the number of
// values, so the variables of a series, and series of one size, share them.
class BootstrapPlans {
 public:
  explicit BootstrapPlans(const Settings& settings) : settings_(settings) {}
  const stats::BootstrapPlan& of(std::size_t n) {
    auto it = plans_.find(n);
    if (it == plans_.end())
      it = plans_.emplace(n, stats::BootstrapPlan(n, settings_.quantiles,
                                                  static_cast<std::size_t>(settings_.bootstrap_resamples),
                                                  settings_.seed, core::default_thread_count())).first;
    return it->second;
  }

 private:
  const Settings& settings_;
  std::map<std::size_t, stats::BootstrapPlan> plans_;
};

VariableSummary summarize(std::string name, std::string unit, std::vector<double> values, const Settings& settings,
                          BootstrapPlans& plans) {
  VariableSummary v;
  v.name = std::move(name);
  v.unit = std::move(unit);
  std::vector<double> present;
  for (double x : values)
    if (std::isnan(x))
      ++v.missing;
    else
      present.push_back(x);
  v.values = present;
  if (present.empty()) return v;
  v.sample.emplace(present, v.name.c_str());
  const stats::Sample& s = *v.sample;
  const double alpha = 1.0 - settings.confidence;
  for (double p : settings.quantiles) v.quantiles.push_back(s.quantile(p));
  if (settings.bootstrap_resamples > 0)
    v.intervals = plans.of(s.size()).intervals(s, alpha);
  v.dkw_epsilon = stats::dkw_epsilon(s.size(), alpha);
  if (present.size() >= 2) {
    std::vector<stats::Statistic> followed = {{stats::Statistic::Kind::mean}};
    for (double p : settings.convergence_quantiles) followed.push_back({stats::Statistic::Kind::quantile, p});
    const auto counts =
        stats::convergence_counts(present.size(), static_cast<std::size_t>(settings.convergence_points));
    for (const auto& statistic : followed)
      v.convergence.push_back({statistic, stats::convergence(present, statistic, counts),
                               stats::realizations_needed(present, statistic, settings.convergence_target)});
  }
  return v;
}

}  // namespace

VariableSummary summarize(std::string name, std::string unit, std::vector<double> values, const Settings& settings) {
  BootstrapPlans plans(settings);
  return summarize(std::move(name), std::move(unit), std::move(values), settings, plans);
}

namespace {

// The statistics of the records `rows` (indices into run.data.records) of one run.
Series make_series(const Run& run, std::size_t run_index, const std::string& block,
                   const std::vector<std::size_t>& rows, const std::array<double, 3>& shift,
                   const Settings& settings, BootstrapPlans& plans) {
  const auto& records = run.file.data.records;
  const auto& info = run.file.info;
  Series s;
  s.run = run.name;
  s.block = block;
  s.run_index = run_index;
  s.realizations = rows.size();
  // Numerically failed realizations carry no trustworthy values: counted, not used.
  // Blocks cut by the step limit or gone off the terrain did not stop: where they would
  // have stopped is unknown (their runout is a lower bound), so they are censored from the
  // stop-position variables and counted. Their speeds, heights and energies so far are real
  // and stay in.
  std::vector<std::size_t> good, stopped;
  for (std::size_t r : rows) {
    if (!dda::is_failure(records[r].end)) good.push_back(r);
    if (records[r].end == dda::EndReason::rest) stopped.push_back(r);
  }
  const auto column = [&](auto member, const std::vector<std::size_t>& which) {
    std::vector<double> out;
    for (std::size_t r : which) out.push_back(records[r].*member);
    return out;
  };
  for (const auto& [name, member] : {std::pair{"runout", &mc::Record::runout}, std::pair{"lateral", &mc::Record::lateral}}) {
    s.variables.push_back(summarize(name, "m", column(member, stopped), settings, plans));
    s.variables.back().censored = good.size() - stopped.size();
  }
  s.variables.push_back(summarize("max_speed", "m/s", column(&mc::Record::max_speed, good), settings, plans));
  s.variables.push_back(summarize("max_jump_height", "m", column(&mc::Record::max_jump_height, good), settings, plans));
  s.variables.push_back(
      summarize("max_normal_jump_height", "m", column(&mc::Record::max_normal_jump_height, good), settings, plans));
  s.variables.push_back(summarize("max_kinetic_energy", "J", column(&mc::Record::max_kinetic_energy, good), settings, plans));

  // Barriers: the first crossing of each realization (where a barrier would catch it).
  std::map<std::uint32_t, std::size_t> position_of;  // realization → index in `good`
  for (std::size_t k = 0; k < good.size(); ++k) position_of[records[good[k]].realization] = k;
  const std::size_t barriers = info.barriers.size();
  std::vector<std::vector<double>> height(barriers, std::vector<double>(good.size(), kNaN));
  std::vector<std::vector<double>> energy(barriers, std::vector<double>(good.size(), kNaN));
  std::vector<std::vector<bool>> crossed(barriers, std::vector<bool>(good.size(), false));
  for (const auto& c : run.file.data.crossings) {
    const auto it = position_of.find(c.realization);
    if (it == position_of.end() || c.barrier < 0 || static_cast<std::size_t>(c.barrier) >= barriers) continue;
    const auto b = static_cast<std::size_t>(c.barrier);
    if (crossed[b][it->second]) continue;  // rows are in time order within a realization
    crossed[b][it->second] = true;
    height[b][it->second] = c.height;
    energy[b][it->second] = c.kinetic_energy;
  }
  for (std::size_t b = 0; b < barriers; ++b) {
    s.variables.push_back(summarize(info.barriers[b] + ".passing_height", "m", height[b], settings, plans));
    s.variables.push_back(summarize(info.barriers[b] + ".kinetic_energy", "J", energy[b], settings, plans));
  }

  const double n = static_cast<double>(rows.size());
  const auto fraction = [&](std::string name, std::uint64_t count) {
    s.fractions.push_back({std::move(name), count, static_cast<double>(count) / n});
  };
  // Stop classes hold the blocks that stopped there, and those that left the terrain
  // ("out of domain"); a block cut by the step limit or failed stopped nowhere.
  for (std::size_t c = 0; c < info.stop_classes.size(); ++c)
    fraction("stop:" + info.stop_classes[c],
             static_cast<std::uint64_t>(std::count_if(rows.begin(), rows.end(), [&](std::size_t r) {
               const dda::EndReason end = records[r].end;
               return (end == dda::EndReason::rest || end == dda::EndReason::left_terrain) &&
                      records[r].stop_class == static_cast<std::int32_t>(c);
             })));
  for (std::size_t b = 0; b < barriers; ++b)
    fraction("cross:" + info.barriers[b],
             static_cast<std::uint64_t>(std::count(crossed[b].begin(), crossed[b].end(), true)));
  for (double d : settings.reach_distances)
    fraction("runout>=" + core::format_number(d),
             static_cast<std::uint64_t>(std::count_if(good.begin(), good.end(),
                                                      [&](std::size_t r) { return records[r].runout >= d; })));
  for (int k = static_cast<int>(dda::EndReason::rest); k <= static_cast<int>(dda::EndReason::penetration); ++k) {
    const auto reason = static_cast<dda::EndReason>(k);
    fraction("end:" + std::string(dda::to_string(reason)),
             static_cast<std::uint64_t>(
                 std::count_if(rows.begin(), rows.end(), [&](std::size_t r) { return records[r].end == reason; })));
  }
  fraction("numerical_failure", rows.size() - good.size());
  for (std::size_t r : stopped)
    s.stop_points.push_back({records[r].final_position.x() + shift[0], records[r].final_position.y() + shift[1]});
  return s;
}

// Pairs that differ in one factor: two blocks of one run, or one block (or "all") in two runs.
bool comparable(const Series& a, const Series& b) {
  if (a.run == b.run) return a.block != "all" && b.block != "all" && a.block != b.block;
  return a.block == b.block;
}

terrain::DemGrid raster_like(const mc::HazardGridSpec& g, const std::array<double, 3>& shift, double fill) {
  terrain::DemGrid dem;
  dem.spec = {g.x0 + 0.5 * g.size + shift[0], g.y0 + 0.5 * g.size + shift[1], g.size, g.size, g.nx, g.ny};
  dem.z.assign(dem.spec.point_count(), fill);
  return dem;
}

// The terrain file of a run: --set terrain, else the path the run names as given, as
// made absolute when it ran, or relative to the run file's directory (the first that
// exists; the path as given when none does).
std::string terrain_path_of(const Run& run, const Settings& settings) {
  if (!settings.terrain.empty()) return settings.terrain;
  const std::string& inputs = run.file.info.provenance.inputs;
  const std::string named = inputs.substr(0, inputs.find('\n'));
  if (named.empty()) return named;
  const std::filesystem::path beside = std::filesystem::path(run.files.front()).parent_path() / named;
  for (const std::string& candidate : {named, run.file.info.terrain_file, beside.string()})
    if (!candidate.empty() && std::filesystem::exists(candidate)) return candidate;
  return named;
}

RunResult run_result(const Run& run, const Settings& settings, std::optional<double> release_frequency) {
  RunResult out;
  const auto& info = run.file.info;
  const bool grid = info.hazard.size > 0.0 && info.hazard.nx > 0 && info.hazard.ny > 0;
  // Rasters and vector layers without the origin shift and CRS would be misplaced or
  // unreferenced in a GIS: they need the terrain.
  const bool rasters = settings.hazard_maps && grid;
  const bool vectors = settings.vector_format != "none";
  // Observed stops are checked against the terrain's CRS (a file in another is refused).
  const bool observed = !settings.observed.file.empty();
  const bool need_terrain = rasters || vectors || settings.plots || observed;
  const std::string path = terrain_path_of(run, settings);
  std::shared_ptr<const terrain::Terrain> ground;
  if (need_terrain && !path.empty() && std::filesystem::exists(path)) {
    ground = std::make_shared<const terrain::Terrain>(io::read_terrain_file(path));
    // Hazard rasters and plan views on another terrain would be silently wrong.
    if (const std::string& expected = info.terrain_fingerprint; !expected.empty()) {
      const std::string found = io::terrain_fingerprint(*ground);
      if (found != expected)
        throw core::InputError(path, "is not the terrain of the run " + run.files.front() + " (terrain fingerprint " +
                                         found + ", the run's " + expected +
                                         "): give the run's terrain with --set terrain=FILE");
    }
    out.terrain_file = path;
    out.crs_wkt = ground->crs_wkt;
    if (observed) out.terrain = ground;
    out.origin_shift = {ground->origin_shift.x(), ground->origin_shift.y(), ground->origin_shift.z()};
  } else if (rasters || vectors || observed) {
    std::string without = rasters && vectors ? "--set hazard_maps=false --set vector_format=none"
                          : rasters          ? "--set hazard_maps=false"
                          : vectors          ? "--set vector_format=none"
                                             : "";
    if (observed) without += std::string(without.empty() ? "" : ", and ") + "no observed.file";
    throw core::InputError(run.files.front(),
                           path.empty() ? "the run names no terrain file: give it with --set terrain=FILE "
                                          "(or " + without + ")"
                                        : "terrain file '" + path + "'" +
                                              (settings.terrain.empty() ? " named by the run" : "") +
                                              " is missing: give it with --set terrain=FILE (or " + without + ")");
  }
  if (settings.hazard_maps && grid) out.hazard = hazard_maps(run.file, out.origin_shift, settings, release_frequency);
  const auto& shift = out.origin_shift;
  PlanView& plan = out.plan;
  // The plan view's terrain: the whole mesh up to two million points; a grid of more
  // points is thinned to about 600 points along its longer side (finer than the figure
  // shows); a larger TIN is left out.
  if (ground && ground->mesh.vertices.size() <= 2000000) {
    for (const auto& v : ground->mesh.vertices) {
      plan.terrain_x.push_back(v.x() + shift[0]);
      plan.terrain_y.push_back(v.y() + shift[1]);
      plan.terrain_z.push_back(v.z() + shift[2]);
    }
    for (const auto& t : ground->mesh.triangles) plan.terrain_triangles.push_back({t[0], t[1], t[2]});
  } else if (ground && ground->grid) {
    const terrain::GridSpec& g = *ground->grid;
    const std::int32_t stride = std::max<std::int32_t>(1, static_cast<std::int32_t>(std::ceil(std::max(g.nx, g.ny) / 600.0)));
    const std::int32_t mx = (g.nx - 1) / stride + 1, my = (g.ny - 1) / stride + 1;
    for (std::int32_t j = 0; j < my; ++j)
      for (std::int32_t i = 0; i < mx; ++i) {
        const auto& v = ground->mesh.vertices[g.index(i * stride, j * stride)];
        plan.terrain_x.push_back(v.x() + shift[0]);
        plan.terrain_y.push_back(v.y() + shift[1]);
        plan.terrain_z.push_back(v.z() + shift[2]);
      }
    for (std::int32_t j = 0; j + 1 < my; ++j)
      for (std::int32_t i = 0; i + 1 < mx; ++i) {
        const std::int32_t a = j * mx + i;
        plan.terrain_triangles.push_back({a, a + 1, a + mx + 1});
        plan.terrain_triangles.push_back({a, a + mx + 1, a + mx});
      }
  }
  std::set<std::uint32_t> drawn;
  for (const auto& p : run.file.data.trajectories) {
    if (!drawn.count(p.realization)) {
      if (drawn.size() >= static_cast<std::size_t>(settings.plot_trajectories)) continue;
      drawn.insert(p.realization);
    }
    plan.trajectory_realization.push_back(p.realization);
    plan.trajectory_position.push_back(
        {p.sample.position.x() + shift[0], p.sample.position.y() + shift[1], p.sample.position.z() + shift[2]});
  }
  plan.barrier_names = info.barriers;
  for (const auto& line : info.barrier_lines) {
    auto& shifted = plan.barrier_lines.emplace_back();
    for (const auto& v : line) shifted.push_back({v[0] + shift[0], v[1] + shift[1]});
  }
  plan.barrier_downslope.assign(info.barrier_lines.size(), 0);
  if (ground) {
    const terrain::Surface smooth = terrain::Surface::realize(*ground, std::nullopt);
    const double cell = ground->grid ? std::max(ground->grid->dx, ground->grid->dy) : 0.0;
    // Two DEM cells either side, at least 2 m: past the roughness of single cells.
    const double offset = std::max(2.0, 2.0 * cell);
    for (std::size_t b = 0; b < info.barrier_lines.size(); ++b)
      plan.barrier_downslope[b] = downslope_side(smooth, info.barrier_lines[b], offset);
    if (settings.plots) plan.hillshade = hillshade(smooth, cell, shift);
  }
  plan.release_kind = info.release_kind;
  for (const auto& area : info.release)
    for (const auto& part : area.parts)
      for (const auto& ring : part) {
        auto& shifted = plan.release_rings.emplace_back();
        for (const auto& v : ring) shifted.push_back({v[0] + shift[0], v[1] + shift[1]});
      }
  if (!out.crs_wkt.empty()) plan.crs_name = io::crs_name(out.crs_wkt);
  return out;
}

}  // namespace

int downslope_side(const terrain::Surface& ground, const std::vector<std::array<double, 2>>& line, double offset) {
  double rise_right = 0.0;  // Σ (z right − z left) · length along the line
  for (std::size_t k = 1; k < line.size(); ++k) {
    const double dx = line[k][0] - line[k - 1][0], dy = line[k][1] - line[k - 1][1];
    const double length = std::hypot(dx, dy);
    if (!(length > 0.0)) continue;
    const double lx = -dy / length * offset, ly = dx / length * offset;  // towards the left
    const auto pieces = static_cast<int>(std::ceil(length / (0.5 * offset)));
    for (int i = 0; i < pieces; ++i) {
      const double t = (i + 0.5) / pieces;
      const double x = line[k - 1][0] + t * dx, y = line[k - 1][1] + t * dy;
      const auto left = ground.height_at(x + lx, y + ly), right = ground.height_at(x - lx, y - ly);
      if (left && right) rise_right += (right->z - left->z) * length / pieces;
    }
  }
  return rise_right > 0.0 ? 1 : rise_right < 0.0 ? -1 : 0;
}

terrain::DemGrid hillshade(const terrain::Surface& ground, double finest, const std::array<double, 3>& shift) {
  const geometry::Aabb& b = ground.bounds();
  terrain::DemGrid out;
  const double wide = std::max(b.hi.x() - b.lo.x(), b.hi.y() - b.lo.y());
  if (!(wide > 0.0)) return out;
  const double h = std::max(finest, wide / 800.0);
  const auto nx = static_cast<std::int32_t>(std::max(1.0, std::round((b.hi.x() - b.lo.x()) / h)));
  const auto ny = static_cast<std::int32_t>(std::max(1.0, std::round((b.hi.y() - b.lo.y()) / h)));
  const double dx = (b.hi.x() - b.lo.x()) / nx, dy = (b.hi.y() - b.lo.y()) / ny;
  out.spec = {b.lo.x() + 0.5 * dx + shift[0], b.lo.y() + 0.5 * dy + shift[1], dx, dy, nx, ny};
  std::vector<double> z(out.spec.point_count(), kNaN);
  for (std::int32_t j = 0; j < ny; ++j)
    for (std::int32_t i = 0; i < nx; ++i)
      if (const auto hit = ground.height_at(b.lo.x() + (i + 0.5) * dx, b.lo.y() + (j + 0.5) * dy))
        z[out.spec.index(i, j)] = hit->z;
  // Light from azimuth 315° (clockwise from north), 45° up: the GIS default.
  const double up = std::sin(M_PI / 4), across = std::cos(M_PI / 4);
  const double lx = across * std::sin(-M_PI / 4), ly = across * std::cos(-M_PI / 4);
  out.z.assign(z.size(), kNaN);
  const auto at = [&](std::int32_t i, std::int32_t j) {
    return i < 0 || j < 0 || i >= nx || j >= ny ? kNaN : z[out.spec.index(i, j)];
  };
  // A central difference, one-sided at the edge of the ground.
  const auto slope = [](double below, double here, double above, double step) {
    if (!std::isnan(below) && !std::isnan(above)) return (above - below) / (2 * step);
    if (!std::isnan(above)) return (above - here) / step;
    if (!std::isnan(below)) return (here - below) / step;
    return 0.0;
  };
  for (std::int32_t j = 0; j < ny; ++j)
    for (std::int32_t i = 0; i < nx; ++i) {
      const double c = at(i, j);
      if (std::isnan(c)) continue;
      const double p = slope(at(i - 1, j), c, at(i + 1, j), dx), q = slope(at(i, j - 1), c, at(i, j + 1), dy);
      out.z[out.spec.index(i, j)] = std::max(0.0, (-p * lx - q * ly + up) / std::sqrt(p * p + q * q + 1.0));
    }
  return out;
}

std::optional<double> VariableSummary::censored_share() const {
  if (!censored) return std::nullopt;
  const std::size_t total = values.size() + *censored;
  return total == 0 ? 0.0 : static_cast<double>(*censored) / static_cast<double>(total);
}

const HazardLayer& HazardMaps::layer(const std::string& name) const {
  for (const auto& l : layers)
    if (l.name == name) return l;
  throw std::out_of_range("no hazard layer " + name);
}

namespace {

// The frequency class of an exceedance frequency f (1/yr) against the return periods
// T1 < T2 < T3: 3 high (f ≥ 1/T1), 2 medium (≥ 1/T2), 1 low (≥ 1/T3), 0 very low.
int frequency_class(double f, const std::vector<double>& periods) {
  if (f * periods[0] >= 1.0) return 3;
  if (f * periods[1] >= 1.0) return 2;
  if (f * periods[2] >= 1.0) return 1;
  return 0;
}

// The intensity–frequency diagram of FOEN 2016 (rows: intensity low, medium, high;
// columns: frequency very low, low, medium, high): 0 none, 1 residual, 2 low (yellow),
// 3 medium (blue), 4 high (red).
constexpr int kHazardMatrix[3][4] = {{0, 2, 2, 3}, {1, 3, 3, 4}, {1, 4, 4, 4}};

}  // namespace

void add_intensity_layers(HazardMaps& maps, const io::RunFile& run, const std::array<double, 3>& origin_shift,
                          const Settings& settings, double release_frequency) {
  const mc::HazardGridSpec& g = run.info.hazard;
  const auto n = static_cast<double>(run.data.records.size());
  const auto& e = settings.intensity_thresholds;
  const auto& t = settings.return_periods;
  const std::string e1 = core::format_number(e[0] * 1e-3) + " kJ", e2 = core::format_number(e[1] * 1e-3) + " kJ";
  const auto add = [&](std::string name, std::string title, std::string description, std::string unit, bool integer) {
    maps.layers.push_back({std::move(name), std::move(title), {std::move(description), std::move(unit), integer},
                           raster_like(g, origin_shift, 0.0)});
    return maps.layers.size() - 1;
  };
  // Exceedance frequency of each intensity class's lower bound: any passage, E ≥ e1, E ≥ e2.
  const std::array<double, 3> bounds = {0.0, e[0], e[1]};
  const std::array<std::size_t, 3> frequency = {
      add("frequency_low", "frequency of a passage",
          "exceedance frequency of a passage of any energy: release frequency × passages / realizations", "1/yr", false),
      add("frequency_medium", "frequency of E ≥ " + e1,
          "exceedance frequency of a passage with kinetic energy ≥ " + e1, "1/yr", false),
      add("frequency_high", "frequency of E ≥ " + e2,
          "exceedance frequency of a passage with kinetic energy ≥ " + e2, "1/yr", false)};
  std::vector<std::size_t> intensity;
  for (double period : t) {
    const std::string years = core::format_number(period);
    intensity.push_back(add("intensity_T" + years, "intensity class, " + years + "-year event",
                            "intensity class (0 none, 1 low < " + e1 + " ≤ 2 medium < " + e2 +
                                " ≤ 3 high) of the kinetic energy exceeded once in " + years + " years",
                            "class", true));
  }
  const std::size_t hazard =
      add("hazard_class", "hazard class (intensity–frequency)",
          "intensity-frequency class (FOEN 2016): 0 none, 1 residual, 2 low, 3 medium, 4 high", "class", true);
  for (const auto& [id, cell] : run.data.hazard.cells()) {
    const auto k = static_cast<std::size_t>(id);
    int worst = 0;
    for (std::size_t level = 0; level < 3; ++level) {
      // Passages of any energy count for the low class (the bound 0 takes them all).
      const double count = level == 0 ? static_cast<double>(cell.reach)
                                      : cell.count_at_least(mc::HazardVariable::energy, bounds[level]);
      const double f = release_frequency * count / n;
      maps.layers[frequency[level]].grid.z[k] = f;
      if (std::isnan(f) || count == 0.0) continue;
      worst = std::max(worst, kHazardMatrix[level][frequency_class(f, t)]);
    }
    maps.layers[hazard].grid.z[k] = worst;
    for (std::size_t s = 0; s < t.size(); ++s) {
      // The energy exceeded with frequency 1/T: the k-th largest passage energy, k = N/(λT)
      // passages of the N realizations (none when fewer passages reached the cell).
      const double passages = n / (release_frequency * t[s]);
      const auto rank = static_cast<std::uint64_t>(std::ceil(passages - 1e-9));
      double& z = maps.layers[intensity[s]].grid.z[k];
      if (rank == 0 || rank > cell.reach) continue;
      const double energy = cell.kth_largest(mc::HazardVariable::energy, rank);
      z = std::isnan(energy) ? kNaN : energy >= e[1] ? 3.0 : energy >= e[0] ? 2.0 : 1.0;
    }
  }
}

HazardMaps hazard_maps(const io::RunFile& run, const std::array<double, 3>& origin_shift, const Settings& settings,
                       std::optional<double> release_frequency) {
  const mc::HazardGridSpec& g = run.info.hazard;
  const std::string& energy_unit = settings.energy_unit;
  const double to_unit = energy_unit == "kJ" ? 1e-3 : 1.0;
  HazardMaps maps;
  const auto add = [&](std::string name, std::string title, const std::string& description, const std::string& unit,
                       double fill, bool integer = false) {
    maps.layers.push_back({std::move(name), std::move(title), {description, unit, integer},
                           raster_like(g, origin_shift, fill)});
  };
  add("reach_probability", "reach probability",
      "reach probability: realizations whose path reached the cell / realizations", "1", 0.0);
  add("passage_count", "passages", "passage count: realizations whose path reached the cell", "count", 0.0, true);
  add("deposition_count", "deposits", "deposition count: realizations that came to rest with the centroid in the cell",
      "count", 0.0, true);
  // The statistic layers: each variable, then its statistics in the order mean, median,
  // quantiles, max.
  struct Statistic {
    std::string name, title;
    std::function<double(const mc::HazardAccumulator::Cell&, mc::HazardVariable)> of;
  };
  std::vector<Statistic> statistics;
  const auto wanted = [&](const char* s) {
    return std::find(settings.hazard_statistics.begin(), settings.hazard_statistics.end(), s) !=
           settings.hazard_statistics.end();
  };
  if (wanted("mean")) statistics.push_back({"mean", "mean", [](const auto& c, auto v) { return c.mean(v); }});
  if (wanted("median"))
    statistics.push_back({"median", "median", [](const auto& c, auto v) { return c.quantile(v, 0.5); }});
  for (double p : settings.hazard_quantiles) {
    std::string q = stats::Statistic{stats::Statistic::Kind::quantile, p}.name();
    std::string lower = q;
    lower[0] = 'p';
    statistics.push_back({lower, q, [p](const auto& c, auto v) { return c.quantile(v, p); }});
  }
  if (wanted("max")) statistics.push_back({"max", "largest", [](const auto& c, auto v) { return c.max(v); }});
  struct Variable {
    mc::HazardVariable id;
    const char* name;
    const char* title;
    const char* description;
    std::string unit;
    double scale;
  };
  const std::vector<Variable> all = {
      {mc::HazardVariable::energy, "energy", "kinetic energy", "largest kinetic energy", energy_unit, to_unit},
      {mc::HazardVariable::height, "height", "passing height", "largest passing height", "m", 1.0},
      {mc::HazardVariable::speed, "speed", "speed", "largest centroid speed", "m/s", 1.0}};
  struct Mapped {
    std::size_t layer;
    mc::HazardVariable variable;
    double scale;
    const Statistic* statistic;
  };
  std::vector<Mapped> mapped;
  for (const Variable& v : all) {
    if (std::find(settings.hazard_variables.begin(), settings.hazard_variables.end(), v.name) ==
        settings.hazard_variables.end())
      continue;
    for (const Statistic& st : statistics) {
      mapped.push_back({maps.layers.size(), v.id, v.scale, &st});
      add(std::string(v.name) + "_" + st.name, st.title + " " + v.title,
          st.title + " over the passages (at least " + std::to_string(settings.hazard_min_passages) + ") of the " +
              v.description + " in the cell",
          v.unit, kNaN);
    }
  }
  auto& reach = maps.layers[0].grid.z;
  auto& passages = maps.layers[1].grid.z;
  auto& deposits = maps.layers[2].grid.z;
  const double n = static_cast<double>(run.data.records.size());
  const auto min_passages = static_cast<std::uint64_t>(settings.hazard_min_passages);
  for (const auto& [id, cell] : run.data.hazard.cells()) {
    if (id < 0 || static_cast<std::size_t>(id) >= reach.size())
      throw core::InputError("hazard", "cell " + std::to_string(id) + " outside the hazard grid");
    const auto k = static_cast<std::size_t>(id);
    reach[k] = static_cast<double>(cell.reach) / n;
    passages[k] = static_cast<double>(cell.reach);
    // Too few passages for a statistic that means something: no data (NaN).
    if (cell.reach < min_passages) continue;
    // Unknown values (NaN) stay no data: maxima and speed sketches of earlier run files.
    for (const Mapped& m : mapped) maps.layers[m.layer].grid.z[k] = m.scale * m.statistic->of(cell, m.variable);
  }
  // Stop points of the realizations that ended at rest (the run's local frame, as the grid).
  for (const auto& rec : run.data.records) {
    if (rec.end != dda::EndReason::rest) continue;
    const std::int64_t id = g.cell(rec.final_position.x(), rec.final_position.y());
    if (id >= 0 && static_cast<std::size_t>(id) < deposits.size()) deposits[static_cast<std::size_t>(id)] += 1.0;
  }
  if (release_frequency) add_intensity_layers(maps, run, origin_shift, settings, *release_frequency);
  return maps;
}

int ead_energy_class(double energy) {
  if (std::isnan(energy)) return -1;
  static constexpr std::array<double, 7> kMel = {100e3, 250e3, 500e3, 1000e3, 2000e3, 3000e3, 4500e3};
  for (std::size_t k = 0; k < kMel.size(); ++k)
    if (energy <= kMel[k]) return static_cast<int>(k);
  return 7;
}

namespace {

// The design sheet of each barrier of a run: first crossings by segment of
// barrier_segment_length along the line, then the whole line.
std::vector<BarrierSegment> barrier_sheet(const Run& run, const Settings& settings) {
  const auto& info = run.file.info;
  std::set<std::uint32_t> failed;
  for (const auto& r : run.file.data.records)
    if (dda::is_failure(r.end)) failed.insert(r.realization);
  std::vector<BarrierSegment> out;
  const double alpha = 1.0 - settings.confidence;
  const auto resamples = static_cast<std::size_t>(settings.bootstrap_resamples);
  const auto quantiles = [&](std::vector<double> values, std::array<double, 2>& q,
                             std::array<stats::Interval, 2>& ci) {
    const double nan = kNaN;
    q = {nan, nan};
    ci = {stats::Interval{nan, nan}, stats::Interval{nan, nan}};
    if (values.empty()) return;
    const stats::Sample sample(std::move(values), "barrier crossings");
    q = {sample.quantile(0.95), sample.quantile(0.99)};
    if (sample.size() < 2 || resamples == 0) return;
    const auto intervals = stats::bootstrap_quantile_intervals(sample, {0.95, 0.99}, alpha, resamples, settings.seed);
    ci = {intervals[0], intervals[1]};
  };
  for (std::size_t b = 0; b < info.barriers.size() && b < info.barrier_lines.size(); ++b) {
    double length = 0.0;
    const auto& line = info.barrier_lines[b];
    for (std::size_t k = 1; k < line.size(); ++k)
      length += std::hypot(line[k][0] - line[k - 1][0], line[k][1] - line[k - 1][1]);
    const double step = settings.barrier_segment_length;
    const auto segments = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(length / step - 1e-9)));
    std::vector<std::vector<double>> energy(segments + 1), height(segments + 1);
    std::vector<std::size_t> count(segments + 1, 0);
    std::set<std::uint32_t> seen;
    for (const auto& c : run.file.data.crossings) {
      if (c.barrier != static_cast<std::int32_t>(b) || failed.count(c.realization) || !seen.insert(c.realization).second)
        continue;  // the first crossing of each realization (rows in time order)
      const auto k = std::min(segments - 1, static_cast<std::size_t>(std::max(0.0, std::floor(c.position / step))));
      for (const std::size_t at : {k, segments}) {
        ++count[at];
        energy[at].push_back(c.kinetic_energy);
        if (!std::isnan(c.height)) height[at].push_back(c.height);
      }
    }
    for (std::size_t k = 0; k <= segments; ++k) {
      BarrierSegment s;
      s.barrier = info.barriers[b];
      s.segment = k < segments ? std::to_string(k + 1) : "all";
      s.from = k < segments ? static_cast<double>(k) * step : 0.0;
      s.to = k < segments ? std::min(length, static_cast<double>(k + 1) * step) : length;
      s.crossings = count[k];
      quantiles(energy[k], s.energy, s.energy_ci);
      quantiles(height[k], s.height, s.height_ci);
      out.push_back(std::move(s));
    }
  }
  return out;
}

}  // namespace

Analysis analyze(const std::vector<Run>& runs, const Settings& settings) {
  Analysis a;
  BootstrapPlans plans(settings);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const Run& run = runs[r];
    const auto& f = settings.release_frequencies;
    a.runs.push_back(run_result(run, settings, r < f.size() ? std::optional<double>(f[r]) : std::nullopt));
    a.runs.back().barrier_sheet = barrier_sheet(run, settings);
    const auto& shift = a.runs.back().origin_shift;
    const auto& records = run.file.data.records;
    std::vector<std::size_t> all(records.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = k;
    a.series.push_back(make_series(run, r, "all", all, shift, settings, plans));
    std::set<std::int32_t> blocks;
    for (const auto& rec : records) blocks.insert(rec.block);
    if (!settings.by_block || blocks.size() < 2) continue;
    for (std::int32_t b : blocks) {
      if (b < 0 || static_cast<std::size_t>(b) >= run.file.info.blocks.size())
        throw core::InputError(run.files.front(), "record of block " + std::to_string(b) + " not in /run/blocks");
      std::vector<std::size_t> rows;
      for (std::size_t k = 0; k < records.size(); ++k)
        if (records[k].block == b) rows.push_back(k);
      a.series.push_back(make_series(run, r, run.file.info.blocks[static_cast<std::size_t>(b)], rows, shift, settings, plans));
    }
  }
  // Stop-position quantiles of a run most of whose blocks never stopped describe the few
  // that did: say so where the numbers are read, once per run.
  for (const Series& s : a.series) {
    if (s.block != "all") continue;
    for (const VariableSummary& v : s.variables) {
      if (v.name != "runout" || !v.censored_share() || *v.censored_share() <= kCensoredWarning) continue;
      char share[16];
      std::snprintf(share, sizeof share, "%.0f %%", 100.0 * *v.censored_share());
      a.warnings.push_back(s.run + ": " + share + " of the realizations (" + std::to_string(*v.censored) + " of " +
                     std::to_string(v.values.size() + *v.censored) +
                     ") did not stop on the terrain (left it or reached the step limit): the runout and lateral "
                     "quantiles are of the stopped blocks only (a larger terrain or engine.max_time)");
    }
  }
  for (std::size_t i = 0; i < a.series.size(); ++i)
    for (std::size_t j = i + 1; j < a.series.size(); ++j) {
      if (!comparable(a.series[i], a.series[j])) continue;
      for (std::size_t v = 0; v < a.series[i].variables.size(); ++v) {
        const VariableSummary& x = a.series[i].variables[v];
        // Barrier variables are matched by name: runs may have different barriers.
        const auto other = std::find_if(a.series[j].variables.begin(), a.series[j].variables.end(),
                                        [&](const VariableSummary& y) { return y.name == x.name; });
        if (other == a.series[j].variables.end() || !x.sample || !other->sample) continue;
        Comparison c{x.name, i, j, x.sample->size(), other->sample->size(), 0.0, 1.0};
        c.distance = stats::ks_distance(*x.sample, *other->sample);
        c.p_value = stats::ks_p_value(c.distance, c.n_a, c.n_b);
        a.comparisons.push_back(c);
      }
    }
  return a;
}

std::optional<Validation> validate_against_observed(const Analysis& a, const Settings& settings,
                                                   const core::SettingsOrigins& origins) {
  const Observed& o = settings.observed;
  if (o.file.empty()) return std::nullopt;
  const Series* series = nullptr;
  for (const Series& s : a.series)
    if (s.block == "all" && (o.series.empty() || s.run == o.series)) {
      series = &s;
      break;
    }
  if (series == nullptr)
    throw core::InputError(origins.of("observed.series"), "observed.series: no run named '" + o.series + "'");
  if (series->stop_points.empty())
    throw core::InputError(origins.of({"observed.series", "observed.file"}),
                           "observed: run '" + series->run + "' has no realization at rest to compare");

  const io::ObservedStops stops =
      io::read_observed_stops(o.file, o.layer, a.runs[series->run_index].crs_wkt, "observed.file");
  if (!stops.has_points())
    throw core::InputError(o.file, "gives runouts; stats compares stop points (x and y columns), as the simulated "
                                   "ones are measured from observed.origin");
  const std::vector<std::array<double, 2>>& observed = stops.points;
  // A stop off the run's terrain (mapped past the DEM's edge, or given in another frame)
  // can never be matched by a simulated one: its runout and offset would be compared as
  // if it could.
  const RunResult& run = a.runs[series->run_index];
  if (run.terrain != nullptr) {
    const terrain::Surface ground = terrain::Surface::realize(*run.terrain, std::nullopt);
    const Eigen::Vector2d shift(run.origin_shift[0], run.origin_shift[1]);
    for (std::size_t k = 0; k < observed.size(); ++k) {
      const Eigen::Vector2d p(observed[k][0], observed[k][1]);
      const std::string off = mc::observed_stop_off_terrain(ground, p, shift);
      if (!off.empty())
        throw core::InputError(o.file, stops.rows[k] + ": observed stop (" + core::format_number(p.x()) + ", " +
                                           core::format_number(p.y()) + ")" + off);
    }
  }

  const double azimuth = o.main_direction_deg * M_PI / 180.0;
  const double dx = std::cos(azimuth), dy = std::sin(azimuth);
  auto project = [&](const std::vector<std::array<double, 2>>& points, bool along) {
    std::vector<double> out;
    for (const auto& p : points) {
      const double ex = p[0] - o.origin[0], ey = p[1] - o.origin[1];
      out.push_back(along ? dx * ex + dy * ey : dx * ey - dy * ex);
    }
    return out;
  };
  Validation v;
  v.series = series->run;
  v.file = o.file;
  const double alpha = 1.0 - settings.confidence;
  for (const bool along : {true, false}) {
    ValidationVariable var;
    var.name = along ? "runout" : "lateral";
    var.unit = "m";
    const stats::Sample obs(project(observed, along), o.file.c_str());
    const stats::Sample sim(project(series->stop_points, along), "simulated stop points");
    var.observed = obs.sorted();
    var.simulated = sim.sorted();
    for (const VariableSummary& summary : series->variables)
      if (summary.name == var.name && summary.censored_share()) var.censored_share = *summary.censored_share();
    var.ks_distance = stats::ks_distance(obs, sim);
    var.ks_p_value = stats::ks_p_value(var.ks_distance, obs.size(), sim.size());
    const double eps = stats::dkw_epsilon(sim.size(), alpha);
    for (double p : settings.quantiles) {
      var.observed_quantiles.push_back(obs.quantile(p));
      var.simulated_quantiles.push_back(sim.quantile(p));
      var.band_low.push_back(sim.quantile(std::max(0.0, p - eps)));
      var.band_high.push_back(sim.quantile(std::min(1.0, p + eps)));
    }
    const double lo = sim.quantile(0.05), hi = sim.quantile(0.95);
    var.inside_p5_p95 = static_cast<double>(std::count_if(var.observed.begin(), var.observed.end(),
                                                          [&](double x) { return x >= lo && x <= hi; })) /
                        static_cast<double>(var.observed.size());
    v.variables.push_back(std::move(var));
  }
  return v;
}

}  // namespace talus::stats_tool
