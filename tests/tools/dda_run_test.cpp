// End-to-end tests of the dda-run executable: run the built binary on a small scene,
// check exit codes, one-line messages and the run files (threads, shards and merge,
// kill and resume, MPI ranks, bad scenes).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../mc/mc_fixtures.hpp"
#include "tool_run.hpp"
#include "../mc/run_compare.hpp"
#include "talus/block/solids.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/run_file.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/vector.hpp"

namespace talus {
namespace {

namespace fs = std::filesystem;

using geometry::Vec3;
using Outcome = testing::ToolOutcome;
using testing::read_text;

// Six realizations of two blocks on a 20 m wide rough bench slope, flushed in chunks of
// two, with a barrier at the toe, a hazard grid and bench zones. Blocks start on the
// lowest slope and run at most 4 s, so the tests stay quick under the sanitizers.
const char* kScene = R"(schema_version: "1.0"
terrain: terrain.h5
block_file: blocks.h5
release:
  points: [[26.0, 10.0]]
  height: 2.5
engine:
  max_steps: 4000
realizations: 6
seed: 5
outputs:
  hazard_cell_size: 4
  chunk: 2
  barriers:
    - name: toe
      line: [[36, 0], [36, 20]]
stop_zones:
  - name: bench 1
    x_range: [5.5, 9]
  - name: slope
    x_range: [-1, 35.5]
  - name: run-out
    x_range: [35.5, 61]
)";

// A unit cube over the 45° plane z = 20 − x (x in [0, 20]), axis-aligned at (5, 5): with
// its centroid 0.3 m above the plane its uphill bottom edge is 0.7 m inside it.
const char* kPlaneScene = R"(terrain: plane.h5
block_file: cube.h5
release:
  points: [[5.0, 5.0]]
  height: 0.3
  orientation: fixed
realizations: 1
)";

class DdaRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("talus_dda_run_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    io::Provenance p;
    p.tool = "test";
    io::write_terrain_file((dir_ / "terrain.h5").string(), mc::testing::bench_terrain(0.1), p);
    io::write_block_file((dir_ / "blocks.h5").string(),
                         mc::testing::library({block::SolidKind::cube, block::SolidKind::octahedron}), p);
    std::ofstream(dir_ / "scene.yaml") << kScene;
    io::write_terrain_file((dir_ / "plane.h5").string(), mc::testing::plane_terrain(45.0), p);
    io::write_block_file((dir_ / "cube.h5").string(), mc::testing::library({block::SolidKind::cube}), p);
    std::ofstream(dir_ / "plane.yaml") << kPlaneScene;
    // The reference: one uninterrupted run on one thread.
    const Outcome r = run({"-c", "scene.yaml", "--threads", "1", "-o", "single.h5"});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static Outcome run(const std::vector<std::string>& args, const std::string& env = {},
                     const std::string& launcher = {}) {
    return testing::run_tool(testing::tool_path("dda-run"), args, dir_, env, launcher);
  }

  static io::RunFile load(const std::string& name) { return io::read_run_file((dir_ / name).string()); }

  static void expect_same_run(const io::RunFile& a, const io::RunFile& b) {
    mc::testing::expect_same_run(a.data, b.data);
    EXPECT_EQ(a.info.blocks, b.info.blocks);
    EXPECT_EQ(a.info.stop_classes, b.info.stop_classes);
  }

  static fs::path dir_;
};
fs::path DdaRun::dir_;

TEST_F(DdaRun, WritesOneRecordPerRealization) {
  const io::RunFile f = load("single.h5");
  EXPECT_EQ(f.info.realizations, 6u);
  EXPECT_EQ(f.info.shard, "0/1");
  EXPECT_EQ(f.info.blocks, (std::vector<std::string>{"cube", "octahedron"}));
  EXPECT_EQ(f.info.stop_classes, (std::vector<std::string>{"bench 1", "slope", "run-out", "other", "out of domain"}));
  ASSERT_EQ(f.data.records.size(), 6u);
  for (std::uint32_t i = 0; i < 6; ++i) EXPECT_EQ(f.data.records[i].realization, i);
  EXPECT_FALSE(f.data.hazard.cells().empty());
  EXPECT_FALSE(f.data.crossings.empty());  // released 10 m above the toe barrier
  EXPECT_NE(f.info.provenance.settings_yaml.find("realizations: 6"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "single.h5.journal"));  // removed once the output is complete
}

