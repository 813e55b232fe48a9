#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/terrain/build.hpp"

namespace talus::terrain {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

DemGrid small_dem(std::int32_t nx, std::int32_t ny) {
  DemGrid dem;
  dem.spec = GridSpec{100.0, 200.0, 2.0, 3.0, nx, ny};
  dem.z.resize(dem.spec.point_count());
  for (std::int32_t j = 0; j < ny; ++j)
    for (std::int32_t i = 0; i < nx; ++i) dem.z[dem.spec.index(i, j)] = 10.0 * i + j;
  return dem;
}

// The message of the InputError `f` throws ("" when it throws nothing).
template <class F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const core::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ValidateDem, AcceptsAGoodGrid) { EXPECT_NO_THROW(validate_dem(small_dem(3, 2), "a.asc")); }

TEST(ValidateDem, NamesTheProblem) {
  DemGrid d = small_dem(4, 3);
  d.z[d.spec.index(2, 1)] = kNaN;
  d.z[d.spec.index(3, 2)] = kNaN;
  EXPECT_EQ(input_error([&] { validate_dem(d, "a.asc"); }),
            "a.asc: DEM point (i=2, j=1) at (x=104, y=203) has no data (NODATA); crop or trim the DEM");
  d = small_dem(4, 3);
  d.z[0] = std::numeric_limits<double>::infinity();
  EXPECT_NE(input_error([&] { validate_dem(d, "a.asc"); }).find("(i=0, j=0)"), std::string::npos);
  d = small_dem(1, 3);
  EXPECT_EQ(input_error([&] { validate_dem(d, "a.asc"); }), "a.asc: DEM needs at least 2 x 2 points, got 1 x 3");
  d = small_dem(3, 3);
  d.spec.dx = 0.0;
  EXPECT_NE(input_error([&] { validate_dem(d, "a.asc"); }).find("cell size"), std::string::npos);
  d = small_dem(3, 3);
  d.spec.dy = kNaN;
  EXPECT_NE(input_error([&] { validate_dem(d, "a.asc"); }).find("cell size"), std::string::npos);
  d = small_dem(3, 3);
  d.z.pop_back();
  EXPECT_EQ(input_error([&] { validate_dem(d, "a.asc"); }), "a.asc: DEM has 8 elevations for 3 x 3 points");
}

TEST(CropDem, KeepsThePointsInsideTheWindow) {
  const DemGrid d = small_dem(10, 8);
  // Window edges exactly on points 2 and 5 (x) and 1 and 3 (y): boundaries included.
  const DemGrid c = crop_dem(d, 104.0, 203.0, 110.0, 209.0, "a.asc");
  EXPECT_EQ(c.spec.nx, 4);
  EXPECT_EQ(c.spec.ny, 3);
  EXPECT_EQ(c.spec.x0, 104.0);
  EXPECT_EQ(c.spec.y0, 203.0);
  EXPECT_EQ(c.spec.dx, 2.0);
  for (std::int32_t j = 0; j < 3; ++j)
    for (std::int32_t i = 0; i < 4; ++i) EXPECT_EQ(c.z[c.spec.index(i, j)], 10.0 * (i + 2) + (j + 1));
  // A window larger than the DEM keeps all of it.
  EXPECT_EQ(crop_dem(d, -1e9, -1e9, 1e9, 1e9, "a.asc").z, d.z);
}

TEST(CropDem, TooSmallOrBadWindowIsAnError) {
  const DemGrid d = small_dem(10, 8);
  EXPECT_NE(input_error([&] { crop_dem(d, 104.5, 203.0, 105.9, 220.0, "a.asc"); }).find("keeps 0 x"),
            std::string::npos);
  EXPECT_NE(input_error([&] { crop_dem(d, 0.0, 0.0, 50.0, 50.0, "a.asc"); }).find("at least 2 x 2"),
            std::string::npos);
  EXPECT_NE(input_error([&] { crop_dem(d, 110.0, 0.0, 100.0, 50.0, "a.asc"); }).find("non-empty"),
            std::string::npos);
}

