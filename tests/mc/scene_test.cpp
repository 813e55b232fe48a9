#include "talus/mc/scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <tuple>

#include "../support/temp_path.hpp"
#include "mc_fixtures.hpp"
#include "talus/core/error.hpp"
#include "talus/mc/clearance.hpp"
#include "talus/mc/realization.hpp"
#include "talus/mc/runner.hpp"
#include "talus/terrain/material_classes.hpp"

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
      {[](SceneSettings& s) { s.realizations = 0; }, "scene.yaml: realizations = 0: must be in [1, 4294967295]"},
      {[](SceneSettings& s) { s.realizations = -3; }, "scene.yaml: realizations = -3: must be in [1, 4294967295]"},
      {[](SceneSettings& s) { s.outputs.chunk = 0; }, "outputs.chunk = 0: must be in [1, 4294967295]"},
      {[](SceneSettings& s) { s.release.points = {{70.0, 10.0}}; }, "release point (70, 10) is outside the terrain"},
      {[](SceneSettings& s) { s.release.kind = "line"; }, "needs at least 2 points"},
      {[](SceneSettings& s) { s.release.points.clear(); },
       "release.kind 'point' needs at least 1 point in release.points, got 0"},
      {[](SceneSettings& s) {
         s.release.height_reference = "lowest_point";
         s.release.height = -0.1;
       },
       "release.height -0.1 m is negative"},
      {[](SceneSettings& s) { s.release.clearance_gap = -1.0; }, "release.clearance_gap = -1: must be in [0, 1000] m"},
      {[](SceneSettings& s) { s.blocks = {"R9"}; }, "block 'R9' is not in the block file (it has: cube)"},
      {[](SceneSettings& s) { s.materials = {restitution_override("rock", 0.5)}; }, "material 'rock' is not in the terrain file"},
      {[](SceneSettings& s) { s.materials = {restitution_override("slope", -0.5)}; }, "materials[0].restitution_mean = -0.5: must be in [0, 1]"},
      {[](SceneSettings& s) { s.outputs.barriers = {{"b", {{1.0, 1.0}}}}; }, "barrier 'b' needs at least 2"},
      {[](SceneSettings& s) { s.stop_zones = {{"z", {3.0, 1.0}, {}}}; }, "x_range must be [x_min, x_max]"},
      // Names of crossings' statistics must differ; lines and zones beside the terrain
      // would give zeros that look like results.
      {[](SceneSettings& s) { s.outputs.barriers[1].name = s.outputs.barriers[0].name; },
       "barrier name 'lower slope' is taken by another barrier"},
      {[](SceneSettings& s) { s.outputs.barriers = {{"far", {{100.0, 0.0}, {100.0, 20.0}}}}; },
       "barrier 'far' lies outside the terrain (input coordinates: x in [0, 60], y in [0, 20]), so no block can "
       "reach it"},
      // A polygon drawn crossing itself (a bowtie: zero area, or the area of neither lobe).
      {[](SceneSettings& s) {
         s.release.kind = "polygon";
         s.release.points = {{20.0, 5.0}, {30.0, 15.0}, {30.0, 5.0}, {20.0, 15.0}};
       },
       "release polygon crosses itself (edges 1 and 3 of release.points meet)"},
      {[](SceneSettings& s) { s.stop_zones = {{"toe", {}, {{40.0, 5.0}, {50.0, 15.0}, {50.0, 5.0}, {40.0, 12.0}}}}; },
       "stop zone 'toe': polygon crosses itself (edges 1 and 3 meet)"},
      {[](SceneSettings& s) { s.stop_zones = {{"beyond", {70.0, 80.0}, {}}}; },
       "stop zone 'beyond' lies outside the terrain"},
      {[](SceneSettings& s) { s.stop_zones = {{"pond", {}, {{-9.0, -9.0}, {-5.0, -9.0}, {-5.0, -5.0}}}}; },
       "stop zone 'pond' lies outside the terrain"},
      {[](SceneSettings& s) { s.outputs.hazard_cell_size = -1.0; }, "outputs.hazard_cell_size = -1: must be in [0, inf) m"},
      {[](SceneSettings& s) { s.engine.time_step = -1.0; }, "engine.time_step = -1: must be in (0, 0.05] s"},
      // The engine's refusal of one block names it and the engine's key.
      {[](SceneSettings& s) { s.engine.penalty_stiffness = 1e4; },
       "scene.yaml: block 'cube': engine.penalty_stiffness = 10000 N/m gives this block"},
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

