// SPDX-License-Identifier: MIT
// The contact law (contact_law.cpp) on hand-built contacts: a 1 m cube on flat ground
// (z = −0.5 m under its centroid) with its four bottom corners as vertex–face contacts.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "contact_law.hpp"
#include "dda_fixtures.hpp"

namespace talus::dda {
namespace {

using detail::VecN;

constexpr double kDt = 1e-3;  // s
constexpr double kG = 9.81;   // m/s²

struct CubeOnGround {
  explicit CubeOnGround(Settings set = {}) : m(Model::build(set, testing::cube(1.0))) {}
  Model m;
  State s;

  // The four bottom corners, each `gap` (m) above the ground, in `mode`.
  std::vector<Contact> corners(double gap, ContactMode mode) const {
    std::vector<Contact> out;
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      if (m.vertices[i].z() > -0.5 + 1e-12) continue;
      Contact c;
      c.kind = ContactKind::vertex_face;
      c.block_feature = static_cast<std::int32_t>(i);
      c.terrain_feature = 0;
      c.triangle = 0;
      c.point = s.position + m.vertices[i];
      c.normal = Vec3::UnitZ();
      c.gap = gap;
      c.mode = mode;
      out.push_back(c);
    }
    return out;
  }

  // The corners sliding along +x, compressed by the block's weight (a quarter each).
  std::vector<Contact> sliding_corners() const {
    std::vector<Contact> out = corners(-m.mass * kG / (4.0 * m.stiffness), ContactMode::sliding);
    for (Contact& c : out) {
      c.slip_direction = Vec3::UnitX();
      c.normal_force = m.mass * kG / 4.0;
    }
    return out;
  }

