#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "mc_fixtures.hpp"
#include "run_compare.hpp"
#include "talus/core/error.hpp"
#include "talus/mc/realization.hpp"
#include "talus/mc/runner.hpp"
#include "talus/stats/sample.hpp"

namespace talus::mc {
namespace {

using testing::bench_scene;
using testing::bench_terrain;
using testing::flat_terrain;
using testing::library;

RunData run_all(const Scene& scene, const std::vector<std::uint32_t>& indices, unsigned threads) {
  RunData data;
  data.hazard = HazardAccumulator(scene.hazard_grid(), scene.settings().outputs.hazard_relative_accuracy);
  run_realizations(scene, indices, threads, [&](RealizationResult&& r) { data.add(std::move(r)); });
  data.sort("test");
  return data;
}

std::vector<std::uint32_t> all_indices(std::uint32_t n) {
  std::vector<std::uint32_t> v(n);
  for (std::uint32_t i = 0; i < n; ++i) v[i] = i;
  return v;
}

class BenchRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The blocks in turn (not the default weighted draw), so every run has both.
    SceneSettings s = bench_scene(4);
    s.block_selection = "cycle";
    scene_ = new Scene(
        Scene::build(s, bench_terrain(), library({block::SolidKind::cube, block::SolidKind::octahedron}), "test"));
    single_ = new RunData(run_all(*scene_, all_indices(4), 1));
  }
  static void TearDownTestSuite() {
    delete single_;
    delete scene_;
  }
  static Scene* scene_;
  static RunData* single_;
};
Scene* BenchRun::scene_ = nullptr;
RunData* BenchRun::single_ = nullptr;

TEST_F(BenchRun, RecordsAreSaneAndCoverEveryRealization) {
  ASSERT_EQ(single_->records.size(), 4u);
  for (std::uint32_t i = 0; i < 4; ++i) {
    const Record& r = single_->records[i];
    EXPECT_EQ(r.realization, i);
    EXPECT_EQ(r.block, static_cast<std::int32_t>(i % 2));  // cycle selection
    EXPECT_NE(r.end, dda::EndReason::running);
    EXPECT_GT(r.max_speed, 0.0);
    EXPECT_GT(r.max_kinetic_energy, 0.0);
    EXPECT_GE(r.stop_class, 0);
    EXPECT_LT(r.stop_class, 5);
  }
  // Every realization passes over some hazard cells; reach counts each realization once
  // per cell, so no cell exceeds the number of realizations.
  ASSERT_FALSE(single_->hazard.cells().empty());
  for (const auto& [id, c] : single_->hazard.cells()) {
    EXPECT_LE(c.reach, 4u);
    EXPECT_EQ(c.energy.count(), c.reach);
  }
  // Released at x = 26 m, every block crosses the line at x = 30 m.
  std::vector<bool> crossed(4, false);
  for (const Crossing& c : single_->crossings)
    if (c.barrier == 0) crossed[c.realization] = true;
  EXPECT_EQ(crossed, std::vector<bool>(4, true));
  // Crossings of the lines lie on them, by a block going downslope: walking along the
  // line (toward +y) the block comes from the left (−x) and leaves to the right.
  for (const Crossing& c : single_->crossings) {
    EXPECT_GE(c.position, 0.0);
    EXPECT_LE(c.position, 20.0);
    EXPECT_EQ(c.direction, -1);
    EXPECT_GT(c.velocity.x(), 0.0);
  }
}

TEST_F(BenchRun, IdenticalAtOneTwoAndFourThreads) {
  testing::expect_same_run(*single_, run_all(*scene_, all_indices(4), 2));
  testing::expect_same_run(*single_, run_all(*scene_, all_indices(4), 4));
}

TEST_F(BenchRun, ThreeShardsMergeToTheSingleRun) {
  RunData merged;
  merged.hazard = HazardAccumulator(scene_->hazard_grid(), 0.01);
  for (std::uint32_t k = 0; k < 3; ++k) merged.append(run_all(*scene_, Shard{k, 3}.indices(4), 1));
  merged.sort("test");
  testing::expect_same_run(*single_, merged);
  // A realization present twice is refused.
  RunData twice = run_all(*scene_, {1}, 1);
  twice.append(run_all(*scene_, {1}, 1));
  EXPECT_THROW(twice.sort("shards"), core::InputError);
}