TEST(TrimNodata, DropsAllNodataBorders) {
  DemGrid d = small_dem(6, 5);
  for (std::int32_t j = 0; j < 5; ++j) {
    d.z[d.spec.index(0, j)] = kNaN;  // first column
    d.z[d.spec.index(5, j)] = kNaN;  // last column
  }
  for (std::int32_t i = 0; i < 6; ++i) d.z[d.spec.index(i, 4)] = kNaN;  // last row
  d.z[d.spec.index(2, 0)] = kNaN;  // an inner hole in a kept row stays
  const DemGrid t = trim_nodata(d);
  EXPECT_EQ(t.spec.nx, 4);
  EXPECT_EQ(t.spec.ny, 4);
  EXPECT_EQ(t.spec.x0, 102.0);
  EXPECT_EQ(t.spec.y0, 200.0);
  EXPECT_TRUE(std::isnan(t.z[t.spec.index(1, 0)]));
  EXPECT_EQ(t.z[t.spec.index(0, 0)], 10.0);
  EXPECT_THROW(validate_dem(t, "a.asc"), core::InputError);  // the hole remains NODATA
  DemGrid all = small_dem(3, 3);
  std::fill(all.z.begin(), all.z.end(), kNaN);
  EXPECT_EQ(trim_nodata(all).spec.point_count(), 0u);
}

TEST(BuildGridTerrain, ValidatesAndFillsTheModel) {
  const DemGrid d = small_dem(5, 4);
  const Terrain t = build_grid_terrain(d, Diagonal::alternating, 9, "a.asc");
  ASSERT_TRUE(t.grid);
  EXPECT_EQ(t.mesh.vertex_count(), 20u);
  EXPECT_EQ(t.mesh.triangle_count(), 24u);
  EXPECT_EQ(t.material_of_triangle, std::vector<std::int32_t>(24, 0));
  ASSERT_EQ(t.materials.size(), 1u);
  EXPECT_EQ(t.roughness.seed, 9u);
  EXPECT_EQ(t.roughness.sigma, 0.0);
  EXPECT_EQ(t.mesh.vertices[7], Vec3(104.0, 203.0, 21.0));
  DemGrid bad = d;
  bad.z[3] = kNaN;
  EXPECT_THROW(build_grid_terrain(bad, Diagonal::fixed, 1, "a.asc"), core::InputError);
}

