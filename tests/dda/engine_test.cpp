// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dda_fixtures.hpp"
#include "talus/core/error.hpp"
#include "talus/dda/engine.hpp"

namespace talus::dda {
namespace {

using testing::cube;
using testing::incline;
using testing::material;

constexpr double kG = 9.81;

core::RandomStream impacts(std::uint32_t realization = 0) {
  return core::RandomStream(7, core::Stream::impact, realization);
}

// Runs n steps (or until the state ends).
void advance(const Model& m, const Ground& g, State& s, int n) {
  for (int i = 0; i < n && s.end == EndReason::running; ++i) step(m, g, s);
}

// Free fall and projectile flight: Shi's constant-acceleration scheme is exact for
// gravity, so positions match the parabola to round-off on both DOF paths (the 12-DOF
// path solves its contact-free step instead of advancing the parabola in closed form).
TEST(DdaFlight, ProjectileIsExact) {
  const terrain::Surface ground_surface = incline(0.0, 2000.0);
  const std::vector<terrain::Material> mats{material(0.3)};
  const Ground g{&ground_surface, mats};
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const Model m = Model::build(set, cube(1.0));
    Release r;
    r.position = Vec3(0.0, 0.0, 500.0);
    r.velocity = Vec3(12.0, -3.0, 8.0);
    r.angular_velocity = Vec3(1.0, 2.0, -0.5);
    State s = start(m, r, impacts());
    advance(m, g, s, 2000);
    ASSERT_EQ(s.end, EndReason::running);
    const double t = s.time;
    EXPECT_NEAR(t, 2.0, 1e-12);
    const Vec3 exact = r.position + r.velocity * t + 0.5 * Vec3(0, 0, -kG) * t * t;
    // 2000 additions of O(10 m) increments: a few hundred ulp of 500 m.
    EXPECT_LT((s.position - exact).norm(), 1e-10) << dof;
    EXPECT_LT((s.velocity.head<3>() - (r.velocity + Vec3(0, 0, -kG) * t)).norm(), 1e-10) << dof;
    EXPECT_EQ(s.counters.contact_steps, 0u) << dof;
    EXPECT_NEAR(s.max_jump_height, 500.0 - 0.5 + 8.0 * 8.0 / (2 * kG) + 0.5, 1e-3) << dof;
  }
}

// A cube at rest on flat ground stays at rest; it sinks by mg/(n·k) with n = 4 vertex
// springs.
TEST(DdaContact, RestOnFlatGround) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(0.5)};
  const Ground g{&flat, mats};
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    set.rest_dwell = 1e9;  // keep stepping: the test watches the rest itself
    const Model m = Model::build(set, cube(1.0));
    State s = start(m, testing::on_incline(0.0, 1.0, 1.0, 3.0), impacts());
    const Vec3 p0 = s.position;
    double sum = 0.0;
    int n = 0;
    for (int i = 0; i < 2000; ++i) {
      step(m, g, s);
      ASSERT_EQ(s.end, EndReason::running) << dof << " " << to_string(s.end) << " at " << s.time;
      if (i >= 1000) {
        sum += s.position.z();
        ++n;
      }
    }
    const double sink = 0.5 - sum / n;
    const double expected = m.mass * kG / (4.0 * set.penalty_stiffness);
    std::printf("%s: sink %.6e expected %.6e, drift %.3e, iterations/step %.2f\n", dof, sink, expected,
                (s.position - p0).head<2>().norm(),
                double(s.counters.open_close_iterations) / double(s.counters.contact_steps));
    if (std::string(dof) == "rigid6") {
      EXPECT_NEAR(sink, expected, 0.02 * expected) << dof;  // 2 %: the spring's residual oscillation
    } else {
      // The strains add the block's own compression under its weight: εz = mg/(2AE) with
      // free lateral strain, (1+ν)(1−2ν)/(1−ν) = 0.9 of it with the base held by the
      // locked shear springs; the centroid sinks by (a/2)εz more.
      const double free = 0.5 * m.mass * kG / (2.0 * 1.0 * set.young_modulus);
      EXPECT_GT(sink - expected, 0.89 * free);
      EXPECT_LT(sink - expected, 1.0 * free);
    }
    EXPECT_LT((s.position - p0).head<2>().norm(), 1e-9) << dof;
    EXPECT_LT(s.velocity.head<6>().norm(), 1e-3) << dof;
  }
}

