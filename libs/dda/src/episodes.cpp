// SPDX-License-Identifier: MIT
// Contact episodes and the impact–rebound law (SPEC §4): what an impact draws, when it
// ends, how the rebound is limited and scattered.
#include "episodes.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>

#include "talus/core/error.hpp"

namespace talus::dda::detail {

namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 rotate_about(const Vec3& v, const Vec3& axis, double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, axis) * v;
}

// Horizontal unit direction of travel for the lateral tilt axis.
Vec3 travel_axis(const Vec3& v_in, const Release& release) {
  Vec3 h(v_in.x(), v_in.y(), 0.0);
  if (h.norm() < 1e-9) h = Vec3(release.main_direction.x(), release.main_direction.y(), 0.0);
  return h.normalized();
}

// SPEC §4's speed scaling SF = 1 / (1 + (speed/K)²).
double speed_factor(double speed, double k) { return 1.0 / (1.0 + (speed / k) * (speed / k)); }

// The rebound of a rigid impact at one contact point r (from the centroid) on ground of
// unit normal n (Stronge 2000, Impact Mechanics, ch. 2–4): the point leaves along n at e
// times its approach speed, and friction stops its tangential slip, by an impulse within
// the Coulomb cone |P_t| ≤ μ·P_n; beyond the cone it slips against its approach's slip
// direction. The block's velocity v, spin w (world) and inverse world inertia are changed
// in place; false if the point does not approach the ground.
bool point_impact(Vec3& v, Vec3& w, const Vec3& r, const Vec3& n, double mass, const Eigen::Matrix3d& inverse_inertia,
                  double e, double mu, double plough) {
  const Vec3 u = v + w.cross(r);
  const double un = u.dot(n);
  if (!(un < 0.0)) return false;
  Eigen::Matrix3d rx;
  rx << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  // The point's velocity change per unit impulse at the point.
  const Eigen::Matrix3d W = Eigen::Matrix3d::Identity() / mass - rx * inverse_inertia * rx;
  const Vec3 ut = u - un * n;
  Vec3 impulse = W.ldlt().solve(Vec3(-e * un * n - u));
  const double pn = impulse.dot(n);
  const Vec3 pt = impulse - pn * n;
  if (pt.norm() > mu * pn && ut.norm() > 0.0) {
    // Slip through the impact: the friction impulse opposes the approach's slip.
    const Vec3 direction = n - mu * ut.normalized();
    const double response = n.dot(W * direction);
    if (!(response > 0.0)) return false;
    impulse = (-(1.0 + e) * un / response) * direction;
  }
  v += impulse / mass;
  w += inverse_inertia * r.cross(impulse);
  // Ground that gives way is ploughed: it resists the block's sliding along it, not only
  // the point's slip, by up to `plough` times the normal impulse, never reversing it.
  const Vec3 vt = v - v.dot(n) * n;
  const double sliding = vt.norm();
  if (plough > 0.0 && sliding > 0.0) v -= std::min(plough * impulse.dot(n) / mass, sliding) / sliding * vt;
  return true;
}

}  // namespace

const terrain::Material& material_of(const Ground& ground, std::int32_t triangle) {
  const std::int32_t m = ground.surface->material(static_cast<std::size_t>(triangle));
  if (m < 0 || static_cast<std::size_t>(m) >= ground.materials.size())
    throw core::InputError("terrain", "triangle " + std::to_string(triangle) + " names material " +
                                          std::to_string(m) + " but only " +
                                          std::to_string(ground.materials.size()) + " are defined");
  return ground.materials[static_cast<std::size_t>(m)];
}

double mean_friction(const terrain::Material& mat) {
  return std::tan(mat.friction_angle_mean_deg * kPi / 180.0);
}

void start_episode(const Model& model, const Ground& ground, State& s, const Vec3& v_in, double kinetic_in,
                   PointApproach point) {
  // The normal-force-weighted mean normal of the closed contacts; equal weights when no
  // contact carries force yet (an impact's first step ends at the moment of touch).
  double total_force = 0.0;
  for (const Contact& c : s.contacts)
    if (c.mode != ContactMode::open) total_force += std::max(0.0, c.normal_force);
  Vec3 n = Vec3::Zero();
  std::int32_t triangle = -1;
  double strongest = -1.0;
  for (const Contact& c : s.contacts) {
    if (c.mode == ContactMode::open) continue;
    const double w = total_force > 0.0 ? std::max(0.0, c.normal_force) : 1.0;
    n += w * c.normal;
    if (w > strongest) {
      strongest = w;
      triangle = c.triangle;
    }
  }
  start_episode_along(model, ground, s, v_in, kinetic_in, n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::UnitZ(),
                      triangle, point);
}

