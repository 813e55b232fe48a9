// SPDX-License-Identifier: MIT
#include "contact_law.hpp"
#include "rotation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace talus::dda::detail {

namespace {

// Per-contact terms of one step, computed once and reused by the open–close iterations.
template <int N>
struct Work {
  Eigen::Matrix<double, 3, N> t;        // T(r) at the contact point
  VecN<N> gn;                           // Tᵀn: the gap's gradient
  Eigen::Matrix<double, 3, N> ta;       // T(r) at the shear anchor
  Vec3 s0;                              // shear spring stretch at the step start
  double g0 = 0.0;                      // gap − offset at the step start
  double mu = 1.0;                      // share of the friction coefficient a sliding contact gets
  // At its friction limit a locked contact's shear spring is replaced by the implicit
  // Coulomb force against `limit_direction` (the exact return mapping); `unloaded`: it
  // moved back, elastic again.
  bool at_limit = false;
  bool unloaded = false;
  Vec3 limit_direction = Vec3::Zero();
  // The direction follows the stretch (a radial return): linearised about the solution
  // `limit_at` it was taken from, the force turns with the stretch at a stiffness
  // `limit_turn` = μ·F_n/|stretch| (N/m) across it.
  double limit_turn = 0.0;
  VecN<N> limit_at = VecN<N>::Zero();
};

// A member's held state in the complementarity pass: its mode and what goes with it.
struct HeldState {
  ContactMode mode;
  ContactMode resume;
  Vec3 slip_direction;
};

// The buffers of one solve, kept from step to step to avoid allocations (their contents
// never outlive a call).
template <int N>
struct Buffers {
  std::vector<Work<N>> work;
  std::vector<std::uint8_t> visited, held, first_open;
  std::vector<double> open_depth, closed_tension, last_shift;
  std::vector<std::size_t> members;
  std::vector<HeldState> member_start;
  std::vector<Vec3> member_slip;
};

std::uint8_t bit(ContactMode m) { return static_cast<std::uint8_t>(1u << static_cast<unsigned>(m)); }

// The mode a contact's re-judgement asks for, with the slip direction or re-stick it implies.
struct Transition {
  ContactMode next;
  Vec3 slip;
  bool restick = false;
};

// Whether judging the contacts changed a mode, or moved an anchor or a spring zero (the
// solution must then be redone).
struct Judged {
  bool changed = false;
  bool shifted = false;
};

// One step's contact law. A contact whose re-judgement would revisit a mode, or that
// changes after max_open_close_iterations, is held: the iteration always ends (docs/dda.md,
// The open–close iteration).
template <int N>
class ContactLaw {
 public:
  ContactLaw(const Model& model, const Pose& pose, const State& s, double dt, double friction,
             std::vector<Contact>& contacts, VecN<N>& d, PhaseTimes& times, bool freeze_strain, bool impact_phase)
      : model_(model), set_(model.settings), pose_(pose), s_(s), dt_(dt), friction_(friction), contacts_(contacts),
        d_(d), times_(times), timing_(model.settings.time_phases), freeze_strain_(freeze_strain),
        impact_phase_(impact_phase), p_(model.stiffness), ps_(p_ / model.settings.shear_stiffness_ratio),
        b_(buffers()), work_(b_.work) {}

  StepOutcome solve();

 private:
  static Buffers<N>& buffers() {
    thread_local Buffers<N> b;
    return b;
  }
  void assemble();
  void trial_slip();
  void start_iteration();
  void solve_modes(VecN<N>& x);
  void judge(std::size_t i, int iter, Judged& j);
  void judge_held(Contact& c, Work<N>& w, std::size_t i, double g, Judged& j);
  bool propose(Contact& c, Work<N>& w, double g, Transition& t, Judged& j);
  bool resolve_cycle(Contact& c, Work<N>& w, std::size_t i, double g, Transition& t, Judged& j);
  void change_mode(Contact& c, Work<N>& w, std::size_t i, double g, const Transition& t, Judged& j);
  void restick(Contact& c, Work<N>& w, double g);
  bool cap_at_friction(Contact& c, Work<N>& w, double g, double slack);
  void set_limit(Work<N>& w, const Vec3& st, double g);
  bool drop_pushing_friction();
  double violation(const VecN<N>& x) const;
  bool complement();
  void set_member_modes(unsigned code);
  void restore_member(std::size_t k);
  StepOutcome accept();

