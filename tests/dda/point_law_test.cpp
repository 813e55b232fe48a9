// SPDX-License-Identifier: MIT
// The contact-point impact law (restitution: point, docs/dda.md "Impact–rebound"): a rigid
// impact at the point where the impact's contact impulse acted, with Newton's normal
// restitution, Coulomb friction and the ground's ploughing.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dda_cases.hpp"
#include "dda_fixtures.hpp"
#include "episodes.hpp"

namespace talus::dda {
namespace {

using testing::cube;

struct Impact {
  Vec3 v_in, w_in;  // velocity and spin brought in (m/s, rad/s)
  Vec3 point;       // contact point from the centroid (m)
  double restitution = 0.5, friction = 0.6, ploughing = 0.0;
};

// The state after the law, for a unit cube on flat ground (normal +z, no tilt), the raw
// rebound set to something the law must ignore, and no time spent in the impact.
State after_law(const Model& m, const Impact& c) {
  State s = start(m, Release{}, testing::impact_stream());
  s.episode.active = true;
  s.episode.impact = true;
  s.episode.velocity_in = c.v_in;
  s.episode.spin_in = c.w_in;
  const Vec3 wb = s.orientation.conjugate() * c.w_in;
  s.episode.kinetic_in = 0.5 * m.mass * c.v_in.squaredNorm() + 0.5 * wb.dot(m.inertia * wb);
  s.episode.normal = Vec3::UnitZ();
  s.episode.restitution = c.restitution;
  s.episode.restitution_scale = 1e3;  // SF = 1 within 1e-4 below 10 m/s
  s.episode.ploughing = c.ploughing;
  s.episode.impulse = 1.0;
  s.episode.impulse_moment = c.point;
  s.friction = c.friction;
  s.velocity.setZero();
  s.velocity.head<3>() = Vec3(9.0, -7.0, 30.0);
  detail::finish_impact(m, s);
  return s;
}

double kinetic(const Model& m, const Vec3& v, const Vec3& w) {
  return 0.5 * m.mass * v.squaredNorm() + 0.5 * w.dot(m.inertia * w);  // identity orientation
}

Model point_model() {
  Settings set;
  set.restitution = "point";
  return Model::build(set, cube(1.0));
}

// A corner striking with enough friction leaves with its point sticking: no tangential
// velocity at the point, and the point's normal velocity e times its approach.
TEST(DdaPointLaw, CornerImpactLeavesSticking) {
  const Model m = point_model();
  const Impact c{Vec3(3.0, 0.5, -4.0), Vec3(0.2, -1.0, 0.3), Vec3(-0.5, -0.5, -0.5), 0.4, 5.0, 0.0};
  const double sf = 1.0 / (1.0 + std::pow(c.v_in.norm() / 1e3, 2));
  const State s = after_law(m, c);
  const Vec3 v = s.velocity.head<3>(), w = s.velocity.segment<3>(3);
  const Vec3 u_in = c.v_in + c.w_in.cross(c.point);
  const Vec3 u = v + w.cross(c.point);
  EXPECT_NEAR(u.z(), -c.restitution * sf * u_in.z(), 1e-12);
  EXPECT_NEAR(u.head<2>().norm(), 0.0, 1e-12);
  EXPECT_LT(kinetic(m, v, w), kinetic(m, c.v_in, c.w_in));
}

// With little friction the point slips through the impact: the tangential impulse is μ
// times the normal one, against the approach's slip.
TEST(DdaPointLaw, CornerImpactSlipsWithinTheFrictionCone) {
  const Model m = point_model();
  const Impact c{Vec3(3.0, 0.0, -4.0), Vec3::Zero(), Vec3(0.3, 0.0, -0.5), 0.5, 0.1, 0.0};
  const State s = after_law(m, c);
  const Vec3 impulse = m.mass * (s.velocity.head<3>() - c.v_in);
  EXPECT_GT(impulse.z(), 0.0);
  EXPECT_NEAR(-impulse.x(), c.friction * impulse.z(), 1e-9 * impulse.z());
  EXPECT_NEAR(impulse.y(), 0.0, 1e-9 * impulse.z());
  const Vec3 u = s.velocity.head<3>() + s.velocity.segment<3>(3).cross(c.point);
  EXPECT_NEAR(u.z(), 0.5 * 4.0, 1e-3);  // SF at 5 m/s, K = 1000 m/s: 0.99997
  EXPECT_GT(u.x(), 0.0);                // still slipping forwards
}

// A face landing flat acts under the centroid: the block leaves straight up at e·v_in,
// without spin, whatever it slid at (friction stops the point, and the point is the
// centroid's projection).
TEST(DdaPointLaw, FaceLandingReboundsWithoutSpin) {
  const Model m = point_model();
  const Impact c{Vec3(0.0, 0.0, -6.0), Vec3::Zero(), Vec3(0.0, 0.0, -0.5), 0.3, 0.6, 0.0};
  const State s = after_law(m, c);
  EXPECT_NEAR(s.velocity.z(), 0.3 * 6.0, 1e-3);
  EXPECT_LT(s.velocity.segment<3>(3).norm(), 1e-12);
}

// Ploughing takes plough·P_n/m off the centroid's sliding, never reversing it.
TEST(DdaPointLaw, PloughingResistsTheSlidingUpToItsShare) {
  const Model m = point_model();
  Impact c{Vec3(8.0, 0.0, -2.0), Vec3::Zero(), Vec3(0.0, 0.0, -0.5), 0.5, 0.0, 0.0};
  const State free = after_law(m, c);
  c.ploughing = 0.4;
  const State ploughed = after_law(m, c);
  const double pn = m.mass * (free.velocity.z() - c.v_in.z());
  EXPECT_NEAR(free.velocity.x(), 8.0, 1e-12);
  EXPECT_NEAR(ploughed.velocity.x(), 8.0 - 0.4 * pn / m.mass, 1e-9);
  EXPECT_NEAR(ploughed.velocity.z(), free.velocity.z(), 1e-12);
  c.ploughing = 10.0;
  EXPECT_NEAR(after_law(m, c).velocity.x(), 0.0, 1e-12);
}

// No impact gains energy, over random points, velocities, spins and ground parameters.
TEST(DdaPointLaw, NoImpactGainsEnergy) {
  const Model m = point_model();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0), p(0.0, 1.0);
  int acted = 0;
  for (int i = 0; i < 20000; ++i) {
    Impact c{Vec3(10 * u(rng), 10 * u(rng), -10 * p(rng)), Vec3(5 * u(rng), 5 * u(rng), 5 * u(rng)),
             Vec3(0.5 * u(rng), 0.5 * u(rng), -0.5 * p(rng)), p(rng), 2.0 * p(rng), 2.0 * p(rng)};
    const State s = after_law(m, c);
    const double in = kinetic(m, c.v_in, c.w_in);
    const double out = kinetic(m, s.velocity.head<3>(), s.velocity.segment<3>(3));
    ASSERT_LE(out, in * (1.0 + 1e-12)) << i;
    acted += out < in * (1.0 - 1e-9);
  }
  EXPECT_GT(acted, 15000);
}

// Through the engine: a face-down cube thrown onto flat ground leaves at the law's speed,
// e·SF·V_in, whatever the penalty spring's raw rebound.
TEST(DdaPointLaw, NormalImpactFollowsTheLawThroughTheEngine) {
  for (const char* dof : {"rigid6", "full12"})
    for (const double v_in : {3.0, 7.0, 12.0}) {
      Settings set;
      set.dof = dof;
      set.restitution = "point";
      const double r_v = 0.5, k = 12.0;
      const double expected = r_v / (1.0 + (v_in / k) * (v_in / k)) * v_in;
      const testing::ReboundResult law = testing::rebound(set, v_in, r_v);
      EXPECT_NEAR(law.v_out, expected, 0.01 * expected) << dof << " v_in " << v_in;
    }
}

}  // namespace
}  // namespace talus::dda
