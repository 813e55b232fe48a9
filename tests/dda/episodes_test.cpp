// SPDX-License-Identifier: MIT
// Impact episodes and the restitution law (episodes.cpp) on hand-set velocities: what an
// impact draws, and what its end leaves of the rebound.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dda_cases.hpp"
#include "dda_fixtures.hpp"
#include "episodes.hpp"

namespace talus::dda {
namespace {

// A 1 m³ cube over flat ground of R_v = 0.8, K = 12 m/s, μ = 0.2 (no spread).
struct Impact {
  Impact() : plane(testing::incline(0.0)), mats{testing::material(0.2, 0.8, 12.0)}, g{&plane, mats} {
    s = start(m, Release{}, testing::impact_stream());
  }
  Model m = Model::build(Settings{}, testing::cube(1.0));
  terrain::Surface plane;
  std::vector<terrain::Material> mats;
  Ground g;
  State s;
  double kinetic(const Vec3& v) const { return 0.5 * m.mass * v.squaredNorm(); }
  // An episode begun at velocity v_in (m/s), along the ground's normal, by the face under
  // the centroid: its points approach as the centroid does, on the block's whole mass.
  void begin(const Vec3& v_in) {
    const double approach = std::max(0.0, -v_in.z());
    detail::start_episode_along(m, g, s, v_in, kinetic(v_in), Vec3::UnitZ(), 0,
                                {approach, 0.5 * m.mass * approach * approach});
  }
};

// A normal impact: the law draws R_v (no spread: 0.8) and leaves |V_out| = R_v·SF·|V_in|,
// SF = 1/(1 + (V_in/K)²), of an elastic raw rebound.
TEST(DdaEpisodes, NormalImpactFollowsTheLaw) {
  for (const double speed : {3.0, 10.0, 25.0, 50.0}) {
    Impact t;
    t.begin(Vec3(0.0, 0.0, -speed));
    ASSERT_TRUE(t.s.episode.impact);
    EXPECT_EQ(t.s.impacts, 1u);
    EXPECT_DOUBLE_EQ(t.s.episode.restitution, 0.8);
    EXPECT_NEAR(t.s.friction, 0.2, 1e-15);
    t.s.velocity.head<3>() = Vec3(0.0, 0.0, speed);
    detail::end_episode(t.m, t.s);
    EXPECT_FALSE(t.s.episode.active);
    const double sf = 1.0 / (1.0 + (speed / 12.0) * (speed / 12.0));
    // Relative 1e-14: a scaling of the velocity, a few round-offs.
    EXPECT_NEAR(t.s.velocity.head<3>().norm(), 0.8 * sf * speed, 1e-14 * speed) << speed;
    EXPECT_GT(t.s.velocity.z(), 0.0);
  }
}

// An approach slower than impact_min_normal_speed (0.5 m/s) is rolling or sliding, not an
// impact: no draws, and its end leaves the velocity as it is.
TEST(DdaEpisodes, SlowApproachIsNoImpact) {
  Impact t;
  t.begin(Vec3(2.0, 0.0, -0.3));
  EXPECT_TRUE(t.s.episode.active);
  EXPECT_FALSE(t.s.episode.impact);
  EXPECT_EQ(t.s.impacts, 0u);
  EXPECT_FALSE(t.s.friction_drawn);
  const Vec3 v(2.0, 0.0, 0.3);
  t.s.velocity.head<3>() = v;
  detail::end_episode(t.m, t.s);
  EXPECT_EQ(t.s.velocity.head<3>(), v);
}

// An oblique impact removes at most the kinetic energy of its normal approach (the bound
// by the normal approach, docs/dda.md "Impact–rebound"): a grazing 10 m/s hop at 1 m/s
// towards the ground keeps all but ½·m·(1 m/s)² of an elastic rebound.
TEST(DdaEpisodes, ObliqueImpactLosesAtMostItsNormalApproach) {
  Impact t;
  const Vec3 v_in(10.0, 0.0, -1.0);
  t.begin(v_in);
  ASSERT_TRUE(t.s.episode.impact);
  t.s.velocity.head<3>() = Vec3(10.0, 0.0, 1.0);
  const double before = t.kinetic(t.s.velocity.head<3>());
  detail::end_episode(t.m, t.s);
  const double lost = before - t.kinetic(t.s.velocity.head<3>());
  EXPECT_NEAR(lost, 0.5 * t.m.mass * 1.0, 1e-9 * before);
  // The law's own cap would have taken far more: (R_v·SF)² of the energy kept.
  const double sf = 1.0 / (1.0 + v_in.squaredNorm() / 144.0);
  EXPECT_GT(before * (1.0 - 0.64 * sf * sf), 10.0 * lost);
}

// An impact whose block stays in contact has rebounded once it no longer approaches along
// the impact normal and its springs hold at most 1 % of the impact's kinetic energy.
TEST(DdaEpisodes, ReboundCompleteWaitsForTheSprings) {
  Impact t;
  const Vec3 v_in(0.0, 0.0, -10.0);
  t.begin(v_in);
  const double impact_energy = t.kinetic(v_in);
  t.s.velocity.head<3>() = Vec3(0.0, 0.0, -0.1);
  EXPECT_FALSE(detail::rebound_complete(t.m, t.s, 0.0));
  t.s.velocity.head<3>() = Vec3(0.0, 0.0, 0.1);
  EXPECT_FALSE(detail::rebound_complete(t.m, t.s, 0.02 * impact_energy));
  EXPECT_TRUE(detail::rebound_complete(t.m, t.s, 0.005 * impact_energy));
}

// The lateral tilt turns the rebound about the horizontal travel direction by the drawn
// angle, keeping its speed.
TEST(DdaEpisodes, LateralTiltTurnsTheRebound) {
  Impact t;
  t.mats[0].lateral_tilt_sd_deg = 5.0;
  const Vec3 v_in(0.0, 0.0, -5.0);
  t.s.release.main_direction = Eigen::Vector2d::UnitX();
  t.begin(v_in);
  ASSERT_TRUE(t.s.episode.impact);
  const double tilt = t.s.episode.tilt_deg * M_PI / 180.0;
  ASSERT_NE(tilt, 0.0);
  t.s.velocity.head<3>() = Vec3(0.0, 0.0, 5.0);
  detail::end_episode(t.m, t.s);
  const Vec3 v = t.s.velocity.head<3>();
  EXPECT_NEAR(v.x(), 0.0, 1e-12);
  EXPECT_NEAR(std::atan2(-v.y(), v.z()), tilt, 1e-12);
}

}  // namespace
}  // namespace talus::dda