  const Model& model_;
  const Settings& set_;
  const Pose& pose_;
  const State& s_;
  const double dt_;
  const double friction_;
  std::vector<Contact>& contacts_;
  VecN<N>& d_;
  PhaseTimes& times_;
  const bool timing_;
  const bool freeze_strain_;
  const bool impact_phase_;
  const double p_;   // normal spring (N/m)
  const double ps_;  // shear spring (N/m)
  Buffers<N>& b_;
  std::vector<Work<N>>& work_;
  MatN<N> k0_;  // the step's matrix without contacts
  VecN<N> f0_;  // and its right-hand side
  int free_iterations_ = 0;
  StepOutcome out_;
};

// Inertia (2M/Δt²), the velocity and gravity terms, the 12-DOF elasticity, and each
// contact's terms at the step start.
template <int N>
void ContactLaw<N>::assemble() {
  PhaseTimer timer(timing_, times_.assemble);
  const MatN<N> m = current_mass<N>(model_, pose_);
  const VecN<N> v0 = s_.velocity.template head<N>();
  k0_ = (2.0 / (dt_ * dt_)) * m;
  f0_ = (2.0 / dt_) * (m * v0);
  f0_.template head<3>() += model_.mass * gravity_vector(model_);
  if (!model_.isotropic) {
    // Euler's equations: the inertial prediction is the torque-free rotation, not ω₀·Δt
    // (the gyroscopic term), so a step with no contact closed turns exactly as flight.
    const FreeSpin free = free_spin(model_, s_.orientation, v0.template segment<3>(3), dt_);
    f0_.template segment<3>(3) += (2.0 / (dt_ * dt_)) * (m.template block<3, 3>(3, 3) *
                                                          (free.theta - dt_ * v0.template segment<3>(3)));
  }
  if constexpr (N == 12) {
    // Accumulated strain (body frame, from the stretch U) acts as an initial stress.
    const Mat3 e_body = 0.5 * (s_.stretch + s_.stretch.transpose()) - Mat3::Identity();
    const Mat3 e_world = pose_.rotation * e_body * pose_.rotation.transpose();
    const Eigen::Matrix<double, 6, 1> sigma = model_.elasticity * voigt(e_world);
    k0_.template bottomRightCorner<6, 6>() += model_.volume * model_.elasticity;
    f0_.template tail<6>() -= model_.volume * sigma;
  }
  work_.resize(contacts_.size());
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    Contact& c = contacts_[i];
    Work<N>& w = work_[i];
    w.t = dof_matrix<N>(c.point - pose_.centre);
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
      const Vec3 xa = pose_.centre + pose_.map * c.body_anchor;
      w.ta = dof_matrix<N>(xa - pose_.centre);
      const Vec3 s_raw = xa - c.ground_anchor;
      w.s0 = s_raw - c.normal * c.normal.dot(s_raw);
    }
  }
}

// Friction of a contact sliding into the step opposes the trial slip (the frictionless
// solution), the implicit direction; the last step's lags and let a slowly sliding cube
// sway and creep.
template <int N>
void ContactLaw<N>::trial_slip() {
  if (!(N == 6 && friction_ > 0.0 && std::any_of(contacts_.begin(), contacts_.end(), [](const Contact& c) {
          return c.mode == ContactMode::sliding;
        })))
    return;
  PhaseTimer timer(timing_, times_.open_close);
  MatN<N> k = k0_;
  VecN<N> f = f0_;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Contact& c = contacts_[i];
    const Work<N>& w = work_[i];
    if (c.mode == ContactMode::open) continue;
    k.noalias() += p_ * w.gn * w.gn.transpose();
    f -= p_ * w.g0 * w.gn;
    if (c.mode != ContactMode::locked) continue;
    const Eigen::Matrix<double, 3, N>& ta = c.anchored ? w.ta : w.t;
    const VecN<N> gt = ta.transpose() * c.normal;
    k.noalias() += ps_ * (gram<N>(ta) - gt * gt.transpose());
    if (c.anchored) f -= ps_ * (ta.transpose() * w.s0);
  }
  const VecN<N> trial = SymmetricSolver<N>(k).solve(f);
  if (!trial.allFinite()) return;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    Contact& c = contacts_[i];
    if (c.mode != ContactMode::sliding) continue;
    const Vec3 du = work_[i].t * trial;
    const Vec3 ut = du - c.normal * c.normal.dot(du);
    if (ut.norm() > 0.0) c.slip_direction = ut.normalized();
  }
}

