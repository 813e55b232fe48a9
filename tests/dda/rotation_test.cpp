// SPDX-License-Identifier: MIT
// Rigid-body rotation (detail::rotate_free, free_spin, rotation_curvature) against Euler's
// equations integrated finely, the conserved angular momentum and energy, the
// intermediate-axis instability and the bound on the points' acceleration.

#include <gtest/gtest.h>

#include <cmath>

#include "dda_fixtures.hpp"
#include "rotation.hpp"
#include "talus/dda/model.hpp"

namespace talus::dda {
namespace {

using detail::free_spin;
using detail::rotate_free;
using detail::rotation_curvature;

// A 2 × 1 × 0.5 m slab: principal moments in the ratio 1.25 : 4.25 : 5.
Model slab() { return Model::build(Settings{}, testing::box(2.0, 1.0, 0.5)); }

Mat3 world_inertia(const Model& m, const Eigen::Quaterniond& q) {
  const Mat3 r = q.toRotationMatrix();
  return r * m.inertia * r.transpose();
}

double rotational_energy(const Model& m, const Eigen::Quaterniond& q, const Vec3& w) {
  return 0.5 * w.dot(world_inertia(m, q) * w);
}

// Euler's equations in the body frame and q̇ = ½·(0, ω_world)·q, classical Runge–Kutta with
// a step of `h` (s): the slow reference.
void reference_rotation(const Model& m, Eigen::Quaterniond& q, Vec3& w_world, double duration, double h) {
  const Mat3 j = m.inertia, j_inv = m.inertia.inverse();
  Vec3 w = q.conjugate() * w_world;  // body frame
  Eigen::Vector4d qv(q.w(), q.x(), q.y(), q.z());
  const auto rates = [&](const Eigen::Vector4d& qq, const Vec3& wb, Eigen::Vector4d& dq, Vec3& dw) {
    dw = j_inv * ((j * wb).cross(wb));
    // q̇ = ½ q ⊗ (0, ω_body)
    const Eigen::Quaterniond a(qq(0), qq(1), qq(2), qq(3));
    const Eigen::Quaterniond b(0.0, wb.x(), wb.y(), wb.z());
    const Eigen::Quaterniond p = a * b;
    dq = 0.5 * Eigen::Vector4d(p.w(), p.x(), p.y(), p.z());
  };
  const int n = static_cast<int>(std::round(duration / h));
  for (int k = 0; k < n; ++k) {
    Eigen::Vector4d k1q, k2q, k3q, k4q;
    Vec3 k1w, k2w, k3w, k4w;
    rates(qv, w, k1q, k1w);
    rates(qv + 0.5 * h * k1q, w + 0.5 * h * k1w, k2q, k2w);
    rates(qv + 0.5 * h * k2q, w + 0.5 * h * k2w, k3q, k3w);
    rates(qv + h * k3q, w + h * k3w, k4q, k4w);
    qv += h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
    w += h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
    qv.normalize();
  }
  q = Eigen::Quaterniond(qv(0), qv(1), qv(2), qv(3));
  w_world = q * w;
}

TEST(DdaRotation, PlatonicSolidsAreIsotropicAndSlabsAreNot) {
  for (const auto kind : {block::SolidKind::tetrahedron, block::SolidKind::cube, block::SolidKind::octahedron,
                          block::SolidKind::dodecahedron, block::SolidKind::icosahedron})
    EXPECT_TRUE(Model::build(Settings{}, testing::solid(kind, 1.0)).isotropic);
  const Model m = slab();
  EXPECT_FALSE(m.isotropic);
  // Ascending moments, axes a proper rotation: for the box, ρV(b² + c²)/12 about x etc.
  const double mass = m.mass;
  EXPECT_NEAR(m.principal_moments(0), mass * (1.0 + 0.25) / 12.0, 1e-9 * mass);
  EXPECT_NEAR(m.principal_moments(2), mass * (4.0 + 1.0) / 12.0, 1e-9 * mass);
  EXPECT_NEAR(m.principal_axes.determinant(), 1.0, 1e-12);
}

TEST(DdaRotation, IsotropicSpinKeepsOmega) {
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const Vec3 w0(3.0, -2.0, 7.0);
  Vec3 w = w0;
  rotate_free(m, q, w, 0.25);
  EXPECT_EQ(w, w0);
  const Eigen::AngleAxisd turned(q);
  EXPECT_NEAR(turned.angle(), w0.norm() * 0.25, 1e-12);
}

// Torque-free: L = J_world·ω keeps its length and direction and ½ωᵀJω its value to round-off
// over 10 s of 1 ms steps (10 000 calls) and of 8 ms steps.
TEST(DdaRotation, TorqueFreeSlabKeepsAngularMomentumAndEnergy) {
  const Model m = slab();
  for (const double h : {1e-3, 8e-3}) {
    Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Vec3(1.0, 2.0, -0.5).normalized()));
    Vec3 w(1.5, -2.0, 4.0);
    const Vec3 l0 = world_inertia(m, q) * w;
    const double e0 = rotational_energy(m, q, w);
    const int n = static_cast<int>(std::round(10.0 / h));
    double worst_l = 0.0, worst_e = 0.0;
    for (int k = 0; k < n; ++k) {
      rotate_free(m, q, w, h);
      worst_l = std::max(worst_l, (world_inertia(m, q) * w - l0).norm() / l0.norm());
      worst_e = std::max(worst_e, std::abs(rotational_energy(m, q, w) - e0) / e0);
    }
    EXPECT_LT(worst_l, 1e-12) << "h = " << h;
    EXPECT_LT(worst_e, 1e-12) << "h = " << h;
    EXPECT_NEAR(q.norm(), 1.0, 1e-14);
  }
}

