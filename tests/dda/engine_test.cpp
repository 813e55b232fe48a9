// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "contacts.hpp"
#include "dda_cases.hpp"
#include "episodes.hpp"
#include "talus/block/solids.hpp"
#include "talus/core/error.hpp"
#include "talus/dda/engine.hpp"

namespace talus::dda {
namespace {

using testing::cube;
using testing::incline;
using testing::material;

constexpr double kG = 9.81;

core::RandomStream impacts() { return testing::impact_stream(); }

// Runs n steps (or until the state ends).
void advance(const Model& m, const Ground& g, State& s, Workspace& ws, int n) {
  for (int i = 0; i < n && s.end == EndReason::running; ++i) step(m, g, s, ws);
}

// Free fall and projectile flight: Shi's constant-acceleration scheme is exact for
// gravity, so positions match the parabola to round-off on both DOF paths (the 12-DOF
// path solves its contact-free step instead of advancing the parabola in closed form).
TEST(DdaFlight, ProjectileIsExact) {
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const testing::FlightResult f = testing::projectile(set, 2.0);
    ASSERT_EQ(f.end, EndReason::running);
    // rigid6 flies in steps of up to flight_step_ratio nominal ones: the run stops at the
    // first step end at or past 2 s.
    EXPECT_GE(f.time, 2.0 - 1e-12);
    EXPECT_LT(f.time, 2.0 + set.flight_step_ratio * set.time_step);
    // 2000 additions of O(10 m) increments: a few hundred ulp of 500 m.
    EXPECT_LT(f.position_error, 1e-10) << dof;
    EXPECT_LT(f.velocity_error, 1e-10) << dof;
    EXPECT_EQ(f.contact_steps, 0u) << dof;
    // No terrain contact yet: the release flight is no jump.
    EXPECT_EQ(f.max_jump_height, 0.0) << dof;
  }
}

// The dynamic coefficient damps the velocity carried out of contact steps only: at any
// k_d the free flight is the exact parabola, and a cube dropped from 2 m lands and comes
// to rest on the ground, not in the air where it was released.
TEST(DdaEngine, DynamicCoefficientDampsContactStepsOnly) {
  for (const double kd : {0.0, 0.5, 0.9}) {
    for (const char* dof : {"rigid6", "full12"}) {
      Settings set;
      set.dof = dof;
      set.dynamic_coefficient = kd;
      const testing::FlightResult f = testing::projectile(set, 1.0);
      EXPECT_LT(f.position_error, 1e-10) << dof << " k_d " << kd;
      EXPECT_LT(f.velocity_error, 1e-10) << dof << " k_d " << kd;
      const terrain::Surface surface = incline(0.0, 20.0);
      const std::vector<terrain::Material> mats{material(0.5)};
      const Ground g{&surface, mats};
      const Model m = Model::build(set, cube(1.0));
      Release r;
      r.position = Vec3(0.0, 0.0, 2.5);
      const Summary out = run(m, g, r, testing::impact_stream());
      EXPECT_EQ(out.end, EndReason::rest) << dof << " k_d " << kd;
      // Resting on its face: the centroid half the edge above the ground.
      EXPECT_NEAR(out.final_position.z(), 0.5, 0.01) << dof << " k_d " << kd;
    }
  }
}

// A cube hopping from 1 mm above a 30° incline, tilted 10° so that one edge is lowest,
// launched at 1 m/s off the plane and 0.5 m/s down it, spinning at 2 rad/s about the
// normal (no point approaches the plane by turning); `set` chooses the engine settings.
struct Hop {
  static constexpr double theta = 30.0;
  terrain::Surface ground_surface = incline(theta);
  std::vector<terrain::Material> materials{material(0.5)};
  Ground g{&ground_surface, materials};
  Model m;
  Vec3 n = testing::incline_normal(theta);
  Release r = testing::on_incline(theta, 1.0, 0.0, 0.0);

  explicit Hop(const Settings& set) : m(Model::build(set, cube(1.0))) {
    r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(10.0 * M_PI / 180.0, Vec3::UnitX())) * r.orientation;
    // Lifted so that the lowest vertex is 1 mm off the plane (n·x = 0).
    r.position += (1e-3 - clearance(start(m, r, impacts()))) * n;
    r.velocity = 1.0 * n + 0.5 * testing::incline_down(theta);
    r.angular_velocity = 2.0 * n;
  }
  // Height of the lowest vertex above the plane (m).
  double clearance(const State& state) const {
    double least = std::numeric_limits<double>::infinity();
    for (const Vec3& v : world_vertices(m, state)) least = std::min(least, n.dot(v));
    return least;
  }
  // The free parabola from the release, at time t.
  Vec3 parabola(double t) const { return r.position + r.velocity * t + 0.5 * Vec3(0.0, 0.0, -kG) * t * t; }
};

// A block that flies close to the ground without touching it makes no contact step: the
// flight test looks at the block's vertices against the planes of the triangles below,
// then at the contact search's candidates on the free motion, and only a step in which a
// contact closes is a contact step. The cube of Hop: until it comes back down it is on
// the exact parabola and spin, and it lands with the first contact step.
TEST(DdaFlight, HopNearTheGroundIsFlight) {
  const Hop hop{Settings{}};
  State s = start(hop.m, hop.r, impacts());
  Workspace ws;
  std::uint64_t steps_in_flight = 0;
  double flown = 0.0;
  while (s.end == EndReason::running && s.counters.contact_steps == 0) {
    step(hop.m, hop.g, s, ws);
    if (s.counters.contact_steps > 0) break;
    ++steps_in_flight;
    const double t = s.time;
    flown = t;
    EXPECT_LT((s.position - hop.parabola(t)).norm(), 1e-12) << t;
    EXPECT_LT((s.velocity.segment<3>(3) - hop.r.angular_velocity).norm(), 1e-12) << t;
    EXPECT_GT(hop.clearance(s), 0.0) << t;  // nothing of the block below the plane
  }
  // Up and back down along the normal: 2·v_n/(g cos θ) = 0.24 s, less the last steps.
  EXPECT_GT(flown, 0.2);
  EXPECT_EQ(s.counters.flight_steps, steps_in_flight);
  EXPECT_EQ(s.counters.contact_steps, 1u);
  EXPECT_EQ(s.end, EndReason::running);
}