// A scene's material override may name a class: it sets the six parameters, and the
// fields given beside it override them.
// A release point inside the terrain's extent but over a hole in a TIN's surface is
// refused for having no terrain under it, not for lying outside the terrain.
TEST(Scene, ReleaseOverAHoleHasNoTerrainUnderIt) {
  terrain::Terrain t;
  // A 4 × 4 m square of 1 m cells with the middle four cells left out.
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) t.mesh.vertices.emplace_back(i, j, 0.0);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      if ((i == 1 || i == 2) && (j == 1 || j == 2)) continue;
      const int a = j * 5 + i;
      t.mesh.triangles.push_back({a, a + 1, a + 6});
      t.mesh.triangles.push_back({a, a + 6, a + 5});
    }
  t.material_of_triangle.assign(t.mesh.triangles.size(), 0);
  t.materials = bench_terrain().materials;
  t.materials.resize(1);
  SceneSettings s = bench_scene();
  s.release.points = {{2.0, 2.0}};
  s.stop_zones.clear();
  s.outputs.barriers.clear();
  std::string message;
  try {
    Scene::build(s, t, library({block::SolidKind::cube}), "scene.yaml");
  } catch (const core::InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("release point (2, 2) has no terrain under it (a hole or gap"), std::string::npos)
      << message;
  s.release.points = {{0.5, 0.5}};
  message.clear();
  try {
    Scene::build(s, t, library({block::SolidKind::cube}), "scene.yaml");
  } catch (const core::InputError& e) {
    message = e.what();
  }
  EXPECT_EQ(message.find("release point"), std::string::npos) << message;
}

TEST(Scene, MaterialOverrideByClass) {
  SceneSettings s = bench_scene();
  MaterialOverride o;
  o.name = "slope";
  o.class_name = "compact_scree";
  o.lateral_tilt_sd_deg = 6.0;
  s.materials = {o};
  const Scene scene = Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "scene.yaml");
  const terrain::Material& m = scene.materials().at(0);
  const terrain::MaterialClass& c = *terrain::find_material_class("compact_scree");
  EXPECT_EQ(m.class_name, "compact_scree");
  EXPECT_EQ(m.restitution_mean, c.restitution_mean);
  EXPECT_EQ(m.restitution_scale, c.restitution_scale);
  EXPECT_EQ(m.friction_angle_mean_deg, c.friction_angle_mean_deg);
  EXPECT_EQ(m.lateral_tilt_sd_deg, 6.0);
  o.class_name = "granite";
  s.materials = {o};
  EXPECT_NE(build_error(s).find("materials[0].class = 'granite': must be one of none, bedrock"), std::string::npos)
      << build_error(s);
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