  detail::StepOutcome solve(std::vector<Contact>& contacts, double friction, VecN<6>& d) {
    PhaseTimes times;
    return detail::solve_step<6>(m, detail::pose_of(m, s), s, kDt, friction, contacts, d, times);
  }
};

// A cube set down at rest closes its four corners locked; the step's sink is Shi's
// implicit one, (2m/Δt² + 4k)·d = −m·g (the locked shear springs are unstretched, the
// pose symmetric), and nothing moves sideways or turns.
TEST(DdaContactLaw, StickOnFlatGround) {
  CubeOnGround cube;
  std::vector<Contact> contacts = cube.corners(0.0, ContactMode::open);
  ASSERT_EQ(contacts.size(), 4u);
  VecN<6> d;
  const detail::StepOutcome out = cube.solve(contacts, 0.6, d);
  ASSERT_TRUE(out.converged);
  for (const Contact& c : contacts) EXPECT_EQ(c.mode, ContactMode::locked);
  const double m = cube.m.mass, k = cube.m.stiffness;
  // Relative 1e-12: the round-off of one 6 × 6 solve.
  EXPECT_NEAR(d.z(), -m * kG / (2.0 * m / (kDt * kDt) + 4.0 * k), 1e-12 * std::abs(d.z()));
  EXPECT_LT(d.head<2>().norm(), 1e-15);
  EXPECT_LT(d.tail<3>().norm(), 1e-15);
  EXPECT_EQ(out.held, 0);
}

// A cube sliding at 1 m/s on its compressed corners slides on, decelerated by Coulomb
// friction on the normal force of this very step: Δx = v·Δt − ½·μ·(F_n/m)·Δt², F_n the
// corners' spring force at the step end.
TEST(DdaContactLaw, SlideDeceleratesByCoulomb) {
  CubeOnGround cube;
  const double m = cube.m.mass, k = cube.m.stiffness;
  cube.s.velocity.head<3>() = Vec3(1.0, 0.0, 0.0);
  std::vector<Contact> contacts = cube.sliding_corners();
  VecN<6> d;
  const double mu = 0.2;
  ASSERT_TRUE(cube.solve(contacts, mu, d).converged);
  double normal_force = 0.0;
  for (const Contact& c : contacts) {
    EXPECT_EQ(c.mode, ContactMode::sliding);
    normal_force += k * std::max(0.0, -(c.gap - c.gap_offset + (d.head<3>() + d.tail<3>().cross(c.point)).z()));
  }
  // The rows' round-off, relative to the friction's part of the displacement.
  const double friction_part = 0.5 * mu * normal_force / m * kDt * kDt;
  EXPECT_NEAR(1.0 * kDt - d.x(), friction_part, 1e-9 * friction_part);
  EXPECT_NEAR(normal_force, m * kG, 0.01 * m * kG);  // the weight, to 1 %
}

// Sliding so slowly that friction would reverse the slip within the step, the corners
// stick again (re-stick): locked, their shear springs stretched to the friction force they
// carried, so the block neither slides on nor is thrown back: it moves by the springs'
// elastic recoil only, nanometres against the 2.9 µm friction would take off in a step.
TEST(DdaContactLaw, SlowSlideSticksAgain) {
  CubeOnGround cube;
  const double v = 1e-4;  // m/s, far below μ·g·Δt = 5.9e-3 m/s
  cube.s.velocity.head<3>() = Vec3(v, 0.0, 0.0);
  std::vector<Contact> contacts = cube.sliding_corners();
  VecN<6> d;
  ASSERT_TRUE(cube.solve(contacts, 0.6, d).converged);
  for (const Contact& c : contacts) {
    EXPECT_EQ(c.mode, ContactMode::locked);
    EXPECT_TRUE(c.anchored);
  }
  EXPECT_LT(std::abs(d.x()), 0.01 * 0.5 * 0.6 * kG * kDt * kDt);
}

// A block leaving the ground opens its locked corners; with a single free iteration each
// is held in its new state, and the step is the free parabola exactly (no spring, no
// friction acts on an open contact).
TEST(DdaContactLaw, LiftOffOpensEveryCorner) {
  Settings set;
  set.max_open_close_iterations = 1;
  CubeOnGround cube(set);
  cube.s.velocity.head<3>() = Vec3(0.5, 0.0, 1.0);
  std::vector<Contact> contacts = cube.corners(0.0, ContactMode::locked);
  for (Contact& c : contacts) {
    c.anchored = true;
    c.body_anchor = c.point - cube.s.position;
    c.ground_anchor = c.point;
  }
  VecN<6> d;
  const detail::StepOutcome out = cube.solve(contacts, 0.6, d);
  ASSERT_TRUE(out.converged);
  for (const Contact& c : contacts) EXPECT_EQ(c.mode, ContactMode::open);
  EXPECT_NEAR(d.x(), 0.5 * kDt, 1e-15);
  EXPECT_NEAR(d.z(), 1.0 * kDt - 0.5 * kG * kDt * kDt, 1e-15);
  EXPECT_LT(d.tail<3>().norm(), 1e-15);
}

// A locked contact loaded sideways beyond μ·F_n slips: pushed at 2 m/s into a step whose
// friction cannot stop it, every corner ends sliding (or at its limit), and the shear
// force a locked corner is left with never exceeds μ·F_n.
TEST(DdaContactLaw, OverloadedStickSlides) {
  CubeOnGround cube;
  const double m = cube.m.mass, k = cube.m.stiffness;
  cube.s.velocity.head<3>() = Vec3(2.0, 0.0, 0.0);
  std::vector<Contact> contacts = cube.corners(-m * kG / (4.0 * k), ContactMode::locked);
  for (Contact& c : contacts) {
    c.anchored = true;
    c.body_anchor = c.point - cube.s.position;
    c.ground_anchor = c.point + Vec3(0.0, 0.0, m * kG / (4.0 * k));
    c.normal_force = m * kG / 4.0;
  }
  VecN<6> d;
  const double mu = 0.3;
  ASSERT_TRUE(cube.solve(contacts, mu, d).converged);
  const double ps = k / cube.m.settings.shear_stiffness_ratio;
  for (const Contact& c : contacts) {
    const Vec3 du = d.head<3>() + d.tail<3>().cross(c.point - cube.s.position);
    const double normal = k * std::max(0.0, -(c.gap - c.gap_offset + du.z()));
    if (c.mode == ContactMode::locked) {
      const Vec3 stretch = c.point + du - c.ground_anchor;
      // 1e-6 of the limit: the return mapping's tolerance.
      EXPECT_LE(ps * stretch.head<2>().norm(), mu * normal * (1.0 + 1e-6));
    } else {
      EXPECT_EQ(c.mode, ContactMode::sliding);
    }
  }
  // Friction decelerates the block by at most μ·g over the step.
  EXPECT_LT(d.x(), 2.0 * kDt);
  EXPECT_GT(d.x(), 2.0 * kDt - 0.5 * mu * kG * kDt * kDt * 1.01);
}

}  // namespace
}  // namespace talus::dda
