// SPDX-License-Identifier: MIT
// The contact law of the DDA step: the block's matrices, Shi's implicit solve with the
// open–close iteration over Mohr–Coulomb penalty contacts, the carrying of contact states
// from step to step and the settling of persistent contacts. Included by engine.cpp only
// (templates on the number of unknowns, 6 or 12).
#pragma once
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

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

// The largest displacement (m) of a block vertex under the step displacement d, or `floor`
// when none moves further: above `floor` it is the maximum a scan of the vertices finds,
// with the same numbers. A detailed block is searched by branch and bound over its vertex
// tree: u is affine in r, u = a + A·r, and r = F·b over a body box of centre c and
// half-sizes h, so |u| ≤ |a + A·F·c| + Σⱼ |(A·F)ⱼ| hⱼ there.
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

// Per-contact terms of one step, computed once and reused by the open–close iterations.
template <int N>
struct Work {
  Eigen::Matrix<double, 3, N> t;        // T(r) at the contact point
  VecN<N> gn;                           // Tᵀn: the gap's gradient
  Eigen::Matrix<double, 3, N> ta;       // T(r) at the shear anchor
  Vec3 s0;                              // shear spring stretch at the step start
  double g0 = 0.0;                      // gap − offset at the step start
  double mu = 1.0;                      // share of the friction coefficient a sliding contact gets
  // A locked contact at its friction limit in this step: its shear spring is replaced in
  // the solve by the Coulomb force μ·F_n against `limit_direction` (F_n implicit, as for a
  // sliding contact), the exact return mapping of the spring; its anchor is moved to the
  // limit once the step is accepted. `unloaded`: it was at the limit and its point moved
  // back, so it is an elastic spring again for the rest of the step.
  bool at_limit = false;
  bool unloaded = false;
  Vec3 limit_direction = Vec3::Zero();
  // The direction follows the stretch (a radial return): linearised about the solution
  // `limit_at` it was taken from, the force turns with the stretch at a stiffness
  // `limit_turn` = μ·F_n/|stretch| (N/m) across it.
  double limit_turn = 0.0;
  VecN<N> limit_at = VecN<N>::Zero();
};

struct StepOutcome {
  bool converged = false;
  int iterations = 0;
  int held = 0;  // contacts held in their state before the iteration settled
};