// With the flight test off (`flight_test: false`, for measuring what it saves) every step
// is a contact step, and one in which no contact closes is still the free motion: the
// cube of Hop follows the same parabola and spin to round-off until it lands.
TEST(DdaFlight, WithoutTheFlightTestEveryStepSearchesAndFliesTheSame) {
  Settings set;
  set.flight_test = false;
  const Hop hop{set};
  State s = start(hop.m, hop.r, impacts());
  Workspace ws;
  // Up and back down along the normal takes 0.24 s; until 0.2 s nothing can touch.
  while (s.end == EndReason::running && s.time < 0.2) {
    step(hop.m, hop.g, s, ws);
    const double t = s.time;
    EXPECT_LT((s.position - hop.parabola(t)).norm(), 1e-12) << t;
    EXPECT_LT((s.velocity.segment<3>(3) - hop.r.angular_velocity).norm(), 1e-12) << t;
    EXPECT_GT(hop.clearance(s), 0.0) << t;
    EXPECT_TRUE(s.contacts.empty()) << t;
  }
  EXPECT_EQ(s.end, EndReason::running);
  EXPECT_GT(s.counters.steps, 190u);
  EXPECT_EQ(s.counters.flight_steps, 0u);
  EXPECT_EQ(s.counters.contact_steps, s.counters.steps);
}

// A cube at rest on flat ground stays at rest; it sinks by mg/(n·k) with n = 4 vertex
// springs.
TEST(DdaContact, RestOnFlatGround) {
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const testing::SlideResult r = testing::on_slope(set, 0.0, 0.5, 2.0);
    ASSERT_EQ(r.end, EndReason::running) << dof;
    const double mass = 2800.0;
    const double expected = mass * kG / (4.0 * Model::build(set, cube(1.0)).stiffness);
    if (std::string(dof) == "rigid6") {
      EXPECT_NEAR(r.mean_sink, expected, 0.02 * expected);  // 2 %: the spring's residual oscillation
    } else {
      // The strains add the block's own compression under its weight: εz = mg/(2AE) with
      // free lateral strain, (1+ν)(1−2ν)/(1−ν) = 0.9 of it with the base held by the
      // locked shear springs; the centroid sinks by (a/2)εz more.
      const double free = 0.5 * mass * kG / (2.0 * 1.0 * set.young_modulus);
      EXPECT_GT(r.mean_sink - expected, 0.89 * free);
      EXPECT_LT(r.mean_sink - expected, 1.0 * free);
    }
    EXPECT_LT(r.drift, 1e-9) << dof;
    EXPECT_LT(r.drift_rotation, 1e-9) << dof;
  }
}

// Sliding on a 30° incline: displacement after 1 s against g(sin θ − μ cos θ)t²/2.
TEST(DdaContact, SlidingOnIncline) {
  const double th = 30.0 * M_PI / 180.0;
  for (const char* dof : {"rigid6", "full12"})
    for (const double mu : {0.0, 0.2, 0.4, 0.5}) {
      Settings set;
      set.dof = dof;
      const testing::SlideResult r = testing::on_slope(set, 30.0, mu, 1.0);
      // At the step that ends past 1 s (steps grow while the block starts from rest).
      const double exact = 0.5 * kG * (std::sin(th) - mu * std::cos(th)) * r.time * r.time;
      // 0.1 % on the rigid path (measured: < 1e-4 %); the 12-DOF path's barely damped
      // strain mode takes 0.1 % of the friction work at μ = 0.5 (measured), so 0.2 %.
      const double tol = std::string(dof) == "rigid6" ? 1e-3 : 2e-3;
      EXPECT_NEAR(r.distance, exact, tol * exact) << dof << " mu " << mu;
      EXPECT_LT(r.rotation, 1e-6) << dof << " mu " << mu;
    }
}

// Sticking when tan θ ≤ μ: no creep over 10 s (locked contacts keep their anchors; a
// contact that re-sticks after slipping keeps its force).
TEST(DdaContact, StickingDoesNotCreep) {
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const testing::SlideResult r = testing::on_slope(set, 30.0, 0.6, 10.0);
    ASSERT_EQ(r.end, EndReason::running) << dof;
    EXPECT_LT(r.drift, 1e-6) << dof;
    EXPECT_LT(r.drift_rotation, 1e-6) << dof;
  }
}

