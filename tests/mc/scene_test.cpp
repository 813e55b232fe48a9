#include "talus/mc/scene.hpp"

#include <gtest/gtest.h>

#include <functional>

#include "mc_fixtures.hpp"
#include "talus/core/error.hpp"
#include "talus/mc/realization.hpp"

namespace talus::mc {
namespace {

using testing::bench_scene;
using testing::bench_terrain;
using testing::library;

MaterialOverride restitution_override(const std::string& name, double mean) {
  MaterialOverride o;
  o.name = name;
  o.restitution_mean = mean;
  return o;
}

// The message of the InputError that building `s` throws ("" if none).
std::string build_error(const SceneSettings& s) {
  try {
    Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "scene.yaml");
  } catch (const core::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Scene, RefusesBadScenesWithOneLineReasons) {
  const std::vector<std::pair<std::function<void(SceneSettings&)>, std::string>> cases = {
      {[](SceneSettings& s) { s.schema_version = "2.0"; }, "scene schema version 2.0 is not supported"},
      {[](SceneSettings& s) { s.schema_version = "x"; }, "is not MAJOR.MINOR"},
      {[](SceneSettings& s) { s.realizations = 0; }, "realizations must be positive, got 0"},
      {[](SceneSettings& s) { s.realizations = -3; }, "realizations must be positive, got -3"},
      {[](SceneSettings& s) { s.outputs.chunk = 0; }, "outputs.chunk must be positive"},
      {[](SceneSettings& s) { s.release.points = {{70.0, 10.0}}; }, "release point (70, 10) is outside the terrain"},
      {[](SceneSettings& s) { s.release.kind = "line"; }, "needs at least 2 points"},
      {[](SceneSettings& s) { s.release.height = 0.5; }, "puts block 'cube' into the ground"},
      {[](SceneSettings& s) { s.blocks = {"R9"}; }, "block 'R9' is not in the block file (it has: cube)"},
      {[](SceneSettings& s) { s.materials = {restitution_override("rock", 0.5)}; }, "material 'rock' is not in the terrain file"},
      {[](SceneSettings& s) { s.materials = {restitution_override("slope", -0.5)}; }, "material 'slope': values must be finite"},
      {[](SceneSettings& s) { s.outputs.barriers = {{"b", {{1.0, 1.0}}}}; }, "barrier 'b' needs at least 2"},
      {[](SceneSettings& s) { s.stop_zones = {{"z", {3.0, 1.0}, {}}}; }, "x_range must be [x_min, x_max]"},
      {[](SceneSettings& s) { s.outputs.hazard_cell_size = -1.0; }, "hazard_cell_size must be >= 0"},
      {[](SceneSettings& s) { s.engine.time_step = -1.0; }, "dda settings"},
  };
  for (const auto& [edit, expected] : cases) {
    SceneSettings s = bench_scene();
    edit(s);
    const std::string message = build_error(s);
    EXPECT_NE(message.find(expected), std::string::npos) << "got: " << message << "\nexpected: " << expected;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
  EXPECT_EQ(build_error(bench_scene()), "");
}

TEST(Scene, ClassifiesStopsByZoneInOrder) {
  const Scene scene = Scene::build(bench_scene(), bench_terrain(), library({block::SolidKind::cube}), "s");
  EXPECT_EQ(scene.stop_classes(), (std::vector<std::string>{"bench 1", "slope", "run-out", "other", "out of domain"}));
  EXPECT_EQ(scene.classify({7.0, 3.0}, false), 0);   // bench before slope: first match wins
  EXPECT_EQ(scene.classify({12.0, 3.0}, false), 1);
  EXPECT_EQ(scene.classify({40.0, 3.0}, false), 2);
  EXPECT_EQ(scene.classify({80.0, 3.0}, false), 3);
  EXPECT_EQ(scene.classify({40.0, 3.0}, true), 4);
}

TEST(Scene, HazardGridCoversTheTerrain) {
  const Scene scene = Scene::build(bench_scene(), bench_terrain(), library({block::SolidKind::cube}), "s");
  const HazardGridSpec& g = scene.hazard_grid();
  EXPECT_EQ(g.nx, 15);  // 60 m / 4 m
  EXPECT_EQ(g.ny, 5);   // 20 m / 4 m
  EXPECT_EQ(g.cell(0.0, 0.0), 0);
  EXPECT_EQ(g.cell(5.0, 4.5), 16);
  EXPECT_EQ(g.cell(-0.1, 1.0), -1);
  EXPECT_EQ(g.cell(1.0, 20.5), -1);
}

TEST(Shard, ParsesAndSplitsRoundRobin) {
  const Shard s = Shard::parse("1/3");
  EXPECT_EQ(s.index, 1u);
  EXPECT_EQ(s.count, 3u);
  EXPECT_EQ(s.indices(8), (std::vector<std::uint32_t>{1, 4, 7}));
  EXPECT_EQ(s.text(), "1/3");
  for (const char* bad : {"3/3", "1", "a/2", "1/0", "-1/2", "1/2x", ""}) EXPECT_THROW(Shard::parse(bad), core::UsageError) << bad;
}

TEST(Release, DrawsAreFunctionsOfSeedAndIndex) {
  SceneSettings s = bench_scene();
  s.release.kind = "polygon";
  s.release.points = {{1.0, 5.0}, {4.0, 5.0}, {4.0, 15.0}, {1.0, 15.0}};
  s.block_selection = "weighted";
  const Scene scene = Scene::build(s, bench_terrain(), library({block::SolidKind::cube, block::SolidKind::octahedron}), "s");
  const terrain::Surface ground = scene.base_surface().realization(3);
  const ReleaseDraw a = draw_release(scene, ground, 3);
  const ReleaseDraw b = draw_release(scene, ground, 3);
  const ReleaseDraw c = draw_release(scene, ground, 4);
  EXPECT_EQ(a.release.position, b.release.position);
  EXPECT_EQ(a.release.orientation.coeffs(), b.release.orientation.coeffs());
  EXPECT_NE(a.release.position, c.release.position);
  // Inside the polygon, 2.5 m above the realized ground there; a unit quaternion.
  EXPECT_GE(a.release.position.x(), 1.0);
  EXPECT_LE(a.release.position.x(), 4.0);
  EXPECT_NEAR(a.release.position.z() - ground.height_at(a.release.position.x(), a.release.position.y())->z, 2.5,
              1e-12);  // one addition
  EXPECT_NEAR(a.release.orientation.norm(), 1.0, 1e-15);
  // Weighted selection with equal weights picks both blocks over a few draws.
  int first = 0;
  for (std::uint32_t i = 0; i < 40; ++i) first += draw_release(scene, ground, i).block == 0 ? 1 : 0;
  EXPECT_GT(first, 5);
  EXPECT_LT(first, 35);
}

}  // namespace
}  // namespace talus::mc