// Scene coordinates are the terrain's input coordinates (frame: input, the default): the
// origin shift stays inside the terrain file. frame: local reads them in the shifted frame.
TEST(Scene, CoordinatesAreTheTerrainsInputCoordinates) {
  terrain::Terrain shifted = bench_terrain();
  shifted.origin_shift = Vec3(2601000.0, 1180000.0, 0.0);
  const Eigen::Vector2d shift(2601000.0, 1180000.0);
  SceneSettings input = bench_scene();
  for (auto& p : input.release.points) p = {p[0] + shift.x(), p[1] + shift.y()};
  for (auto& b : input.outputs.barriers)
    for (auto& p : b.line) p = {p[0] + shift.x(), p[1] + shift.y()};
  for (auto& z : input.stop_zones) {
    for (auto& x : z.x_range) x += shift.x();
    for (auto& p : z.polygon) p = {p[0] + shift.x(), p[1] + shift.y()};
  }
  SceneSettings local = bench_scene();
  local.frame = "local";
  const auto cube = library({block::SolidKind::cube});
  const Scene a = Scene::build(input, shifted, cube, "s");
  const Scene b = Scene::build(local, shifted, cube, "s");
  const Scene plain = Scene::build(bench_scene(), bench_terrain(), cube, "s");
  // The same scene in the engine's frame, whichever way it was written.
  ASSERT_EQ(a.barriers().size(), plain.barriers().size());
  for (std::size_t k = 0; k < a.barriers().size(); ++k) {
    EXPECT_EQ(a.barriers()[k].line, plain.barriers()[k].line);
    EXPECT_EQ(b.barriers()[k].line, plain.barriers()[k].line);
  }
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(7.0, 3.0), Eigen::Vector2d(12.0, 3.0), Eigen::Vector2d(40.0, 3.0)}) {
    EXPECT_EQ(a.classify(p, false), plain.classify(p, false));
    EXPECT_EQ(b.classify(p, false), plain.classify(p, false));
  }
  EXPECT_EQ(a.release_zone(), plain.release_zone());
  EXPECT_EQ(b.release_zone(), plain.release_zone());

  // A scene written in the shifted frame without saying so: one line that says what to do.
  const std::string message = [&] {
    try {
      Scene::build(bench_scene(), shifted, cube, "scene.yaml");
    } catch (const core::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  }();
  EXPECT_NE(message.find("is outside the terrain (input coordinates: x in [2601000, 2601060]"), std::string::npos)
      << message;
  EXPECT_NE(message.find("set frame: local"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);

  // So are barriers and stop zones written in the shifted frame (the release right).
  const auto local_line_message = [&](const std::function<void(SceneSettings&)>& edit) {
    SceneSettings s = input;
    edit(s);
    try {
      Scene::build(s, shifted, cube, "scene.yaml");
    } catch (const core::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  for (const std::string& m :
       {local_line_message([](SceneSettings& s) { s.outputs.barriers = bench_scene().outputs.barriers; }),
        local_line_message([](SceneSettings& s) { s.stop_zones = {{"run-out", {35.5, 61.0}, {}}}; })}) {
    EXPECT_NE(m.find("lies outside the terrain (input coordinates: x in [2601000, 2601060]"), std::string::npos) << m;
    EXPECT_NE(m.find("it lies on the terrain in its local frame"), std::string::npos) << m;
    EXPECT_NE(m.find("set frame: local"), std::string::npos) << m;
  }
}

// A block that could travel more than max_step_travel of its diameter in one nominal step
// at the fastest its scene allows (free fall over the relief plus the release velocity)
// gets a shorter time_step; the bench's 1 m³ blocks keep theirs.
TEST(Scene, SmallFastBlocksGetAShorterTimeStep) {
  const auto step_of = [](const SceneSettings& s, double volume) {
    block::SolidSpec spec;
    spec.volume = volume;
    const std::vector<block::Block> lib = {
        block::make_block("cube", block::make_solid(spec, "test"), 2800.0, "test")};
    return Scene::build(s, bench_terrain(), lib, "s").blocks()[0].model.settings.time_step;
  };
  const SceneSettings bench = bench_scene();
  EXPECT_EQ(step_of(bench, 1.0), 1e-3);
  // Fired at 50 m/s, a 0.001 m³ cube (diameter 0.173 m) may reach 50 + √(2g·drop) m/s,
  // the drop being the relief, 8 σ of roughness, the release height and its diameter:
  // 3 % of its diameter per step is about 0.07 ms.
  SceneSettings fast = bench;
  fast.release.velocity = {50.0, 0.0, 0.0};
  const double step = step_of(fast, 0.001);
  const geometry::Aabb relief = bench_terrain().mesh.bounds();
  const double fastest =
      50.0 + std::sqrt(2.0 * 9.81 *
                       (relief.hi.z() - relief.lo.z() + 8.0 * 0.1 + fast.release.height + std::sqrt(3.0) * 0.1));
  EXPECT_NEAR(step, 0.03 * std::sqrt(3.0) * 0.1 / fastest, 1e-9);
  EXPECT_LT(step, 1.2e-4);
  // Off, or with a stiffness given in N/m (its Ω is the step's), the step is time_step.
  SceneSettings off = fast;
  off.engine.max_step_travel = 0.0;
  EXPECT_EQ(step_of(off, 0.001), 1e-3);
}

TEST(Scene, HazardGridCoversTheTerrain) {
  // The bench terrain's DEM: 2 m cells, points x = 0 … 60, y = 0 … 20 (31 × 11). Hazard
  // cells of 4 m lie on the DEM grid: they start at the DEM's own raster corner (−1, −1)
  // and cover its 31 × 11 cells (62 m × 22 m).
  const Scene scene = Scene::build(bench_scene(), bench_terrain(), library({block::SolidKind::cube}), "s");
  const HazardGridSpec& g = scene.hazard_grid();
  EXPECT_DOUBLE_EQ(g.x0, -1.0);
  EXPECT_DOUBLE_EQ(g.y0, -1.0);
  EXPECT_EQ(g.nx, 16);  // ceil(62 / 4)
  EXPECT_EQ(g.ny, 6);   // ceil(22 / 4)
  EXPECT_EQ(g.cell(0.0, 0.0), 0);
  EXPECT_EQ(g.cell(5.0, 4.5), 17);
  EXPECT_EQ(g.cell(-1.1, 1.0), -1);
  EXPECT_EQ(g.cell(1.0, 23.1), -1);
}

TEST(Scene, HazardCellsOfTheDemsSizeAreItsCells) {
  SceneSettings s = bench_scene();
  s.outputs.hazard_cell_size = 2.0;
  const HazardGridSpec g = Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "s").hazard_grid();
  EXPECT_DOUBLE_EQ(g.x0, -1.0);
  EXPECT_EQ(g.nx, 31);
  EXPECT_EQ(g.ny, 11);
  EXPECT_EQ(g.cell(6.0, 4.0), 2 * 31 + 3);  // the cell centred on DEM point (6, 4)
  s.outputs.hazard_cell_size = 0.5;          // a divisor: four cells per DEM cell edge
  EXPECT_EQ(Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "s").hazard_grid().nx, 124);
  s.outputs.hazard_cell_size = 3.0;  // neither: refused
  EXPECT_THROW(Scene::build(s, bench_terrain(), library({block::SolidKind::cube}), "s"), core::InputError);
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
  // The closing vertex given again (as GeoJSON writes rings) is no crossing.
  SceneSettings closed = s;
  closed.release.points.push_back(closed.release.points.front());
  EXPECT_NO_THROW(Scene::build(closed, bench_terrain(), library({block::SolidKind::cube}), "s"));
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

// A unit cube over the 45° plane z = 20 − x, released at (5, 5) with a fixed orientation
// (axis-aligned unless told): its uphill bottom edge lies 1 m lower than the centroid
// relative to the plane, so a centroid `height` above the plane leaves a gap height − 1.
SceneSettings plane_scene(double height) {
  SceneSettings s;
  s.release.points = {{5.0, 5.0}};
  s.release.height = height;
  s.release.orientation = "fixed";
  s.realizations = 1;
  return s;
}

struct PlaneRelease {
  Scene scene;
  terrain::Surface ground;
  explicit PlaneRelease(const SceneSettings& s)
      : scene(Scene::build(s, testing::plane_terrain(45.0), library({block::SolidKind::cube}), "plane.yaml")),
        ground(scene.base_surface().realization(std::nullopt)) {}
  ReleaseDraw draw(std::uint32_t i = 0) const { return draw_release(scene, ground, i); }
  double gap(const ReleaseDraw& d) const {
    return vertical_clearance(scene.blocks()[0].model, d.release.position, d.release.orientation, ground).gap;
  }
};

std::string draw_error(const PlaneRelease& p) {
  try {
    p.draw();
  } catch (const core::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Release, RefusesABlockStartingInTheGround) {
  // Centroid 0.3 m above the plane: the cube reaches 0.7 m into the uphill ground.
  const std::string message = draw_error(PlaneRelease(plane_scene(0.3)));
  EXPECT_EQ(message.rfind("plane.yaml: release of realization 0 at (5, 5): block 'cube' reaches 0.7 m into the "
                          "ground (at x 4.5, y ",
                          0),
            0u)
      << message;
  EXPECT_NE(message.find("raise release.height by at least 0.7 m, or set release.clearance to lift"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  // 1.2 m leaves a gap of 0.2 m: accepted, and the centroid is where the scene says.
  const PlaneRelease clear(plane_scene(1.2));
  EXPECT_NEAR(clear.draw().release.position.z(), 15.0 + 1.2, 1e-12);
  // Unless a larger gap is required.
  SceneSettings s = plane_scene(1.2);
  s.release.clearance_gap = 0.5;
  const std::string near = draw_error(PlaneRelease(s));
  EXPECT_NE(near.find("block 'cube' is only 0.2 m above the ground"), std::string::npos) << near;
  EXPECT_NE(near.find("less than release.clearance_gap 0.5 m: raise release.height by at least 0.3 m"),
            std::string::npos)
      << near;
}

TEST(Release, LiftRaisesTheBlockJustClearOfTheGround) {
  // Lifted vertically by the 0.7 m it reached into the ground (plus the gap asked for):
  // the gap is then exactly the one asked for (round-off of sums of O(20) values).
  for (const double gap : {0.0, 0.05}) {
    SceneSettings s = plane_scene(0.3);
    s.release.clearance = "lift";
    s.release.clearance_gap = gap;
    const PlaneRelease p(s);
    const ReleaseDraw d = p.draw();
    EXPECT_NEAR(d.release.position.x(), 5.0, 0.0);
    EXPECT_NEAR(d.release.position.z(), 16.0 + gap, 1e-12);
    EXPECT_NEAR(p.gap(d), gap, 1e-12);
  }
  // A block already clear enough is not moved.
  SceneSettings s = plane_scene(1.2);
  s.release.clearance = "lift";
  EXPECT_EQ(PlaneRelease(s).draw().release.position.z(), 15.0 + 1.2);
}

TEST(Release, LowestPointHeightIsTheGapUnderTheBlock) {
  // Height 0 puts the cube on the plane, touching along its uphill bottom edge.
  for (const double height : {0.0, 0.25}) {
    SceneSettings s = plane_scene(height);
    s.release.height_reference = "lowest_point";
    const PlaneRelease p(s);
    const ReleaseDraw d = p.draw();
    EXPECT_NEAR(d.release.position.z(), 16.0 + height, 1e-12);
    EXPECT_NEAR(p.gap(d), height, 1e-12);
  }
  // Random orientations on the rough bench slope (each realization its own ground): every
  // block starts touching its ground, to round-off.
  SceneSettings s = bench_scene(20);
  s.release.kind = "line";
  s.release.points = {{1.0, 5.0}, {50.0, 15.0}};
  s.release.height = 0.0;
  s.release.height_reference = "lowest_point";
  const Scene scene = Scene::build(s, bench_terrain(0.2), library({block::SolidKind::tetrahedron, block::SolidKind::cube}), "s");
  for (std::uint32_t i = 0; i < 20; ++i) {
    const terrain::Surface ground = scene.base_surface().realization(i);
    const ReleaseDraw d = draw_release(scene, ground, i);
    const dda::Model& m = scene.blocks()[static_cast<std::size_t>(d.block)].model;
    EXPECT_NEAR(vertical_clearance(m, d.release.position, d.release.orientation, ground).gap, 0.0, 1e-9) << i;
  }
}

// A drop test from a fixed elevation: the centroid at `height` in the scene's frame
// (input coordinates: the terrain's origin shift taken off), whatever the ground below;
// a block that would start in the ground is refused or lifted as with a centroid height.
TEST(Release, ElevationPlacesTheCentroidAtThatAbsoluteHeight) {
  terrain::Terrain shifted = testing::plane_terrain(45.0);
  shifted.origin_shift = Vec3(2601000.0, 1180000.0, 400.0);
  SceneSettings s = plane_scene(0.0);
  for (auto& p : s.release.points) p = {p[0] + 2601000.0, p[1] + 1180000.0};
  s.release.height_reference = "elevation";
  s.release.height = 420.25;  // m: the plane is at z 15 (local) under (5, 5), 415 in input coordinates
  const auto cube = library({block::SolidKind::cube});
  const Scene scene = Scene::build(s, shifted, cube, "drop.yaml");
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  const ReleaseDraw d = draw_release(scene, ground, 0);
  EXPECT_EQ(d.release.position.z(), 20.25);
  EXPECT_EQ(d.release.position.x(), 5.0);
  // The same drop written in the local frame.
  SceneSettings local = plane_scene(20.25);
  local.frame = "local";
  local.release.height_reference = "elevation";
  EXPECT_EQ(draw_release(Scene::build(local, shifted, cube, "drop.yaml"), ground, 0).release.position.z(), 20.25);
  // An elevation in the ground: refused with the height to add, or lifted clear.
  s.release.height = 415.3;
  try {
    draw_release(Scene::build(s, shifted, cube, "drop.yaml"), ground, 0);
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("reaches 0.7 m into the ground"), std::string::npos) << e.what();
  }
  s.release.clearance = "lift";
  const ReleaseDraw lifted = draw_release(Scene::build(s, shifted, cube, "drop.yaml"), ground, 0);
  EXPECT_NEAR(lifted.release.position.z(), 16.0, 1e-12);
}

TEST(Release, CheckReleasesReportsTheLowestFailingRealization) {
  // Random orientations 1.17 m above the 45° plane: a cube reaches into it when its
  // support along (1, 0, 1)/√2, between 0.5 and 0.87 m, exceeds 1.17/√2 m. The check names
  // the first of them at any thread count.
  SceneSettings s = plane_scene(1.19);
  s.release.orientation = "random";
  s.realizations = 40;
  const PlaneRelease p(s);
  std::string first;
  std::uint32_t refused = 0;
  for (std::uint32_t i = 0; i < 40; ++i) try {
      p.draw(i);
    } catch (const core::InputError& e) {
      if (first.empty()) first = e.what();
      ++refused;
    }
  // Which orientations reach into the plane is fixed by the seed (deterministic draws).
  EXPECT_EQ(refused, 8u);
  ASSERT_EQ(first.rfind("plane.yaml: release of realization 9 at (5, 5): block 'cube' reaches ", 0), 0u) << first;
  std::vector<std::uint32_t> all(40);
  for (std::uint32_t i = 0; i < 40; ++i) all[i] = i;
  for (const unsigned threads : {1u, 2u, 3u}) {
    try {
      check_releases(p.scene, all, threads);
      ADD_FAILURE() << "no error at " << threads << " threads";
    } catch (const core::InputError& e) {
      EXPECT_EQ(std::string(e.what()), first) << threads;
    }
  }
  s.release.clearance = "lift";
  EXPECT_NO_THROW(check_releases(PlaneRelease(s).scene, all, 2));
}

// x, y and z of the "(at x …, y …, z …)" of a release message (NaN without one).
Vec3 message_point(const std::string& message) {
  Vec3 p = Vec3::Constant(std::nan(""));
  const auto at = message.find("(at x ");
  if (at != std::string::npos) std::sscanf(message.c_str() + at, "(at x %lf, y %lf, z %lf)", &p.x(), &p.y(), &p.z());
  return p;
}

// A block placed in the ground on a terrain with an origin shift: the message gives the
// release point and the deepest point in the terrain's input coordinates, as the scene
// was written, not in the shifted frame the engine works in (frame: local keeps that one).
TEST(Release, ErrorsGivePositionsInTheTerrainsInputCoordinates) {
  terrain::Terrain shifted = testing::plane_terrain(45.0);
  const Vec3 shift(2601000.0, 1180000.0, 400.0);
  shifted.origin_shift = shift;
  const auto cube = library({block::SolidKind::cube});
  auto error = [&](const SceneSettings& s) {
    try {
      const Scene scene = Scene::build(s, shifted, cube, "site.yaml");
      draw_release(scene, scene.base_surface().realization(std::nullopt), 0);
    } catch (const core::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SceneSettings input = plane_scene(0.3);
  for (auto& p : input.release.points) p = {p[0] + shift.x(), p[1] + shift.y()};
  SceneSettings local = plane_scene(0.3);
  local.frame = "local";
  const std::string in_input = error(input), in_local = error(local);
  EXPECT_EQ(in_input.rfind("site.yaml: release of realization 0 at (2601005, 1180005): block 'cube' reaches 0.7 m "
                           "into the ground (at x 2601004.5, y 11800",
                           0),
            0u)
      << in_input;
  EXPECT_EQ(in_local.rfind("site.yaml: release of realization 0 at (5, 5): block 'cube' reaches 0.7 m into the "
                           "ground (at x 4.5, y ",
                           0),
            0u)
      << in_local;
  // The same point, shifted; the messages print 10 significant digits, so a 7-digit
  // coordinate keeps 3 decimals.
  const Vec3 a = message_point(in_input), b = message_point(in_local);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k] + shift[k], 1e-3) << k << ": " << in_input;
  EXPECT_NEAR(a.z(), 414.8, 1e-9);  // the cube's uphill bottom edge: 15 + 0.3 − 0.5 m local
  // A block too near the ground: the same point, also in input coordinates.
  input.release.height = 1.2;
  input.release.clearance_gap = 0.5;
  const std::string near = error(input);
  EXPECT_EQ(near.rfind("site.yaml: release of realization 0 at (2601005, 1180005): block 'cube' is only 0.2 m above "
                       "the ground (at x 2601004.5, y 11800",
                       0),
            0u)
      << near;
  EXPECT_NEAR(message_point(near).z(), 415.7, 1e-9);
  EXPECT_EQ(near.find('\n'), std::string::npos);
}

// The blocks of realizations 0 … n−1 (on the smooth ground).
std::vector<std::int32_t> block_draws(const Scene& scene, std::uint32_t n) {
  std::vector<std::int32_t> blocks;
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < n; ++i) blocks.push_back(draw_release(scene, ground, i).block);
  return blocks;
}

// Block weights are honoured by default: each realization draws its block with the
// library's weights (one of weight 0 never), a pure function of the seed and the index;
// cycle still takes them in turn.
TEST(Release, BlocksAreDrawnByTheirWeightsByDefault) {
  EXPECT_EQ(SceneSettings{}.block_selection, "weighted");
  auto blocks = library({block::SolidKind::cube, block::SolidKind::octahedron, block::SolidKind::tetrahedron});
  blocks[0].weight = 3.0;
  blocks[1].weight = 1.0;
  blocks[2].weight = 0.0;
  SceneSettings s = bench_scene();
  s.release.clearance = "lift";
  const Scene scene = Scene::build(s, bench_terrain(), blocks, "s");
  constexpr std::uint32_t n = 800;
  const std::vector<std::int32_t> drawn = block_draws(scene, n);
  // Within 4.5 binomial standard deviations of n·3/4 (the draws are fixed by the seed: a
  // check of the method, not a flaky one).
  EXPECT_NEAR(static_cast<double>(std::count(drawn.begin(), drawn.end(), 0)), 0.75 * n, 4.5 * std::sqrt(n * 0.75 * 0.25));
  EXPECT_EQ(std::count(drawn.begin(), drawn.end(), 2), 0);
  // The same draws from another scene of the same seed; other ones from another seed.
  EXPECT_EQ(block_draws(Scene::build(s, bench_terrain(), blocks, "s"), n), drawn);
  s.seed = 12;
  EXPECT_NE(block_draws(Scene::build(s, bench_terrain(), blocks, "s"), n), drawn);
  // Cycle: block i mod 3, whatever the weights.
  s.block_selection = "cycle";
  const Scene cycled = Scene::build(s, bench_terrain(), blocks, "s");
  const terrain::Surface ground = cycled.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 6; ++i) EXPECT_EQ(draw_release(cycled, ground, i).block, static_cast<std::int32_t>(i % 3));
  // Nothing to draw from: refused, with the way out.
  s.block_selection = "weighted";
  for (auto& b : blocks) b.weight = 0.0;
  try {
    Scene::build(s, bench_terrain(), blocks, "s.yaml");
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "s.yaml: every block has sampling weight 0, so block_selection weighted has none to "
                                     "draw: give some a weight (block-gen 'weight') or set block_selection: cycle");
  }
  // One block is used whatever its weight.
  EXPECT_NO_THROW(Scene::build(s, bench_terrain(), {blocks[0]}, "s.yaml"));
}

// A file of orientations at `name` in the temporary directory, holding `text`.
std::string orientation_file(const std::string& name, const std::string& text) {
  const std::string path = talus::testing::temp_path("mc_scene", name);
  std::ofstream(path) << text;
  return path;
}

// Orientations from a file: with blocks cycled, B consecutive realizations share a row, so
// B·N realizations meet every block in every row; else row i mod N. A header row and
// comments are skipped; Euler rows are orientation_deg's rotations.
TEST(Release, OrientationsFromAFileAreTakenInTurn) {
  const double h = std::sqrt(0.5);
  const std::vector<Eigen::Quaterniond> rows = {Eigen::Quaterniond(h, 0.0, 0.0, h), Eigen::Quaterniond(0.0, 1.0, 0.0, 0.0),
                                                Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5)};
  SceneSettings s = bench_scene();
  s.release.clearance = "lift";
  s.release.orientation = "list";
  s.release.orientation_file = orientation_file(
      "q.txt", "q0\tq1\tq2\tq3\n# from the data's drop conditions\n0.7071067812 0 0 0.7071067812\n0 1 0 0\n\n"
               "0.5, 0.5, -0.5, 0.5  # the last\n");
  s.block_selection = "cycle";
  const auto blocks = library({block::SolidKind::cube, block::SolidKind::octahedron});
  const Scene cycled = Scene::build(s, bench_terrain(), blocks, "s.yaml");
  const terrain::Surface ground = cycled.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 12; ++i) {
    const ReleaseDraw d = draw_release(cycled, ground, i);
    EXPECT_EQ(d.block, static_cast<std::int32_t>(i % 2));
    EXPECT_LT((d.release.orientation.coeffs() - rows[(i / 2) % 3].coeffs()).norm(), 1e-10) << i;
  }
  s.block_selection = "weighted";
  const Scene one = Scene::build(s, bench_terrain(), {blocks[0]}, "s.yaml");
  for (std::uint32_t i = 0; i < 6; ++i)
    EXPECT_LT((draw_release(one, ground, i).release.orientation.coeffs() - rows[i % 3].coeffs()).norm(), 1e-10) << i;
  // Euler rows: the rotation orientation_deg gives.
  s.release.orientation_format = "euler_zyx_deg";
  s.release.orientation_file = orientation_file("e.txt", "30 -20 75\n");
  const Eigen::Quaterniond euler = draw_release(Scene::build(s, bench_terrain(), {blocks[0]}, "s.yaml"), ground, 5).release.orientation;
  s.release.orientation = "fixed";
  s.release.orientation_file.clear();
  s.release.orientation_deg = {30.0, -20.0, 75.0};
  EXPECT_EQ(draw_release(Scene::build(s, bench_terrain(), {blocks[0]}, "s.yaml"), ground, 5).release.orientation.coeffs(),
            euler.coeffs());
  // A quarter turn about the vertical of y-up axes is one about z.
  s.release.orientation = "list";
  s.release.orientation_format = "quaternion";
  s.release.orientation_up_axis = "y";
  s.release.orientation_file = orientation_file("y.txt", "0.7071067811865476 0 0.7071067811865476 0\n");
  const Eigen::Quaterniond turned = draw_release(Scene::build(s, bench_terrain(), {blocks[0]}, "s.yaml"), ground, 0).release.orientation;
  EXPECT_LT((turned.coeffs() - Eigen::Quaterniond(h, 0.0, 0.0, h).coeffs()).norm(), 1e-12);
}

