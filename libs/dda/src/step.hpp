// SPDX-License-Identifier: MIT
// The parts of a step (docs/dda.md, "The step"): the flight step (flight.cpp), the
// contact step (contact_step.cpp), and what both share -- the energies and the energy
// limiter (energy.cpp), the search distances and the bookkeeping of an accepted step
// (bookkeeping.cpp), and the update of the state by an accepted displacement.
#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "kinematics.hpp"
#include "rotation.hpp"

namespace talus::dda::detail {

struct Scratch;

// --- Energies (energy.cpp) ---------------------------------------------------------------

/// ½mv² + ½ωᵀJω: the rigid part of the kinetic energy (J).
double rigid_kinetic_energy(const Model& model, const State& s);
/// Elastic energy of the block's accumulated strain on the 12-DOF path (J): in flight
/// and at contacts the strain vibrates, trading this energy with the kinetic energy of
/// the strain rates, so a balance without it would see gains and losses that are neither.
double strain_energy(const Model& model, const State& s);
/// Kinetic, potential (z = 0 reference), strain and contact-spring energy of the state (J).
double total_energy(const Model& model, const State& s);
/// Takes back whatever a step gained over `energy_start` (J) beyond round-off: from the
/// motion, then the normal springs, the shear springs, and last the block's height
/// (docs/dda.md, "Energy limiter"), counted in the state.
void limit_energy(const Model& model, State& s, double energy_start);
/// With Settings::check_invariants: the rise of the total energy over the last step,
/// recorded and counted when beyond round-off.
void check_energy(const Model& model, State& s);

// --- Search distances (bookkeeping.cpp) ------------------------------------------------

/// How far any point of the block can move in a step of length dt on its step-start
/// motion (translation, spin, strain rates and gravity) (m).
double predicted_reach(const Model& model, const State& s, double dt);
/// The contact search distance of a step of length h: twice the farthest any point of
/// the block can move in it, and at least the step control's displacement bound (m).
double search_reach(const Model& model, const State& s, double h);
/// The near search distance of a contact step of length h (m), or 0 for none: every
/// candidate the full search finds beyond it has a gap of more than `scale` times what
/// its point moves at the step-start motion (point_reach), so a detailed rigid block
/// searches its vertex–triangle and edge–ridge pairs only within it, and the step looks
/// beyond it only when its solution moves some point that far. Full until the
/// realization's friction is drawn.
double near_reach(const Model& model, const State& s, double h, double scale);
/// How far the block point x (world, m) can move in a step of length h at the step-start
/// motion, `scale` times over (m): its velocity, the strain rates' bound and gravity.
double point_reach(const Model& model, const State& s, const Vec3& x, double h, double scale);
/// Aims `pass` at a rigid detailed block's near search from `pose` for a step of length h
/// with the set-aside scale `scale` (MotionFilter): the step-start motion in the body frame,
/// the fall and the round-off allowance. The keep lists are left as they are.
void aim_pass_over(const Model& model, const State& s, const Pose& pose, double h, double scale, MotionFilter& pass);

// --- Bookkeeping of an accepted step (bookkeeping.cpp) -----------------------------------

/// Ends the realization with `reason` unless it has ended already.
void end_with(State& s, EndReason reason);
/// A trajectory sample at time `t` (s) if one is due: centroid position (m), velocity
/// (m/s), height above the terrain (m, NaN off it), mechanical energy (J), orientation,
/// angular velocity (world, rad/s) and what the block is doing.
void sample_trajectory(const Model& model, State& s, double t, const Vec3& p, const Vec3& v, double height,
                       double energy, const Eigen::Quaterniond& orientation, const Vec3& omega, Motion motion);
/// What the block does at the end of the last step (a trajectory sample's `motion`).
Motion motion_of(const State& s);
/// The centroid `height` (m) above the terrain triangle `triangle` below it: the jump
/// maxima, from the first touch on.
void note_jump(const terrain::Surface& surf, State& s, double height, std::int32_t triangle);
/// Time, kinetic energy, height, maxima, rest, leaving, trajectory and limits after an
/// accepted step of length dt (s).
void finish_step(const Model& model, const Ground& ground, State& s, double dt);

// --- The state moved by an accepted displacement -------------------------------------------

/// Applies an accepted displacement d (N components) to the state.
/// The velocity carried into the next step is k_d·v₁ (dynamic_coefficient) after a contact
/// step, v₁ itself after a flight step (`damped` false): the coefficient damps contact
/// steps only, and free flight stays the exact parabola whatever its value. (Damping
/// flight too held a block released with k_d = 0 in the air, where the rest test then
/// ended it, and took one factor per flight step whatever its length.)
template <int N>
void apply_displacement(const Model& model, State& s, const VecN<N>& d, double dt, bool strain_frozen = false,
                        bool damped = true) {
  const Mat3 r_old = s.orientation.toRotationMatrix();
  const Eigen::Quaterniond q_old = s.orientation;
  const Vec3 theta = d.template segment<3>(3);
  s.position += d.template head<3>();
  const double angle = theta.norm();
  if (angle > 0.0) s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle)) * s.orientation;
  s.orientation.normalize();
  if constexpr (N == 12) {
    const Mat3 e = strain_tensor(d.template tail<6>());
    s.stretch = s.stretch + r_old.transpose() * e * r_old * s.stretch;
  }
  VecN<N> v1 = (2.0 / dt) * d - s.velocity.template head<N>();
  if (!model.isotropic) {
    // The spin the torque-free rotation ends with, plus what the contacts added to its
    // turn (rotation.hpp, free_spin: the step's inertial prediction).
    const FreeSpin free = free_spin(model, q_old, s.velocity.template segment<3>(3), dt);
    v1.template segment<3>(3) = free.omega + (2.0 / dt) * (theta - free.theta);
  }
  s.velocity.template head<N>() = damped ? model.settings.dynamic_coefficient * v1 : v1;
  if constexpr (N == 12) {
    if (strain_frozen) s.velocity.template tail<6>().setZero();
  }
}

// --- The two kinds of step -------------------------------------------------------------

/// A flight step, if the block is clear of the terrain for at least one step: returns its
/// length (s), 0 if the block needs a contact step (flight.cpp).
double flight_step(const Model& model, const Ground& ground, State& s, Scratch& w);

/// A contact step of the path with N unknowns (contact_step.cpp).
template <int N>
void contact_step(const Model& model, const Ground& ground, State& s, Scratch& w);

}  // namespace talus::dda::detail