TEST_F(BenchRun, HazardTablesRoundTripExactly) {
  HazardAccumulator copy(scene_->hazard_grid(), 0.01);
  copy.merge(single_->hazard.table(), "table");
  RunData a;
  a.hazard = copy;
  RunData b;
  b.hazard = single_->hazard;
  testing::expect_same_run(a, b);
  auto bad = single_->hazard.table();
  bad.cell.back() = 10000;
  HazardAccumulator other(scene_->hazard_grid(), 0.01);
  EXPECT_THROW(other.merge(bad, "table"), core::InputError);
  // Maxima of one length but not the cells' are refused too.
  auto short_maxima = single_->hazard.table();
  short_maxima.speed_max.pop_back();
  HazardAccumulator third(scene_->hazard_grid(), 0.01);
  EXPECT_THROW(third.merge(short_maxima, "table"), core::InputError);
}

// A table of a file written before the maxima were kept has none: the cells' maxima are
// unknown (NaN), also after merging with a shard that has them; the rest is unchanged.
TEST_F(BenchRun, HazardMaximaOfOlderFilesAreUnknown) {
  auto old = single_->hazard.table();
  ASSERT_FALSE(old.speed_max.empty());
  for (const double v : old.speed_max) EXPECT_GT(v, 0.0);
  old.speed_max.clear();
  old.height_max.clear();
  HazardAccumulator merged(scene_->hazard_grid(), 0.01);
  merged.merge(old, "old file");
  merged.merge(single_->hazard);
  ASSERT_EQ(merged.cells().size(), single_->hazard.cells().size());
  for (const auto& [id, cell] : merged.cells()) {
    EXPECT_TRUE(std::isnan(cell.max_speed)) << id;
    EXPECT_TRUE(std::isnan(cell.max_height)) << id;
    EXPECT_EQ(cell.reach, 2 * single_->hazard.cells().at(id).reach) << id;
  }
}

// Every cell's statistics agree with a direct computation from the realizations' own
// per-cell values (the maxima of each path in the cell): at these low counts the
// accumulator keeps every value, so quantiles (type 7), means and maxima are exact.
TEST_F(BenchRun, CellStatisticsEqualADirectComputationFromThePaths) {
  std::map<std::int64_t, std::vector<CellVisit>> visits;
  for (std::uint32_t i = 0; i < 4; ++i)
    for (const CellVisit& v : run_realization(*scene_, i).cells) visits[v.cell].push_back(v);
  ASSERT_EQ(visits.size(), single_->hazard.cells().size());
  std::size_t multi = 0;
  for (const auto& [id, list] : visits) {
    const HazardAccumulator::Cell& cell = single_->hazard.cells().at(id);
    ASSERT_EQ(cell.reach, list.size()) << id;
    ASSERT_TRUE(cell.exact()) << id;
    multi += list.size() > 1;
    for (const HazardVariable variable : {HazardVariable::energy, HazardVariable::height, HazardVariable::speed}) {
      std::vector<double> x;
      for (const CellVisit& v : list)
        x.push_back(std::max(variable == HazardVariable::energy   ? v.energy
                             : variable == HazardVariable::height ? v.height
                                                                  : v.speed,
                             0.0));
      const stats::Sample direct(x);
      for (double p : {0.0, 0.1, 0.5, 0.9, 0.95, 0.99, 1.0})
        EXPECT_DOUBLE_EQ(cell.quantile(variable, p), direct.quantile(p)) << id << " p " << p;
      EXPECT_DOUBLE_EQ(cell.mean(variable), direct.mean()) << id;
      EXPECT_EQ(cell.max(variable), direct.max()) << id;
      // With two or more passages a high quantile never lies below the mean.
      if (x.size() > 1) {
        EXPECT_GE(cell.quantile(variable, 0.95), cell.mean(variable)) << id;
      }
    }
  }
  EXPECT_GT(multi, 0u);  // some cells were crossed by several realizations
}

