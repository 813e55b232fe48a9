#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "talus/core/error.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/roughness.hpp"
#include "talus/terrain/synthetic.hpp"

namespace talus::terrain {
namespace {

double z_at(const DemGrid& d, double x, std::int32_t j = 0) {
  const auto i = static_cast<std::int32_t>(std::lround((x - d.spec.x0) / d.spec.dx));
  return d.z[d.spec.index(i, j)];
}

TEST(SyntheticSlope, BenchSlopeIsTheReferenceGeometry) {
  const DemGrid d = make_synthetic(SyntheticSlope{}, "bench.yaml");
  EXPECT_EQ(d.spec.nx, 31);
  EXPECT_EQ(d.spec.ny, 21);
  EXPECT_EQ(d.spec.dx, 2.0);
  EXPECT_EQ(d.spec.dy, 2.0);
  EXPECT_EQ(d.spec.x0, 0.0);
  EXPECT_EQ(d.spec.y0, 0.0);
  // Breakpoint heights are exact; 1:1 sections in between are linear.
  for (std::int32_t j : {0, 10, 20}) {
    EXPECT_EQ(z_at(d, 0, j), 30.0);   // crest
    EXPECT_EQ(z_at(d, 2, j), 28.0);
    EXPECT_EQ(z_at(d, 6, j), 24.0);   // first bench
    EXPECT_EQ(z_at(d, 8, j), 24.0);
    EXPECT_EQ(z_at(d, 14, j), 18.0);  // second bench
    EXPECT_EQ(z_at(d, 16, j), 18.0);
    EXPECT_EQ(z_at(d, 22, j), 12.0);  // third bench
    EXPECT_EQ(z_at(d, 24, j), 12.0);
    EXPECT_EQ(z_at(d, 30, j), 6.0);
    EXPECT_EQ(z_at(d, 36, j), 0.0);   // toe
    EXPECT_EQ(z_at(d, 48, j), 0.0);   // run-out
    EXPECT_EQ(z_at(d, 60, j), 0.0);
  }
  // Mid-bench (x = 7 m) lies between grid points: the surface is flat there too.
  const Terrain t = build_grid_terrain(d, Diagonal::alternating, 1, "bench");
  const Surface s = Surface::realize(t, std::nullopt);
  EXPECT_EQ(s.height_at(7.0, 20.0)->z, 24.0);
  EXPECT_EQ(s.height_at(15.0, 3.0)->z, 18.0);
  EXPECT_EQ(s.height_at(23.0, 39.0)->z, 12.0);
  EXPECT_NEAR(s.height_at(3.0, 5.0)->z, 27.0, 1e-12);  // 1:1 slope, round-off only
  EXPECT_EQ(s.height_at(50.0, 5.0)->z, 0.0);
}

TEST(SyntheticSlope, PlaneAndProfile) {
  SyntheticSlope plane;
  plane.kind = "plane";
  plane.length = 20.0;
  plane.width = 10.0;
  plane.cell_size = 2.5;
  plane.slope_angle_deg = 30.0;
  const DemGrid p = make_synthetic(plane, "p.yaml");
  EXPECT_EQ(p.spec.nx, 9);
  EXPECT_EQ(p.spec.ny, 5);
  const double tan30 = std::tan(30.0 * std::numbers::pi / 180.0);
  for (std::int32_t i = 0; i < 9; ++i) EXPECT_NEAR(p.z[p.spec.index(i, 4)], (20.0 - 2.5 * i) * tan30, 1e-12);

  SyntheticSlope prof;
  prof.kind = "profile";
  prof.profile = {{-4, 10}, {0, 10}, {5, 0}};
  prof.cell_size = 1.0;
  prof.width = 3.0;
  const DemGrid q = make_synthetic(prof, "q.yaml");
  EXPECT_EQ(q.spec.x0, -4.0);
  EXPECT_EQ(q.spec.nx, 10);
  EXPECT_EQ(q.spec.ny, 4);
  EXPECT_EQ(z_at(q, -2, 3), 10.0);
  EXPECT_NEAR(z_at(q, 2, 3), 6.0, 1e-12);
  EXPECT_EQ(z_at(q, 5, 3), 0.0);
}

TEST(SyntheticSlope, BadSettingsAreInputErrors) {
  SyntheticSlope s;
  s.cell_size = 0.0;
  EXPECT_THROW(make_synthetic(s, "s.yaml"), core::InputError);
  s = SyntheticSlope{};
  s.width = 1.0;
  EXPECT_THROW(make_synthetic(s, "s.yaml"), core::InputError);
  s = SyntheticSlope{};
  s.kind = "plane";
  s.slope_angle_deg = 90.0;
  EXPECT_THROW(make_synthetic(s, "s.yaml"), core::InputError);
  s = SyntheticSlope{};
  s.kind = "profile";
  EXPECT_THROW(make_synthetic(s, "s.yaml"), core::InputError);
  s.profile = {{0, 5}, {3, 1}, {3, 0}};
  try {
    make_synthetic(s, "s.yaml");
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "s.yaml: synthetic slope: profile x must increase, but point 2 has x = 3 after 3");
  }
}

TEST(Roughness, IndexToSigmaFollowsTheReferenceTable) {
  // σ = 0.8 R m; 1e-15 allows the division by F = 1/400.
  EXPECT_NEAR(sigma_from_roughness_index(1.0 / 8.0), 0.1, 1e-15);
  EXPECT_NEAR(sigma_from_roughness_index(1.0 / 4.0), 0.2, 1e-15);
  EXPECT_NEAR(sigma_from_roughness_index(1.0 / 2.0), 0.4, 1e-15);
  EXPECT_EQ(sigma_from_roughness_index(0.0), 0.0);
  EXPECT_THROW(sigma_from_roughness_index(-0.1), core::InputError);
  EXPECT_THROW(sigma_from_roughness_index(std::nan("")), core::InputError);
}

}  // namespace
}  // namespace talus::terrain