TEST(Release, RefusesBadOrientationFilesWithOneLineReasons) {
  const std::string missing = talus::testing::temp_path("mc_scene", "none.txt");
  const std::string three = orientation_file("three.txt", "w x y z\n1 0 0\n");
  const std::string scaled = orientation_file("scaled.txt", "1 0 0 0\n2 0 0 0\n");
  const std::string empty = orientation_file("empty.txt", "# nothing\n");
  const std::string text = orientation_file("text.txt", "1 0 0 0\none two three four\n");
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"list", "", "scene.yaml: release.orientation list needs release.orientation_file"},
      {"random", three, "release.orientation_file needs release.orientation: list (it is random)"},
      {"list", missing, missing + ": cannot open the release orientation file"},
      {"list", three, three + ": line 2: expected 4 numbers (a quaternion w x y z), got 3"},
      {"list", scaled, scaled + ": line 2: quaternion norm 2 is not 1 (w x y z, scalar first)"},
      {"list", empty, empty + ": the release orientation file has no orientations"},
      {"list", text, text + ": line 2: expected 4 numbers (a quaternion w x y z), got 'one two three four'"},
  };
  for (const auto& [orientation, file, message] : cases) {
    SceneSettings s = bench_scene();
    s.release.orientation = orientation;
    s.release.orientation_file = file;
    const std::string error = build_error(s);
    EXPECT_NE(error.find(message), std::string::npos) << error;
  }
}