// Shi's implicit step: assemble, iterate on the contact states, solve. On return `d`
// holds the step displacement and each contact's mode its converged state.
template <int N>
StepOutcome solve_step(const Model& model, const Pose& pose, const State& s, double dt, double friction,
                       std::vector<Contact>& contacts, VecN<N>& d, PhaseTimes& times, bool freeze_strain = false,
                       bool impact_phase = false) {
  const Settings& set = model.settings;
  const bool timing = set.time_phases;
  MatN<N> k0;
  VecN<N> f0;
  thread_local std::vector<Work<N>> work;
  {
    PhaseTimer timer(timing, times.assemble);
    const MatN<N> m = current_mass<N>(model, pose);
    const VecN<N> v0 = s.velocity.template head<N>();
    k0 = (2.0 / (dt * dt)) * m;
    f0 = (2.0 / dt) * (m * v0);
    f0.template head<3>() += model.mass * gravity_vector(model);
    if constexpr (N == 12) {
      // Accumulated strain (body frame, from the stretch U) acts as an initial stress.
      const Mat3 e_body = 0.5 * (s.stretch + s.stretch.transpose()) - Mat3::Identity();
      const Mat3 e_world = pose.rotation * e_body * pose.rotation.transpose();
      const Eigen::Matrix<double, 6, 1> sigma = model.elasticity * voigt(e_world);
      k0.template bottomRightCorner<6, 6>() += model.volume * model.elasticity;
      f0.template tail<6>() -= model.volume * sigma;
    }
    work.resize(contacts.size());
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      Contact& c = contacts[i];
      Work<N>& w = work[i];
      w.t = dof_matrix<N>(c.point - pose.centre);
      w.gn = w.t.transpose() * c.normal;
      // A slip direction carried from an earlier step (an edge–edge normal turns with
      // the block) is made tangent again: friction must have no normal part.
      const Vec3 slip = c.slip_direction - c.normal * c.normal.dot(c.slip_direction);
      c.slip_direction = slip.norm() > 1e-9 ? Vec3(slip.normalized()) : Vec3::Zero();
      w.g0 = c.gap - c.gap_offset;
      w.mu = 1.0;
      w.at_limit = false;
      w.unloaded = false;
      if (c.anchored) {
        const Vec3 xa = pose.centre + pose.map * c.body_anchor;
        w.ta = dof_matrix<N>(xa - pose.centre);
        const Vec3 s_raw = xa - c.ground_anchor;
        w.s0 = s_raw - c.normal * c.normal.dot(s_raw);
      }
    }
  }
  const double p = model.stiffness;
  const double ps = p / set.shear_stiffness_ratio;
  // The Coulomb force of a contact that slides into this step opposes its trial slip: the
  // slip of this step's solution with no friction at all (open contacts out, closed ones
  // with their normal springs, locked ones with their shear springs). For a translating
  // block that is the implicit (radial-return) direction, the one the converged slip
  // takes; the previous step's slip lags behind it, and on a block sliding slowly with a
  // small sideways velocity the lagging force overshot sideways each step: a sway of
  // ±1.4 mm/s that kept a cube sliding at 2.4 mm/s down a slope it should stick to.
  // The rigid path only: on the 12-DOF path a friction set against the trial slip kept 3 of
  // 8 cubes of the landing case sliding at 2.7 mm/s, with a rocking velocity that flipped
  // sign every step; set against the previous step's slip, all 8 stick (cause not traced).
  if (N == 6 && friction > 0.0 && std::any_of(contacts.begin(), contacts.end(),
                                    [](const Contact& c) { return c.mode == ContactMode::sliding; })) {
    PhaseTimer timer(timing, times.open_close);
    MatN<N> k = k0;
    VecN<N> f = f0;
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const Contact& c = contacts[i];
      const Work<N>& w = work[i];
      if (c.mode == ContactMode::open) continue;
      k.noalias() += p * w.gn * w.gn.transpose();
      f -= p * w.g0 * w.gn;
      if (c.mode != ContactMode::locked) continue;
      const Eigen::Matrix<double, 3, N>& ta = c.anchored ? w.ta : w.t;
      const VecN<N> gt = ta.transpose() * c.normal;
      k.noalias() += ps * (gram<N>(ta) - gt * gt.transpose());
      if (c.anchored) f -= ps * (ta.transpose() * w.s0);
    }
    const VecN<N> trial = SymmetricSolver<N>(k).solve(f);
    if (trial.allFinite()) {
      for (std::size_t i = 0; i < contacts.size(); ++i) {
        Contact& c = contacts[i];
        if (c.mode != ContactMode::sliding) continue;
        const Vec3 du = work[i].t * trial;
        const Vec3 ut = du - c.normal * c.normal.dot(du);
        if (ut.norm() > 0.0) c.slip_direction = ut.normalized();
      }
    }
  }
  // The largest penetration a contact held open may leave (m): see the open–close cycle.
  const double shallow = 1e-3 * model.penetration_limit();
  // Each contact may visit each of its three modes once per step; a contact whose
  // re-judgement would take it back to a mode it already had in this step (open -> locked
  // -> open, locked -> sliding -> locked, ...) is held closed -- sliding if it slid -- for
  // the rest of the step, and so is every contact that changes state after
  // `max_open_close_iterations`. The iteration therefore always ends, after at most
  // max_open_close_iterations + 5·(contacts) + 1 solves (the last ones dropping friction
  // that would push, below); a held contact carries at most the small tension or slip
  // error of one state flip (counted in Counters::held_contacts).
  thread_local std::vector<std::uint8_t> visited;
  thread_local std::vector<std::uint8_t> held;
  visited.assign(contacts.size(), 0);
  held.assign(contacts.size(), 0);
  auto bit = [](ContactMode m) { return static_cast<std::uint8_t>(1u << static_cast<unsigned>(m)); };
  for (std::size_t i = 0; i < contacts.size(); ++i) visited[i] = bit(contacts[i].mode);
  // The last penetration of a contact's open state and tension of its closed state (m):
  // which of the two violates less decides how a contact cycling between them is held.
  thread_local std::vector<double> open_depth, closed_tension;
  open_depth.assign(contacts.size(), std::numeric_limits<double>::infinity());
  closed_tension.assign(contacts.size(), 0.0);
  thread_local std::vector<std::uint8_t> first_open;
  first_open.clear();
  for (const Contact& c : contacts) first_open.push_back(c.mode == ContactMode::open ? 1 : 0);
  // The last move of each contact's spring zero in this step (below): unbounded for a
  // contact that starts the step with its spring unloaded at its accepted offset, zero
  // (no move allowed) for any other.
  thread_local std::vector<double> last_shift;
  last_shift.clear();
  for (const Contact& c : contacts)
    last_shift.push_back(c.gap - c.gap_offset == 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  StepOutcome out;
  const int free_iterations = static_cast<int>(set.max_open_close_iterations);
  const int max_iter = free_iterations + 4 * static_cast<int>(contacts.size()) + 1;
  // A held sliding contact may end the step in tension (g ≥ 0) or with its point moving
  // against its friction direction. Its implicit Coulomb force μ·p·(−g) then pushes
  // along the motion: in tension the "normal force" is negative. One such contact, held
  // closed 3e-5 m in tension under a tetrahedron spinning at 12 rad/s, put 6e6 N of
  // friction along a 13 mm slip and gave the step 78 kJ. A contact that carries no
  // compression has no friction, and friction never works along the motion: once the
  // modes are final, such contacts slide without friction and the step is solved again
  // with the modes kept (each contact loses its friction at most once). True if any did.
  // A contact at its friction limit pushes the same way in tension or once its point moves
  // back against its stretch: it is an elastic spring again, and the step is solved again.
  auto drop_pushing_friction = [&]() {
    bool dropped = false;
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const Contact& c = contacts[i];
      Work<N>& w = work[i];
      if (c.mode == ContactMode::locked && w.at_limit) {
        const Vec3 da = w.ta * d;
        if (w.g0 + w.gn.dot(d) >= 0.0 || (da - c.normal * c.normal.dot(da)).dot(w.limit_direction) < 0.0) {
          w.at_limit = false;
          w.unloaded = true;
          dropped = true;
        }
        continue;
      }
      if (c.mode != ContactMode::sliding || w.mu == 0.0 || !(friction > 0.0)) continue;
      const Vec3 du = w.t * d;
      if (w.g0 + w.gn.dot(d) >= 0.0 || (du - c.normal * c.normal.dot(du)).dot(c.slip_direction) < 0.0) {
        w.mu = 0.0;
        dropped = true;
      }
    }
    return dropped;
  };
  // Return mapping: moves a locked contact's anchor so that its shear spring carries at
  // most μ·F_n of this solution (F_n = −p·g, nothing in tension) once it carries more
  // than `slack` times that. True if it moved.
  auto cap_at_friction = [&](Contact& c, Work<N>& w, double g, double slack) {
    const Vec3 sv = w.s0 + w.ta * d;
    const Vec3 st = sv - c.normal * c.normal.dot(sv);
    const double limit = friction * std::max(0.0, -p * g) / ps;
    const double stretch = st.norm();
    if (stretch <= slack * limit * (1.0 + 1e-9) + 1e-15 * model.radius) return false;
    const Vec3 shift = st * (limit / stretch - 1.0);
    w.s0 += shift;
    c.ground_anchor -= shift;
    return true;
  };
  auto accept = [&]() {
    // A contact at its friction limit ends the step with its anchor moved to the limit.
    for (std::size_t i = 0; i < contacts.size(); ++i)
      if (contacts[i].mode == ContactMode::locked && work[i].at_limit)
        cap_at_friction(contacts[i], work[i], work[i].g0 + work[i].gn.dot(d), 1.0);
    out.converged = true;
    for (const std::uint8_t h : held) out.held += h > 0 ? 1 : 0;
    return out;
  };
  // Assembles the step's system for the contacts' current modes and solves it into x.
  auto solve_modes = [&](VecN<N>& x) {
    MatN<N> k = k0;
    VecN<N> f = f0;
    bool unsymmetric = false;  // a contact slides or is at its friction limit
    {
      PhaseTimer timer(timing, times.open_close);
      for (std::size_t i = 0; i < contacts.size(); ++i) {
        Contact& c = contacts[i];
        Work<N>& w = work[i];
        if (c.mode == ContactMode::open) continue;
        k.noalias() += p * w.gn * w.gn.transpose();
        f -= p * w.g0 * w.gn;
        if (c.mode == ContactMode::locked) {
          if (!c.anchored) {
            // A contact closing now is anchored where it touches at the step start.
            c.anchored = true;
            c.body_anchor = pose.inverse_map * (c.point - pose.centre);
            c.ground_anchor = c.point - c.gap * c.normal;
            w.ta = w.t;
            w.s0.setZero();
          }
          if (w.at_limit) {
            // At the friction limit: the Coulomb force μ·F_n against the stretch, at the
            // anchored point, with F_n implicit in d, and its turn with the stretch.
            const VecN<N> ts = w.ta.transpose() * w.limit_direction;
            k.noalias() -= friction * p * ts * w.gn.transpose();
            f += friction * p * w.g0 * ts;
            const Mat3 across = Mat3::Identity() - c.normal * c.normal.transpose() -
                                w.limit_direction * w.limit_direction.transpose();
            const Eigen::Matrix<double, 3, N> turn = across * w.ta;
            const MatN<N> kt = w.limit_turn * (turn.transpose() * turn);
            k.noalias() += kt;
            f.noalias() += kt * w.limit_at;
            unsymmetric = true;
            continue;
          }
          // ps·(P T)ᵀ(P T) with P = I − nnᵀ equals ps·(TᵀT − (Tᵀn)(Tᵀn)ᵀ).
          const VecN<N> gt = w.ta.transpose() * c.normal;
          k.noalias() += ps * (gram<N>(w.ta) - gt * gt.transpose());
          f -= ps * (w.ta.transpose() * w.s0);
        } else {
          // Sliding: Coulomb force μ·F_n against the slip, with F_n implicit in d so the
          // friction matches the normal force of this very step.
          const VecN<N> ts = w.t.transpose() * c.slip_direction;
          k.noalias() -= w.mu * friction * p * ts * w.gn.transpose();
          f += w.mu * friction * p * w.g0 * ts;
          unsymmetric = true;
        }
      }
    }
    {
      PhaseTimer timer(timing, times.solve);
      // Symmetric positive definite unless a contact slides or is at its friction limit
      // (implicit friction).
      if constexpr (N == 12) {
        if (freeze_strain) {
          // Strain increments held at zero: the rigid block of the system.
          const Mat6 k6 = k.template topLeftCorner<6, 6>();
          const Eigen::Matrix<double, 6, 1> f6 = f.template head<6>();
          x.setZero();
          if (unsymmetric) x.template head<6>() = PivotedLu6(k6).solve(f6);
          else x.template head<6>() = Cholesky6(k6).solve(f6);
        }
      }
      if (!(N == 12 && freeze_strain)) {
        if (unsymmetric) x = GeneralSolver<N>(k).solve(f);
        else x = SymmetricSolver<N>(k).solve(f);
      }
    }
  };
  // Contacts held after cycling between open and closed get a complementarity solution
  // once the iteration has settled: the held state only ends the cycle, and it can be
  // wrong both ways -- held open, a landing vertex sinks; held closed, it pulls in tension
  // (a rolling sphere's landing vertex held closed 9e-5 m in tension, 1e8 N, beside a
  // compressed one 9 cm away: the couple reversed a 5.8 rad/s spin in one step and took
  // 96 % of the block's kinetic energy). Each such contact is open, sliding (along its
  // tangential motion in the held solution) or locked; of the 3^m combinations (m <= 4,
  // the others kept as they are) the first in which every one of them is consistent is
  // taken -- an open contact does not penetrate, a closed one carries no tension, a
  // locked one's shear force is within μ·F_n and a sliding one does not move against its
  // friction: the solution of the small complementarity problem. If none is, the one that
  // violates least (penetration or tension, m). True if it changed the modes; d then
  // holds the chosen solution.
  // A member's held state: its mode and what goes with it.
  struct HeldState {
    ContactMode mode;
    ContactMode resume;
    Vec3 slip_direction;
  };
  thread_local std::vector<std::size_t> members;
  thread_local std::vector<HeldState> member_start;
  thread_local std::vector<Vec3> member_slip;
  auto complement = [&]() {
    const std::uint8_t open_bit = bit(ContactMode::open);
    members.clear();
    for (std::size_t i = 0; i < contacts.size(); ++i)
      if (held[i] && (visited[i] & open_bit) && (visited[i] & static_cast<std::uint8_t>(~open_bit)))
        members.push_back(i);
    if (members.empty() || members.size() > 4) return false;
    const double tolerance = 1e-9 * model.radius;
    // How far x violates the members' modes (m; 0 if consistent).
    auto violation = [&](const VecN<N>& x) {
      double worst = 0.0;
      for (const std::size_t i : members) {
        const Contact& c = contacts[i];
        const Work<N>& w = work[i];
        const double g = w.g0 + w.gn.dot(x);
        if (c.mode == ContactMode::open) {
          worst = std::max(worst, -g - tolerance);
          continue;
        }
        worst = std::max(worst, g - tolerance);
        if (!(friction > 0.0)) continue;
        if (c.mode == ContactMode::locked) {
          const Vec3 sv = w.s0 + w.ta * x;
          const double stretch = (sv - c.normal * c.normal.dot(sv)).norm();
          const double limit = friction * std::max(0.0, -p * g) / ps;
          worst = std::max(worst, stretch - limit * (1.0 + 1e-9) - tolerance);
        } else {
          const Vec3 du = w.t * x;
          worst = std::max(worst, -(du - c.normal * c.normal.dot(du)).dot(c.slip_direction) - tolerance);
        }
      }
      return worst;
    };
    double best = violation(d);
    if (!(best > 0.0)) return false;
    member_start.clear();
    member_slip.clear();
    for (const std::size_t i : members) {
      const Contact& c = contacts[i];
      member_start.push_back({c.mode, c.resume, c.slip_direction});
      const Vec3 du = work[i].t * d;
      const Vec3 ut = du - c.normal * c.normal.dot(du);
      member_slip.push_back(ut.norm() > 0.0 ? Vec3(ut.normalized()) : c.slip_direction);
    }
    // Back to member k's held state. (An anchor a trial set for a contact closing locked
    // stays: it is where the contact touches at the step start whichever combination set
    // it, and the chosen solution's shear force acts on it.)
    auto restore = [&](std::size_t k) {
      Contact& c = contacts[members[k]];
      c.mode = member_start[k].mode;
      c.resume = member_start[k].resume;
      c.slip_direction = member_start[k].slip_direction;
    };
    // Combination `code` in base 3, one digit per member: 0 open, 1 sliding, 2 locked.
    auto set_modes = [&](unsigned code) {
      for (std::size_t k = 0; k < members.size(); ++k, code /= 3) {
        Contact& c = contacts[members[k]];
        const ContactMode start_mode = member_start[k].mode;
        restore(k);
        const unsigned digit = code % 3;
        if (digit == 0) {
          c.mode = ContactMode::open;
          if (start_mode != ContactMode::open) c.resume = start_mode;
        } else if (digit == 1) {
          c.mode = ContactMode::sliding;
          if (start_mode != ContactMode::sliding) c.slip_direction = member_slip[k];
        } else {
          c.mode = ContactMode::locked;
        }
      }
    };
    unsigned combinations = 1;
    for (std::size_t k = 0; k < members.size(); ++k) combinations *= 3;
    unsigned chosen = combinations;  // the held modes
    VecN<N> x, best_x = d;
    for (unsigned code = 0; code < combinations; ++code) {
      set_modes(code);
      // The held modes are solved again too: the anchor and spring-zero moves of the last
      // iteration came after d was solved. A changed member must be possible: without
      // friction a closed contact only slides, and a sliding one needs a direction.
      bool usable = true;
      for (std::size_t k = 0; k < members.size(); ++k) {
        const Contact& c = contacts[members[k]];
        if (c.mode == member_start[k].mode && (c.mode != ContactMode::sliding || c.slip_direction == member_start[k].slip_direction))
          continue;
        if (c.mode == ContactMode::locked && !(friction > 0.0)) usable = false;
        if (c.mode == ContactMode::sliding && friction > 0.0 && c.slip_direction.squaredNorm() == 0.0) usable = false;
      }
      if (!usable) continue;
      ++out.iterations;
      solve_modes(x);
      if (!x.allFinite()) continue;
      const double v = violation(x);
      if (v < best) {
        best = v;
        chosen = code;
        best_x = x;
        if (!(v > 0.0)) break;
      }
    }
    if (chosen == combinations) {
      for (std::size_t k = 0; k < members.size(); ++k) restore(k);
      return false;
    }
    set_modes(chosen);
    d = best_x;
    return true;
  };
  bool settled = false;  // the modes are final; only frictions are being dropped
  bool complemented = false;  // complement() has run
  for (int iter = 0; iter < max_iter || settled; ++iter) {
    ++out.iterations;
    solve_modes(d);
    PhaseTimer timer(timing, times.open_close);
    if (!d.allFinite()) return out;
    if (settled) {
      if (drop_pushing_friction()) continue;
      return accept();
    }
    bool changed = false;
    bool shifted = false;
    // A contact that re-sticks after slipping gets its shear spring stretched to the
    // friction force it carried, so the force is continuous and the load does not jump
    // to the other contacts (which would make a block ratchet down a slope it should
    // stick to). That stretch stores ½(μF_n)²/k_s that no force stored, negligible at
    // rest but not under an impact's forces: there the anchor starts unstretched. Nor
    // does it exceed the friction force the contact carried into the step (its normal
    // force at the end of the last step): a force it never carried is not continued,
    // and a transient iterate pressing a contact that opened the step with a gap 1e-3 m
    // deep pre-stretched its anchor with 847 J that turned into motion of a block at rest.
    auto restick_stretch = [&](const Contact& c, double g) {
      return impact_phase ? 0.0 : friction * std::min(-p * g, c.normal_force) / ps;
    };
    // A contact at its friction limit takes the direction of its stretch `st` in this
    // solution, and is linearised about it.
    auto set_limit = [&](Work<N>& w, const Vec3& st, double g) {
      w.limit_direction = st.normalized();
      w.limit_turn = friction * std::max(0.0, -p * g) / st.norm();
      w.limit_at = d;
    };
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      Contact& c = contacts[i];
      Work<N>& w = work[i];
      const double g = w.g0 + w.gn.dot(d);
      if (c.mode == ContactMode::open) {
        if (g < 0.0) open_depth[i] = -g;
      } else {
        closed_tension[i] = std::max(0.0, g);
      }
      if (held[i]) {
        // A held contact keeps its mode but not a force friction cannot carry: a locked
        // one has its anchor moved to the friction limit of this solution (none in
        // tension), and a sliding one may still stick once, since Coulomb friction must
        // never push along the slip. Nor a pull that does work: a closed contact that
        // started the step with a gap and ends it in tension (0 < g < g₀) pulls the block
        // towards the ground along its whole approach. It opens, and stays open (held):
        // a contact held locked after the free iterations, 9 mm off at the step start and
        // 0.17 mm in tension at its end, did 1.7 MJ of work on a block at rest.
        if (c.mode != ContactMode::open && w.g0 > 0.0 && g > 0.0) {
          c.resume = c.mode;
          c.mode = ContactMode::open;
          changed = true;
          continue;
        }
        // A held contact that started the step unloaded (at its accepted offset, as a
        // landing vertex found already below the surface does) and ends it in tension has
        // its spring's zero moved to where its point ends, never above the surface (a
        // return mapping of the normal spring, as the anchor's for friction), and the
        // solution is redone; again only while the tension it is left with shrinks. (Moved
        // whatever the tension, the shifts of two sliding contacts of a 1000 m³ cube fed on
        // each other, a zero went 2.4 cm up in eight iterations and the step gained
        // 2.2e10 J.) Opened instead, it could sink with nothing to stop it; held with its
        // pull, a rolling sphere's landing vertex held 4e-5 m in tension (4.5e7 N) beside
        // a compressed one 4 cm away, and the couple turned 5 rad/s of rolling spin into
        // 3 rad/s about the slope line: 17 % of the block's kinetic energy in one step.
        if (c.mode != ContactMode::open && g > 1e-12 * model.radius && c.gap_offset < 0.0 && g < last_shift[i]) {
          const double shift = std::min(g, -c.gap_offset);
          c.gap_offset += shift;
          w.g0 -= shift;
          last_shift[i] = shift;
          shifted = true;
        }
        if (c.mode == ContactMode::locked) {
          shifted = cap_at_friction(c, w, g, 2.0) || shifted;
        } else if (held[i] == 1 && c.mode == ContactMode::sliding && g < 0.0) {
          const Vec3 du = w.t * d;
          if ((du - c.normal * c.normal.dot(du)).dot(c.slip_direction) < 0.0) {
            c.mode = ContactMode::locked;
            c.anchored = true;
            w.s0 = restick_stretch(c, g) * c.slip_direction;
            c.body_anchor = pose.inverse_map * (c.point - pose.centre);
            c.ground_anchor = c.point - c.gap * c.normal - w.s0;
            w.ta = w.t;
            held[i] = 2;
            changed = true;
          }
        }
        continue;
      }
      // The state the solution asks for, and the slip direction or re-stick it implies.
      ContactMode next = c.mode;
      Vec3 slip = c.slip_direction;
      bool restick = false;
      if (c.mode == ContactMode::open) {
        // Without friction a closed contact only slides: no shear spring at all.
        if (g < 0.0 && !(friction > 0.0)) {
          next = ContactMode::sliding;
          const Vec3 du = w.t * d;
          const Vec3 ut = du - c.normal * c.normal.dot(du);
          if (c.slip_direction.squaredNorm() == 0.0 && ut.norm() > 0.0) slip = ut.normalized();
        } else if (g < 0.0) {
          // A contact that slid before it opened resumes sliding only while its point
          // still moves along the remembered slip: a stale direction (a rolling block's
          // vertex landing again) would turn the Coulomb force against the motion.
          const Vec3 du = w.t * d;
          const Vec3 ut = du - c.normal * c.normal.dot(du);
          next = c.resume == ContactMode::sliding && ut.dot(c.slip_direction) > 0.0 ? ContactMode::sliding
                                                                                    : ContactMode::locked;
        }
      } else if (g >= 0.0) {
        next = ContactMode::open;
      } else if (c.mode == ContactMode::locked) {
        const Vec3 sv = w.s0 + w.ta * d;
        const Vec3 st = sv - c.normal * c.normal.dot(sv);
        const double fs = ps * st.norm();
        if (w.at_limit) {
          // At the limit while its anchored point moves on along the stretch; moved back
          // (or no longer stretched past the limit), it unloads: an elastic spring again.
          // Its force follows the stretch's direction (a radial return): the solution is
          // redone until the direction holds, and only then may a larger slip slide.
          const Vec3 da = w.ta * d;
          if ((da - c.normal * c.normal.dot(da)).dot(w.limit_direction) < 0.0 || !(fs > friction * (-p * g))) {
            w.at_limit = false;
            w.unloaded = true;
            shifted = true;
            continue;
          }
          const Vec3 direction = st.normalized();
          if (direction.dot(w.limit_direction) < 1.0 - 1e-9) {
            set_limit(w, st, g);
            shifted = true;
            continue;
          }
        }
        if (fs > friction * (-p * g) * (1.0 + 1e-12) && st.norm() > 0.0) {
          // A slip within the shear spring's elastic range (μ·F_n/k_s) leaves the contact
          // locked at its friction limit (a return mapping, as in elastoplastic
          // friction): a sticking contact at its limit -- the uphill edge of a block
          // resting on a slope -- stays locked instead of alternating between sliding
          // and re-sticking each step, which made a resting block creep. A larger slip
          // slides, with the Coulomb force implicit and opposite the motion.
          const Vec3 du = w.t * d;
          const double slipped = (du - c.normal * c.normal.dot(du)).norm();
          if (slipped <= friction * (-p * g) / ps) {
            // The spring is replaced by the Coulomb force along the stretch and the step
            // solved again: the exact return mapping. Moving the anchor to the limit of
            // each solution instead converged by a factor Σk_s / (2m/Δt² + Σk_s), 0.997 for
            // four springs of a 1 m³ cube at 1 ms, and the iteration's bound stopped it
            // at a few percent of the displacement: a cube whose contacts were all at
            // their limit on a plane 0.5 % steeper than its friction angle did not slide.
            // A contact that unloaded in this step has its anchor moved instead, as
            // before (bounded: it cannot cycle between the two). So has every contact on
            // the 12-DOF path: there the Coulomb force let a cube whose friction angle
            // exceeds the slope by 0.05° slide off at 2.5 mm/s (its strain mode keeps
            // vibrating), while with anchors moved it stays.
            if (N == 12 || w.unloaded) {
              shifted = cap_at_friction(c, w, g, 1.0) || shifted;
            } else if (!w.at_limit) {
              w.at_limit = true;
              set_limit(w, st, g);
              shifted = true;
            }
            continue;
          }
          next = ContactMode::sliding;
          slip = st.normalized();
        }
      } else {
        const Vec3 du = w.t * d;
        const Vec3 dt_slip = du - c.normal * c.normal.dot(du);
        if (dt_slip.dot(c.slip_direction) < 0.0) {
          next = ContactMode::locked;
          restick = true;
        }
      }
      if (next == c.mode) continue;
      const bool revisit = (visited[i] & bit(next)) != 0;
      if (revisit || iter >= free_iterations) held[i] = 1;
      if (revisit) {
        const bool touched_open = ((visited[i] | bit(next)) & bit(ContactMode::open)) != 0;
        if (!touched_open) {
          // Cycling between sticking and slipping: the contact is at the friction limit.
          // It is held locked with its anchor moved so that the shear spring carries
          // exactly μ·F_n along the stretch of this solution (a return mapping): a
          // sticking block that just stopped keeps its load shared, without more slip.
          if (c.mode == ContactMode::locked) {
            w.at_limit = false;
            shifted = cap_at_friction(c, w, g, 1.0) || shifted;
            continue;
          }
          next = ContactMode::locked;  // the re-stick below pre-stretches it to the limit
          if (!(friction > 0.0)) continue;  // nothing to stick with: it keeps sliding
        } else {
          // Cycling between open and closed: the contact carries almost no load (a closed
          // state in tension against an open one that penetrates). A contact compressed at
          // the step start is held closed and sliding along its tangential motion in this
          // solution, so it bears the bounded Coulomb force; locked only if it does not
          // move tangentially at all.
          // A contact that starts the step with a gap is held open instead: closed, its
          // spring would pull with the whole gap as tension. So is a contact that was open
          // at the step start if its open state penetrates less than its closed state
          // pulls, and by no more than `shallow`: a rolling block's vertex landing again at
          // zero gap sank 1.5e-5 m open but pulled at 6e-5 m of tension (7e7 N) held
          // closed, and the block lost most of its spin in one step. (A held-open
          // penetration becomes the next step's accepted offset, so deeper ones would let
          // a soft-contact block sink step by step.)
          if (w.g0 > 0.0 || (first_open[i] && open_depth[i] < closed_tension[i] && open_depth[i] <= shallow)) {
            if (c.mode == ContactMode::open) continue;
            next = ContactMode::open;
            restick = false;
            visited[i] |= bit(next);
            changed = true;
            c.resume = c.mode;
            c.mode = next;
            w.at_limit = false;
            continue;
          }
          const Vec3 du = w.t * d;
          const Vec3 tangential = du - c.normal * c.normal.dot(du);
          if (c.mode == ContactMode::sliding) {
            // It stays sliding, against its motion in this solution.
            if (tangential.norm() > 0.0 && c.slip_direction.dot(tangential.normalized()) < 1.0 - 1e-9) {
              c.slip_direction = tangential.normalized();
              changed = true;
            }
            continue;
          }
          if (tangential.norm() > 0.0) {
            next = ContactMode::sliding;
            slip = tangential.normalized();
          } else if (c.mode == ContactMode::locked) {
            continue;
          } else {
            next = ContactMode::locked;
          }
          restick = false;
        }
      }
      visited[i] |= bit(next);
      changed = true;
      if (next == ContactMode::sliding && (c.mode != ContactMode::sliding || c.slip_direction.squaredNorm() == 0.0))
        c.slip_direction = slip;
      if (next == ContactMode::open) c.resume = c.mode;
      if (restick) {
        // The friction would reverse the slip: the contact sticks. Its shear spring
        // starts stretched to the friction force it carried, so the force is
        // continuous; a zero-stretch anchor would let the load jump to the other
        // contacts and make the block ratchet down a slope it should stick to.
        c.anchored = true;
        w.s0 = restick_stretch(c, g) * c.slip_direction;
        c.body_anchor = pose.inverse_map * (c.point - pose.centre);
        c.ground_anchor = c.point - c.gap * c.normal - w.s0;
        w.ta = w.t;
      }
      c.mode = next;
      w.at_limit = false;
    }
    // Anchor moves of held contacts converge geometrically; the last iteration accepts
    // what is left of them.
    if (!changed && (!shifted || iter + 1 >= max_iter)) {
      if (!complemented) {
        complemented = true;
        complement();
      }
      settled = drop_pushing_friction();
      if (!settled) return accept();
    }
  }
  return out;
}