// Two squares, the second given upside down (clockwise from above) and with one triangle
// wound against its neighbour, plus a degenerate sliver and a vertical wall part.
TEST(BuildTinTerrain, OrientsComponentsUpAndDropsDegenerates) {
  geometry::TriangleMesh a;
  a.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 2, 0}};
  a.triangles = {{0, 1, 2}, {0, 3, 2}, {0, 2, 4}};  // second inconsistent, third degenerate
  geometry::TriangleMesh b;
  b.vertices = {{5, 0, 1}, {6, 0, 1}, {6, 1, 1}, {5, 1, 1}};
  b.triangles = {{0, 2, 1}, {0, 3, 2}};  // both facing down, consistent
  geometry::TriangleMesh wall;
  wall.vertices = {{0, 5, 0}, {1, 5, 0}, {1, 5, 1}, {0, 5, 1}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  TinReport report;
  const Terrain t = build_tin_terrain({a, b, wall}, {"rock", "scree"}, "parts", &report);
  EXPECT_FALSE(t.grid);
  EXPECT_EQ(report.degenerate_dropped, 1u);
  EXPECT_EQ(report.components, 3u);
  EXPECT_EQ(report.components_flipped, 1u);
  EXPECT_EQ(report.triangles_flipped, 3u);
  EXPECT_EQ(report.orientation_conflicts, 0u);
  ASSERT_EQ(t.mesh.triangle_count(), 6u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(t.mesh.area_normal(k).z(), 0.0) << k;
  EXPECT_EQ(t.mesh.area_normal(4).z(), 0.0);  // the wall is kept, as it is
  EXPECT_LT(t.mesh.area_normal(4).y(), 0.0);
  EXPECT_EQ(t.material_of_triangle, (std::vector<std::int32_t>{0, 0, 1, 1, 2, 2}));
  ASSERT_EQ(t.materials.size(), 3u);
  EXPECT_EQ(t.materials[0].name, "rock");
  EXPECT_EQ(t.materials[1].name, "scree");
  EXPECT_EQ(t.materials[2].name, "part2");
  EXPECT_EQ(t.mesh.vertex_count(), 13u);
  // Part b's vertices follow part a's.
  EXPECT_EQ(t.mesh.triangles[2][0], 5);
}

TEST(BuildTinTerrain, BadPartsAreInputErrors) {
  geometry::TriangleMesh good;
  good.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  good.triangles = {{0, 1, 2}};
  EXPECT_EQ(input_error([&] { build_tin_terrain({good, {}}, {"a", "b"}, "x.obj"); }),
            "x.obj: part 1 ('b') has no triangles");
  geometry::TriangleMesh nan = good;
  nan.vertices[1].y() = kNaN;
  EXPECT_EQ(input_error([&] { build_tin_terrain({nan}, {}, "x.obj"); }),
            "x.obj: part 0: vertex 1 has a non-finite coordinate");
  geometry::TriangleMesh index = good;
  index.triangles.push_back({0, 2, 3});
  EXPECT_EQ(input_error([&] { build_tin_terrain({index}, {}, "x.obj"); }),
            "x.obj: part 0: triangle 1 refers to vertex 3 of 3");
  geometry::TriangleMesh flat = good;
  flat.vertices[2] = {2, 0, 0};
  EXPECT_NE(input_error([&] { build_tin_terrain({flat}, {}, "x.obj"); }).find("degenerate"), std::string::npos);
  EXPECT_NE(input_error([&] { build_tin_terrain({}, {}, "x.obj"); }).find("no terrain mesh"), std::string::npos);
}

TEST(BuildTinTerrain, HeightFieldFromAGridFacesUp) {
  // A grid mesh with random per-triangle winding comes out consistent and facing up.
  const Terrain grid = build_grid_terrain(small_dem(12, 9), Diagonal::random, 3, "a.asc");
  geometry::TriangleMesh m = grid.mesh;
  const core::RandomStream rng(5, core::Stream::bootstrap, 0);
  std::size_t reversed = 0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t)
    if (rng.uniform(t) < 0.7) {
      std::swap(m.triangles[t][0], m.triangles[t][1]);
      ++reversed;
    }
  TinReport report;
  const Terrain tin = build_tin_terrain({m}, {}, "a.obj", &report);
  EXPECT_EQ(report.components, 1u);
  EXPECT_EQ(report.triangles_flipped, reversed);
  for (std::size_t t = 0; t < tin.mesh.triangle_count(); ++t) EXPECT_GT(tin.mesh.area_normal(t).z(), 0.0);
}