// Just below and just above the friction angle on a 30° incline. A cube set down at rest
// with tan θ barely above μ has its contacts at their friction limit: it slides as Coulomb
// has it, g(sin θ − μ cos θ)t²/2. When the return mapping of a contact at its limit moved
// its anchor to the limit of each solution, that converged by Σk_s/(2m/Δt² + Σk_s) ≈ 0.997
// per solve and stopped at the iteration bound: for μ/tan θ above 1 − (1 + tan θ)h₂/(2Ω²)
// ≈ 0.995 the rigid cube did not move (1e-6 m against 0.247 m at φ = 29.9° after 5 s), and
// turned 20° or 30° about the normal it did not move at φ = 29.5° either. With tan θ barely below μ it stays
// where it settled, on both DOF paths. (The 12-DOF path had no such band, but this close
// to the limit its strain mode makes it slide 5–75 % too far, as before; not asserted.)
TEST(DdaContact, SlidesJustBelowTheFrictionAngle) {
  const double th = 30.0 * M_PI / 180.0;
  // (turn about the normal, friction angle), degrees.
  const std::vector<std::pair<double, double>> slides{{0.0, 29.9},  {0.0, 29.95},  {0.0, 29.99}, {45.0, 29.9},
                                                      {45.0, 29.99}, {20.0, 29.5}, {20.0, 29.9}, {30.0, 29.95},
                                                      {30.0, 29.99}};
  for (const auto& [turn, phi] : slides) {
    const double mu = std::tan(phi * M_PI / 180.0);
    const testing::SlideResult r = testing::on_slope(Settings{}, 30.0, mu, 5.0, 0.1, turn);
    const double exact = 0.5 * kG * (std::sin(th) - mu * std::cos(th)) * r.time * r.time;
    // 1 %: the first contact step, which takes up the shear springs' stretch, leaves the
    // block about 3e-5 m/s down the slope, 1.5e-4 m over 5 s (measured: 0.02 % at 29.9°,
    // 0.6 % at 29.99°, where the travel is 2.5 cm; turned 20°, 0.8 % at 29.9°).
    EXPECT_NEAR(r.distance, exact, 0.01 * exact) << "turn " << turn << " phi " << phi;
    EXPECT_LT(r.rotation, 1e-6) << "turn " << turn << " phi " << phi;
  }
  for (const char* dof : {"rigid6", "full12"}) {
    for (const double turn : {0.0, 45.0}) {
      for (const double phi : {30.05, 30.5}) {
        Settings set;
        set.dof = dof;
        const testing::SlideResult r =
            testing::on_slope(set, 30.0, std::tan(phi * M_PI / 180.0), 5.0, 0.1, turn);
        ASSERT_EQ(r.end, EndReason::running) << dof;
        EXPECT_LT(r.drift, 1e-6) << dof << " turn " << turn << " phi " << phi;
        EXPECT_LT(r.drift_rotation, 1e-6) << dof << " turn " << turn << " phi " << phi;
      }
    }
  }
}

// A normal impact returns the rebound speed of the restitution law: the default
// stiffness makes the raw penalty rebound nearly elastic (Ω = √(nk/m)Δt ≈ 38 for four
// vertex springs), so the law, not the spring, sets the rebound.
TEST(DdaImpact, NormalImpactFollowsTheLaw) {
  for (const char* dof : {"rigid6", "full12"})
  for (const double v_in : {3.0, 7.0, 12.0}) {
    SCOPED_TRACE(dof);
    Settings set;
    set.dof = dof;
    const double r_v = 0.95, k = 12.0;
    const double expected = r_v / (1.0 + (v_in / k) * (v_in / k)) * v_in;
    const testing::ReboundResult law = testing::rebound(set, v_in, r_v);
    // The step is cut at the moment of touch on the free motion (measured within 5e-4
    // of the speed at the ground on the 12-DOF path, whose flight solves its strains).
    EXPECT_NEAR(law.v_in, v_in, 1e-3 * v_in);
    EXPECT_NEAR(law.v_out, expected, 0.01 * expected) << "v_in " << v_in;
    set.restitution = "normal_component";
    EXPECT_NEAR(testing::rebound(set, v_in, r_v).v_out, expected, 0.01 * expected) << "normal variant, v_in " << v_in;
    // Without the law the raw rebound is nearly elastic at the default stiffness
    // (measured 0.93 at 3 m/s, 0.95 at 7 and 12 m/s), above the law's cap.
    set.restitution = "off";
    const testing::ReboundResult raw = testing::rebound(set, v_in, r_v);
    EXPECT_GT(raw.v_out / raw.v_in, 0.92) << "v_in " << v_in;
    EXPECT_LE(raw.v_out / raw.v_in, 1.0 + 1e-9) << "v_in " << v_in;
    EXPECT_GT(raw.v_out, expected) << "v_in " << v_in;
  }
}

// The rebound of an impact does not depend on the time step. A 1 m³ cube dropped 3 m
// onto flat ground lands on a corner, turns and slaps down on its face. When a step cut
// to the moment of touch grew back from the touch (×1.3 per step from a fraction of Δt),
// the contact that followed was integrated over many short steps where Shi's scheme damps
// a spring most, and was settled plastically as persistent: the cube's first rebound was
// 0.94 m at Δt = 1 ms against 1.45 m at 0.1 ms (μ = tan 10°). The impact now gets the step
// the cut shortened, and the slap, whose contact points strike at an impact's speed, is
// an impact under the law. Measured (the largest jump is the first rebound's): μ = tan 10°,
// 1.301–1.302 m at 2, 1, 0.5, 0.2, 0.1 and 0.05 ms. With μ = 0.6 the tumble after the
// corner takes one of two courses by the step (docs/dda.md, Known limits), so it is not
// asserted here.
TEST(DdaImpact, ReboundDoesNotDependOnTheStep) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(std::tan(10.0 * M_PI / 180.0), 0.95)};
  const Ground g{&flat, mats};
  const auto first_rebound = [&](double dt) {
    Settings set;
    set.time_step = dt;
    const Model m = Model::build(set, cube(1.0));
    Release r;
    r.position = Vec3(0.0, 0.0, 3.0);
    r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(20.0 * M_PI / 180.0, Vec3::UnitZ()) *
                                       Eigen::AngleAxisd(10.0 * M_PI / 180.0, Vec3::UnitY()));
    State s = start(m, r, impacts());
    Workspace ws;
    while (s.end == EndReason::running && s.time < 3.0) step(m, g, s, ws);
    EXPECT_FALSE(is_failure(s.end)) << to_string(s.end);
    return s.max_jump_height;
  };
  const double reference = first_rebound(1e-4);
  EXPECT_GT(reference, 1.0);
  for (const double dt : {2e-3, 1e-3, 5e-4})
    EXPECT_NEAR(first_rebound(dt), reference, 0.02 * reference) << "time step " << dt;
}