// Exact values are kept up to kExactLimit passages and give way to the sketch above it;
// merging shards whose total exceeds the limit drops them, whatever the order.
TEST(HazardExactValues, KeptUpToTheLimitThenSketched) {
  const HazardGridSpec grid{0.0, 0.0, 1.0, 2, 1};
  HazardAccumulator a(grid, 0.01), b(grid, 0.01), whole(grid, 0.01);
  const auto limit = HazardAccumulator::kExactLimit;
  for (std::uint64_t k = 0; k < limit + 1; ++k) {
    const double x = static_cast<double>(k + 1);
    const std::vector<CellVisit> v = {{0, 10.0 * x, 0.1 * x, x}};
    (k % 2 ? a : b).add(v);
    whole.add(v);
    if (k + 1 == limit) {
      ASSERT_TRUE(whole.cells().at(0).exact());
      EXPECT_DOUBLE_EQ(whole.cells().at(0).quantile(HazardVariable::energy, 0.5), 5.0 * static_cast<double>(limit + 1));
    }
  }
  EXPECT_FALSE(whole.cells().at(0).exact());
  EXPECT_TRUE(whole.cells().at(0).exact_energy.empty());
  // Sketched: within α of the type-7 median 510 J of 10, 20, …, 1010 J.
  EXPECT_NEAR(whole.cells().at(0).quantile(HazardVariable::energy, 0.5), 510.0, 5.1);
  EXPECT_EQ(whole.cells().at(0).max(HazardVariable::energy), 10.0 * static_cast<double>(limit + 1));
  HazardAccumulator ab(grid, 0.01), ba(grid, 0.01);
  ab.merge(a);
  ab.merge(b);
  ba.merge(b.table(), "table");
  ba.merge(a.table(), "table");
  EXPECT_FALSE(ab.cells().at(0).exact());
  RunData x, y;
  x.hazard = ab;
  y.hazard = ba;
  testing::expect_same_run(x, y);
  // Two halves within the limit merge to the exact values of the whole, in order.
  HazardAccumulator c(grid, 0.01), d(grid, 0.01), cd(grid, 0.01);
  c.add({{1, 3.0, 0.3, 3.0}});
  d.add({{1, 1.0, 0.1, 1.0}});
  d.add({{1, 2.0, 0.2, 2.0}});
  cd.merge(c.table(), "table");
  cd.merge(d);
  ASSERT_TRUE(cd.cells().at(1).exact());
  EXPECT_EQ(cd.cells().at(1).exact_energy, (std::vector<double>{1.0, 2.0, 3.0}));
}

TEST(Barrier, CrossingOfAFreeFlightMatchesTheParabola) {
  // A cube thrown horizontally at 5 m/s from 10 m over a flat plane crosses x = 7 at
  // t = 1 s, z = 10 − g/2, with velocity (5, 0, −g), before it lands.
  SceneSettings s;
  s.release.points = {{2.0, 10.0}};
  s.release.height = 10.0;
  s.release.orientation = "fixed";
  s.release.velocity = {5.0, 0.0, 0.0};
  s.realizations = 1;
  s.outputs.barriers = {{"fence", {{7.0, 20.0}, {7.0, 0.0}}}};
  s.outputs.hazard_cell_size = 2.0;
  const Scene scene = Scene::build(s, flat_terrain(), library({block::SolidKind::cube}), "test");
  const RealizationResult r = run_realization(scene, 0);
  ASSERT_GE(r.crossings.size(), 1u);
  const Crossing& c = r.crossings.front();
  const double g = 9.81;
  // The engine's flight steps are the exact parabola; the crossing is interpolated on it:
  // errors are round-off of a few operations on O(10) values.
  EXPECT_NEAR(c.time, 1.0, 1e-9);
  EXPECT_NEAR(c.height, 10.0 - 0.5 * g, 1e-9);
  EXPECT_NEAR(c.position, 10.0, 1e-9);  // from (7, 20) toward (7, 0)
  EXPECT_NEAR(c.velocity.x(), 5.0, 1e-9);
  EXPECT_NEAR(c.velocity.z(), -g, 1e-9);
  const double mass = scene.blocks()[0].model.mass;
  EXPECT_NEAR(c.kinetic_energy, 0.5 * mass * (25.0 + g * g), 1e-9 * mass);
  // Walking along the line (toward −y) the block comes from the right (−x) to the left.
  EXPECT_EQ(c.direction, 1);
  // The hazard grid lies on the DEM grid (2 m cells centred on the DEM points, from
  // x = y = −1). The flight path at y = 10 (row 5) reaches the cells from x = 2 (column 1)
  // to beyond 7.
  ASSERT_DOUBLE_EQ(scene.hazard_grid().x0, -1.0);
  ASSERT_DOUBLE_EQ(scene.hazard_grid().y0, -1.0);
  std::vector<std::int64_t> row;
  for (const auto& v : r.cells)
    if (v.cell / scene.hazard_grid().nx == 5) row.push_back(v.cell % scene.hazard_grid().nx);
  for (std::int64_t i = 1; i <= 3; ++i) EXPECT_NE(std::find(row.begin(), row.end(), i), row.end()) << i;
  // In cell 3 (x in [5, 7), t in [0.6, 1.0)) the highest passage is at t = 0.6; the path
  // is sampled every quarter cell (0.5 m, 0.1 s of flight), so the recorded maximum lies
  // between z(0.7) and z(0.6).
  bool seen = false;
  for (const auto& v : r.cells)
    if (v.cell == 5 * scene.hazard_grid().nx + 3) {
      seen = true;
      EXPECT_LE(v.height, 10.0 - 0.5 * g * 0.36 + 1e-9);
      EXPECT_GE(v.height, 10.0 - 0.5 * g * 0.49);
    }
  EXPECT_TRUE(seen);
}

