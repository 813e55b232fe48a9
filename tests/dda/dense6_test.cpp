// SPDX-License-Identifier: MIT
// The 6 × 6 factorizations of the rigid step (dense6.hpp) against Eigen's LLT and
// PartialPivLU, which they replace: the same solution to the last bit, on random
// matrices over twelve orders of magnitude, on systems shaped like a step's (mass over
// Δt² plus contact springs 1e6 times stiffer, with and without a sliding contact's
// unsymmetric term), and on matrices that are not positive definite or are singular.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <cstring>

#include "dense6.hpp"
#include "talus/core/random.hpp"

namespace talus::dda {
namespace {

using Mat = Eigen::Matrix<double, 6, 6>;
using Vec = Eigen::Matrix<double, 6, 1>;

bool same_bits(const Vec& a, const Vec& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 6) == 0; }

// A 6 × 6 matrix of normal entries, each scaled by 10^u with u uniform in (−3, 3).
Mat random_matrix(core::RandomSequence& rng) {
  Mat a;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) a(i, j) = rng.normal() * std::pow(10.0, (-3.0 + 6.0 * rng.uniform()));
  return a;
}

Vec random_vector(core::RandomSequence& rng, double scale) {
  Vec v;
  for (int i = 0; i < 6; ++i) v(i) = scale * rng.normal();
  return v;
}

// A step's system: 2/Δt² times a block's mass matrix (mass m, rotational inertia with
// off-diagonal terms) plus `contacts` normal springs p·gₙ·gₙᵀ, p = 1e9 N/m.
Mat step_system(core::RandomSequence& rng, int contacts) {
  const double mass = std::pow(10.0, (4.0 * rng.uniform()));
  Mat m = Mat::Zero();
  m.diagonal() << mass, mass, mass, 0.3 * mass, 0.4 * mass, 0.2 * mass;
  const Mat a = random_matrix(rng);
  m.bottomRightCorner<3, 3>() += 0.02 * mass * (a.topLeftCorner<3, 3>() + a.topLeftCorner<3, 3>().transpose()) /
                                  a.topLeftCorner<3, 3>().cwiseAbs().maxCoeff();
  Mat k = 2e6 * m;
  for (int c = 0; c < contacts; ++c) {
    const Vec gn = random_vector(rng, 1.0);
    k += 1e9 * gn * gn.transpose();
  }
  return k;
}

// Both solutions NaN somewhere (a singular or indefinite system's meaningless answer) or
// the same bits.
void expect_same(const Vec& eigen, const Vec& ours, int trial) {
  if (eigen.hasNaN() && ours.hasNaN()) return;
  EXPECT_TRUE(same_bits(eigen, ours)) << "trial " << trial << "\nEigen " << eigen.transpose() << "\nours  "
                                      << ours.transpose();
}

TEST(DdaDense6, CholeskyEqualsEigenBitForBit) {
  core::RandomSequence rng(core::RandomStream(20261128, core::Stream::release, 0));
  int indefinite = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Mat k;
    switch (trial % 3) {
      case 0: {
        const Mat a = random_matrix(rng);
        k = a * a.transpose();
        break;
      }
      case 1:
        k = step_system(rng, trial % 8);
        break;
      default:
        k = random_matrix(rng);  // rarely positive definite
        break;
    }
    const Vec f = random_vector(rng, 1e3);
    const Eigen::LLT<Mat> eigen(k);
    const detail::Cholesky6 ours(k);
    EXPECT_EQ(eigen.info() == Eigen::Success, ours.positive_definite()) << "trial " << trial;
    indefinite += ours.positive_definite() ? 0 : 1;
    expect_same(eigen.solve(f), ours.solve(f), trial);
  }
  // The indefinite ones were exercised too (the random third, mostly).
  EXPECT_GT(indefinite, 5000);
}

TEST(DdaDense6, PivotedLuEqualsEigenBitForBit) {
  core::RandomSequence rng(core::RandomStream(7, core::Stream::release, 0));
  for (int trial = 0; trial < 20000; ++trial) {
    Mat k;
    switch (trial % 4) {
      case 0:
        k = random_matrix(rng);
        break;
      case 1: {
        // A sliding contact's term −μ·p·(Tᵀs)·gₙᵀ on a step's system.
        k = step_system(rng, 1 + trial % 5);
        const Vec ts = random_vector(rng, 1.0), gn = random_vector(rng, 1.0);
        k -= 0.6 * 1e9 * ts * gn.transpose();
        break;
      }
      case 2: {
        // Singular: a repeated row, a zero column.
        k = random_matrix(rng);
        k.row(4) = k.row(1);
        if (trial % 8 == 2) k.col(2).setZero();
        break;
      }
      default: {
        // Ties in a pivot column: the first of equal magnitudes is taken.
        k = random_matrix(rng);
        k(3, 0) = -k(0, 0);
        k(5, 0) = k(0, 0);
        break;
      }
    }
    const Vec f = random_vector(rng, 1e3);
    expect_same(Eigen::PartialPivLU<Mat>(k).solve(f), detail::PivotedLu6(k).solve(f), trial);
  }
}

// The solutions solve their systems (a check independent of Eigen).
TEST(DdaDense6, SolutionsSolveTheirSystems) {
  core::RandomSequence rng(core::RandomStream(3, core::Stream::release, 0));
  for (int trial = 0; trial < 2000; ++trial) {
    const Mat k = step_system(rng, trial % 6);
    const Vec f = random_vector(rng, 1e3);
    const Vec x = detail::Cholesky6(k).solve(f);
    EXPECT_LE((k * x - f).norm(), 1e-9 * (k.norm() * x.norm() + f.norm())) << "trial " << trial;
    Mat u = k;
    u -= 5e8 * random_vector(rng, 1.0) * random_vector(rng, 1.0).transpose();
    const Vec y = detail::PivotedLu6(u).solve(f);
    EXPECT_LE((u * y - f).norm(), 1e-8 * (u.norm() * y.norm() + f.norm())) << "trial " << trial;
  }
}

}  // namespace
}  // namespace talus::dda