// A corner that strikes the ground is an impact however slowly the centroid approaches:
// a tetrahedron set rocking on flat ground strikes with its corners at about 1 m/s while
// its centroid barely moves. When such strikes were judged by the centroid they were no
// impacts, the stiff penalty spring returned them nearly elastically, and 14 of 16
// tetrahedra released 2 cm above the ground spinning at 1.8 rad/s still rocked after 60 s
// (dda-run, plane-0-smooth of the stress suite). Judged by the contact point, each strike
// is an impact under the law and the block comes to rest within 3 s.
TEST(DdaImpact, RockingBlockComesToRest) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(std::tan(10.0 * M_PI / 180.0), 0.95)};
  const Ground g{&flat, mats};
  const Model m = Model::build(Settings{}, testing::tetrahedron(std::cbrt(6.0 * std::sqrt(2.0))));
  for (const Vec3& axis : {Vec3(1, 0, 0), Vec3(1, 2, 0.5), Vec3(-0.3, 1, 2), Vec3(2, -1, 1)}) {
    Release r;
    r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.9, axis.normalized()));
    r.angular_velocity = Vec3(1.5, 1.0, 0.0);
    State s = start(m, r, impacts());
    Workspace ws;
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vec3& x : world_vertices(m, s)) lowest = std::min(lowest, x.z());
    r.position.z() += 0.02 - lowest;
    s = start(m, r, impacts());
    const double e0 = mechanical_energy(m, s);
    double gain = 0.0;
    while (s.end == EndReason::running && s.time < 20.0) {
      step(m, g, s, ws);
      gain = std::max(gain, mechanical_energy(m, s) - e0);
    }
    EXPECT_EQ(s.end, EndReason::rest) << "axis " << axis.transpose() << " t " << s.time;
    EXPECT_LT(s.time, 6.0) << "axis " << axis.transpose();
    EXPECT_GT(s.impacts, 3u) << "axis " << axis.transpose();
    EXPECT_LT(gain, 1e-6 * e0);
  }
}

// The scaled law removes at most the kinetic energy of the impact's normal approach: a
// normal impact is scaled by R_v·SF exactly, a grazing one (a facet hop) loses no more
// than ½·m·v_n², and without the bound (restitution_bound: none) the grazing impact is cut
// like a normal one.
TEST(DdaImpact, LawRemovesAtMostTheNormalApproachEnergy) {
  for (const char* bound : {"normal_approach", "none"}) {
    SCOPED_TRACE(bound);
    Settings set;
    set.restitution_bound = bound;
    const Model m = Model::build(set, cube(1.0));
    const double r_v = 0.95, k = 12.0;
    struct Case {
      Vec3 v_in, v_raw;  // centroid velocity at the start of the impact, DDA rebound (m/s)
    };
    for (const Case& c : {Case{Vec3(0, 0, -7), Vec3(0, 0, 7)}, Case{Vec3(5, 0, -0.4), Vec3(5, 0, 0.4)},
                          Case{Vec3(3, 2, -1.5), Vec3(3, 2, 1.2)}}) {
      State s = start(m, Release{}, impacts());
      Workspace ws;
      s.episode.active = true;
      s.episode.impact = true;
      s.episode.velocity_in = c.v_in;
      s.episode.kinetic_in = 0.5 * m.mass * c.v_in.squaredNorm();
      s.episode.normal = Vec3::UnitZ();
      s.episode.approach_speed = -c.v_in.z();
      s.episode.restitution = r_v;
      s.episode.restitution_scale = k;
      s.velocity.setZero();
      s.velocity.head<3>() = c.v_raw;
      detail::finish_impact(m, s);
      const double speed_in = c.v_in.norm();
      const double cap = r_v / (1.0 + (speed_in / k) * (speed_in / k));
      const double raw = 0.5 * m.mass * c.v_raw.squaredNorm();
      const double removed = raw - 0.5 * m.mass * s.velocity.head<3>().squaredNorm();
      const double normal = 0.5 * m.mass * c.v_in.z() * c.v_in.z();
      const double by_law = raw - std::pow(cap * speed_in, 2) * 0.5 * m.mass;
      SCOPED_TRACE(c.v_in.transpose());
      // Round-off of a velocity scaling: 1e-12 of the energies involved.
      if (std::string(bound) == "normal_approach") {
        EXPECT_LE(removed, normal * (1.0 + 1e-12) + 1e-12 * raw);
        EXPECT_NEAR(removed, std::min(by_law, normal), 1e-9 * raw);
      } else {
        EXPECT_NEAR(removed, by_law, 1e-9 * raw);
      }
      EXPECT_GE(removed, -1e-12 * raw);  // never adds energy
      // The rebound direction is kept (no tilt drawn here).
      EXPECT_NEAR(s.velocity.head<3>().normalized().dot(c.v_raw.normalized()), 1.0, 1e-12);
    }
  }
}

