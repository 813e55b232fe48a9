#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "talus/core/error.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/materials.hpp"

namespace talus::terrain {
namespace {

// A 10 x 10 m flat grid of 1 m cells with materials "default", "rock" and "scree".
Terrain flat_terrain() {
  DemGrid dem;
  dem.spec = GridSpec{0.0, 0.0, 1.0, 1.0, 11, 11};
  dem.z.assign(dem.spec.point_count(), 0.0);
  Terrain t = build_grid_terrain(dem, Diagonal::alternating, 1, "flat");
  t.materials.push_back(Material{"rock"});
  t.materials.push_back(Material{"scree"});
  return t;
}

Vec3 centroid(const Terrain& t, std::size_t k) {
  const auto& tri = t.mesh.triangles[k];
  return (t.mesh.vertices[tri[0]] + t.mesh.vertices[tri[1]] + t.mesh.vertices[tri[2]]) / 3.0;
}

TEST(AssignZones, LastContainingZoneWins) {
  Terrain t = flat_terrain();
  const std::vector<MaterialZone> zones{
      {"rock", {{0, 0}, {6, 0}, {6, 10}, {0, 10}}},     // x < 6
      {"scree", {{4, 4}, {4, 8}, {8, 8}, {8, 4}}},      // clockwise square over it
  };
  assign_zones(t, zones, "zones.yaml");
  std::size_t counts[3] = {0, 0, 0};
  for (std::size_t k = 0; k < t.mesh.triangle_count(); ++k) {
    const Vec3 c = centroid(t, k);
    std::int32_t expected = 0;
    if (c.x() < 6.0) expected = 1;
    if (c.x() > 4.0 && c.x() < 8.0 && c.y() > 4.0 && c.y() < 8.0) expected = 2;
    EXPECT_EQ(t.material_of_triangle[k], expected) << k;
    ++counts[t.material_of_triangle[k]];
  }
  // 4 x 4 cells of scree, 6 x 10 − 2 x 4 of rock, 2 triangles per cell.
  EXPECT_EQ(counts[2], 32u);
  EXPECT_EQ(counts[1], 2u * (60u - 8u));
}

TEST(AssignZones, NonConvexPolygon) {
  Terrain t = flat_terrain();
  // An L shape: the notch [5, 10] x [5, 10] stays default.
  assign_zones(t, {{"rock", {{0, 0}, {10, 0}, {10, 5}, {5, 5}, {5, 10}, {0, 10}}}}, "zones.yaml");
  for (std::size_t k = 0; k < t.mesh.triangle_count(); ++k) {
    const Vec3 c = centroid(t, k);
    EXPECT_EQ(t.material_of_triangle[k], (c.x() > 5.0 && c.y() > 5.0) ? 0 : 1) << k;
  }
}

TEST(AssignZones, BadZonesAreInputErrors) {
  Terrain t = flat_terrain();
  try {
    assign_zones(t, {{"mud", {{0, 0}, {1, 0}, {1, 1}}}}, "zones.yaml");
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "zones.yaml: zone 0 (material 'mud'): unknown material 'mud' (known: default, rock, scree)");
  }
  try {
    assign_zones(t, {{"rock", {{0, 0}, {1, 0}, {1, 1}}}, {"rock", {{0, 0}, {1, 0}}}}, "zones.yaml");
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "zones.yaml: zone 1 (material 'rock'): polygon has 2 points, at least 3 are needed");
  }
}

TEST(AssignMaterialRaster, NearestRasterPointGivesTheId) {
  Terrain t = flat_terrain();
  // A 2 m raster of ids offset by half a metre: point (i, j) covers a 2 x 2 m cell.
  DemGrid ids;
  ids.spec = GridSpec{0.5, 0.5, 2.0, 2.0, 6, 6};
  ids.z.resize(ids.spec.point_count());
  for (std::int32_t j = 0; j < 6; ++j)
    for (std::int32_t i = 0; i < 6; ++i) ids.z[ids.spec.index(i, j)] = (i + 2 * j) % 3;
  assign_material_raster(t, ids, "ids.asc");
  for (std::size_t k = 0; k < t.mesh.triangle_count(); ++k) {
    const Vec3 c = centroid(t, k);
    const auto i = static_cast<std::int32_t>(std::round((c.x() - 0.5) / 2.0));
    const auto j = static_cast<std::int32_t>(std::round((c.y() - 0.5) / 2.0));
    EXPECT_EQ(t.material_of_triangle[k], (i + 2 * j) % 3) << k;
  }
}

TEST(AssignMaterialRaster, BadIdsAndCoverageAreInputErrors) {
  Terrain t = flat_terrain();
  DemGrid ids;
  ids.spec = GridSpec{0.0, 0.0, 2.0, 2.0, 6, 6};
  ids.z.assign(ids.spec.point_count(), 1.0);
  ids.z[ids.spec.index(3, 2)] = 3.0;
  try {
    assign_material_raster(t, ids, "ids.asc");
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "ids.asc: material id 3 at raster point (i=3, j=2) at (x=6, y=4) is not in [0, 3)");
  }
  ids.z[ids.spec.index(3, 2)] = 1.5;
  EXPECT_THROW(assign_material_raster(t, ids, "ids.asc"), core::InputError);
  ids.z[ids.spec.index(3, 2)] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(assign_material_raster(t, ids, "ids.asc"), core::InputError);
  // A raster that stops short of the terrain.
  DemGrid small;
  small.spec = GridSpec{0.0, 0.0, 2.0, 2.0, 3, 6};
  small.z.assign(small.spec.point_count(), 0.0);
  try {
    assign_material_raster(t, small, "ids.asc");
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lies outside the material raster"), std::string::npos);
  }
}

}  // namespace
}  // namespace talus::terrain