// Per contact: the modes visited, whether held, its open penetration and closed tension
// (which violates less decides how a cycling contact is held), its spring zero's last move.
template <int N>
void ContactLaw<N>::start_iteration() {
  const std::size_t n = contacts_.size();
  b_.visited.assign(n, 0);
  b_.held.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) b_.visited[i] = bit(contacts_[i].mode);
  b_.open_depth.assign(n, std::numeric_limits<double>::infinity());
  b_.closed_tension.assign(n, 0.0);
  b_.first_open.clear();
  for (const Contact& c : contacts_) b_.first_open.push_back(c.mode == ContactMode::open ? 1 : 0);
  b_.last_shift.clear();
  for (const Contact& c : contacts_)
    b_.last_shift.push_back(c.gap - c.gap_offset == 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  free_iterations_ = static_cast<int>(set_.max_open_close_iterations);
}

// Assembles the step's system for the contacts' current modes and solves it into x.
template <int N>
void ContactLaw<N>::solve_modes(VecN<N>& x) {
  MatN<N> k = k0_;
  VecN<N> f = f0_;
  bool unsymmetric = false;  // a contact slides or is at its friction limit
  {
    PhaseTimer timer(timing_, times_.open_close);
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
      Contact& c = contacts_[i];
      Work<N>& w = work_[i];
      if (c.mode == ContactMode::open) continue;
      k.noalias() += p_ * w.gn * w.gn.transpose();
      f -= p_ * w.g0 * w.gn;
      if (c.mode == ContactMode::locked) {
        if (!c.anchored) {
          // A contact closing now is anchored where it touches at the step start.
          c.anchored = true;
          c.body_anchor = pose_.inverse_map * (c.point - pose_.centre);
          c.ground_anchor = c.point - c.gap * c.normal;
          w.ta = w.t;
          w.s0.setZero();
        }
        if (w.at_limit) {
          // At the friction limit: the Coulomb force μ·F_n against the stretch, at the
          // anchored point, with F_n implicit in d, and its turn with the stretch.
          const VecN<N> ts = w.ta.transpose() * w.limit_direction;
          k.noalias() -= friction_ * p_ * ts * w.gn.transpose();
          f += friction_ * p_ * w.g0 * ts;
          const Mat3 across =
              Mat3::Identity() - c.normal * c.normal.transpose() - w.limit_direction * w.limit_direction.transpose();
          const Eigen::Matrix<double, 3, N> turn = across * w.ta;
          const MatN<N> kt = w.limit_turn * (turn.transpose() * turn);
          k.noalias() += kt;
          f.noalias() += kt * w.limit_at;
          unsymmetric = true;
          continue;
        }
        // ps·(P T)ᵀ(P T) with P = I − nnᵀ equals ps·(TᵀT − (Tᵀn)(Tᵀn)ᵀ).
        const VecN<N> gt = w.ta.transpose() * c.normal;
        k.noalias() += ps_ * (gram<N>(w.ta) - gt * gt.transpose());
        f -= ps_ * (w.ta.transpose() * w.s0);
      } else {
        // Sliding: Coulomb force μ·F_n against the slip, with F_n implicit in d so the
        // friction matches the normal force of this very step.
        const VecN<N> ts = w.t.transpose() * c.slip_direction;
        k.noalias() -= w.mu * friction_ * p_ * ts * w.gn.transpose();
        f += w.mu * friction_ * p_ * w.g0 * ts;
        unsymmetric = true;
      }
    }
  }
  PhaseTimer timer(timing_, times_.solve);
  // Symmetric positive definite unless a contact slides or is at its friction limit
  // (implicit friction).
  if constexpr (N == 12) {
    if (freeze_strain_) {
      // Strain increments held at zero: the rigid block of the system.
      const Mat6 k6 = k.template topLeftCorner<6, 6>();
      const Eigen::Matrix<double, 6, 1> f6 = f.template head<6>();
      x.setZero();
      if (unsymmetric) x.template head<6>() = PivotedLu6(k6).solve(f6);
      else x.template head<6>() = Cholesky6(k6).solve(f6);
      return;
    }
  }
  if (unsymmetric) x = GeneralSolver<N>(k).solve(f);
  else x = SymmetricSolver<N>(k).solve(f);
}

