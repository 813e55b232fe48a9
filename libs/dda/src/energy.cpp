// SPDX-License-Identifier: MIT
// The energies of a state and the energy limiter (step.hpp).
#include <algorithm>
#include <cmath>

#include "step.hpp"

namespace talus::dda::detail {

// ½mv² + ½ωᵀJω: the rigid part of the kinetic energy (J).
double rigid_kinetic_energy(const Model& model, const State& s) {
  const Vec3 v = s.velocity.head<3>();
  const Vec3 w = s.velocity.segment<3>(3);
  const Vec3 wb = s.orientation.conjugate() * w;  // body frame
  return 0.5 * model.mass * v.squaredNorm() + 0.5 * wb.dot(model.inertia * wb);
}

// Elastic energy of the block's accumulated strain on the 12-DOF path (J): in flight
// and at contacts the strain vibrates, trading this energy with the kinetic energy of
// the strain rates, so a balance without it would see gains and losses that are neither.
double strain_energy(const Model& model, const State& s) {
  if (model.dof != DofPath::full12) return 0.0;
  const Mat3 e_body = 0.5 * (s.stretch + s.stretch.transpose()) - Mat3::Identity();
  const Mat3 r = s.orientation.toRotationMatrix();
  const Eigen::Matrix<double, 6, 1> e = voigt(r * e_body * r.transpose());
  return 0.5 * model.volume * e.dot(model.elasticity * e);
}

// Kinetic, potential (z = 0 reference), strain and contact-spring energy of the state (J).
double total_energy(const Model& model, const State& s) {
  return mechanical_energy(model, s) + strain_energy(model, s) + s.stored_energy;
}

namespace {

// The size of the energy terms whose round-off bounds a step's energy balance (J).
double energy_scale(const Model& model, const State& s, double total) {
  const double weight = model.mass * model.settings.gravity;
  return std::abs(total) + std::abs(weight * s.position.z()) + weight * model.radius;
}

// Takes up to `rest` (J) out of springs that hold `energy` (J): returns the factor their
// stretch is to be scaled by (1 when there is nothing to take), books what it removes in
// the state and lowers `rest` by it.
double relax_springs(State& s, double energy, double& rest) {
  if (!(energy > 0.0) || !(rest > 0.0)) return 1.0;
  const double keep = std::sqrt(std::max(0.0, energy - rest) / energy);
  const double removed = energy * (1.0 - keep * keep);
  s.stored_energy -= removed;
  s.energy_removed += removed;
  rest -= removed;
  return keep;
}

}  // namespace

// Nothing in the model is a source of energy, yet a contact step can gain some: the gain
// beyond round-off is taken back from the motion (direction kept), then the springs, and
// counted.
void limit_energy(const Model& model, State& s, double energy_start) {
  const double kinetic = kinetic_energy(model, s);
  // total_energy(model, s), written out to reuse the kinetic energy.
  const double total =
      kinetic + model.mass * model.settings.gravity * s.position.z() + strain_energy(model, s) + s.stored_energy;
  const double excess = total - energy_start;
  const double scale = energy_scale(model, s, energy_start);
  if (!(excess > 1e-10 * scale)) return;
  ++s.counters.energy_limited;
  const double from_motion = std::min(excess, kinetic);
  if (kinetic > 0.0) s.velocity *= std::sqrt((kinetic - from_motion) / kinetic);
  s.energy_removed += from_motion;
  // A gain larger than the motion holds sits in the normal springs: their compression is
  // relaxed (the accepted penetration grows) until they hold no more than was there.
  double rest = excess - from_motion;
  if (!(rest > 0.0)) return;
  const double p = model.stiffness;
  double normal_energy = 0.0;
  for (const Contact& c : s.contacts) normal_energy += 0.5 * p * c.spring_gap * c.spring_gap;
  const double keep_normal = relax_springs(s, normal_energy, rest);
  if (keep_normal < 1.0)
    for (Contact& c : s.contacts) c.spring_gap *= keep_normal;
  // What is left sits in the shear springs of locked contacts: their anchors slip towards
  // the block (friction work) until the springs hold no more than was there.
  if (!(rest > 0.0)) return;
  const double ps = p / model.settings.shear_stiffness_ratio;
  double shear_energy = 0.0;
  for (const Contact& c : s.contacts)
    if (c.anchored && std::isfinite(c.spring_shear)) shear_energy += 0.5 * c.spring_shear * c.spring_shear / ps;
  const double keep_shear = relax_springs(s, shear_energy, rest);
  if (keep_shear < 1.0) {
    const Pose pose = pose_of(model, s);
    for (Contact& c : s.contacts) {
      if (!c.anchored || !std::isfinite(c.spring_shear)) continue;
      const Vec3 sv = pose.centre + pose.map * c.body_anchor - c.ground_anchor;
      c.ground_anchor += (1.0 - keep_shear) * (sv - c.normal * c.normal.dot(sv));
      c.spring_shear *= keep_shear;
    }
  }
  // What is left raised the block: the rise is taken back; the next step's contacts take
  // the extra depth as accepted penetration (carry_contacts), so it is not pushed out
  // again.
  if (!(rest > 0.0) || !(model.settings.gravity > 0.0)) return;
  s.position.z() -= rest / (model.mass * model.settings.gravity);
  s.energy_removed += rest;
}

// The total energy -- kinetic, potential and held by the contact springs -- never rises
// beyond round-off of its terms: nothing in the model is a source.
void check_energy(const Model& model, State& s) {
  const double total = total_energy(model, s);
  if (std::isfinite(s.checked_energy)) {
    const double gain = total - s.checked_energy;
    s.max_energy_gain = std::max(s.max_energy_gain, gain);
    if (gain > 1e-9 * energy_scale(model, s, total)) ++s.counters.energy_violations;
  }
  s.checked_energy = total;
}

}  // namespace talus::dda::detail
