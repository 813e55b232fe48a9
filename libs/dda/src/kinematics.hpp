// SPDX-License-Identifier: MIT
// The block's kinematics as the step sees it: its pose, the displacement matrix T(r) of
// the path's unknowns (6 rigid or 12 with strains), the mass matrix at a pose, the step
// systems' solvers and a phase timer. Shared by the contact law, the flight step and the
// contact step.
#pragma once
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <type_traits>

#include "contacts.hpp"
#include "dense6.hpp"
#include "talus/dda/engine.hpp"

namespace talus::dda::detail {

// Adds the wall time of a scope to a phase total when timing is on.
class PhaseTimer {
 public:
  PhaseTimer(bool on, double& total) : total_(on ? &total : nullptr) {
    if (total_) start_ = std::chrono::steady_clock::now();
  }
  ~PhaseTimer() {
    if (total_) *total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  PhaseTimer(const PhaseTimer&) = delete;
  PhaseTimer& operator=(const PhaseTimer&) = delete;

 private:
  double* total_;
  std::chrono::steady_clock::time_point start_;
};

inline Pose pose_of(const Model& model, const State& s) {
  Pose p;
  p.centre = s.position;
  p.rotation = s.orientation.toRotationMatrix();
  if (model.dof == DofPath::rigid6) {
    p.map = p.rotation;
    p.inverse_map = p.rotation.transpose();
    p.rigid = true;
  } else {
    p.map = p.rotation * s.stretch;
    p.inverse_map = s.stretch.inverse() * p.rotation.transpose();
  }
  return p;
}

inline Vec3 gravity_vector(const Model& model) { return Vec3(0.0, 0.0, -model.settings.gravity); }

// Voigt (εx εy εz γyz γzx γxy) of a symmetric strain tensor.
inline Eigen::Matrix<double, 6, 1> voigt(const Mat3& e) {
  Eigen::Matrix<double, 6, 1> v;
  v << e(0, 0), e(1, 1), e(2, 2), 2.0 * e(1, 2), 2.0 * e(2, 0), 2.0 * e(0, 1);
  return v;
}

inline Mat3 strain_tensor(const Eigen::Matrix<double, 6, 1>& v) {
  Mat3 e;
  e << v(0), v(5) / 2, v(4) / 2,  //
      v(5) / 2, v(1), v(3) / 2,     //
      v(4) / 2, v(3) / 2, v(2);
  return e;
}

template <int N>
using MatN = Eigen::Matrix<double, N, N>;
template <int N>
using VecN = Eigen::Matrix<double, N, 1>;

// The solvers of an N × N step system: a symmetric positive definite one (Cholesky) and
// an unsymmetric one (LU with partial pivoting). The rigid path's 6 × 6 ones give Eigen's
// results bit for bit at a fraction of the cost (dense6.hpp).
template <int N>
using SymmetricSolver = std::conditional_t<N == 6, Cholesky6, Eigen::LLT<MatN<N>>>;
template <int N>
using GeneralSolver = std::conditional_t<N == 6, PivotedLu6, Eigen::PartialPivLU<MatN<N>>>;

// T(r) restricted to the N unknowns of the path (3×6 rigid or 3×12 full).
template <int N>
Eigen::Matrix<double, 3, N> dof_matrix(const Vec3& r) {
  if constexpr (N == 6) {
    Eigen::Matrix<double, 3, 6> t;
    t << 1, 0, 0, 0, r.z(), -r.y(),  //
        0, 1, 0, -r.z(), 0, r.x(),   //
        0, 0, 1, r.y(), -r.x(), 0;
    return t;
  } else {
    return displacement_matrix(r);
  }
}

// TᵀT of a displacement matrix: in closed form for the rigid 3×6 map [I | −[r]×].
template <int N>
MatN<N> gram(const Eigen::Matrix<double, 3, N>& t) {
  if constexpr (N == 6) {
    MatN<6> g;
    const Mat3 a = t.template rightCols<3>();
    g.template topLeftCorner<3, 3>().setIdentity();
    g.template topRightCorner<3, 3>() = a;
    g.template bottomLeftCorner<3, 3>() = a.transpose();
    // Aᵀ A = |r|² I − r rᵀ with r read back from A = −[r]×.
    const Vec3 r(a(2, 1) * -1.0, a(0, 2) * -1.0, a(1, 0) * -1.0);
    g.template bottomRightCorner<3, 3>() = r.squaredNorm() * Mat3::Identity() - r * r.transpose();
    return g;
  } else {
    return t.transpose() * t;
  }
}

// Displacement of the point r (relative to the centroid) for the step displacement d.
template <int N>
Vec3 point_displacement(const Vec3& r, const VecN<N>& d) {
  if constexpr (N == 6) {
    return d.template head<3>() + d.template tail<3>().cross(r);
  } else {
    return displacement_matrix(r) * d;
  }
}

// The largest vertex displacement (m) under d, or `floor` if none moves further: a scan, or
// branch and bound over the vertex tree (u = a + A·F·b is affine over a body box), the same
// numbers.
template <int N>
double max_vertex_displacement_indexed(const PlacedBlock& at, const VecN<N>& d, double floor);

template <int N>
double max_vertex_displacement(const PlacedBlock& at, const VecN<N>& d, double floor) {
  if (at.index() != nullptr) return max_vertex_displacement_indexed<N>(at, d, floor);
  // On squared lengths, one square root at the end: the same number, as √ is monotone.
  double largest = 0.0;
  for (const Vec3& x : at.vertices())
    largest = std::max(largest, point_displacement<N>(x - at.pose().centre, d).squaredNorm());
  return std::max(floor, std::sqrt(largest));
}

template <int N>
[[gnu::noinline]] double max_vertex_displacement_indexed(const PlacedBlock& at, const VecN<N>& d, double floor) {
  const Pose& pose = at.pose();
  const Vec3 a = point_displacement<N>(Vec3::Zero(), d);
  Mat3 A;
  for (int j = 0; j < 3; ++j) A.col(j) = point_displacement<N>(Vec3::Unit(j), d) - a;
  const Mat3 B = A * pose.map;
  const Vec3 columns = B.colwise().norm().transpose();
  // Round-off of the world vertices (relative to the centre's coordinates) and of the
  // products, generously.
  const double slack = 1e-9 * (a.norm() + B.norm() * at.model().radius) +
                       1e-12 * A.norm() * pose.centre.cwiseAbs().maxCoeff();
  const double below = std::max(0.0, floor) * std::max(0.0, floor) * (1.0 - 1e-12);
  const double largest = at.index()->vertices.maximum(
      [&](const geometry::Aabb& b) {
        const double bound = (a + B * b.center()).norm() + columns.dot(0.5 * b.extent()) + slack;
        return bound * bound;
      },
      [&](std::int32_t i) {
        return point_displacement<N>(at.vertex(static_cast<std::size_t>(i)) - pose.centre, d).squaredNorm();
      },
      below);
  return std::max(floor, std::sqrt(largest));
}

template <int N>
MatN<N> current_mass(const Model& model, const Pose& pose) {
  if constexpr (N == 6) {
    MatN<6> m = MatN<6>::Zero();
    m.template topLeftCorner<3, 3>() = model.mass * Mat3::Identity();
    m.template bottomRightCorner<3, 3>() = pose.rotation * model.inertia * pose.rotation.transpose();
    return m;
  } else {
    const Mat3 s = pose.map * model.second_moments * pose.map.transpose();
    return mass_matrix(model.settings.density, model.volume, s);
  }
}

}  // namespace talus::dda::detail