// Carries modes and anchors of contacts that persist from the previous step: the same
// kind and features, or -- for a block vertex -- a coplanar neighbour triangle of the one
// it was on (a vertex sliding across a flat grid keeps its state). An anchor never holds
// more shear stretch than the friction force the contact last carried allows
// (μ·F_n/k_s): an anchor left behind while the contact was open or slid on would
// otherwise pull the block back with a spring force friction cannot have stored, which
// both creates energy and makes the contact flip open and closed without end.
//
// An edge–edge pair that was not in contact in the previous step and is found already
// deeper than `fresh_depth` (the search distance: how far features can approach in one
// step) is dropped: a real crossing is found while it approaches, and the normal e₁ × e₂
// of a pair found deep inside says nothing about the way out.
//
// `matched`, when given, receives per contact of `now` whether it carries a previous one;
// the return value is whether every previous contact is carried by one of `now`.
inline bool carry_contacts(const std::vector<Contact>& previous, std::vector<Contact>& now, const Pose& pose,
                    double friction, double shear_stiffness, double fresh_depth, double radius,
                    std::vector<std::uint8_t>* matched = nullptr) {
  // The previous contacts of the same kind and block feature as c, in their order: all
  // of them for a few contacts, or a range of them sorted by (kind, block feature, order)
  // for many (a detailed block carries hundreds; the pairwise scan was quadratic).
  const auto key = [](const Contact& c) {
    return (static_cast<std::uint64_t>(c.kind) << 32) | static_cast<std::uint32_t>(c.block_feature);
  };
  thread_local std::vector<std::pair<std::uint64_t, std::int32_t>> keyed;
  const bool sorted = previous.size() * now.size() > 256;
  if (sorted) {
    keyed.clear();
    for (std::size_t i = 0; i < previous.size(); ++i) keyed.emplace_back(key(previous[i]), static_cast<std::int32_t>(i));
    std::sort(keyed.begin(), keyed.end());
  }
  const auto for_same = [&](const Contact& c, const auto& visit) {
    if (!sorted) {
      for (const Contact& old : previous)
        if (old.kind == c.kind && old.block_feature == c.block_feature && !visit(old)) return;
      return;
    }
    const std::uint64_t k = key(c);
    for (auto it = std::lower_bound(keyed.begin(), keyed.end(), std::make_pair(k, std::int32_t{-1}));
         it != keyed.end() && it->first == k; ++it)
      if (!visit(previous[static_cast<std::size_t>(it->second)])) return;
  };
  std::erase_if(now, [&](const Contact& c) {
    if (c.kind != ContactKind::edge_edge || c.gap >= -fresh_depth) return false;
    bool carried = false;
    for_same(c, [&](const Contact& old) {
      carried = old.terrain_feature == c.terrain_feature;
      return !carried;
    });
    return !carried;
  });
  if (matched != nullptr) matched->assign(now.size(), 0);
  thread_local std::vector<std::uint8_t> used;
  used.assign(previous.size(), 0);
  for (std::size_t i = 0; i < now.size(); ++i) {
    Contact& c = now[i];
    c.gap_offset = std::min(c.gap, 0.0);
    const Contact* match = nullptr;
    for_same(c, [&](const Contact& old) {
      if (old.terrain_feature == c.terrain_feature) {
        match = &old;
        return false;
      }
      if (c.kind == ContactKind::vertex_face && old.normal.dot(c.normal) > 1.0 - 1e-12) match = &old;
      return true;
    });
    if (match == nullptr) continue;
    if (matched != nullptr) (*matched)[i] = 1;
    used[static_cast<std::size_t>(match - previous.data())] = 1;
    const Contact& old = *match;
    c.mode = old.mode;
    c.resume = old.resume;
    c.anchored = old.anchored;
    c.body_anchor = old.body_anchor;
    c.ground_anchor = old.ground_anchor;
    c.slip_direction = old.slip_direction;
    c.normal_force = old.normal_force;
    c.anchor_force = old.anchor_force;
    // The springs resume where the last solve left them: the exact rotation of the
    // geometry update puts a rotating block's points up to |θ|²·r/2 deeper than the
    // linearised step predicted, and a spring compressed by that extra depth would push
    // it out with energy no force stored. So the compression never exceeds the predicted
    // one, and the accepted penetration follows the block out, never in.
    double offset = old.gap_offset;
    const double extra = old.spring_gap - (c.gap - offset);
    if (extra > 1e-3 * -old.spring_gap && extra > 1e-9 * radius) offset = c.gap - old.spring_gap;
    c.gap_offset = c.gap > offset ? std::min(0.0, c.gap) : offset;
    if (c.anchored) {
      const Vec3 xa = pose.centre + pose.map * c.body_anchor;
      const Vec3 s_raw = xa - c.ground_anchor;
      const Vec3 st = s_raw - c.normal * c.normal.dot(s_raw);
      const double allowed = std::min(friction * c.anchor_force, old.spring_shear) / shear_stiffness;
      const double stretch = st.norm();
      if (stretch > allowed) c.ground_anchor += st * (1.0 - allowed / stretch);
    }
  }
  return std::all_of(used.begin(), used.end(), [](std::uint8_t u) { return u != 0; });
}