void start_episode_along(const Model& model, const Ground& ground, State& s, const Vec3& v_in, double kinetic_in,
                         const Vec3& normal, std::int32_t triangle, PointApproach point) {
  Episode& e = s.episode;
  e = Episode{};
  e.active = true;
  e.velocity_in = v_in;
  e.kinetic_in = kinetic_in;
  e.normal = normal;
  const double approach = -v_in.dot(e.normal);
  e.approach_speed = std::max(0.0, approach);
  e.point_approach_energy = point.energy;
  e.point_in = point.point;
  // What strikes the ground is the contact point, not the centroid: a corner of a tumbling
  // block strikes however slowly the centroid approaches, and a rocking block touching down
  // again after a hop of micrometres does not strike however fast its centroid sinks.
  if (point.speed < model.settings.impact_min_normal_speed) return;
  const terrain::Material& mat = material_of(ground, triangle);
  // Three draws per impact, always in this order, so a setting never shifts later draws.
  const double z_r = s.impacts_rng.normal();
  const double z_f = s.impacts_rng.normal();
  const double z_t = s.impacts_rng.normal();
  e.impact = true;
  e.restitution = std::clamp(mat.restitution_mean + mat.restitution_sd * z_r, 0.0, 1.0);
  s.friction = std::max(0.0, mean_friction(mat) + mat.friction_coefficient_sd * z_f);
  s.friction_drawn = true;
  e.tilt_deg = mat.lateral_tilt_sd_deg * z_t;
  e.normal = rotate_about(e.normal, travel_axis(v_in, s.release), e.tilt_deg * kPi / 180.0);
  e.restitution_scale = mat.restitution_scale;
  e.ploughing = mat.ploughing;
  ++s.impacts;
}