// A block that slides down a slope face onto flat ground hits the flat while its contact
// on the face is still closed: that arrival is an impact along the flat's normal, so the
// restitution law bounds the rebound. (Before, it was part of the sliding episode, had no
// law, and the stiff spring threw the block back up with its whole kinetic energy.) Cube
// of 1 m released at rest on a 40° face (μ = 0.2) that meets a flat floor at x = 0.
TEST(DdaImpact, ArrivalWhileSlidingIsAnImpact) {
  geometry::TriangleMesh mesh;
  const double t = std::tan(40.0 * M_PI / 180.0);
  for (const double y : {-10.0, 10.0})
    for (const double x : {-20.0, 0.0, 20.0}) mesh.vertices.emplace_back(x, y, x < 0.0 ? -x * t : 0.0);
  mesh.triangles = {{0, 1, 4}, {0, 4, 3}, {1, 2, 5}, {1, 5, 4}};
  const terrain::Surface surface = terrain::Surface::from_mesh(mesh);
  const double r_v = 0.3, k = 12.0;
  const std::vector<terrain::Material> mats{material(0.2, r_v, k)};
  const Ground g{&surface, mats};
  Settings set;
  set.check_invariants = true;
  const Model m = Model::build(set, cube(1.0));
  State s = start(m, testing::on_incline(40.0, 1.0, -10.0, 0.0), impacts());
  Workspace ws;
  Vec3 v_in = Vec3::Zero();
  double kinetic_in = 0.0, kinetic_out = -1.0;
  std::int64_t closed_at_arrival = 0;
  while (s.end == EndReason::running && s.time < 6.0) {
    const Vec3 v = s.velocity.head<3>();
    const double kinetic = kinetic_energy(m, s);
    const std::int64_t closed =
        std::count_if(s.contacts.begin(), s.contacts.end(), [](const Contact& c) { return c.mode != ContactMode::open; });
    step(m, g, s, ws);
    if (s.impacts == 1 && kinetic_in == 0.0) {
      v_in = v;
      kinetic_in = kinetic;
      closed_at_arrival = closed;
    }
    if (s.impacts == 1 && !(s.episode.active && s.episode.impact)) {
      kinetic_out = kinetic_energy(m, s);  // the rebound, after the law
      break;
    }
  }
  ASSERT_EQ(s.impacts, 1) << "no impact at the foot of the face";
  ASSERT_GE(kinetic_out, 0.0) << "the impact never ended";
  EXPECT_GT(closed_at_arrival, 0) << "the cube was sliding on the face when it reached the floor";
  const double v_n = -v_in.z();  // approach along the floor's normal
  EXPECT_GT(v_n, 5.0);
  // The scaled law: the rebound keeps at most (R_v·SF)² of the impact's kinetic energy,
  // or, where that would remove more than the normal approach energy ½·m·v_n², what is
  // left after removing that (the raw rebound has no more than the impact brought).
  const double speed = v_in.norm();
  const double sf = 1.0 / (1.0 + (speed / k) * (speed / k));
  const double allowed = std::max(r_v * sf * r_v * sf * kinetic_in, kinetic_in - 0.5 * m.mass * v_n * v_n);
  EXPECT_LE(kinetic_out, allowed * (1.0 + 1e-9)) << "in " << kinetic_in << " J";
  EXPECT_LT(kinetic_out, 0.7 * kinetic_in);
  EXPECT_EQ(s.counters.energy_violations, 0u);
  EXPECT_EQ(s.counters.depth_violations, 0u);
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
      Workspace ws;
      const double e0 = mechanical_energy(m, s);
      double worst = 0.0;
      for (int i = 0; i < 3000 && s.end == EndReason::running; ++i) {
        step(m, g, s, ws);
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
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const testing::SpinResult r = testing::spin(set, 35000);
    EXPECT_EQ(r.end, EndReason::step_limit);
    EXPECT_EQ(r.steps, 35000u);
    // Round-off of a unit quaternion renormalised each step (measured ~1e-15). The
    // 12-DOF solve also leaves round-off strain rates in its undamped strain mode, which
    // the energy sees (measured 2e-12), so 1e-11 there.
    EXPECT_LT(r.volume_error, 1e-12) << dof;
    EXPECT_LT(r.edge_error, 1e-12) << dof;
    EXPECT_LT(r.energy_error, std::string(dof) == "rigid6" ? 1e-12 : 1e-11) << dof;
    EXPECT_GT(r.angle, 0.0);
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
    Workspace ws;
    advance(m, g, s, ws, 1500);
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

// A rigid block slower than `slow_kinetic_energy` outside an impact grows its contact
// steps: a cube sliding to a stop on a 10° incline (μ = 0.5) from 1.5 m/s decelerates at
// a = g(μ cos θ − sin θ) and stops after v²/(2a), with the long steps as with nominal
// ones, in fewer steps, and stays where it stopped.
TEST(DdaStep, SlowBlockTakesLongerStepsAndStopsWhereItShould) {
  const double theta = 10.0, mu = 0.5, v0 = 1.5;
  const double th = theta * M_PI / 180.0;
  const double exact = v0 * v0 / (2.0 * kG * (mu * std::cos(th) - std::sin(th)));  // 0.36 m
  const terrain::Surface plane = incline(theta, 40.0);
  const std::vector<terrain::Material> mats{material(mu)};
  const Ground g{&plane, mats};
  struct Outcome {
    double distance, drift, longest;
    std::uint64_t contact_steps;
  };
  const auto slide = [&](double slow) {
    Settings set;
    set.slow_kinetic_energy = slow;
    set.rest_dwell = 1e9;  // keep stepping after the stop
    const Model m = Model::build(set, cube(1.0));
    Release r = testing::on_incline(theta, 1.0, -10.0, 5.0);
    r.velocity = v0 * testing::incline_down(theta);
    State s = start(m, r, impacts());
    Workspace ws;
    Outcome out{0.0, 0.0, 0.0, 0};
    Vec3 stopped = Vec3::Zero();
    while (s.time < 2.0 - 1e-9 && s.end == EndReason::running) {
      const double before = s.time;
      step(m, g, s, ws);
      out.longest = std::max(out.longest, s.time - before);
      if (before < 1.0 && s.time >= 1.0) stopped = s.position;  // 0.52 s after the stop
    }
    EXPECT_EQ(s.end, EndReason::running) << "slow " << slow;
    out.distance = (s.position - r.position).dot(testing::incline_down(theta));
    out.drift = (s.position - stopped).norm();
    out.contact_steps = s.counters.contact_steps;
    return out;
  };
  const Outcome nominal = slide(0.0);
  const Outcome slow = slide(Settings{}.slow_kinetic_energy);
  // Measured: 7.6e-6 and 7.9e-6 of the distance (the spring's sink and its start), the
  // two 0.13 µm apart; no drift at all once stopped.
  for (const Outcome& o : {nominal, slow}) {
    EXPECT_NEAR(o.distance, exact, 1e-4 * exact);
    EXPECT_LT(o.drift, 1e-9);
  }
  EXPECT_NEAR(slow.distance, nominal.distance, 1e-5 * exact);
  EXPECT_LE(nominal.longest, Settings{}.time_step * (1.0 + 1e-9));
  EXPECT_NEAR(slow.longest, Settings{}.rest_step_ratio * Settings{}.time_step, 1e-9);
  // 2 s: 2 000 nominal steps; 0.33 s above 0.5 m/s, then steps of up to 4 ms (743 in all).
  EXPECT_LT(slow.contact_steps, nominal.contact_steps / 2);
}

// A faceted sphere (1 280 triangles, 1 m³) dropped 3 cm onto a 20° plane (μ = 0.4), so
// that its impact exercises the step's checks, rolls down it for 1 s with the contact
// step's candidates set aside as usual (twice their point's motion), with none set aside
// (every candidate in every solve: the reference), and with nearly all set aside (a
// margin of 1e-9 of the motion, so that the step must widen again and again). Each
// accepted solution leaves every candidate consistent, so the three roll alike (to 1e-6
// of the distance); the invariants hold throughout. Passing over the candidates set aside
// instead of building them changes nothing.
// A faceted ellipsoid of 1 m³ (1 280 triangles, invariants checked) and an incline of 20°
// with friction 0.4: the ground of the tests of candidates set aside.
struct FacetedOnIncline {
  explicit FacetedOnIncline(const Vec3& dimensions, int resolution = 8, double smooth_turn_deg = 0.0) {
    block::SolidSpec spec;
    spec.kind = block::SolidKind::ellipsoid;
    spec.volume = 1.0;
    spec.dimensions = dimensions;
    spec.resolution = resolution;
    Settings set = testing::faceted_settings();
    set.check_invariants = true;
    set.smooth_turn_deg = smooth_turn_deg;
    m = Model::build(set, block::make_solid(spec, "ellipsoid"));
  }
  FacetedOnIncline(const FacetedOnIncline&) = delete;  // g points into it
  FacetedOnIncline& operator=(const FacetedOnIncline&) = delete;
  const double theta = 20.0;
  const terrain::Surface plane = incline(theta, 40.0);
  const std::vector<terrain::Material> mats{material(0.4)};
  const Ground g{&plane, mats};
  const Vec3 n = testing::incline_normal(theta);
  Model m;
};

TEST(DdaContact, CandidatesSetAsideDoNotChangeTheRoll) {
  const FacetedOnIncline scene(Vec3(1.24, 1.24, 1.24));
  const auto& [theta, plane, mats, g, n, m] = scene;
  ASSERT_NE(m.index, nullptr);
  double below = 0.0;  // the sphere's extent along −n
  for (const Vec3& v : m.vertices) below = std::max(below, -n.dot(v));
  struct Outcome {
    double distance;
    Counters counters;
  };
  State last;
  const auto roll = [&](double scale, bool pass_over = true) {
    Release r;
    r.position = Vec3(-10.0, 5.0, 10.0 * std::tan(theta * M_PI / 180.0)) + (below + 0.03) * n;
    State s = start(m, r, impacts());
    Workspace ws({.set_aside_scale = scale, .pass_over = pass_over});
    while (s.time < 1.0 - 1e-9 && s.end == EndReason::running) step(m, g, s, ws);
    EXPECT_EQ(s.end, EndReason::running) << "scale " << scale;
    last = s;
    return Outcome{(s.position - r.position).dot(testing::incline_down(theta)), s.counters};
  };
  const Outcome reference = roll(std::numeric_limits<double>::infinity());
  const Outcome usual = roll(2.0);
  const State passed = last;
  const Outcome widening = roll(1e-9);
  const State widened = last;
  // The near search passes over most candidates set aside (PassOver) and solves again
  // without passing over only where its check of them as a group fails: the roll is the
  // same to the bit as the one that builds and checks each of them, with either margin.
  std::printf("solved again without passing over: %llu of %llu (usual), %llu of %llu (widening)\n",
              static_cast<unsigned long long>(usual.counters.unpassed_steps),
              static_cast<unsigned long long>(usual.counters.contact_steps),
              static_cast<unsigned long long>(widening.counters.unpassed_steps),
              static_cast<unsigned long long>(widening.counters.contact_steps));
  EXPECT_LT(usual.counters.unpassed_steps, usual.counters.contact_steps / 100 + 1);
  EXPECT_GT(widening.counters.unpassed_steps, 0u);  // the check's failures are exercised
  for (const auto& [scale, with] : {std::pair{2.0, &passed}, std::pair{1e-9, &widened}}) {
    roll(scale, false);
    EXPECT_EQ(last.counters.unpassed_steps, 0u);
    EXPECT_EQ(last.counters.contact_steps, with->counters.contact_steps) << scale;
    EXPECT_EQ(last.position, with->position) << scale;
    EXPECT_EQ(last.velocity, with->velocity) << scale;
    EXPECT_EQ(last.orientation.coeffs(), with->orientation.coeffs()) << scale;
  }
  EXPECT_EQ(reference.counters.set_aside_contacts, 0u);
  EXPECT_EQ(reference.counters.widened_steps, 0u);
  // The usual margin sets most candidates aside and hardly ever widens.
  EXPECT_GT(usual.counters.set_aside_contacts, usual.counters.contacts / 2);
  EXPECT_LT(usual.counters.widened_steps, usual.counters.contact_steps / 100 + 1);
  EXPECT_GT(widening.counters.widened_steps, widening.counters.contact_steps / 20);  // measured 14 of 34
  for (const Outcome* o : {&reference, &usual, &widening}) {
    EXPECT_EQ(o->counters.energy_violations, 0u);
    EXPECT_EQ(o->counters.depth_violations, 0u);
  }
  // (5/7)·g·sin θ·t²/2 = 1.20 m for a smooth ball rolling from rest; the bounce and the
  // facets take some of it.
  std::printf("rolled %.9f m (every candidate solved), %.9f m (usual), %.9f m (widening); widened %llu of %llu\n",
              reference.distance, usual.distance, widening.distance,
              static_cast<unsigned long long>(widening.counters.widened_steps),
              static_cast<unsigned long long>(widening.counters.contact_steps));
  // Measured: the same 1.064231792 m all three ways.
  EXPECT_NEAR(usual.distance, reference.distance, 1e-6 * reference.distance);
  EXPECT_NEAR(widening.distance, reference.distance, 1e-6 * reference.distance);
}

// The flight test's near search passes over what a contact step from its pose would set
// aside, and that step takes what was passed over from it: a faceted sphere thrown onto
// the incline, bouncing and rolling, is the same to the bit with and without passing over.
TEST(DdaContact, FlightSearchPassesOverAsTheStepWould) {
  const FacetedOnIncline scene(Vec3(1.4, 1.2, 1.1));
  const auto& [theta, plane, mats, g, n, m] = scene;
  ASSERT_NE(m.index, nullptr);
  const auto fall = [&](bool pass_over) {
    Release r;
    r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, 3.0).normalized()));
    double below = 0.0;  // the block's extent along −n
    for (const Vec3& v : m.vertices) below = std::max(below, -n.dot(r.orientation * v));
    // 1 cm clear of the plane, thrown at it and down the slope, spinning.
    r.position = Vec3(-10.0, 5.0, 10.0 * std::tan(theta * M_PI / 180.0)) + (below + 0.01) * n;
    r.velocity = -0.3 * n + 1.0 * testing::incline_down(theta);
    r.angular_velocity = Vec3(0.3, -1.0, 0.2);
    State s = start(m, r, impacts());
    Workspace ws({.pass_over = pass_over});
    while (s.time < 1.5 - 1e-9 && s.end == EndReason::running) step(m, g, s, ws);
    EXPECT_EQ(s.end, EndReason::running) << s.time;
    EXPECT_EQ(s.counters.energy_violations, 0u);
    EXPECT_EQ(s.counters.depth_violations, 0u);
    return s;
  };
  const State passed = fall(true);
  const State built = fall(false);
  std::printf("flight searches passed over %llu candidates; %llu flight and %llu contact steps\n",
              static_cast<unsigned long long>(passed.counters.flight_passed),
              static_cast<unsigned long long>(passed.counters.flight_steps),
              static_cast<unsigned long long>(passed.counters.contact_steps));
  EXPECT_GT(passed.counters.flight_passed, 0u);
  EXPECT_EQ(built.counters.flight_passed, 0u);
  EXPECT_GT(passed.counters.contact_steps, 100u);
  EXPECT_EQ(passed.counters.steps, built.counters.steps);
  EXPECT_EQ(passed.counters.contact_steps, built.counters.contact_steps);
  EXPECT_EQ(passed.counters.contacts, built.counters.contacts);
  EXPECT_EQ(passed.counters.set_aside_contacts, built.counters.set_aside_contacts);
  EXPECT_EQ(passed.position, built.position);
  EXPECT_EQ(passed.velocity, built.velocity);
  EXPECT_EQ(passed.orientation.coeffs(), built.orientation.coeffs());
}