// Three release points written inline: each realization starts at one of them, all
// equally likely (the rule of a file of Point features without weight_field, drawn by
// the same code), the same ones for the same seed.
TEST(Release, SeveralPointsAreDrawnWithEqualProbability) {
  SceneSettings s = bench_scene();
  const std::vector<Eigen::Vector2d> points = {{3.0, 10.0}, {18.0, 6.0}, {26.0, 14.0}};
  s.release.points.clear();
  for (const auto& p : points) s.release.points.push_back({p.x(), p.y()});
  s.release.clearance = "lift";
  const auto cube = library({block::SolidKind::cube});
  const Scene scene = Scene::build(s, bench_terrain(), cube, "s");
  EXPECT_EQ(scene.release_zone(), points);
  constexpr std::uint32_t n = 600;
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  auto assignment = [&](const Scene& sc) {
    std::vector<int> which;
    for (std::uint32_t i = 0; i < n; ++i) {
      const Eigen::Vector2d xy = draw_release(sc, ground, i).release.position.head<2>();
      const auto it = std::find(points.begin(), points.end(), xy);
      EXPECT_NE(it, points.end()) << "realization " << i << " starts at " << xy.transpose();
      which.push_back(static_cast<int>(it - points.begin()));
    }
    return which;
  };
  const std::vector<int> which = assignment(scene);
  // Within 4.5 binomial standard deviations of n/3 each (fixed by the seed).
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(static_cast<double>(std::count(which.begin(), which.end(), k)), n / 3.0, 4.5 * std::sqrt(n * (1.0 / 3.0) * (2.0 / 3.0)))
        << "point " << k;
  // Same seed, same assignment; another seed, another one.
  EXPECT_EQ(assignment(Scene::build(s, bench_terrain(), cube, "s")), which);
  SceneSettings other = s;
  other.seed = 12;
  EXPECT_NE(assignment(Scene::build(other, bench_terrain(), cube, "s")), which);
  // The draws of a release file holding the same three Point features, bit for bit.
  SceneSettings file = s;
  file.release.points = ReleaseSettings{}.points;
  file.release.file = "points.gpkg";
  SceneVectors vectors;
  for (const auto& p : points) vectors.release.push_back({"feature", "", std::nullopt, {{{p}}}});
  const Scene from_file = Scene::build(file, bench_terrain(), cube, "s", vectors);
  for (std::uint32_t i = 0; i < 50; ++i) {
    const ReleaseDraw a = draw_release(scene, ground, i), b = draw_release(from_file, ground, i);
    EXPECT_EQ(a.release.position, b.release.position) << i;
    EXPECT_EQ(a.release.orientation.coeffs(), b.release.orientation.coeffs()) << i;
  }
}