TEST_F(DdaRun, IdenticalRecordsAtAnyThreadCount) {
  for (const char* threads : {"2", "3"}) {
    const std::string out = std::string("threads") + threads + ".h5";
    const Outcome r = run({"-c", "scene.yaml", "--threads", threads, "-o", out});
    ASSERT_EQ(r.code, 0) << r.err;
    expect_same_run(load("single.h5"), load(out));
  }
}

TEST_F(DdaRun, ThreeShardsMergeToTheSingleRun) {
  for (const char* shard : {"0/3", "1/3", "2/3"}) {
    const Outcome r = run({"-c", "scene.yaml", "--shard", shard, "-o", std::string("shard") + shard[0] + ".h5"});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  EXPECT_EQ(load("shard1.h5").data.records.size(), 2u);  // realizations 1 and 4
  const Outcome m = run({"merge", "shard2.h5", "shard0.h5", "shard1.h5", "-o", "merged.h5"});
  ASSERT_EQ(m.code, 0) << m.err;
  const io::RunFile merged = load("merged.h5");
  EXPECT_EQ(merged.info.shard, "0/1");
  expect_same_run(load("single.h5"), merged);
  // A shard given twice repeats realizations: refused.
  const Outcome twice = run({"merge", "shard0.h5", "shard0.h5", "-o", "twice.h5"});
  EXPECT_EQ(twice.code, 3);
  EXPECT_NE(twice.err.find("appears twice"), std::string::npos) << twice.err;
  EXPECT_FALSE(fs::exists(dir_ / "twice.h5"));
}

TEST_F(DdaRun, MergeIgnoresTheChunkSizeButNotSettingsThatChangeRecords) {
  // Shards written in chunks of 1 and 5 (the scene's: 2) hold the records of the one run.
  ASSERT_EQ(run({"-c", "scene.yaml", "--shard", "0/2", "--set", "outputs.chunk=1", "-o", "chunk0.h5"}).code, 0);
  ASSERT_EQ(run({"-c", "scene.yaml", "--shard", "1/2", "--set", "outputs.chunk=5", "-o", "chunk1.h5"}).code, 0);
  const Outcome m = run({"merge", "chunk0.h5", "chunk1.h5", "-o", "chunk-merged.h5"});
  ASSERT_EQ(m.code, 0) << m.err;
  const io::RunFile merged = load("chunk-merged.h5");
  EXPECT_EQ(merged.info.shard, "0/1");
  expect_same_run(load("single.h5"), merged);
  // A setting that changes the records is refused, and named; so is another seed.
  ASSERT_EQ(run({"-c", "scene.yaml", "--shard", "1/2", "--set", "engine.max_steps=3000", "-o", "steps1.h5"}).code, 0);
  const Outcome steps = run({"merge", "chunk0.h5", "steps1.h5", "-o", "steps-merged.h5"});
  EXPECT_EQ(steps.code, 3);
  EXPECT_EQ(steps.err, "dda-run merge: error: steps1.h5: is not a shard of the same run as chunk0.h5 (the setting "
                       "engine.max_steps differs)\n");
  EXPECT_FALSE(fs::exists(dir_ / "steps-merged.h5"));
  ASSERT_EQ(run({"-c", "scene.yaml", "--shard", "1/2", "--set", "seed=6", "--set", "outputs.chunk=1", "-o",
                 "seed1.h5"}).code,
            0);
  const Outcome seed = run({"merge", "chunk0.h5", "seed1.h5", "-o", "seed-merged.h5"});
  EXPECT_EQ(seed.code, 3);
  EXPECT_NE(seed.err.find("seed1.h5: is not a shard of the same run as chunk0.h5 (the setting seed differs)"),
            std::string::npos)
      << seed.err;
  EXPECT_FALSE(fs::exists(dir_ / "seed-merged.h5"));
}

TEST_F(DdaRun, KilledRunResumesToTheUninterruptedResult) {
  // Dies (as if killed) right after the first chunk of two realizations reached the journal.
  const Outcome killed = run({"-c", "scene.yaml", "--threads", "2", "-o", "resumed.h5"},
                             "TALUS_DDA_RUN_ABORT_AFTER_CHUNKS=1");
  EXPECT_EQ(killed.code, 137);
  EXPECT_FALSE(fs::exists(dir_ / "resumed.h5"));
  ASSERT_TRUE(fs::exists(dir_ / "resumed.h5.journal"));
  // Not without --resume, and not with other settings.
  const Outcome again = run({"-c", "scene.yaml", "-o", "resumed.h5"});
  EXPECT_EQ(again.code, 3);
  EXPECT_NE(again.err.find("add --resume"), std::string::npos) << again.err;
  const Outcome other = run({"-c", "scene.yaml", "--set", "seed=6", "--resume", "-o", "resumed.h5"});
  EXPECT_EQ(other.code, 3);
  EXPECT_NE(other.err.find("other settings or inputs (the setting seed differs)"), std::string::npos) << other.err;
  // outputs.chunk only sets how the journal is written: resumed in chunks of 3.
  const Outcome resumed = run({"-c", "scene.yaml", "--set", "outputs.chunk=3", "--resume", "-v", "-o", "resumed.h5"});
  ASSERT_EQ(resumed.code, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("4 realizations to run (2 already done)"), std::string::npos) << resumed.err;
  EXPECT_FALSE(fs::exists(dir_ / "resumed.h5.journal"));
  expect_same_run(load("single.h5"), load("resumed.h5"));
}

TEST_F(DdaRun, TrajectoriesWithXdmfSidecar) {
  const Outcome r = run({"-c", "scene.yaml", "--set", "realizations=2", "--set", "engine.trajectory_interval=0.05",
                         "-o", "traj.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  const io::RunFile f = load("traj.h5");
  ASSERT_GT(f.data.trajectories.size(), 10u);
  EXPECT_EQ(f.data.trajectories.front().realization, 0u);
  EXPECT_EQ(f.data.trajectories.back().realization, 1u);
  const std::string xmf = read_text(dir_ / "traj.xmf");
  EXPECT_NE(xmf.find("TopologyType=\"Mixed\" NumberOfElements=\"2\""), std::string::npos);
  EXPECT_NE(xmf.find("traj.h5:/trajectories/position"), std::string::npos);
}

// A 2 × 1 × 0.5 m slab released 600 m above the plane and spun, in torque-free flight for
// 10 s, read back from the trajectory's orientation and angular velocity: spun about a
// non-principal axis, L = J_world·ω keeps its length and direction and ½ωᵀJω its value to
// 1e-9; spun about its intermediate axis (y, moments 1.25 : 4.25 : 5) with a 1e-3
// perturbation, that axis flips against L and back.
TEST_F(DdaRun, TorqueFreeSlabKeepsItsAngularMomentumAndFlips) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::box;
  spec.volume = 0.0;
  spec.dimensions = Vec3(2.0, 1.0, 0.5);
  io::Provenance p;
  p.tool = "test";
  const block::Block slab = block::make_block("slab", block::make_solid(spec, "test"), 2800.0, "test");
  io::write_block_file((dir_ / "slab.h5").string(), {slab}, p);
  const auto fly = [&](const std::string& spin, const std::string& out) {
    const Outcome r = run({"-c", "plane.yaml", "--set", "block_file=slab.h5", "--set", "release.height=600",
                           "--set", "release.angular_velocity=" + spin, "--set", "engine.max_time=10",
                           "--set", "engine.trajectory_interval=0.01", "-o", out});
    EXPECT_EQ(r.code, 0) << r.err;
    return load(out).data.trajectories;
  };
  const auto momentum = [&](const dda::TrajectorySample& t) {
    const geometry::Mat3 r = t.orientation.toRotationMatrix();
    return Vec3(r * slab.inertia * r.transpose() * t.angular_velocity);
  };
  const auto path = fly("[1.5, -2.0, 4.0]", "slab-spin.h5");
  ASSERT_GT(path.size(), 990u);
  EXPECT_NEAR(path.back().sample.time, 10.0, 0.02);
  const Vec3 l0 = momentum(path.front().sample);
  const double e0 = 0.5 * path.front().sample.angular_velocity.dot(l0);
  double worst_length = 0.0, worst_turn = 0.0, worst_energy = 0.0;
  bool turned = false;
  for (const auto& t : path) {
    EXPECT_EQ(t.sample.motion, dda::Motion::flight);
    const Vec3 l = momentum(t.sample);
    worst_length = std::max(worst_length, std::abs(l.norm() - l0.norm()) / l0.norm());
    worst_turn = std::max(worst_turn, l.normalized().cross(l0.normalized()).norm());
    worst_energy = std::max(worst_energy, std::abs(0.5 * t.sample.angular_velocity.dot(l) - e0) / e0);
    turned = turned || (t.sample.angular_velocity - path.front().sample.angular_velocity).norm() > 1.0;
  }
  EXPECT_LT(worst_length, 1e-9);
  EXPECT_LT(worst_turn, 1e-9);
  EXPECT_LT(worst_energy, 1e-9);
  EXPECT_TRUE(turned) << "ω should precess";

  const auto tumble = fly("[0.0, 5.0, 0.005]", "slab-tumble.h5");
  ASSERT_GT(tumble.size(), 990u);
  const Vec3 l = momentum(tumble.front().sample).normalized();
  double least = 1.0;
  for (const auto& t : tumble) least = std::min(least, (t.sample.orientation * Vec3::UnitY()).dot(l));
  EXPECT_LT(least, -0.99) << "the intermediate axis should flip";
  const std::string xmf = read_text(dir_ / "slab-tumble.xmf");
  EXPECT_NE(xmf.find("AttributeType=\"Tensor\""), std::string::npos);
  EXPECT_NE(xmf.find("slab-tumble.h5:/trajectories/angular_velocity"), std::string::npos);
}

TEST_F(DdaRun, BadScenesAreRefusedWithOneLine) {
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--set", "terrain=missing.h5"}, "missing.h5: cannot open file"},
      {{"--set", "block_file=nowhere.h5"}, "nowhere.h5: cannot open file"},
      {{"--set", "schema_version=\"2.0\""}, "scene schema version 2.0 is not supported"},
      // Counts out of their range are named by their --set key (or the file's line).
      {{"--set", "realizations=0"}, "--set realizations: must be in [1, 4294967295], got 0"},
      {{"--set", "realizations=-5"}, "--set realizations: must be in [1, 4294967295], got -5"},
      {{"--set", "release.points=[[80, 10]]"}, "release point (80, 10) is outside the terrain"},
      {{"--set", "blocks=[R7]"}, "block 'R7' is not in the block file"},
      {{"--set", "terrain=scene.yaml"}, "scene.yaml: not an HDF5 file"},
      // An engine value out of its range is named by its --set key.
      {{"--set", "engine.penalty_omega=2.9"}, "--set engine.penalty_omega: must be in [3, 300], got 2.9"},
      {{"--set", "engine.time_step=1"}, "--set engine.time_step: must be in (0, 0.05] s, got 1"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"-c", "scene.yaml"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    args.insert(args.end(), {"-o", "bad.h5"});
    const Outcome r = run(args);
    EXPECT_EQ(r.code, 3) << c.message << ": " << r.err;
    EXPECT_EQ(r.err.rfind("dda-run: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "bad.h5"));
    EXPECT_FALSE(fs::exists(dir_ / "bad.h5.journal"));
  }
  // An engine value out of its range in the scene file, named with its line.
  std::string with_omega = kScene;
  with_omega.replace(with_omega.find("engine:\n"), 8, "engine:\n  penalty_omega: 2.9\n");
  std::ofstream(dir_ / "omega.yaml") << with_omega;
  const Outcome omega = run({"-c", "omega.yaml", "-o", "bad.h5"});
  EXPECT_EQ(omega.code, 3);
  EXPECT_NE(omega.err.find("omega.yaml:"), std::string::npos) << omega.err;
  EXPECT_NE(omega.err.find("engine.penalty_omega: must be in [3, 300], got 2.9"), std::string::npos) << omega.err;
  // An unknown key in the scene file, named with its line.
  std::ofstream(dir_ / "typo.yaml") << std::string(kScene) + "realisations: 3\n";
  const Outcome typo = run({"-c", "typo.yaml", "-o", "bad.h5"});
  EXPECT_EQ(typo.code, 3);
  EXPECT_NE(typo.err.find("typo.yaml:"), std::string::npos) << typo.err;
  EXPECT_NE(typo.err.find("unknown key 'realisations'"), std::string::npos) << typo.err;
  // Usage errors.
  EXPECT_EQ(run({"-c", "scene.yaml", "--shard", "3/3", "-o", "bad.h5"}).code, 2);
  EXPECT_EQ(run({"-c", "scene.yaml", "--threads", "x", "-o", "bad.h5"}).code, 2);
  const Outcome no_output = run({"-c", "scene.yaml"});
  EXPECT_EQ(no_output.code, 2);
  EXPECT_NE(no_output.err.find("no output file given"), std::string::npos) << no_output.err;
  EXPECT_EQ(run({"merge", "-o", "bad.h5"}).code, 2);  // no shard given
}

// The toe barrier of kScene as a GeoJSON file (the bench terrain has no CRS and no
// shift), and two release lines with weights 3 and 1 as a GeoPackage.
void write_vector_inputs(const fs::path& dir) {
  std::ofstream(dir / "barriers.geojson") << R"({"type": "FeatureCollection", "features": [
  {"type": "Feature", "properties": {"label": "toe"},
   "geometry": {"type": "LineString", "coordinates": [[36, 0], [36, 20]]}}]})";
  io::VectorLayer lines{"release", io::VectorGeometry::line_string_z, {{"weight", io::FieldType::real}}, {}};
  lines.features.push_back({{{26.0, 4.0, 0.0}, {26.0, 8.0, 0.0}}, {3.0}});
  lines.features.push_back({{{27.0, 12.0, 0.0}, {27.0, 16.0, 0.0}}, {1.0}});
  io::write_vector_file((dir / "zones.gpkg").string(), "gpkg", {lines}, "");
}

TEST_F(DdaRun, ReleaseAndBarriersFromVectorFiles) {
  write_vector_inputs(dir_);
  // The toe read from a file: the same crossings, bit for bit, as the inline line.
  const Outcome barrier = run({"-c", "scene.yaml", "--set", "outputs.barriers=[{file: barriers.geojson, name_field: label}]",
                               "-o", "vector-barrier.h5"});
  ASSERT_EQ(barrier.code, 0) << barrier.err;
  const io::RunFile single = load("single.h5"), from_file = load("vector-barrier.h5");
  EXPECT_EQ(from_file.info.barriers, single.info.barriers);
  EXPECT_EQ(from_file.info.barrier_lines, single.info.barrier_lines);
  expect_same_run(single, from_file);
  ASSERT_FALSE(from_file.data.crossings.empty());
  EXPECT_EQ(from_file.data.crossings, single.data.crossings);
  // The run records the file it read among its inputs (a changed file is another run).
  EXPECT_NE(from_file.info.provenance.inputs.find("barriers.geojson (outputs.barriers[0].file, its only layer, 1 features, "
                                                  "fingerprint "),
            std::string::npos)
      << from_file.info.provenance.inputs;

  // Release lines from a GeoPackage: every block starts on one of them.
  const Outcome release = run({"-c", "scene.yaml", "--set", "release={kind: line, file: zones.gpkg, weight_field: weight}",
                               "-o", "vector-release.h5"});
  ASSERT_EQ(release.code, 0) << release.err;
  const io::RunFile released = load("vector-release.h5");
  ASSERT_EQ(released.data.records.size(), 6u);
  // The feature and point draws are functions of the realization: any thread count.
  ASSERT_EQ(run({"-c", "scene.yaml", "--set", "release={kind: line, file: zones.gpkg, weight_field: weight}",
                 "--threads", "1", "-o", "vector-release-1.h5"})
                .code,
            0);
  expect_same_run(released, load("vector-release-1.h5"));
  for (const auto& r : released.data.records) {
    const Vec3& p = r.release_position;
    EXPECT_TRUE((p.x() == 26.0 && p.y() >= 4.0 && p.y() <= 8.0) || (p.x() == 27.0 && p.y() >= 12.0 && p.y() <= 16.0))
        << r.realization << ": " << p.transpose();
  }

  // A run killed half-way does not resume after its release file changed (same name, same
  // settings, other zones): the run's inputs record the geometry read.
  const std::string zones = "release={kind: line, file: zones.gpkg, weight_field: weight}";
  ASSERT_EQ(run({"-c", "scene.yaml", "--set", zones, "-o", "vector-resumed.h5"}, "TALUS_DDA_RUN_ABORT_AFTER_CHUNKS=1").code,
            137);
  fs::copy_file(dir_ / "zones.gpkg", dir_ / "zones-kept.gpkg");
  io::VectorLayer moved{"release", io::VectorGeometry::line_string_z, {{"weight", io::FieldType::real}}, {}};
  moved.features.push_back({{{25.0, 4.0, 0.0}, {25.0, 8.0, 0.0}}, {3.0}});
  io::write_vector_file((dir_ / "zones.gpkg").string(), "gpkg", {moved}, "");
  const Outcome changed = run({"-c", "scene.yaml", "--set", zones, "--resume", "-o", "vector-resumed.h5"});
  EXPECT_EQ(changed.code, 3);
  EXPECT_NE(changed.err.find("other settings or inputs"), std::string::npos) << changed.err;
  fs::rename(dir_ / "zones-kept.gpkg", dir_ / "zones.gpkg");
  ASSERT_EQ(run({"-c", "scene.yaml", "--set", zones, "--resume", "-o", "vector-resumed.h5"}).code, 0);
  expect_same_run(released, load("vector-resumed.h5"));

  // Bad files: one line naming the file, exit code 3, no output.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"release={kind: line, file: nowhere.gpkg}", "dda-run: error: nowhere.gpkg: cannot open file"},
      {"release={kind: line, file: zones.gpkg, layer: zones}", "dda-run: error: zones.gpkg: has no layer 'zones' (it has: release)"},
      {"release={kind: polygon, file: zones.gpkg}", "dda-run: error: zones.gpkg: layer 'release', feature 1 is a Line String"},
      {"release={kind: line, file: zones.gpkg, weight_field: w}", "dda-run: error: zones.gpkg: layer 'release' has no field 'w'"},
      {"outputs.barriers=[{file: barriers.geojson, name_field: name}]", "dda-run: error: barriers.geojson: layer 'barriers' has no field 'name'"},
  };
  for (const auto& [set, message] : bad) {
    const Outcome r = run({"-c", "scene.yaml", "--set", set, "-o", "bad.h5"});
    EXPECT_EQ(r.code, 3) << r.err;
    EXPECT_EQ(r.err.rfind(message, 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "bad.h5"));
  }
}