// Applies the restitution law to the rebound of the impact in progress; the episode
// goes on as a rolling/sliding one if contacts stay closed.
void finish_impact(const Model& model, State& s, const Separation& separation) {
  Episode& e = s.episode;
  const bool impact = e.impact;
  e.impact = false;
  if (!impact || model.restitution == RestitutionLaw::off) return;
  // The rebound is the velocity at the moment the last contact let go, τ before the step's
  // end: its point then flew away from the ground by its end gap g along n at the end rate
  // u_n, so g = u_n·τ − ½g_n·τ² gives τ = 2g / (u_n + √(u_n² − 2·g_n·g)), within the step.
  const Vec3 gravity(0.0, 0.0, -model.settings.gravity);
  double tau = 0.0;
  if (separation.gap > 0.0) {
    const Vec3& n = separation.normal;
    const Vec3 r = separation.point - s.position;
    const double un = n.dot(s.velocity.head<3>() + s.velocity.segment<3>(3).cross(r));
    const double gn = gravity.dot(n);
    const double root = std::sqrt(std::max(0.0, un * un - 2.0 * gn * separation.gap));
    if (un + root > 0.0) tau = std::min(separation.step, 2.0 * separation.gap / (un + root));
  }
  const Vec3 v_separation = s.velocity.head<3>() - gravity * tau;
  Vec3 v = v_separation;
  Vec3 w = s.velocity.segment<3>(3);
  const auto rotational = [&](const Vec3& omega) {
    const Vec3 wb = s.orientation.conjugate() * omega;
    return 0.5 * wb.dot(model.inertia * wb);
  };
  const double kinetic_out = 0.5 * model.mass * v.squaredNorm() + rotational(w);
  // The rebound's whole kinetic energy (spin included) is bounded too: a contact step
  // can turn translation into spin, which a cap on the speed alone would let through.
  double energy_ratio = 1.0;  // allowed kinetic energy over the impact's
  if (model.restitution == RestitutionLaw::scaled) {
    const double vin = e.velocity_in.norm();
    const double sf = speed_factor(vin, e.restitution_scale);
    const double cap = e.restitution * sf * vin;
    energy_ratio = (e.restitution * sf) * (e.restitution * sf);
    const double vout = v.norm();
    double factor = vout > cap ? cap / vout : 1.0;
    if (kinetic_out * factor * factor > energy_ratio * e.kinetic_in)
      factor = std::sqrt(energy_ratio * e.kinetic_in / kinetic_out);
    // The law supplies the normal inelasticity the stiff penalty contact lacks, so it
    // removes at most the normal approach's kinetic energy: a grazing hop loses little, a
    // chain of bounces a finite amount.
    if (model.bound_by_normal_approach && factor < 1.0 && kinetic_out > 0.0) {
      const double normal_energy =
          std::max(0.5 * model.mass * e.approach_speed * e.approach_speed, e.point_approach_energy);
      if (kinetic_out * (1.0 - factor * factor) > normal_energy)
        factor = std::sqrt(std::max(0.0, 1.0 - normal_energy / kinetic_out));
    }
    if (factor < 1.0) {
      // The whole rigid velocity is scaled: rebound direction and spin-to-speed ratio
      // of the DDA rebound are kept, its kinetic energy scaled by factor².
      v *= factor;
      w *= factor;
      ++s.counters.impacts_rescaled;
    }
    // The lateral scatter turns the rebound about the horizontal travel direction. The
    // spin turns with it and keeps its energy (½ωᵀJω changes under a rotation of ω
    // unless the inertia is isotropic).
    const Vec3 axis = travel_axis(e.velocity_in, s.release);
    const double tilt = e.tilt_deg * kPi / 180.0;
    v = rotate_about(v, axis, tilt);
    const double spin_energy = rotational(w);
    w = rotate_about(w, axis, tilt);
    const double turned = rotational(w);
    if (turned > 0.0) w *= std::sqrt(spin_energy / turned);
  } else if (model.restitution == RestitutionLaw::point) {
    // The impact as a rigid one at its contact point, from the velocity the block brought
    // in: the penalty springs' raw rebound only kept the block out of the ground. The
    // point is where the impact's contact impulse acted (the fastest closing point when
    // that does not approach); the ground carried the weight while the impact lasted.
    const Vec3 vin = e.velocity_in;
    const double vin_norm = vin.norm();
    const double sf = speed_factor(vin_norm, e.restitution_scale);
    const Eigen::Matrix3d rotation = s.orientation.toRotationMatrix();
    const Eigen::Matrix3d inverse_inertia = rotation * model.inertia.inverse() * rotation.transpose();
    const double mu = s.friction;
    Vec3 v_law = vin;
    Vec3 w_law = e.spin_in;
    const bool acted = e.impulse > 0.0 && point_impact(v_law, w_law, e.impulse_moment / e.impulse, e.normal,
                                                       model.mass, inverse_inertia, e.restitution * sf, mu, e.ploughing);
    // Neither point approaching along the tilted normal: the law has nothing to act on,
    // and the raw rebound stands.
    if (!acted) {
      v_law = vin;
      w_law = e.spin_in;
      if (!point_impact(v_law, w_law, e.point_in, e.normal, model.mass, inverse_inertia, e.restitution * sf, mu,
                        e.ploughing)) {
        v_law = v;
        w_law = w;
      }
    }
    // No impact gains energy (Newton's restitution with friction can, when the slip
    // reverses): the rebound never holds more than the block brought in.
    const double kinetic_law = 0.5 * model.mass * v_law.squaredNorm() + rotational(w_law);
    if (kinetic_law > e.kinetic_in && kinetic_law > 0.0) {
      const double factor = std::sqrt(e.kinetic_in / kinetic_law);
      v_law *= factor;
      w_law *= factor;
    }
    v = v_law;
    w = w_law;
    ++s.counters.impacts_rescaled;
  } else if (model.restitution == RestitutionLaw::normal_component) {
    const double vin_n = std::abs(e.velocity_in.dot(e.normal));
    const double sf = speed_factor(vin_n, e.restitution_scale);
    const double cap = e.restitution * sf * vin_n;
    const double vn = v.dot(e.normal);
    if (vn > cap) {
      v -= (vn - cap) * e.normal;
      ++s.counters.impacts_rescaled;
    }
    // The tangential velocity and spin are kept, but never with more kinetic energy
    // than the block brought into the impact.
    const double now = 0.5 * model.mass * v.squaredNorm() + rotational(w);
    if (now > e.kinetic_in && now > 0.0) {
      const double factor = std::sqrt(e.kinetic_in / now);
      v *= factor;
      w *= factor;
    }
  }
  // The flight since the separation is redone with the law's rebound, along the normal of
  // the contact that let go last: the block rose by the raw rebound, and rises by the law's.
  s.position += separation.normal * separation.normal.dot(v - v_separation) * tau;
  // The contacts kept open by a micro-gap remember anchors and springs of the pose the
  // redone flight left: the block flies, and they are dropped.
  if (tau > 0.0) s.contacts.clear();
  s.velocity.head<3>() = v + gravity * tau;
  s.velocity.segment<3>(3) = w;
}

void end_episode(const Model& model, State& s, const Separation& separation) {
  finish_impact(model, s, separation);
  s.episode.active = false;
}

void add_impulse(State& s, double impulse, const Vec3& moment) {
  s.episode.impulse += impulse;
  s.episode.impulse_moment += moment;
}

// An impact whose block stays in contact has rebounded once it no longer approaches along
// the impact normal and its springs hold under 1 % of the impact's kinetic energy.
bool rebound_complete(const Model& model, const State& s, double spring_energy) {
  const Episode& e = s.episode;
  if (s.velocity.head<3>().dot(e.normal) < 0.0) return false;
  return spring_energy <= 0.01 * 0.5 * model.mass * e.velocity_in.squaredNorm();
}

}  // namespace talus::dda::detail