// The smooth surface (docs/dda.md, Smooth surface): a geodesic sphere of 1 280 and of
// 5 120 triangles rolls from rest down 20° (μ = 0.4) for 1.5 s as a ball does, (5/7)·g·
// sin θ·t²/2, within 1 % (measured within 0.3 %); on its facets (smooth_turn_deg 0) the
// pivots cost it several per cent. No invariant is broken either way.
TEST(DdaSmooth, FacetedSpheresRollAsABall) {
  const double duration = 1.5;
  const auto roll = [&](int resolution, double smooth) {
    const FacetedOnIncline scene(Vec3(1.24, 1.24, 1.24), resolution, smooth);
    const auto& [theta, plane, mats, g, n, m] = scene;
    double below = 0.0;
    for (const Vec3& v : m.vertices) below = std::max(below, -n.dot(v));
    Release r;
    r.position = Vec3(-10.0, 5.0, 10.0 * std::tan(theta * M_PI / 180.0)) + (below + 1e-6) * n;
    State s = start(m, r, impacts());
    Workspace ws;
    while (s.time < duration - 1e-9 && s.end == EndReason::running) step(m, g, s, ws);
    EXPECT_EQ(s.end, EndReason::running);
    EXPECT_EQ(s.counters.energy_violations, 0u);
    EXPECT_EQ(s.counters.depth_violations, 0u);
    const double ball = 5.0 / 7.0 * 9.81 * std::sin(theta * M_PI / 180.0) * s.time * s.time / 2.0;
    return (s.position - r.position).dot(testing::incline_down(theta)) / ball;
  };
  for (const int resolution : {8, 16}) {
    const double smooth = roll(resolution, 40.0);
    const double faceted = roll(resolution, 0.0);
    std::printf("%d triangles: smooth %.4f, faceted %.4f of a ball's distance\n", 20 * resolution * resolution,
                smooth, faceted);
    EXPECT_NEAR(smooth, 1.0, 0.01) << resolution;
    EXPECT_LT(faceted, 0.99) << resolution;
  }
}

