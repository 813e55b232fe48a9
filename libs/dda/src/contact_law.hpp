// SPDX-License-Identifier: MIT
// The contact law of the DDA step: Shi's implicit solve with the open–close iteration over
// Mohr–Coulomb penalty contacts (solve_step), the carrying of contact states from step to
// step (carry_contacts) and the settling of persistent contacts (settle_contacts). Defined
// in contact_law.cpp for the rigid path's 6 unknowns and the full path's 12.
#pragma once
#include <cstdint>
#include <vector>

#include "kinematics.hpp"

namespace talus::dda::detail {

struct StepOutcome {
  bool converged = false;
  int iterations = 0;
  int held = 0;  // contacts held in their state before the iteration settled
};

/// Shi's implicit step for the block at `pose` with the state's velocity over a step of
/// `dt` (s), friction coefficient `friction` (-): assemble, iterate on the contact states,
/// solve. On return `d` holds the step displacement and each contact's mode its converged
/// state (anchors and spring zeros moved as the law asks). `freeze_strain` (12 unknowns)
/// holds the strain increments at zero; `impact_phase` starts re-sticking contacts
/// unstretched (docs/dda.md, "The contact law").
template <int N>
StepOutcome solve_step(const Model& model, const Pose& pose, const State& s, double dt, double friction,
                       std::vector<Contact>& contacts, VecN<N>& d, PhaseTimes& times, bool freeze_strain = false,
                       bool impact_phase = false);

/// Carries modes and anchors of contacts that persist from the previous step: the same
/// kind and features, or -- for a block vertex -- a coplanar neighbour triangle of the one
/// it was on (a vertex sliding across a flat grid keeps its state). An anchor never holds
/// more shear stretch than the friction force the contact last carried allows
/// (μ·F_n/k_s): an anchor left behind while the contact was open or slid on would
/// otherwise pull the block back with a spring force friction cannot have stored, which
/// both creates energy and makes the contact flip open and closed without end.
///
/// An edge–edge pair that was not in contact in the previous step and is found already
/// deeper than `fresh_depth` (the search distance: how far features can approach in one
/// step) is dropped: a real crossing is found while it approaches, and the normal e₁ × e₂
/// of a pair found deep inside says nothing about the way out.
///
/// `matched`, when given, receives per contact of `now` whether it carries a previous one;
/// the return value is whether every previous contact is carried by one of `now`.
bool carry_contacts(const std::vector<Contact>& previous, std::vector<Contact>& now, const Pose& pose,
                    double friction, double shear_stiffness, double fresh_depth, double radius,
                    std::vector<std::uint8_t>* matched = nullptr);

/// A contact closed through a whole step, at its end: the point (world, m), the unit
/// normal, and for a contact that ends the step locked the tangential impulse friction can
/// give it over the step (μ·F_n·Δt, N·s; zero if it slides).
struct Persistent {
  Vec3 point;
  Vec3 normal;
  double friction_impulse = 0.0;
  /// The angular impulse rolling resistance can give it over the step (μ_r·r·F_n·Δt, N·m·s).
  double rolling_impulse = 0.0;
};

/// Removes the approaching normal velocity (and, for locked contacts, the tangential
/// velocity within the Coulomb cone) of contacts closed through a whole step, by
/// non-negative impulses on the block's mass metric (docs/dda.md, "Settling").
template <int N>
void settle_contacts(const Model& model, State& s, const std::vector<Persistent>& persistent);

}  // namespace talus::dda::detail