// The motion itself against Runge–Kutta on Euler's equations at 10 µs: the orientation to
// 1e-7 rad and ω to 1e-7 relative after 3 s, at 1 ms and 8 ms steps.
TEST(DdaRotation, FollowsEulersEquations) {
  const Model m = slab();
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(1.1, Vec3(0.3, -1.0, 0.2).normalized()));
  const Vec3 w0(2.0, 0.7, -3.0);
  Eigen::Quaterniond q_ref = q0;
  Vec3 w_ref = w0;
  reference_rotation(m, q_ref, w_ref, 3.0, 1e-5);
  for (const double h : {1e-3, 8e-3}) {
    Eigen::Quaterniond q = q0;
    Vec3 w = w0;
    for (int k = 0; k < static_cast<int>(std::round(3.0 / h)); ++k) rotate_free(m, q, w, h);
    EXPECT_LT(q.angularDistance(q_ref), 1e-7) << "h = " << h;
    EXPECT_LT((w - w_ref).norm() / w_ref.norm(), 1e-7) << "h = " << h;
  }
}

// Spun about its intermediate axis with a 1e-3 perturbation, the slab flips: that axis
// turns from along L to against it and back. About the largest or smallest axis it stays.
TEST(DdaRotation, IntermediateAxisFlipsAndTheOthersDoNot) {
  const Model m = slab();
  const auto axis_along_l = [&](int axis, double seconds, double& least) {
    const Vec3 e = m.principal_axes.col(axis);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    Vec3 w = 5.0 * e + 5e-3 * m.principal_axes.col((axis + 1) % 3);
    const Vec3 l = (world_inertia(m, q) * w).normalized();
    least = 1.0;
    double first_flip = -1.0;
    for (int k = 1; k <= static_cast<int>(seconds / 1e-3); ++k) {
      rotate_free(m, q, w, 1e-3);
      const double along = (q * e).dot(l);
      least = std::min(least, along);
      if (first_flip < 0.0 && along < -0.99) first_flip = k * 1e-3;
    }
    return first_flip;
  };
  double least = 0.0;
  const double flip = axis_along_l(1, 10.0, least);
  EXPECT_GT(flip, 0.0) << "no flip in 10 s";
  EXPECT_LT(least, -0.99);
  for (const int axis : {0, 2}) {
    EXPECT_LT(axis_along_l(axis, 10.0, least), 0.0);
    EXPECT_GT(least, 0.99) << "axis " << axis;
  }
}

// A contact step's inertial prediction: θ and the end ω of free_spin equal the rotation's.
TEST(DdaRotation, FreeSpinIsTheTorqueFreeTurn) {
  const Model m = slab();
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.7, Vec3(1.0, 0.0, 1.0).normalized()));
  const Vec3 w0(-1.0, 3.0, 2.0);
  const detail::FreeSpin f = free_spin(m, q0, w0, 2e-3);
  Eigen::Quaterniond q = q0;
  Vec3 w = w0;
  rotate_free(m, q, w, 2e-3);
  const Eigen::Quaterniond by_theta = Eigen::Quaterniond(Eigen::AngleAxisd(f.theta.norm(), f.theta.normalized())) * q0;
  EXPECT_LT(by_theta.angularDistance(q), 1e-14);
  EXPECT_LT((f.omega - w).norm(), 1e-14 * w.norm());
  // θ = ω·h + ½·ω̇·h² + O(h³), with Euler's ω̇ = −J⁻¹(ω × Jω): the gyroscopic term's sign.
  const Mat3 j = world_inertia(m, q0);
  const Vec3 w_dot = -j.inverse() * w0.cross(j * w0);
  const double h = 2e-3;
  EXPECT_GT((0.5 * h * h * w_dot).norm(), 1e-6);
  EXPECT_LT((f.theta - h * w0 - 0.5 * h * h * w_dot).norm(), 0.01 * (0.5 * h * h * w_dot).norm());
}

// Every vertex's acceleration in torque-free rotation stays within κ·|r| (the flight
// test's curvature), sampled by second differences of the exact motion.
TEST(DdaRotation, CurvatureBoundsThePointsAcceleration) {
  const Model m = slab();
  Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Vec3(0.0, 1.0, 1.0).normalized()));
  Vec3 w = 4.0 * m.principal_axes.col(1) + 0.5 * m.principal_axes.col(0);
  const double kappa = rotation_curvature(m, q.toRotationMatrix(), w);
  EXPECT_GE(kappa, w.squaredNorm());
  const double h = 1e-4;
  double worst = 0.0;
  Eigen::Quaterniond a = q, b = q;
  Vec3 wb = w;
  rotate_free(m, b, wb, h);
  for (int k = 0; k < 20000; ++k) {
    Eigen::Quaterniond c = b;
    Vec3 wc = wb;
    rotate_free(m, c, wc, h);
    for (const Vec3& r : m.vertices) {
      const Vec3 acc = (c * r - 2.0 * (b * r) + a * r) / (h * h);
      worst = std::max(worst, acc.norm() / (kappa * r.norm()));
    }
    a = b;
    b = c;
    wb = wc;
  }
  EXPECT_LT(worst, 1.0 + 1e-3);  // second differences carry O(h²) error
  EXPECT_GT(worst, 0.1);         // and the bound is not absurdly loose
}

}  // namespace
}  // namespace talus::dda