// Rolling resistance (docs/dda.md, Rolling resistance): a smooth sphere of 1 280 and of
// 5 120 triangles rolls from rest down 20° (μ = 0.4) with μ_r = 0.1 as a ball whose
// rolling is resisted by μ_r·R·F_n does, (5/7)·g·(sin θ − μ_r·cos θ)·t²/2, within 1 %;
// launched rolling at 2 m/s down 3° (tan 3° < μ_r) it stops where that deceleration
// stops a ball, v²/(2·(5/7)·g·(μ_r·cos θ − sin θ)), within 3 %, and ends at rest. No
// invariant is broken.
TEST(DdaRolling, SmoothSpheresRollAndStopAsAResistedBall) {
  const double mu_r = 0.1;
  for (const int resolution : {8, 16}) {
    block::SolidSpec spec;
    spec.kind = block::SolidKind::ellipsoid;
    spec.volume = 1.0;
    spec.dimensions = Vec3(1.24, 1.24, 1.24);
    spec.resolution = resolution;
    Settings set;
    set.check_invariants = true;
    set.smooth_turn_deg = 40.0;
    set.rolling_resistance = mu_r;
    const Model m = Model::build(set, block::make_solid(spec, "sphere"));
    const std::vector<terrain::Material> mats{material(0.4)};
    for (const double theta : {20.0, 3.0}) {
      const terrain::Surface plane = incline(theta, 40.0);
      const Ground g{&plane, mats};
      const Vec3 n = testing::incline_normal(theta), down = testing::incline_down(theta);
      double below = 0.0;
      for (const Vec3& v : m.vertices) below = std::max(below, -n.dot(v));
      Release r;
      r.position = Vec3(-20.0, 5.0, 20.0 * std::tan(theta * M_PI / 180.0)) + (below + 1e-6) * n;
      const double th = theta * M_PI / 180.0;
      const double a = 5.0 / 7.0 * 9.81 * (std::sin(th) - mu_r * std::cos(th));
      if (theta < 10.0) {
        r.velocity = 2.0 * down;
        r.angular_velocity = n.cross(down) * (2.0 / below);  // rolling without slip
      }
      State s = start(m, r, impacts());
      Workspace ws;
      const double duration = theta > 10.0 ? 1.5 : 20.0;
      while (s.time < duration - 1e-9 && s.end == EndReason::running) step(m, g, s, ws);
      EXPECT_EQ(s.counters.energy_violations, 0u);
      EXPECT_EQ(s.counters.depth_violations, 0u);
      const double distance = (s.position - r.position).dot(down);
      if (theta > 10.0) {
        EXPECT_EQ(s.end, EndReason::running);
        const double ball = a * s.time * s.time / 2.0;
        std::printf("%d triangles, %.0f deg: %.4f of a resisted ball's distance\n", 20 * resolution * resolution,
                    theta, distance / ball);
        EXPECT_NEAR(distance / ball, 1.0, 0.01) << resolution;
      } else {
        const double stop = 4.0 / (2.0 * -a);
        std::printf("%d triangles, %.0f deg: stopped at %.4f of a resisted ball's distance after %.2f s (%s)\n",
                    20 * resolution * resolution, theta, distance / stop, s.time, std::string(to_string(s.end)).c_str());
        EXPECT_EQ(s.end, EndReason::rest);
        EXPECT_NEAR(distance / stop, 1.0, 0.03) << resolution;
      }
    }
  }
}