TEST(DelaunayTerrain, TriangulatesScatteredPoints) {
  // A jittered 15 x 15 lattice: the Delaunay triangulation covers its convex hull with
  // 2n − 2 − h triangles (h hull vertices), all facing up.
  std::vector<Vec3> pts;
  const core::RandomStream rng(12, core::Stream::bootstrap, 3);
  for (int j = 0; j < 15; ++j)
    for (int i = 0; i < 15; ++i) {
      const auto k = static_cast<std::uint64_t>(j * 15 + i);
      const bool edge = i == 0 || j == 0 || i == 14 || j == 14;
      const double jx = edge ? 0.0 : 0.4 * (rng.uniform(2 * k) - 0.5);
      const double jy = edge ? 0.0 : 0.4 * (rng.uniform(2 * k + 1) - 0.5);
      pts.emplace_back(i + jx, j + jy, std::sin(0.3 * i) + 0.1 * j);
    }
  const Terrain t = build_delaunay_terrain(pts, "cloud.xyz");
  EXPECT_FALSE(t.grid);
  EXPECT_EQ(t.mesh.vertices, pts);
  // h = 56 hull points (collinear edge points count: every one is a vertex of the hull
  // boundary); triangles = 2n − 2 − h.
  EXPECT_EQ(t.mesh.triangle_count(), 2u * 225u - 2u - 56u);
  double area = 0.0;
  for (std::size_t k = 0; k < t.mesh.triangle_count(); ++k) {
    const Vec3 n = t.mesh.area_normal(k);
    EXPECT_GT(n.z(), 0.0);
    area += 0.5 * n.z();
  }
  // The plan area is the 14 x 14 square; 1e-9 allows summation round-off.
  EXPECT_NEAR(area, 196.0, 1e-9);
  EXPECT_EQ(t.material_of_triangle.size(), t.mesh.triangle_count());
  // Its surface interpolates the points: the height at each input point is its z.
  const Surface s = Surface::realize(t, std::nullopt);
  for (const Vec3& p : pts) {
    const auto hit = s.height_at(p.x(), p.y());
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->z, p.z(), 1e-12);  // round-off of the barycentric sum
  }
  // Deterministic numbering.
  EXPECT_EQ(build_delaunay_terrain(pts, "cloud.xyz").mesh.triangles, t.mesh.triangles);
}

TEST(DelaunayTerrain, BadCloudsAreInputErrors) {
  EXPECT_EQ(input_error([] { build_delaunay_terrain({{0, 0, 0}, {1, 0, 0}}, "c.xyz"); }),
            "c.xyz: Delaunay terrain needs at least 3 points, got 2");
  EXPECT_EQ(input_error([] { build_delaunay_terrain({{0, 0, 0}, {1, 0, 0}, {2, 0, 5}, {3, 0, 1}}, "c.xyz"); }),
            "c.xyz: all 4 points are collinear in plan: no surface to triangulate");
  EXPECT_EQ(input_error([] {
              build_delaunay_terrain({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 2}}, "c.xyz");
            }),
            "c.xyz: point 1 (1, 0, 0) and point 4 (1, 0, 2) have the same (x, y)");
  EXPECT_NE(input_error([] { build_delaunay_terrain({{0, 0, 0}, {1, 0, kNaN}, {0, 1, 0}}, "c.xyz"); })
                .find("point 1 is not finite"),
            std::string::npos);
}

TEST(ResampleToGrid, SamplesTheSurfaceAndMarksMisses) {
  // A tilted plane as a TIN, sampled on a lattice that overhangs it by one point.
  std::vector<Vec3> pts;
  for (int j = 0; j <= 4; ++j)
    for (int i = 0; i <= 4; ++i) pts.emplace_back(2.5 * i, 2.5 * j, 0.3 * 2.5 * i - 0.2 * 2.5 * j);
  const Terrain t = build_delaunay_terrain(pts, "plane.xyz");
  const Surface s = Surface::realize(t, std::nullopt);
  const GridSpec spec{-1.0, 0.0, 1.0, 1.0, 13, 11};
  const DemGrid g = resample_to_grid(s, spec);
  ASSERT_EQ(g.z.size(), spec.point_count());
  for (std::int32_t j = 0; j < spec.ny; ++j)
    for (std::int32_t i = 0; i < spec.nx; ++i) {
      const double x = -1.0 + i, y = j;
      const double z = g.z[spec.index(i, j)];
      if (x < 0.0 || x > 10.0) {
        EXPECT_TRUE(std::isnan(z));
      } else {
        EXPECT_NEAR(z, 0.3 * x - 0.2 * y, 1e-12);  // a plane is interpolated exactly up to round-off
      }
    }
  const DemGrid trimmed = trim_nodata(g);
  EXPECT_EQ(trimmed.spec.nx, 11);
  EXPECT_EQ(trimmed.spec.x0, 0.0);
  EXPECT_NO_THROW(validate_dem(trimmed, "resampled"));
}

}  // namespace
}  // namespace talus::terrain