double slide_distance(double theta_deg, double mu, const char* dof, double seconds, double* rotation = nullptr) {
  const terrain::Surface plane = incline(theta_deg);
  const std::vector<terrain::Material> mats{material(mu)};
  const Ground g{&plane, mats};
  Settings set;
  set.dof = dof;
  set.max_steps = 1000000;
  const Model m = Model::build(set, cube(1.0));
  const Release r = testing::on_incline(theta_deg, 1.0, -5.0, 8.0);
  State s = start(m, r, impacts());
  while (s.time < seconds - 1e-9 && s.end == EndReason::running) step(m, g, s);
  EXPECT_EQ(s.end, EndReason::running);
  if (rotation) *rotation = Eigen::AngleAxisd(s.orientation * r.orientation.inverse()).angle();
  return (s.position - r.position).dot(testing::incline_down(theta_deg));
}

// Sliding on a 30° incline: displacement after 1 s against g(sin θ − μ cos θ)t²/2.
TEST(DdaContact, SlidingOnIncline) {
  const double th = 30.0 * M_PI / 180.0;
  for (const char* dof : {"rigid6", "full12"})
    for (const double mu : {0.0, 0.2, 0.4, 0.5}) {
      double rot = 0.0;
      const double d = slide_distance(30.0, mu, dof, 1.0, &rot);
      const double exact = 0.5 * kG * (std::sin(th) - mu * std::cos(th));
      std::printf("%s mu %.1f: %.6f vs %.6f (%.4f %%), rotation %.2e rad\n", dof, mu, d, exact,
                  100.0 * (d - exact) / exact, rot);
      // 0.1 % on the rigid path (measured: < 1e-4 %); the 12-DOF path's barely damped
      // strain mode takes 0.1 % of the friction work at μ = 0.5 (measured), so 0.2 %.
      const double tol = std::string(dof) == "rigid6" ? 1e-3 : 2e-3;
      EXPECT_NEAR(d, exact, tol * exact) << dof << " mu " << mu;
      EXPECT_LT(rot, 1e-6) << dof << " mu " << mu;
    }
}

// Sticking when tan θ ≤ μ: no creep (locked contacts keep their anchors).
TEST(DdaContact, StickingDoesNotCreep) {
  const terrain::Surface plane = incline(30.0);
  const std::vector<terrain::Material> mats{material(0.6)};
  const Ground g{&plane, mats};
  Settings set;
  set.max_steps = 1000000;
  set.rest_dwell = 1e9;
  const Model m = Model::build(set, cube(1.0));
  const Release r = testing::on_incline(30.0, 1.0, -5.0, 8.0);
  State s = start(m, r, impacts());
  advance(m, g, s, 100);
  const Vec3 settled = s.position;
  const Eigen::Quaterniond q_settled = s.orientation;
  while (s.time < 10.0 - 1e-9 && s.end == EndReason::running) step(m, g, s);
  const double drift = (s.position - settled).norm();
  const double rot = Eigen::AngleAxisd(s.orientation * q_settled.inverse()).angle();
  std::printf("settling %.3e m, drift %.3e m, rotation %.3e rad, end %s\n", (settled - r.position).norm(), drift, rot,
              std::string(to_string(s.end)).c_str());
  EXPECT_LT(drift, 1e-6);
  EXPECT_LT(rot, 1e-9);
}