// Return mapping: moves a locked contact's anchor so that its shear spring carries at
// most μ·F_n of this solution (F_n = −p·g, nothing in tension) once it carries more
// than `slack` times that. True if it moved.
template <int N>
bool ContactLaw<N>::cap_at_friction(Contact& c, Work<N>& w, double g, double slack) {
  const Vec3 sv = w.s0 + w.ta * d_;
  const Vec3 st = sv - c.normal * c.normal.dot(sv);
  const double limit = friction_ * std::max(0.0, -p_ * g) / ps_;
  const double stretch = st.norm();
  if (stretch <= slack * limit * (1.0 + 1e-9) + 1e-15 * model_.radius) return false;
  const Vec3 shift = st * (limit / stretch - 1.0);
  w.s0 += shift;
  c.ground_anchor -= shift;
  return true;
}

// A contact at its friction limit takes the direction of its stretch `st` in this
// solution, and is linearised about it.
template <int N>
void ContactLaw<N>::set_limit(Work<N>& w, const Vec3& st, double g) {
  w.limit_direction = st.normalized();
  w.limit_turn = friction_ * std::max(0.0, -p_ * g) / st.norm();
  w.limit_at = d_;
}

// A re-sticking contact's spring starts stretched to the friction force it carried (never
// more than its last normal force allows), so the load does not jump; under an impact,
// unstretched.
template <int N>
void ContactLaw<N>::restick(Contact& c, Work<N>& w, double g) {
  const double stretch = impact_phase_ ? 0.0 : friction_ * std::min(-p_ * g, c.normal_force) / ps_;
  c.anchored = true;
  w.s0 = stretch * c.slip_direction;
  c.body_anchor = pose_.inverse_map * (c.point - pose_.centre);
  c.ground_anchor = c.point - c.gap * c.normal - w.s0;
  w.ta = w.t;
}

// A held contact keeps its mode but no force friction cannot carry, and a closed one that
// started with a gap and ends in tension opens: it would pull the block in along its whole
// approach.
template <int N>
void ContactLaw<N>::judge_held(Contact& c, Work<N>& w, std::size_t i, double g, Judged& j) {
  if (c.mode != ContactMode::open && w.g0 > 0.0 && g > 0.0) {
    c.resume = c.mode;
    c.mode = ContactMode::open;
    j.changed = true;
    return;
  }
  // A held contact that started unloaded at its offset and ends in tension has its spring's
  // zero moved to its end point (never above the surface), and only while its tension
  // shrinks.
  if (c.mode != ContactMode::open && g > 1e-12 * model_.radius && c.gap_offset < 0.0 && g < b_.last_shift[i]) {
    const double shift = std::min(g, -c.gap_offset);
    c.gap_offset += shift;
    w.g0 -= shift;
    b_.last_shift[i] = shift;
    j.shifted = true;
  }
  if (c.mode == ContactMode::locked) {
    j.shifted = cap_at_friction(c, w, g, 2.0) || j.shifted;
  } else if (b_.held[i] == 1 && c.mode == ContactMode::sliding && g < 0.0) {
    const Vec3 du = w.t * d_;
    if ((du - c.normal * c.normal.dot(du)).dot(c.slip_direction) < 0.0) {
      c.mode = ContactMode::locked;
      restick(c, w, g);
      b_.held[i] = 2;
      j.changed = true;
    }
  }
}