// The Platonic solids and boxes are all corners at the default of 40° (their faces turn by
// 41.8° or more at every vertex): no vertex is rounded and no search is widened, so their
// contacts are the polyhedron's. A geodesic sphere's vertices carry spheres within 1 % of
// its circumradius, and its searches widen by under 2 % of its radius.
TEST(DdaSmooth, PlatonicSolidsStayPolyhedraAndSpheresRound) {
  Settings set;
  set.smooth_turn_deg = 40.0;
  for (const auto kind : {block::SolidKind::tetrahedron, block::SolidKind::cube, block::SolidKind::octahedron,
                          block::SolidKind::dodecahedron, block::SolidKind::icosahedron}) {
    block::SolidSpec spec;
    spec.kind = kind;
    spec.volume = 1.0;
    const Model m = Model::build(set, block::make_solid(spec, "solid"));
    EXPECT_EQ(m.rounding_reach, 0.0);
    for (const double rho : m.vertex_rounding) EXPECT_EQ(rho, 0.0);
  }
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 1.0;
  spec.dimensions = Vec3(1.24, 1.24, 1.24);
  spec.resolution = 8;
  const Model m = Model::build(set, block::make_solid(spec, "sphere"));
  for (const double rho : m.vertex_rounding) EXPECT_NEAR(rho, m.radius, 0.01 * m.radius);
  EXPECT_GT(m.rounding_reach, 0.0);
  EXPECT_LT(m.rounding_reach, 0.02 * m.radius);  // ρ·(1 − cos 2α), α ≈ 5° at 1 280 triangles
  set.smooth_turn_deg = 0.0;
  EXPECT_TRUE(Model::build(set, block::make_solid(spec, "sphere")).vertex_rounding.empty());
}

}  // namespace
}  // namespace talus::dda
