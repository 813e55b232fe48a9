// SPDX-License-Identifier: MIT
// The analytic validation cases, as functions of the engine settings: the tests assert
// on them, the dda_accuracy bench sweeps them over Δt, stiffness and DOF path.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include "dda_fixtures.hpp"

namespace talus::dda::testing {

inline core::RandomStream impact_stream() { return core::RandomStream(7, core::Stream::impact, 0); }

/// Projectile flight for `seconds` from 500 m above flat ground: the largest centroid
/// position error against the exact parabola (m), and the velocity error (m/s).
struct FlightResult {
  double position_error = 0.0;
  double velocity_error = 0.0;
  double max_jump_height = 0.0;
  std::uint64_t contact_steps = 0;
  double time = 0.0;
  EndReason end = EndReason::running;
};
inline FlightResult projectile(const Settings& set, double seconds) {
  const terrain::Surface surface = incline(0.0, 2000.0);
  const std::vector<terrain::Material> mats{material(0.3)};
  const Ground g{&surface, mats};
  const Model m = Model::build(set, cube(1.0));
  Release r;
  r.position = Vec3(0.0, 0.0, 500.0);
  r.velocity = Vec3(12.0, -3.0, 8.0);
  r.angular_velocity = Vec3(1.0, 2.0, -0.5);
  State s = start(m, r, impact_stream());
  Workspace ws;
  FlightResult out;
  const Vec3 gv(0.0, 0.0, -set.gravity);
  while (s.time < seconds - 1e-9 && s.end == EndReason::running) {
    step(m, g, s, ws);
    const double t = s.time;
    out.position_error = std::max(out.position_error, (s.position - (r.position + r.velocity * t + 0.5 * gv * t * t)).norm());
    out.velocity_error = std::max(out.velocity_error, (s.velocity.head<3>() - (r.velocity + gv * t)).norm());
  }
  out.max_jump_height = s.max_jump_height;
  out.contact_steps = s.counters.contact_steps;
  out.time = s.time;
  out.end = s.end;
  return out;
}

/// A cube (edge 1 m) set down on an incline of θ with friction μ, stepped for `seconds`;
/// `turn_deg` turns it about the incline's normal (0: edges along and across the slope).
struct SlideResult {
  double distance = 0.0;         ///< centroid displacement down the slope (m)
  double rotation = 0.0;         ///< rad
  double drift = 0.0;            ///< displacement after the first `settle` seconds (m)
  double drift_rotation = 0.0;   ///< rotation after the first `settle` seconds (rad)
  double mean_sink = 0.0;        ///< mean centroid sink over the second half (m)
  double time = 0.0;             ///< when the run stopped: `seconds`, or the step across it (s)
  EndReason end = EndReason::running;
};
inline SlideResult on_slope(Settings set, double theta_deg, double mu, double seconds, double settle = 0.1,
                            double turn_deg = 0.0) {
  const terrain::Surface surface = incline(theta_deg);
  const std::vector<terrain::Material> mats{material(mu)};
  const Ground g{&surface, mats};
  set.rest_dwell = 1e9;  // keep stepping: the cases watch the rest themselves
  set.max_steps = 1 << 30;
  const Model m = Model::build(set, cube(1.0));
  Release r = on_incline(theta_deg, 1.0, -5.0, 8.0);
  r.orientation = r.orientation * Eigen::Quaterniond(Eigen::AngleAxisd(turn_deg * M_PI / 180.0, Vec3::UnitZ()));
  State s = start(m, r, impact_stream());
  Workspace ws;
  while (s.time < settle - 1e-9 && s.end == EndReason::running) step(m, g, s, ws);
  const Vec3 settled = s.position;
  const Eigen::Quaterniond q_settled = s.orientation;
  const Vec3 normal = incline_normal(theta_deg);
  double sink = 0.0;
  int samples = 0;
  while (s.time < seconds - 1e-9 && s.end == EndReason::running) {
    step(m, g, s, ws);
    if (s.time > 0.5 * seconds) {
      sink += (r.position - s.position).dot(normal);
      ++samples;
    }
  }
  SlideResult out;
  out.distance = (s.position - r.position).dot(incline_down(theta_deg));
  out.rotation = Eigen::AngleAxisd(s.orientation * r.orientation.inverse()).angle();
  out.drift = (s.position - settled).norm();
  out.drift_rotation = Eigen::AngleAxisd(s.orientation * q_settled.inverse()).angle();
  out.mean_sink = samples > 0 ? sink / samples : 0.0;
  out.time = s.time;
  out.end = s.end;
  return out;
}

/// A cube (edge 1 m) falling face down onto flat ground at `v_in`: the centroid speed
/// once every contact has opened again (NaN if it never leaves the ground).
struct ReboundResult {
  double v_in = 0.0;
  double v_out = std::nan("");
  double omega = 0.0;  ///< Ω = √(n·k/m)·Δt with the four vertex springs
};
inline ReboundResult rebound(const Settings& set, double v_in, double restitution) {
  const terrain::Surface flat = incline(0.0);
  const std::vector<terrain::Material> mats{material(0.5, restitution)};
  const Ground g{&flat, mats};
  const Model m = Model::build(set, cube(1.0));
  Release r = on_incline(0.0, 1.0, 0.3, 0.2);
  const double h = 0.05;
  r.position.z() += h;
  r.velocity = Vec3(0.0, 0.0, -std::sqrt(std::max(0.0, v_in * v_in - 2.0 * set.gravity * h)));
  State s = start(m, r, impact_stream());
  Workspace ws;
  ReboundResult out;
  out.omega = std::sqrt(4.0 * m.stiffness / m.mass) * set.time_step;
  bool touched = false;
  for (int i = 0; i < 20000 && s.end == EndReason::running; ++i) {
    const Vec3 v_before = s.velocity.head<3>();
    step(m, g, s, ws);
    const bool closed = std::any_of(s.contacts.begin(), s.contacts.end(),
                                    [](const Contact& c) { return c.mode != ContactMode::open; });
    if (closed && !touched) {
      touched = true;
      out.v_in = v_before.norm();
    }
    if (touched && !closed) {
      out.v_out = s.velocity.head<3>().norm();
      break;
    }
  }
  return out;
}

/// A regular tetrahedron (1 m³) spinning at 10 rad/s without gravity for `steps` steps:
/// relative errors of volume, edge lengths and kinetic energy.
struct SpinResult {
  double volume_error = 0.0;
  double edge_error = 0.0;
  double energy_error = 0.0;
  double angle = 0.0;  ///< final orientation angle (rad)
  std::uint64_t steps = 0;
  EndReason end = EndReason::running;
};
inline SpinResult spin(Settings set, std::int64_t steps) {
  const terrain::Surface far_below = incline(0.0, 1e5);
  const std::vector<terrain::Material> mats{material(0.3)};
  const Ground g{&far_below, mats};
  set.gravity = 0.0;
  set.max_steps = steps;
  const geometry::Polyhedron block = tetrahedron(2.03965);
  const Model m = Model::build(set, block);
  Release r;
  r.position = Vec3(0.0, 0.0, 100.0);
  r.angular_velocity = 10.0 * Vec3(0.3, -0.5, 0.8).normalized();
  r.velocity = Vec3(1.0, 0.0, 0.0);
  State s = start(m, r, impact_stream());
  Workspace ws;
  const double e0 = kinetic_energy(m, s);
  while (s.end == EndReason::running) step(m, g, s, ws);
  geometry::Polyhedron now = block;
  now.vertices = world_vertices(m, s);
  SpinResult out;
  out.volume_error = std::abs(geometry::mass_properties(now).volume / m.volume - 1.0);
  for (const BlockEdge& e : m.edges) {
    const double l0 = (m.vertices[e.a] - m.vertices[e.b]).norm();
    const double l1 = (now.vertices[e.a] - now.vertices[e.b]).norm();
    out.edge_error = std::max(out.edge_error, std::abs(l1 / l0 - 1.0));
  }
  out.energy_error = std::abs(kinetic_energy(m, s) / e0 - 1.0);
  out.angle = Eigen::AngleAxisd(s.orientation).angle();
  out.steps = s.counters.steps;
  out.end = s.end;
  return out;
}

}  // namespace talus::dda::testing