// The state the solution asks for (into t), and the slip direction or re-stick it
// implies. False when the contact is settled for this iteration without a mode change
// (an anchor moved or a limit set instead, recorded in j).
template <int N>
bool ContactLaw<N>::propose(Contact& c, Work<N>& w, double g, Transition& t, Judged& j) {
  if (c.mode == ContactMode::open) {
    // Without friction a closed contact only slides: no shear spring at all.
    if (g < 0.0 && !(friction_ > 0.0)) {
      t.next = ContactMode::sliding;
      const Vec3 du = w.t * d_;
      const Vec3 ut = du - c.normal * c.normal.dot(du);
      if (c.slip_direction.squaredNorm() == 0.0 && ut.norm() > 0.0) t.slip = ut.normalized();
    } else if (g < 0.0) {
      // A contact that slid before it opened resumes sliding only while its point still
      // moves along the remembered slip: a stale direction (a rolling block's vertex
      // landing again) would turn the Coulomb force against the motion.
      const Vec3 du = w.t * d_;
      const Vec3 ut = du - c.normal * c.normal.dot(du);
      t.next = c.resume == ContactMode::sliding && ut.dot(c.slip_direction) > 0.0 ? ContactMode::sliding
                                                                                  : ContactMode::locked;
    }
    return true;
  }
  if (g >= 0.0) {
    t.next = ContactMode::open;
    return true;
  }
  if (c.mode == ContactMode::sliding) {
    const Vec3 du = w.t * d_;
    const Vec3 dt_slip = du - c.normal * c.normal.dot(du);
    if (dt_slip.dot(c.slip_direction) < 0.0) {
      t.next = ContactMode::locked;
      t.restick = true;
    }
    return true;
  }
  // Locked.
  const Vec3 sv = w.s0 + w.ta * d_;
  const Vec3 st = sv - c.normal * c.normal.dot(sv);
  const double fs = ps_ * st.norm();
  if (w.at_limit) {
    // At the limit while its point moves on along the stretch; moved back or no longer past
    // the limit, it unloads. The force follows the stretch's direction until that holds (a
    // radial return).
    const Vec3 da = w.ta * d_;
    if ((da - c.normal * c.normal.dot(da)).dot(w.limit_direction) < 0.0 || !(fs > friction_ * (-p_ * g))) {
      w.at_limit = false;
      w.unloaded = true;
      j.shifted = true;
      return false;
    }
    const Vec3 direction = st.normalized();
    if (direction.dot(w.limit_direction) < 1.0 - 1e-9) {
      set_limit(w, st, g);
      j.shifted = true;
      return false;
    }
  }
  if (fs > friction_ * (-p_ * g) * (1.0 + 1e-12) && st.norm() > 0.0) {
    // A slip within the spring's elastic range (μ·F_n/k_s) leaves the contact locked at its
    // limit (elastoplastic friction), so a block resting at its limit does not creep; a
    // larger slip slides.
    const Vec3 du = w.t * d_;
    const double slipped = (du - c.normal * c.normal.dot(du)).norm();
    if (slipped <= friction_ * (-p_ * g) / ps_) {
      // The implicit Coulomb force replaces the spring (exact return mapping; moving the
      // anchor each iteration converged too slowly to let a cube slide). The 12-DOF path
      // and unloaded contacts move anchors.
      if (N == 12 || w.unloaded) {
        j.shifted = cap_at_friction(c, w, g, 1.0) || j.shifted;
      } else if (!w.at_limit) {
        w.at_limit = true;
        set_limit(w, st, g);
        j.shifted = true;
      }
      return false;
    }
    t.next = ContactMode::sliding;
    t.slip = st.normalized();
  }
  return true;
}