TEST_F(DdaRun, ExampleScenesRun) {
  // The documented scenes of configs/scenes, on the full-width bench slope, with few
  // realizations.
  io::Provenance p;
  p.tool = "test";
  io::write_terrain_file((dir_ / "bench40.h5").string(), mc::testing::bench_terrain(0.1, 40.0), p);
  auto blocks = mc::testing::library({block::SolidKind::tetrahedron, block::SolidKind::cube});
  blocks[0].name = "R1";
  blocks[1].name = "R2";
  io::write_block_file((dir_ / "platonic.h5").string(), blocks, p);
  const fs::path configs = fs::path(TALUS_SOURCE_DIR) / "configs" / "scenes";
  int count = 0;
  for (const auto& e : fs::directory_iterator(configs)) {
    if (e.path().extension() != ".yaml") continue;
    ++count;
    const Outcome r = run({"-c", e.path().string(), "--set", "terrain=bench40.h5", "--set", "block_file=platonic.h5",
                           "--set", "realizations=2", "-o", "example.h5"});
    EXPECT_EQ(r.code, 0) << e.path() << ": " << r.err;
    EXPECT_EQ(load("example.h5").data.records.size(), 2u) << e.path();
  }
  EXPECT_GE(count, 2);
}


// The presets of docs/dda-run.md ("Presets"): each runs, --print-config shows the time
// step it documents, and a field given beside a preset wins over it.
TEST_F(DdaRun, PresetsRunAndPrintTheirSettings) {
  const std::vector<std::pair<std::string, std::string>> documented = {
      {"screening", "time_step: 0.002 "}, {"design", "time_step: 0.001 "}, {"research", "time_step: 0.0002 "}};
  for (const auto& [preset, line] : documented) {
    SCOPED_TRACE(preset);
    const Outcome printed = run({"-c", "scene.yaml", "--set", "engine.preset=" + preset, "--print-config"});
    ASSERT_EQ(printed.code, 0) << printed.err;
    EXPECT_NE(printed.out.find("preset: " + preset + " "), std::string::npos) << printed.out;
    EXPECT_NE(printed.out.find(line), std::string::npos) << printed.out;
    const Outcome r = run({"-c", "scene.yaml", "--set", "engine.preset=" + preset, "--set", "realizations=2",
                           "--threads", "1", "-o", "preset.h5"});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(load("preset.h5").data.records.size(), 2u);
  }
  const Outcome explicit_step = run({"-c", "scene.yaml", "--set", "engine.preset=screening", "--set",
                                     "engine.time_step=5e-4", "--print-config"});
  ASSERT_EQ(explicit_step.code, 0) << explicit_step.err;
  EXPECT_NE(explicit_step.out.find("time_step: 0.0005 "), std::string::npos) << explicit_step.out;
  const Outcome bad = run({"-c", "scene.yaml", "--set", "engine.preset=fast", "--print-config"});
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("screening, design, research"), std::string::npos) << bad.err;
}