// The hazard cells hold, per cell, the largest kinetic energy, height and speed of the states
// the path passes through: here every step moves far less than a quarter cell, so those
// are the step ends, which a trajectory sampled at every step lists. The observer keeps
// a cell's maxima aside while the block stays in it and merges them when it leaves; the
// result must be that of merging every sample.
TEST(Hazard, CellsAreTheMaximaOfTheStepEnds) {
  SceneSettings s = bench_scene(1);
  s.engine.trajectory_interval = 1e-9;  // below Δt: a sample after every step
  // Every step nominal, so that the trajectory's samples are the observer's step ends (a
  // long flight step samples the trajectory at the nominal steps inside it as well).
  s.engine.flight_step_ratio = 1.0;
  const Scene scene = Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "test");
  const RealizationResult r = run_realization(scene, 0);
  ASSERT_GT(r.trajectory.size(), 100u);
  ASSERT_EQ(r.trajectory.size(), r.record.steps + 1);
  const double weight = scene.blocks()[0].model.mass * scene.blocks()[0].model.settings.gravity;
  std::map<std::int64_t, std::pair<double, double>> expected;
  std::map<std::int64_t, double> speed;
  std::size_t changes = 0;
  std::int64_t last = -1;
  for (const dda::TrajectorySample& t : r.trajectory) {
    const std::int64_t id = scene.hazard_grid().cell(t.position.x(), t.position.y());
    if (id < 0) continue;
    changes += id != last;
    last = id;
    const double kinetic = t.energy - weight * t.position.z();
    auto [it, fresh] = expected.try_emplace(id, kinetic, std::isfinite(t.height) ? t.height : 0.0);
    it->second.first = std::max(it->second.first, kinetic);
    if (std::isfinite(t.height)) it->second.second = std::max(it->second.second, t.height);
    speed[id] = std::max(speed[id], t.velocity.norm());
  }
  EXPECT_GT(changes, 3u);  // the path crosses several cells
  ASSERT_EQ(r.cells.size(), expected.size());
  for (const CellVisit& v : r.cells) {
    const auto it = expected.find(v.cell);
    ASSERT_NE(it, expected.end()) << v.cell;
    // The trajectory holds kinetic + potential energy: recovering the kinetic part costs
    // the round-off of m·g·z (~1e5 J) -- 1e-6 J is far above it and far below any
    // difference between two steps' energies.
    EXPECT_NEAR(v.energy, it->second.first, 1e-6) << v.cell;
    // The heights and velocities are the engine's own values in both.
    EXPECT_EQ(v.height, it->second.second) << v.cell;
    EXPECT_EQ(v.speed, speed[v.cell]) << v.cell;
  }
}

TEST(Release, ABlockReleasedAtRestOnASlopeStaysAtRest) {
  // SPEC §7: a cube set face down on a 20° plane (friction angle 35°, so tan 20° < μ) with
  // release.height 0 above its lowest point starts touching and never moves: the run ends
  // at rest after the dwell time, where it started.
  SceneSettings s;
  s.release.points = {{8.0, 5.0}};
  s.release.height = 0.0;
  s.release.height_reference = "lowest_point";
  s.release.orientation = "fixed";
  s.release.orientation_deg = {0.0, 20.0, 0.0};  // the cube's bottom face on the plane
  MaterialOverride rough;
  rough.name = "default";
  rough.friction_angle_mean_deg = 35.0;
  s.materials = {rough};
  s.stochastic.friction = false;
  s.realizations = 1;
  const Scene scene = Scene::build(s, testing::plane_terrain(20.0), library({block::SolidKind::cube}), "test");
  const RealizationResult r = run_realization(scene, 0);
  EXPECT_EQ(r.record.end, dda::EndReason::rest);
  // Its centroid starts half a side above the plane along the normal: 0.5/cos 20° vertically.
  const double plane_z = 12.0 * std::tan(20.0 * M_PI / 180.0);
  EXPECT_NEAR(r.record.release_position.z(), plane_z + 0.5 / std::cos(20.0 * M_PI / 180.0), 1e-12);
  // It only settles onto the penalty springs: mg cos 20°/(4k) ≈ 7e-9 m at the default k.
  EXPECT_LT((r.record.final_position - r.record.release_position).norm(), 1e-7);
  // At rest from the start, so it ends one dwell time (0.5 s) later.
  EXPECT_NEAR(r.record.time, scene.settings().engine.rest_dwell, 1e-3);
  EXPECT_EQ(r.record.impacts, 0u);
}

}  // namespace
}  // namespace talus::mc