// A contact whose proposed mode is one it already had in this step. False when it is
// settled for this iteration (held, or its anchor moved) without the change of t.
template <int N>
bool ContactLaw<N>::resolve_cycle(Contact& c, Work<N>& w, std::size_t i, double g, Transition& t, Judged& j) {
  const bool touched_open = ((b_.visited[i] | bit(t.next)) & bit(ContactMode::open)) != 0;
  if (!touched_open) {
    // Cycling between sticking and slipping: held locked with its anchor moved so its
    // spring carries exactly μ·F_n (a return mapping): the load stays shared, without more
    // slip.
    if (c.mode == ContactMode::locked) {
      w.at_limit = false;
      j.shifted = cap_at_friction(c, w, g, 1.0) || j.shifted;
      return false;
    }
    t.next = ContactMode::locked;  // the re-stick pre-stretches it to the limit
    return friction_ > 0.0;        // nothing to stick with: it keeps sliding
  }
  // Cycling between open and closed: held open if it started with a gap, or if open it
  // penetrates less (and by at most `shallow`) than closed it pulls; otherwise held closed
  // and sliding.
  const double shallow = 1e-3 * model_.penetration_limit();
  if (w.g0 > 0.0 ||
      (b_.first_open[i] && b_.open_depth[i] < b_.closed_tension[i] && b_.open_depth[i] <= shallow)) {
    if (c.mode == ContactMode::open) return false;
    b_.visited[i] |= bit(ContactMode::open);
    j.changed = true;
    c.resume = c.mode;
    c.mode = ContactMode::open;
    w.at_limit = false;
    return false;
  }
  const Vec3 du = w.t * d_;
  const Vec3 tangential = du - c.normal * c.normal.dot(du);
  if (c.mode == ContactMode::sliding) {
    // It stays sliding, against its motion in this solution.
    if (tangential.norm() > 0.0 && c.slip_direction.dot(tangential.normalized()) < 1.0 - 1e-9) {
      c.slip_direction = tangential.normalized();
      j.changed = true;
    }
    return false;
  }
  if (tangential.norm() > 0.0) {
    t.next = ContactMode::sliding;
    t.slip = tangential.normalized();
  } else if (c.mode == ContactMode::locked) {
    return false;
  } else {
    t.next = ContactMode::locked;
  }
  t.restick = false;
  return true;
}

// Puts the contact in the mode t asks for.
template <int N>
void ContactLaw<N>::change_mode(Contact& c, Work<N>& w, std::size_t i, double g, const Transition& t, Judged& j) {
  b_.visited[i] |= bit(t.next);
  j.changed = true;
  if (t.next == ContactMode::sliding && (c.mode != ContactMode::sliding || c.slip_direction.squaredNorm() == 0.0))
    c.slip_direction = t.slip;
  if (t.next == ContactMode::open) c.resume = c.mode;
  // The friction would reverse the slip: the contact sticks, its shear spring stretched
  // to the friction force it carried (restick).
  if (t.restick) restick(c, w, g);
  c.mode = t.next;
  w.at_limit = false;
}

// Re-judges contact i against the solution d: open, sliding or locked.
template <int N>
void ContactLaw<N>::judge(std::size_t i, int iter, Judged& j) {
  Contact& c = contacts_[i];
  Work<N>& w = work_[i];
  const double g = w.g0 + w.gn.dot(d_);
  if (c.mode == ContactMode::open) {
    if (g < 0.0) b_.open_depth[i] = -g;
  } else {
    b_.closed_tension[i] = std::max(0.0, g);
  }
  if (b_.held[i]) {
    judge_held(c, w, i, g, j);
    return;
  }
  Transition t{c.mode, c.slip_direction, false};
  if (!propose(c, w, g, t, j) || t.next == c.mode) return;
  const bool revisit = (b_.visited[i] & bit(t.next)) != 0;
  if (revisit || iter >= free_iterations_) b_.held[i] = 1;
  if (revisit && !resolve_cycle(c, w, i, g, t, j)) return;
  change_mode(c, w, i, g, t, j);
}

// Friction never pushes along the motion: once the modes are final, a sliding contact in
// tension or moving against its friction loses it, and one at its limit unloads; solved
// again. True if any did.
template <int N>
bool ContactLaw<N>::drop_pushing_friction() {
  bool dropped = false;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Contact& c = contacts_[i];
    Work<N>& w = work_[i];
    if (c.mode == ContactMode::locked && w.at_limit) {
      const Vec3 da = w.ta * d_;
      if (w.g0 + w.gn.dot(d_) >= 0.0 || (da - c.normal * c.normal.dot(da)).dot(w.limit_direction) < 0.0) {
        w.at_limit = false;
        w.unloaded = true;
        dropped = true;
      }
      continue;
    }
    if (c.mode != ContactMode::sliding || w.mu == 0.0 || !(friction_ > 0.0)) continue;
    const Vec3 du = w.t * d_;
    if (w.g0 + w.gn.dot(d_) >= 0.0 || (du - c.normal * c.normal.dot(du)).dot(c.slip_direction) < 0.0) {
      w.mu = 0.0;
      dropped = true;
    }
  }
  return dropped;
}