// Drops a cube face-down onto flat ground with approach speed v_in; returns the centroid
// speed once every contact has opened (the rebound), or NaN if it never leaves.
double rebound_speed(const Settings& set, double v_in, double restitution, double* raw_ratio = nullptr) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(0.5, restitution)};
  const Ground g{&flat, mats};
  const Model m = Model::build(set, cube(1.0));
  Release r = testing::on_incline(0.0, 1.0, 0.3, 0.2);
  r.position.z() += 0.05;
  const double h = 0.05;
  r.velocity = Vec3(0.0, 0.0, -std::sqrt(std::max(0.0, v_in * v_in - 2.0 * kG * h)));
  State s = start(m, r, impacts());
  bool touched = false;
  double vin = 0.0;
  for (int i = 0; i < 20000 && s.end == EndReason::running; ++i) {
    const Vec3 v_before = s.velocity.head<3>();
    step(m, g, s);
    const bool closed = std::any_of(s.contacts.begin(), s.contacts.end(),
                                    [](const Contact& c) { return c.mode != ContactMode::open; });
    if (closed && !touched) {
      touched = true;
      vin = v_before.norm();
    }
    if (touched && !closed) {
      if (raw_ratio) *raw_ratio = s.velocity.head<3>().norm() / vin;
      return s.velocity.head<3>().norm();
    }
  }
  return std::nan("");
}

// A normal impact returns the rebound speed of the restitution law: the default
// stiffness makes the raw penalty rebound nearly elastic (Ω = √(nk/m)Δt ≈ 38 for four
// vertex springs), so the law, not the spring, sets the rebound.
TEST(DdaImpact, NormalImpactFollowsTheLaw) {
  for (const double v_in : {3.0, 7.0, 12.0}) {
    Settings set;
    const double r_v = 0.95, k = 12.0;
    const double expected = r_v / (1.0 + (v_in / k) * (v_in / k)) * v_in;
    const double got = rebound_speed(set, v_in, r_v);
    EXPECT_NEAR(got, expected, 0.01 * expected) << "v_in " << v_in;
    set.restitution = "normal_component";
    EXPECT_NEAR(rebound_speed(set, v_in, r_v), expected, 0.01 * expected) << "normal variant, v_in " << v_in;
    // Without the law the raw rebound is nearly elastic at the default stiffness
    // (measured 0.93 at 3 m/s, 0.95 at 7 and 12 m/s), above the law's cap.
    set.restitution = "off";
    double raw = 0.0;
    rebound_speed(set, v_in, r_v, &raw);
    EXPECT_GT(raw, 0.92) << "v_in " << v_in;
    EXPECT_GT(raw * v_in, expected) << "v_in " << v_in;
    EXPECT_LE(raw, 1.0 + 1e-9) << "v_in " << v_in;
  }
}

// Penetration push-out never injects energy: with the restitution law off, a block
// dropped on flat ground (face, edge and corner first) never gains mechanical energy.
TEST(DdaImpact, NoEnergyGainWithoutTheLaw) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(0.4)};
  const Ground g{&flat, mats};
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    set.restitution = "off";
    const Model m = Model::build(set, cube(1.0));
    for (const Vec3& axis : {Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(1, -2, 0.5)}) {
      Release r;
      r.position = Vec3(0.2, -0.4, 2.5);
      r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.6, axis.normalized()));
      r.velocity = Vec3(1.0, 0.5, 0.0);
      r.angular_velocity = Vec3(0.0, 2.0, 1.0);
      State s = start(m, r, impacts());
      const double e0 = mechanical_energy(m, s);
      double worst = 0.0;
      for (int i = 0; i < 3000 && s.end == EndReason::running; ++i) {
        step(m, g, s);
        worst = std::max(worst, mechanical_energy(m, s) - e0);
      }
      // 1e-6 of the initial energy (≈ 7e4 J): round-off and the spring energy stored at
      // the end of a step, which is not counted in the mechanical energy.
      EXPECT_LT(worst, 1e-6 * e0) << dof << " axis " << axis.transpose() << " end " << to_string(s.end);
      EXPECT_FALSE(is_failure(s.end)) << to_string(s.end);
    }
  }
}