// A contact closed through a whole step, at its end: the point (world, m), the unit
// normal, and for a contact that ends the step locked the tangential impulse friction can
// give it over the step (μ·F_n·Δt, N·s; zero if it slides).
struct Persistent {
  Vec3 point;
  Vec3 normal;
  double friction_impulse = 0.0;
};

// Contacts that stay closed through a step have no normal relative velocity in the
// physics: a penalty spring at Ω = √(k/m)·Δt ≫ 1 keeps a barely damped vibration instead,
// which rocks a resting block and turns its friction forces from side to side until it
// creeps down a slope it should stick to. Outside impacts the approaching normal velocity
// of such contacts is therefore removed by non-negative impulses at the contact points
// (projected Gauss–Seidel on the block's mass metric): each impulse only removes kinetic
// energy, and a contact that separates is left to separate. A contact that ends the step
// locked (sticking) has no tangential relative velocity either, yet Shi's velocity update
// v₁ = 2d/Δt − v₀ keeps a velocity that flips sign each step while the displacement
// stays zero (a yaw of ±4e-4 rad/s on a resting cube): its tangential velocity is removed
// too, by impulses each within μ·F_n·Δt/√2 per tangent (inside the Coulomb cone), so a
// sticking contact never holds more than friction could.
template <int N>
void settle_contacts(const Model& model, State& s, const std::vector<Persistent>& persistent) {
  if (persistent.empty()) return;
  const MatN<N> m = current_mass<N>(model, pose_of(model, s));
  const SymmetricSolver<N> llt(m);
  thread_local std::vector<VecN<N>> g, minv_g;
  thread_local std::vector<double> weight, root_weight, impulse, lower, upper;
  g.clear();
  lower.clear();
  upper.clear();
  auto add_row = [&](const Vec3& point, const Vec3& direction, double lo, double hi) {
    g.push_back(dof_matrix<N>(point - s.position).transpose() * direction);
    lower.push_back(lo);
    upper.push_back(hi);
  };
  for (const Persistent& c : persistent) {
    add_row(c.point, c.normal, 0.0, std::numeric_limits<double>::infinity());
    if (!(c.friction_impulse > 0.0)) continue;
    const Vec3 t1 = c.normal.unitOrthogonal();
    const Vec3 t2 = c.normal.cross(t1);
    const double bound = c.friction_impulse / std::sqrt(2.0);
    add_row(c.point, t1, -bound, bound);
    add_row(c.point, t2, -bound, bound);
  }
  const std::size_t n = g.size();
  minv_g.resize(n);
  weight.assign(n, 0.0);
  root_weight.assign(n, 0.0);
  impulse.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    minv_g[i] = llt.solve(g[i]);
    weight[i] = g[i].dot(minv_g[i]);
    if (weight[i] > 0.0) root_weight[i] = std::sqrt(weight[i]);
  }
  VecN<N> v = s.velocity.template head<N>();
  // A sweep that leaves the velocity as it found it (to 1e-9 of it in the mass metric,
  // or 1e-12 m/s) ends the iteration too: the impulses of redundant rows, such as the
  // four corners of a face on the ground, can keep trading among themselves while the
  // velocity they leave, which is all this settles, no longer changes.
  const double still = 1e-18 * v.dot(m * v) + 1e-24 * model.mass;
  for (int sweep = 0; sweep < 16; ++sweep) {
    const VecN<N> v_start = v;
    double largest = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!(weight[i] > 0.0)) continue;
      const double next = std::clamp(impulse[i] - g[i].dot(v) / weight[i], lower[i], upper[i]);
      const double change = next - impulse[i];
      v += change * minv_g[i];
      impulse[i] = next;
      largest = std::max(largest, std::abs(change) * root_weight[i]);
    }
    if (largest <= 1e-12 * (1.0 + v.norm())) break;
    const VecN<N> change = v - v_start;
    if (change.dot(m * change) <= still) break;
  }
  s.velocity.template head<N>() = v;
}

}  // namespace talus::dda::detail