// How far x violates the complementarity members' modes (m; 0 if consistent): an open
// contact does not penetrate, a closed one carries no tension, a locked one's shear force
// is within μ·F_n and a sliding one does not move against its friction.
template <int N>
double ContactLaw<N>::violation(const VecN<N>& x) const {
  const double tolerance = 1e-9 * model_.radius;
  double worst = 0.0;
  for (const std::size_t i : b_.members) {
    const Contact& c = contacts_[i];
    const Work<N>& w = work_[i];
    const double g = w.g0 + w.gn.dot(x);
    if (c.mode == ContactMode::open) {
      worst = std::max(worst, -g - tolerance);
      continue;
    }
    worst = std::max(worst, g - tolerance);
    if (!(friction_ > 0.0)) continue;
    if (c.mode == ContactMode::locked) {
      const Vec3 sv = w.s0 + w.ta * x;
      const double stretch = (sv - c.normal * c.normal.dot(sv)).norm();
      const double limit = friction_ * std::max(0.0, -p_ * g) / ps_;
      worst = std::max(worst, stretch - limit * (1.0 + 1e-9) - tolerance);
    } else {
      const Vec3 du = w.t * x;
      worst = std::max(worst, -(du - c.normal * c.normal.dot(du)).dot(c.slip_direction) - tolerance);
    }
  }
  return worst;
}

// Back to member k's held state. (An anchor a trial set for a contact closing locked
// stays: it is where the contact touches at the step start whichever combination set it,
// and the chosen solution's shear force acts on it.)
template <int N>
void ContactLaw<N>::restore_member(std::size_t k) {
  Contact& c = contacts_[b_.members[k]];
  c.mode = b_.member_start[k].mode;
  c.resume = b_.member_start[k].resume;
  c.slip_direction = b_.member_start[k].slip_direction;
}

// Combination `code` in base 3, one digit per member: 0 open, 1 sliding, 2 locked.
template <int N>
void ContactLaw<N>::set_member_modes(unsigned code) {
  for (std::size_t k = 0; k < b_.members.size(); ++k, code /= 3) {
    Contact& c = contacts_[b_.members[k]];
    const ContactMode start_mode = b_.member_start[k].mode;
    restore_member(k);
    const unsigned digit = code % 3;
    if (digit == 0) {
      c.mode = ContactMode::open;
      if (start_mode != ContactMode::open) c.resume = start_mode;
    } else if (digit == 1) {
      c.mode = ContactMode::sliding;
      if (start_mode != ContactMode::sliding) c.slip_direction = b_.member_slip[k];
    } else {
      c.mode = ContactMode::locked;
    }
  }
}

