// SPDX-License-Identifier: MIT
// The 6 × 6 factorizations of a rigid block's step (Cholesky; LU with partial pivoting when
// a sliding contact makes the system unsymmetric): Eigen 3.4's LLT<Mat6> and
// PartialPivLU<Mat6> operation for operation, so the same bits (DdaDense6), without their
// copies, unused condition estimate and run-time-size loops.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>

namespace talus::dda::detail {

namespace dense6 {

using Mat = Eigen::Matrix<double, 6, 6>;
using Vec = Eigen::Matrix<double, 6, 1>;

// x[start] + … + x[start + length − 1] split in halves, recursively: Eigen's unrolled sum
// of a fixed-size strided product (a row of a column-major matrix times a vector).
template <int Start, int Length, class Term>
inline double halving_sum(const Term& x) {
  if constexpr (Length == 1) {
    return x(Start);
  } else {
    constexpr int half = Length / 2;
    return halving_sum<Start, half>(x) + halving_sum<Start + half, Length - half>(x);
  }
}

// The same sum as Eigen's unrolled, vectorized sum of a fixed-size contiguous product
// with two doubles to a packet: the pairs (x0, x1), (x2, x3), … added as packets in
// halves, the packet's two lanes added, and an odd last term added after.
template <int Start, int Packets, class Term>
inline std::array<double, 2> packet_sum(const Term& x) {
  if constexpr (Packets == 1) {
    return {x(Start), x(Start + 1)};
  } else {
    constexpr int half = Packets / 2;
    const std::array<double, 2> a = packet_sum<Start, half>(x);
    const std::array<double, 2> b = packet_sum<Start + 2 * half, Packets - half>(x);
    return {a[0] + b[0], a[1] + b[1]};
  }
}

template <int Length, class Term>
inline double packet_halving_sum(const Term& x) {
  if constexpr (Length < 2) {
    return x(0);
  } else {
    const std::array<double, 2> p = packet_sum<0, Length / 2>(x);
    const double sum = p[0] + p[1];
    if constexpr (Length % 2 == 1) return sum + x(Length - 1);
    return sum;
  }
}

// Forward substitution with a lower triangle of column-major `l`, row by row (Eigen's
// unrolled triangular solve of a 6-vector): y_d = (b_d − Σ_{j<d} l_dj·y_j) / l_dd, the
// sum halved; no division on a unit diagonal.
template <bool UnitDiagonal, int D = 0>
inline void forward(const Mat& l, Vec& y) {
  if constexpr (D < 6) {
    if constexpr (D > 0) y(D) -= halving_sum<0, D>([&](int j) { return l(D, j) * y(j); });
    if constexpr (!UnitDiagonal) y(D) /= l(D, D);
    forward<UnitDiagonal, D + 1>(l, y);
  }
}

// Back substitution with the upper triangle of column-major `u`:
// x_d = (y_d − Σ_{j>d} u_dj·x_j) / u_dd, the sum halved.
template <int D = 5>
inline void backward_upper(const Mat& u, Vec& x) {
  if constexpr (D >= 0) {
    constexpr int count = 5 - D;
    if constexpr (count > 0) x(D) -= halving_sum<0, count>([&](int j) { return u(D, D + 1 + j) * x(D + 1 + j); });
    x(D) /= u(D, D);
    backward_upper<D - 1>(u, x);
  }
}

// Back substitution with the transpose of the lower triangle of column-major `l`
// (Eigen's adjoint view): x_d = (y_d − Σ_{j>d} l_jd·x_j) / l_dd, the sum over a
// contiguous column, in packets.
template <int D = 5>
inline void backward_transposed(const Mat& l, Vec& x) {
  if constexpr (D >= 0) {
    constexpr int count = 5 - D;
    if constexpr (count > 0)
      x(D) -= packet_halving_sum<count>([&](int j) { return l(D + 1 + j, D) * x(D + 1 + j); });
    x(D) /= l(D, D);
    backward_transposed<D - 1>(l, x);
  }
}

}  // namespace dense6

// The Cholesky factor L (a = L·Lᵀ) of a symmetric 6 × 6 matrix (lower triangle read),
// column by column, the sums in order of j; a pivot that is not positive stops it.
class Cholesky6 {
 public:
  explicit Cholesky6(const dense6::Mat& a) : l_(a) {
    // Unrolled: the loops' bounds are then constants.
#pragma GCC unroll 6
    for (int k = 0; k < 6; ++k) {
      double x = l_(k, k);
      if (k > 0) {
        double s = l_(k, 0) * l_(k, 0);
#pragma GCC unroll 6
        for (int j = 1; j < k; ++j) s += l_(k, j) * l_(k, j);
        x -= s;
      }
      if (x <= 0.0) {
        positive_definite_ = false;
        return;
      }
      l_(k, k) = x = std::sqrt(x);
#pragma GCC unroll 6
      for (int i = k + 1; i < 6; ++i) {
        if (k > 0) {
          double c = 0.0;
#pragma GCC unroll 6
          for (int j = 0; j < k; ++j) c += l_(i, j) * l_(k, j);
          l_(i, k) -= c;
        }
        l_(i, k) /= x;
      }
    }
  }

  bool positive_definite() const { return positive_definite_; }

  // x with a·x = b (meaningless when the matrix is not positive definite).
  dense6::Vec solve(const dense6::Vec& b) const {
    dense6::Vec x = b;
    dense6::forward<false>(l_, x);
    dense6::backward_transposed(l_, x);
    return x;
  }

 private:
  dense6::Mat l_;
  bool positive_definite_ = true;
};

// P·a = L·U with partial pivoting (the first largest magnitude in each column), L with a
// unit diagonal, for an unsymmetric 6 × 6 matrix. A zero pivot column is left as it is.
class PivotedLu6 {
 public:
  explicit PivotedLu6(const dense6::Mat& a) : lu_(a) {
#pragma GCC unroll 5
    for (int k = 0; k < 5; ++k) {
      int pivot = k;
      double biggest = std::abs(lu_(k, k));
#pragma GCC unroll 5
      for (int i = k + 1; i < 6; ++i) {
        const double score = std::abs(lu_(i, k));
        if (score > biggest) {
          biggest = score;
          pivot = i;
        }
      }
      swaps_[static_cast<std::size_t>(k)] = pivot;
      if (biggest != 0.0) {
        if (pivot != k) lu_.row(k).swap(lu_.row(pivot));
#pragma GCC unroll 5
        for (int i = k + 1; i < 6; ++i) lu_(i, k) /= lu_(k, k);
      }
#pragma GCC unroll 5
      for (int j = k + 1; j < 6; ++j)
#pragma GCC unroll 5
        for (int i = k + 1; i < 6; ++i) lu_(i, j) -= lu_(i, k) * lu_(k, j);
    }
    swaps_[5] = 5;
  }

  // x with a·x = b.
  dense6::Vec solve(const dense6::Vec& b) const {
    dense6::Vec x = b;
    for (int k = 0; k < 6; ++k) std::swap(x(k), x(swaps_[static_cast<std::size_t>(k)]));
    dense6::forward<true>(lu_, x);
    dense6::backward_upper(lu_, x);
    return x;
  }

 private:
  dense6::Mat lu_;
  std::array<int, 6> swaps_{};
};

}  // namespace talus::dda::detail