TEST_F(DdaRun, BlockInTheGroundIsRefusedWithOneLine) {
  const Outcome r = run({"-c", "plane.yaml", "-o", "refused.h5"});
  EXPECT_EQ(r.code, 3) << r.err;
  // Named by the line of release.height, the setting to change.
  EXPECT_EQ(r.err.rfind("dda-run: error: plane.yaml:5: release of realization 0 at (5, 5): block 'cube' reaches 0.7 m "
                        "into the ground (at x 4.5, y ",
                        0),
            0u)
      << r.err;
  EXPECT_NE(r.err.find("raise release.height by at least 0.7 m, or set release.clearance to lift\n"), std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // Refused before anything ran: no output, no journal to resume.
  EXPECT_FALSE(fs::exists(dir_ / "refused.h5"));
  EXPECT_FALSE(fs::exists(dir_ / "refused.h5.journal"));
}

TEST_F(DdaRun, LiftedOrLoweredBlocksStartTouchingTheGround) {
  // Lifted by 0.7 m, or lowered onto the plane (height 0 above its lowest point): the
  // centroid starts 1 m above the plane's 15 m at x = 5 (round-off of O(20) values).
  const std::vector<std::vector<std::string>> ways = {
      {"--set", "release.clearance=lift"},
      {"--set", "release.height_reference=lowest_point", "--set", "release.height=0"}};
  for (const auto& way : ways) {
    std::vector<std::string> args = {"-c", "plane.yaml", "-o", "placed.h5"};
    args.insert(args.end(), way.begin(), way.end());
    const Outcome r = run(args);
    ASSERT_EQ(r.code, 0) << way[1] << ": " << r.err;
    const io::RunFile f = load("placed.h5");
    ASSERT_EQ(f.data.records.size(), 1u);
    const Vec3 start = f.data.records[0].release_position;
    EXPECT_EQ(start.x(), 5.0);
    EXPECT_NEAR(start.z(), 16.0, 1e-9) << way[1];
  }
  // 0.25 m above its lowest point: the centroid 0.25 m higher.
  const Outcome r = run({"-c", "plane.yaml", "--set", "release.height_reference=lowest_point", "--set",
                         "release.height=0.25", "-o", "placed.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(load("placed.h5").data.records[0].release_position.z(), 16.25, 1e-9);
}

// The end-of-run summary line (timings vary) and what follows it.
std::string after_summary(const std::string& err, const std::string& output, std::size_t realizations) {
  const std::string head = "dda-run: " + output + ": " + std::to_string(realizations) + " realizations in ";
  if (err.rfind(head, 0) != 0) return "no summary line: " + err;
  return err.substr(err.find('\n') + 1);
}

TEST_F(DdaRun, WarnsOnceWhenRealizationsDoNotEndAtRest) {
  // Cut at 50 steps, no realization reaches rest: one warning line, counts by end reason.
  const Outcome cut = run({"-c", "scene.yaml", "--set", "engine.max_steps=50", "-o", "cut.h5"});
  ASSERT_EQ(cut.code, 0) << cut.err;
  EXPECT_NE(cut.err.find("; ends: 6 step_limit\n"), std::string::npos) << cut.err;
  EXPECT_EQ(after_summary(cut.err, "cut.h5", 6),
            "dda-run: warning: cut.h5: 6 of 6 realizations did not end at rest: 6 step_limit\n");
  // A step of 20 ms would move the cube more than 3 % of its diameter at the fastest the
  // slope allows: the scene shortens it (said with -v), and no warning follows.
  const Outcome shortened = run({"-c", "scene.yaml", "--set", "engine.time_step=0.02", "-v", "-o", "short.h5"});
  ASSERT_EQ(shortened.code, 0) << shortened.err;
  EXPECT_NE(shortened.err.find("block 'cube': time_step "), std::string::npos) << shortened.err;
  EXPECT_EQ(shortened.err.find("warning: short.h5: 6 of 6 realizations moved"), std::string::npos) << shortened.err;
  // Kept at 20 ms (max_step_travel 0), it moves the cube that far: one line more, saying so.
  const Outcome coarse = run({"-c", "scene.yaml", "--set", "engine.time_step=0.02", "--set",
                              "engine.max_step_travel=0", "-o", "coarse.h5"});
  ASSERT_EQ(coarse.code, 0) << coarse.err;
  EXPECT_NE(coarse.err.find("dda-run: warning: coarse.h5: 6 of 6 realizations moved more than 3 % of their block's "
                            "diameter in one time step at their fastest (up to "),
            std::string::npos)
      << coarse.err;
  // The lifted cube slides down the 45° plane and leaves it at its foot.
  const Outcome off = run({"-c", "plane.yaml", "--set", "release.clearance=lift", "-o", "off.h5"});
  ASSERT_EQ(off.code, 0) << off.err;
  EXPECT_EQ(after_summary(off.err, "off.h5", 1),
            "dda-run: warning: off.h5: 1 of 1 realizations did not end at rest: 1 left_terrain\n");
  EXPECT_EQ(load("off.h5").data.records[0].end, dda::EndReason::left_terrain);
  // Set face down on the flat run-out of the bench slope, the cube rests: no warning.
  const Outcome rest = run({"-c", "plane.yaml", "--set", "terrain=terrain.h5", "--set", "release.points=[[50, 10]]",
                            "--set", "release.height_reference=lowest_point", "--set", "release.height=0", "-o",
                            "rest.h5"});
  ASSERT_EQ(rest.code, 0) << rest.err;
  EXPECT_EQ(after_summary(rest.err, "rest.h5", 1), "");
  EXPECT_NE(rest.err.find("; ends: 1 rest\n"), std::string::npos) << rest.err;
  EXPECT_EQ(load("rest.h5").data.records[0].end, dda::EndReason::rest);
  // Joining shards reports the whole run once more.
  for (const char* shard : {"0/2", "1/2"})
    ASSERT_EQ(run({"-c", "scene.yaml", "--set", "engine.max_steps=50", "--shard", shard, "-o",
                   std::string("cut") + shard[0] + ".h5"})
                  .code,
              0);
  const Outcome merged = run({"merge", "cut0.h5", "cut1.h5", "-o", "cut-all.h5"});
  ASSERT_EQ(merged.code, 0) << merged.err;
  EXPECT_EQ(merged.err, "dda-run merge: warning: cut-all.h5: 6 of 6 realizations did not end at rest: 6 step_limit\n");
}

#ifdef TALUS_TEST_MPIEXEC
TEST_F(DdaRun, TwoMpiRanksEqualTheSingleRun) {
  const Outcome r = run({"-c", "scene.yaml", "-o", "mpi.h5"}, {},
                        std::string(TALUS_TEST_MPIEXEC) + " --allow-run-as-root --oversubscribe -n 2");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "mpi.rank0.h5"));
  EXPECT_FALSE(fs::exists(dir_ / "mpi.rank1.h5"));
  expect_same_run(load("single.h5"), load("mpi.h5"));
}
#endif

}  // namespace
}  // namespace talus
