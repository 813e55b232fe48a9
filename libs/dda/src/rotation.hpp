// SPDX-License-Identifier: MIT
// Rigid-body rotation (Euler's equations): torque-free rotation of a block whose inertia
// is not isotropic, the gyroscopic torque of a contact step, and the bound on how fast
// the block's points can accelerate by rotation alone (docs/dda.md, "Rotation").
#pragma once
#include <Eigen/Geometry>

#include "talus/dda/model.hpp"

namespace talus::dda::detail {

/// The torque-free rotation of the block over h (s): the orientation and the world
/// angular velocity ω (rad/s) move as Euler's equations say, the angular momentum
/// L = J_world·ω held exactly and the rotational energy ½ωᵀJω kept to round-off. For an
/// isotropic block ω is constant and the rotation is the exact one of ω·h.
void rotate_free(const Model& model, Eigen::Quaterniond& orientation, Vec3& omega, double h);

/// The torque-free rotation over h from `orientation` and ω (world, rad/s): the world
/// rotation vector θ it turns by (rad) and ω at its end. A contact step takes it as its
/// inertial prediction, so that with no contact closed the step is this rotation exactly
/// and the contacts add to it (docs/dda.md, "Rotation"). θ = ω·h for an isotropic block.
struct FreeSpin {
  Vec3 theta = Vec3::Zero();
  Vec3 omega = Vec3::Zero();
};
FreeSpin free_spin(const Model& model, const Eigen::Quaterniond& orientation, const Vec3& omega, double h);

/// A bound κ (1/s²) on |r̈|/|r| for every body point r in torque-free rotation starting
/// from ω (world, rad/s) at `rotation`, whatever the time: |ω|² + |ω̇| ≤ κ with |ω| and |ω̇|
/// bounded through the conserved energy and angular momentum. |ω|² itself for an
/// isotropic block, whose ω does not change.
double rotation_curvature(const Model& model, const Mat3& rotation, const Vec3& omega);

}  // namespace talus::dda::detail