// One release point draws exactly what it did before several were allowed (values of
// main ea1e533): nothing is drawn to choose it, so records of one-point scenes keep
// their bits.
TEST(Release, OnePointDrawsAsItAlwaysDid) {
  SceneSettings s = bench_scene(3);
  s.block_selection = "cycle";
  const Scene scene =
      Scene::build(s, bench_terrain(), library({block::SolidKind::cube, block::SolidKind::octahedron}), "s");
  const std::array<std::array<double, 5>, 3> expected = {{
      {0x1.902a35e310174p+3, 0x1.c5eacd4fdb2b2p-3, 0x1.3a69b867250e6p-2, -0x1.36f4afba578eep-6, -0x1.d9c527afe8adcp-1},
      {0x1.8c777db645eb1p+3, 0x1.edd1d72321cbap-3, -0x1.8c7ffe9486aeep-1, -0x1.83e249255c58fp-5, 0x1.2a804b988e279p-1},
      {0x1.8ab7e31dba1e9p+3, 0x1.9147351cf9461p-4, -0x1.ea7be400fccbap-1, 0x1.13ba0297ff5ecp-2, 0x1.b7b764d07b5b6p-7},
  }};
  for (std::uint32_t i = 0; i < 3; ++i) {
    const ReleaseDraw d = draw_release(scene, scene.base_surface().realization(i), i);
    const auto& e = expected[i];
    EXPECT_EQ(d.release.position, Vec3(26.0, 10.0, e[0])) << i;
    const Eigen::Quaterniond& q = d.release.orientation;
    const std::array<double, 4> wxyz = {q.w(), q.x(), q.y(), q.z()};
    EXPECT_EQ(wxyz, (std::array<double, 4>{e[1], e[2], e[3], e[4]})) << i;
  }
}

}  // namespace
}  // namespace talus::mc
