// SPDX-License-Identifier: MIT
// Euler's equations for the torque-free block: a splitting into rotations about the
// principal axes, each exact, composed to fourth order (Yoshida), with the angular
// momentum and the energy held on their conserved values.
#include "rotation.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

namespace talus::dda::detail {

namespace {

// Largest angle (rad) the block turns in one sub-step of the composition: its phase error
// is then below 1e-7 per radian turned (DdaRotation.FollowsEulersEquations), far below
// any contact's effect.
constexpr double kSubstepAngle = 0.05;
// Below this angle (rad) a contact step's torque-free turn is taken by its series: its
// third-order term, (ω·h)³/6 at most, is then below 2e-10 rad.
constexpr double kSeriesAngle = 1e-3;

// Rotates the frame `p` (principal → world) and the body angular momentum `m` (principal
// frame) by the exact flow of ½ m_axis²/I_axis over tau: the body turns about its own axis.
void turn_about(int axis, double tau, const Vec3& moments, Eigen::Quaterniond& p, Vec3& m) {
  const double phi = tau * m[axis] / moments[axis];
  // One sine and cosine, of the half angle: the quaternion's, and the full angle's from it.
  const double ch = std::cos(0.5 * phi), sh = std::sin(0.5 * phi);
  const double c = ch * ch - sh * sh, s = 2.0 * sh * ch;
  const int j = (axis + 1) % 3, k = (axis + 2) % 3;
  // m ← R_axis(−φ)·m, so that p·m (the world angular momentum) does not change.
  const double mj = m[j], mk = m[k];
  m[j] = c * mj + s * mk;
  m[k] = -s * mj + c * mk;
  Eigen::Quaterniond r(ch, 0.0, 0.0, 0.0);
  r.vec()[axis] = sh;
  p = p * r;
}

// Strang's splitting of one sub-step: 1 2 3 2 1, second order and symmetric.
void strang(double tau, const Vec3& moments, Eigen::Quaterniond& p, Vec3& m) {
  turn_about(0, 0.5 * tau, moments, p, m);
  turn_about(1, 0.5 * tau, moments, p, m);
  turn_about(2, tau, moments, p, m);
  turn_about(1, 0.5 * tau, moments, p, m);
  turn_about(0, 0.5 * tau, moments, p, m);
}

// Moves m along the sphere |m| = const onto the energy ellipsoid Σ m_i²/I_i = twice_energy
// (Newton along the tangent part of the energy's gradient), turning p so that p·m stays.
void hold_energy(double twice_energy, const Vec3& moments, Eigen::Quaterniond& p, Vec3& m) {
  const double length = m.norm();
  if (!(length > 0.0)) return;
  Vec3 held = m;
  for (int iteration = 0; iteration < 3; ++iteration) {
    const Vec3 w = held.cwiseQuotient(moments);
    const double f = held.dot(w) - twice_energy;
    const Vec3 g = w - (held.dot(w) / (length * length)) * held;
    const double slope = 2.0 * g.squaredNorm();
    if (!(slope > 1e-300) || std::abs(f) <= 1e-16 * twice_energy) break;
    held = (held - (f / slope) * g).normalized() * length;
  }
  p = p * Eigen::Quaterniond::FromTwoVectors(held, m);
  m = held;
}

}  // namespace

void rotate_free(const Model& model, Eigen::Quaterniond& orientation, Vec3& omega, double h) {
  if (model.isotropic) {
    const Vec3 theta = omega * h;
    const double angle = theta.norm();
    if (angle > 0.0) orientation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle)) * orientation;
    orientation.normalize();
    return;
  }
  const Vec3& moments = model.principal_moments;
  const Eigen::Quaterniond axes(model.principal_axes);
  Eigen::Quaterniond p = orientation * axes;  // principal frame → world
  Vec3 m = moments.cwiseProduct(p.conjugate() * omega);
  const Vec3 momentum = p * m;  // world, held
  const double twice_energy = m.dot(m.cwiseQuotient(moments));
  if (!(twice_energy > 0.0)) return;
  const double fastest = std::sqrt(twice_energy / moments.minCoeff());
  const int n = std::max(1, static_cast<int>(std::ceil(fastest * std::abs(h) / kSubstepAngle)));
  const double tau = h / n;
  // Yoshida's triple jump makes the symmetric second-order step fourth order.
  const double w1 = 1.0 / (2.0 - std::cbrt(2.0));
  const double w0 = 1.0 - 2.0 * w1;
  for (int k = 0; k < n; ++k) {
    strang(w1 * tau, moments, p, m);
    strang(w0 * tau, moments, p, m);
    strang(w1 * tau, moments, p, m);
    p.normalize();
  }
  hold_energy(twice_energy, moments, p, m);
  // The sub-rotations keep p·m to round-off; turn the last of it back onto L.
  p = Eigen::Quaterniond::FromTwoVectors(p * m, momentum) * p;
  p.normalize();
  omega = p * m.cwiseQuotient(moments);
  orientation = (p * axes.conjugate()).normalized();
}

FreeSpin free_spin(const Model& model, const Eigen::Quaterniond& orientation, const Vec3& omega, double h) {
  FreeSpin out;
  out.omega = omega;
  if (model.isotropic) {
    out.theta = omega * h;
    return out;
  }
  if (omega.norm() * std::abs(h) < kSeriesAngle) {
    // A short turn by its series, θ = ω·h + ½ω̇·h² and ω + ω̇·h (ω̇ = −J⁻¹(ω × Jω)): the
    // difference of two orientations would carry their round-off (1e-16) into a term that
    // the step's inertia multiplies by 2/h².
    const Mat3 r = orientation.toRotationMatrix();
    const Vec3 body = r.transpose() * omega;
    const Vec3 accel = -(r * model.inertia.ldlt().solve(body.cross(model.inertia * body)));
    out.theta = omega * h + 0.5 * accel * h * h;
    out.omega = omega + accel * h;
    return out;
  }
  Eigen::Quaterniond q = orientation;
  rotate_free(model, q, out.omega, h);
  Eigen::Quaterniond turn = (q * orientation.conjugate()).normalized();
  if (turn.w() < 0.0) turn.coeffs() *= -1.0;
  const Eigen::AngleAxisd a(turn);
  out.theta = a.angle() * a.axis();
  return out;
}

double rotation_curvature(const Model& model, const Mat3& rotation, const Vec3& omega) {
  const double spin2 = omega.squaredNorm();
  if (model.isotropic) return spin2;
  const Vec3 body = rotation.transpose() * omega;
  const Vec3 momentum = model.inertia * body;
  const double smallest = model.principal_moments.minCoeff();
  const double largest = model.principal_moments.maxCoeff();
  // |ω| is bounded by both conserved quantities; |ω̇| = |J⁻¹((J − c)ω × ω)| with c the
  // middle of the moments' range is at most (I_max − I_min)/(2·I_min)·|ω|².
  const double fastest2 = std::min(momentum.squaredNorm() / (smallest * smallest), body.dot(momentum) / smallest);
  const double kappa = fastest2 * (1.0 + 0.5 * (largest - smallest) / smallest);
  return std::max(spin2, kappa * (1.0 + 1e-9));
}

}  // namespace talus::dda::detail