// Contacts held between open and closed get a small complementarity solution once the
// iteration settles: of the 3^m mode combinations (m ≤ 4) the first consistent one, else
// the least violating.
template <int N>
bool ContactLaw<N>::complement() {
  const std::uint8_t open_bit = bit(ContactMode::open);
  b_.members.clear();
  for (std::size_t i = 0; i < contacts_.size(); ++i)
    if (b_.held[i] && (b_.visited[i] & open_bit) && (b_.visited[i] & static_cast<std::uint8_t>(~open_bit)))
      b_.members.push_back(i);
  if (b_.members.empty() || b_.members.size() > 4) return false;
  double best = violation(d_);
  if (!(best > 0.0)) return false;
  b_.member_start.clear();
  b_.member_slip.clear();
  for (const std::size_t i : b_.members) {
    const Contact& c = contacts_[i];
    b_.member_start.push_back({c.mode, c.resume, c.slip_direction});
    const Vec3 du = work_[i].t * d_;
    const Vec3 ut = du - c.normal * c.normal.dot(du);
    b_.member_slip.push_back(ut.norm() > 0.0 ? Vec3(ut.normalized()) : c.slip_direction);
  }
  unsigned combinations = 1;
  for (std::size_t k = 0; k < b_.members.size(); ++k) combinations *= 3;
  unsigned chosen = combinations;  // the held modes
  VecN<N> x, best_x = d_;
  for (unsigned code = 0; code < combinations; ++code) {
    set_member_modes(code);
    // The held modes are solved again too: the anchor and spring-zero moves of the last
    // iteration came after d was solved. A changed member must be possible: without
    // friction a closed contact only slides, and a sliding one needs a direction.
    bool usable = true;
    for (std::size_t k = 0; k < b_.members.size(); ++k) {
      const Contact& c = contacts_[b_.members[k]];
      if (c.mode == b_.member_start[k].mode &&
          (c.mode != ContactMode::sliding || c.slip_direction == b_.member_start[k].slip_direction))
        continue;
      if (c.mode == ContactMode::locked && !(friction_ > 0.0)) usable = false;
      if (c.mode == ContactMode::sliding && friction_ > 0.0 && c.slip_direction.squaredNorm() == 0.0) usable = false;
    }
    if (!usable) continue;
    ++out_.iterations;
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
    for (std::size_t k = 0; k < b_.members.size(); ++k) restore_member(k);
    return false;
  }
  set_member_modes(chosen);
  d_ = best_x;
  return true;
}

// The converged solution: a contact at its friction limit ends the step with its anchor
// moved to the limit.
template <int N>
StepOutcome ContactLaw<N>::accept() {
  for (std::size_t i = 0; i < contacts_.size(); ++i)
    if (contacts_[i].mode == ContactMode::locked && work_[i].at_limit)
      cap_at_friction(contacts_[i], work_[i], work_[i].g0 + work_[i].gn.dot(d_), 1.0);
  out_.converged = true;
  for (const std::uint8_t h : b_.held) out_.held += h > 0 ? 1 : 0;
  return out_;
}

// Solve, re-judge every contact, repeat until no mode changes and no anchor moves; then
// the complementarity pass for contacts held between open and closed, and the solves that
// drop friction that would push.
template <int N>
StepOutcome ContactLaw<N>::solve() {
  assemble();
  trial_slip();
  start_iteration();
  const int max_iter = free_iterations_ + 4 * static_cast<int>(contacts_.size()) + 1;
  bool settled = false;       // the modes are final; only frictions are being dropped
  bool complemented = false;  // complement() has run
  for (int iter = 0; iter < max_iter || settled; ++iter) {
    ++out_.iterations;
    solve_modes(d_);
    PhaseTimer timer(timing_, times_.open_close);
    if (!d_.allFinite()) return out_;
    if (settled) {
      if (drop_pushing_friction()) continue;
      return accept();
    }
    Judged j;
    for (std::size_t i = 0; i < contacts_.size(); ++i) judge(i, iter, j);
    // Anchor moves of held contacts converge geometrically; the last iteration accepts
    // what is left of them.
    if (!j.changed && (!j.shifted || iter + 1 >= max_iter)) {
      if (!complemented) {
        complemented = true;
        complement();
      }
      settled = drop_pushing_friction();
      if (!settled) return accept();
    }
  }
  return out_;
}

}  // namespace

template <int N>
StepOutcome solve_step(const Model& model, const Pose& pose, const State& s, double dt, double friction,
                       std::vector<Contact>& contacts, VecN<N>& d, PhaseTimes& times, bool freeze_strain,
                       bool impact_phase) {
  return ContactLaw<N>(model, pose, s, dt, friction, contacts, d, times, freeze_strain, impact_phase).solve();
}


template StepOutcome solve_step<6>(const Model&, const Pose&, const State&, double, double, std::vector<Contact>&,
                                   VecN<6>&, PhaseTimes&, bool, bool);
template StepOutcome solve_step<12>(const Model&, const Pose&, const State&, double, double, std::vector<Contact>&,
                                    VecN<12>&, PhaseTimes&, bool, bool);

}  // namespace talus::dda::detail