// A block spinning at 10 rad/s in free flight for 35 000 steps keeps its volume, edge
// lengths and energy: the rotation is applied exactly.
TEST(DdaFlight, SpinKeepsVolumeAndEnergy) {
  const terrain::Surface far_below = incline(0.0, 1e5);
  const std::vector<terrain::Material> mats{material(0.3)};
  const Ground g{&far_below, mats};
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    set.gravity = 0.0;
    set.max_steps = 35000;
    const geometry::Polyhedron block = testing::tetrahedron(2.03965);
    const Model m = Model::build(set, block);
    Release r;
    r.position = Vec3(0.0, 0.0, 100.0);
    r.angular_velocity = 10.0 * Vec3(0.3, -0.5, 0.8).normalized();
    r.velocity = Vec3(1.0, 0.0, 0.0);
    State s = start(m, r, impacts());
    const double e0 = kinetic_energy(m, s);
    while (s.end == EndReason::running) step(m, g, s);
    EXPECT_EQ(s.end, EndReason::step_limit);
    EXPECT_EQ(s.counters.steps, 35000u);
    geometry::Polyhedron now = block;
    now.vertices = s.world_vertices;
    const double v = geometry::mass_properties(now).volume;
    const double tol = std::string(dof) == "rigid6" ? 1e-12 : 1e-10;
    EXPECT_NEAR(v / m.volume, 1.0, tol) << dof;
    for (const BlockEdge& e : m.edges) {
      const double l0 = (m.vertices[e.a] - m.vertices[e.b]).norm();
      const double l1 = (s.world_vertices[e.a] - s.world_vertices[e.b]).norm();
      EXPECT_NEAR(l1 / l0, 1.0, tol) << dof;
    }
    EXPECT_NEAR(kinetic_energy(m, s) / e0, 1.0, tol) << dof;
    // 35 s of spin: 350 rad, so the orientation really turned.
    EXPECT_GT(Eigen::AngleAxisd(s.orientation).angle(), 0.0);
  }
}

// A cube on an incline with high friction: it stays below 45° and topples above; with
// μ < 1 it slides without toppling on the steep slope (the friction couple μN·a/2 cannot
// shift the normal force past the downhill edge).
TEST(DdaContact, SlideVersusTopple) {
  struct Case {
    double theta, mu;
    bool moves, topples;
  };
  for (const Case& c : {Case{40.0, 1.5, false, false}, Case{50.0, 1.5, true, true}, Case{50.0, 0.5, true, false}}) {
    const terrain::Surface plane = incline(c.theta, 40.0);
    const std::vector<terrain::Material> mats{material(c.mu)};
    const Ground g{&plane, mats};
    Settings set;
    set.rest_dwell = 1e9;
    const Model m = Model::build(set, cube(1.0));
    const Release r = testing::on_incline(c.theta, 1.0, -20.0, 5.0);
    State s = start(m, r, impacts());
    advance(m, g, s, 1500);
    const double moved = (s.position - r.position).norm();
    const double turned = Eigen::AngleAxisd(s.orientation * r.orientation.inverse()).angle();
    SCOPED_TRACE(::testing::Message() << "theta " << c.theta << " mu " << c.mu << " moved " << moved
                                      << " turned " << turned << " end " << to_string(s.end));
    EXPECT_FALSE(is_failure(s.end));
    if (c.moves) EXPECT_GT(moved, 0.5);
    else EXPECT_LT(moved, 1e-6);
    if (c.topples) EXPECT_GT(turned, M_PI / 4);   // past the tipping point
    else EXPECT_LT(turned, 1e-3);
  }
}

}  // namespace
}  // namespace talus::dda
