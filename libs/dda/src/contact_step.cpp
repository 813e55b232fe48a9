// SPDX-License-Identifier: MIT
// The contact step (docs/dda.md, "The step"; step.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "contact_law.hpp"
#include "episodes.hpp"
#include "invariants.hpp"
#include "step.hpp"
#include "workspace.hpp"

namespace talus::dda::detail {

namespace {

// Earliest time in (0, dt] at which a contact that was open at the step start and
// closed in the solution touches on the free (contact-free) motion, among those
// approaching faster than the impact threshold; dt if none.
template <int N>
double time_of_impact(const Model& model, const State& s, const Pose& pose, const std::vector<Contact>& contacts,
                      const std::vector<ContactMode>& start_modes, double dt) {
  VecN<N> acc = VecN<N>::Zero();
  acc.template head<3>() = gravity_vector(model);
  const VecN<N> v0 = s.velocity.template head<N>();
  double toi = dt;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    const double g0 = c.gap - c.gap_offset;
    if (start_modes[i] != ContactMode::open || c.mode == ContactMode::open || g0 <= 0.0) continue;
    const VecN<N> gn = dof_matrix<N>(c.point - pose.centre).transpose() * c.normal;
    const double a1 = gn.dot(v0);
    const double a2 = gn.dot(acc);
    if (-a1 < model.settings.impact_min_normal_speed) continue;
    const double disc = a1 * a1 - 2.0 * a2 * g0;
    if (disc < 0.0) continue;
    toi = std::min(toi, 2.0 * g0 / (-a1 + std::sqrt(disc)));
  }
  return toi;
}

// A closed contact's springs at the end of a step with displacement d: the normal gap g
// (m, negative when compressed) and, for a locked anchored contact, the shear stretch
// (m; 0 otherwise).
struct EndSprings {
  double gap = 0.0;
  double stretch = 0.0;
};

template <int N>
EndSprings end_springs(const Pose& pose, const Contact& c, const VecN<N>& d) {
  EndSprings out;
  out.gap = c.gap - c.gap_offset + c.normal.dot(point_displacement<N>(c.point - pose.centre, d));
  if (c.mode == ContactMode::locked && c.anchored) {
    const Vec3 xa = pose.centre + pose.map * c.body_anchor;
    const Vec3 sv = xa + point_displacement<N>(xa - pose.centre, d) - c.ground_anchor;
    out.stretch = (sv - c.normal * c.normal.dot(sv)).norm();
  }
  return out;
}

// The total energy (kinetic, potential, strain and contact springs, J) the state would
// have after the displacement d over dt; s is left as it was.
template <int N>
double energy_after(const Model& model, State& s, const Pose& pose, const std::vector<Contact>& contacts,
                    const VecN<N>& d, double dt, bool freeze_strain) {
  const double p = model.stiffness;
  const double ps = p / model.settings.shear_stiffness_ratio;
  double springs = 0.0;
  for (const Contact& c : contacts) {
    if (c.mode == ContactMode::open) continue;
    const EndSprings e = end_springs<N>(pose, c, d);
    springs += 0.5 * p * std::min(0.0, e.gap) * std::min(0.0, e.gap) + 0.5 * ps * e.stretch * e.stretch;
  }
  const Vec3 position = s.position;
  const Eigen::Quaterniond orientation = s.orientation;
  const Vec12 velocity = s.velocity;
  const Mat3 stretch = s.stretch;
  apply_displacement<N>(model, s, d, dt, freeze_strain);
  const double total = mechanical_energy(model, s) + strain_energy(model, s) + springs;
  s.position = position;
  s.orientation = orientation;
  s.velocity = velocity;
  s.stretch = stretch;
  return total;
}

// Why a contact step's solution is not accepted as it is, and what the step does then.
enum class Retry : std::uint8_t {
  none,          // accepted
  unpass,        // a candidate the near search passed over may close: solved again with all
  widen,         // a candidate set aside closes: the set-aside margin widened, solved again
  cut_to_touch,  // a contact closes from a gap at an impact's speed: the step ends at the touch
  shorten,       // not converged, too large a displacement or an energy gain: a shorter step
  fail,          // not converged at the smallest step, or a non-finite solution: the run ends
};

// What the check after the solve reads of a candidate set aside (a contact is some 200
// bytes, and most candidates of a fine mesh are set aside).
struct Aside {
  Vec3 point, normal;
  double gap, gap_offset;
};

// The buffers of one contact step, kept from step to step to avoid allocations (their
// contents never outlive a call).
struct StepBuffers {
  std::vector<ContactMode> start_modes;
  std::vector<Aside> set_aside;
  std::vector<std::uint8_t> carried, far_carried;
  std::vector<Contact> far;
  std::vector<std::int32_t> keep, keep_edges, keep_terrain;
  std::vector<std::pair<Vec3, Vec3>> closed_end;
  std::vector<Persistent> persistent;
  std::vector<std::pair<double, Vec3>> opened;  // contacts that opened: end gap (m), normal
};

// The fastest approach of a contact point that closes in the step, at the step start:
// along its normal, translation and spin (m/s), the kinetic energy of that approach on
// the block's effective mass at the point (J), its normal and triangle.
struct Approach {
  double speed = 0.0;
  double energy = 0.0;
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::Zero();
  std::int32_t triangle = -1;
};

// One contact step of the path with N unknowns, as its phases: find the candidates, solve
// the contact law, judge the solution (and retry), keep the contacts, move the block,
// update the impact episode, settle, and choose the next step's length.
template <int N>
class ContactStep {
 public:
  ContactStep(const Model& model, const Ground& ground, State& s, Scratch& w);

  void detect();
  void solve();
  Retry judge();
  void retry(Retry reason);
  void count();
  bool keep_contacts();
  void move();
  void update_episode();
  void settle();
  double next_step_length() const;

 private:
  static StepBuffers& buffers() {
    thread_local StepBuffers b;
    return b;
  }
  void keep_carried_features();
  void find_candidates();
  void carry_states();
  void set_candidates_aside();
  bool carry(std::vector<Contact>& into, std::vector<std::uint8_t>& matched) const;
  void search_in_full(std::vector<Contact>& into, std::vector<std::uint8_t>& matched) const;
  bool goes_aside(const Contact& c, bool carries) const;
  template <class C>
  bool closes(const C& c) const;
  bool passed_over_may_close() const;
  bool set_aside_closes();
  double shortening() const;
  bool gains_energy() const;
  double approach_energy(const VecN<6>& gn, double speed);
  double end_approach() const;
  void check_overlap();

  const Model& model_;
  const Ground& ground_;
  State& s_;
  Scratch& w_;
  const Settings& set_;
  StepBuffers& b_;
  const bool timing_;
  const double limit_;  // the largest vertex displacement of a step (m)
  const double depth_;  // the penetration limit (m)
  const Vec3 v_start_;
  const Vec3 w_start_;
  const double kinetic_now_;    // kinetic energy at the step start (J)
  const double kinetic_start_;  // its rigid part (J)
  const double energy_start_;   // total energy at the step start (J)
  double dt_;
  std::vector<Contact>& contacts_;
  const Pose pose_;
  const PlacedBlock at_;
  double friction_;
  VecN<N> d_;
  StepOutcome outcome_;
  bool impact_cut_ = false;
  double dt_before_touch_ = 0.0;  // the step a cut to the moment of touch shortened (s)
  double touch_ = 0.0;            // the moment of touch a cut ends the step at (s)
  double factor_ = 1.0;           // a shortening's factor on the step
  // full12: the constant-strain mode would keep most of an impact's energy as undamped
  // vibration (docs/dda.md), so unless asked its increments are held at zero through
  // arrivals and impacts.
  bool arriving_ = false;
  bool freeze_strain_ = false;
  double aside_scale_;
  std::size_t found_ = 0;
  double near_ = 0.0;
  bool pass_over_ = false;
  MotionFilter pass_;
  // The solution's largest translation (m) and squared turn (rad²), for `closes`.
  double shift_ = 0.0, turn2_ = 0.0;
  // Of the contacts kept at the step end.
  bool any_closed_ = false;
  double spring_energy_ = 0.0;
  // The normal impulse of the kept contacts (N·s) and its moment about the step-start
  // centroid (N·s·m): where an impact acts.
  double impulse_ = 0.0;
  Vec3 impulse_moment_ = Vec3::Zero();
  Approach arrival_, closing_;
  // The contact that opened in the step with the least end gap: the last to let go
  // (finish_impact).
  Separation separation_;
  std::optional<Cholesky6> mass_llt_;
};

template <int N>
ContactStep<N>::ContactStep(const Model& model, const Ground& ground, State& s, Scratch& w)
    : model_(model),
      ground_(ground),
      s_(s),
      w_(w),
      set_(model.settings),
      b_(buffers()),
      timing_(model.settings.time_phases),
      limit_(model.max_step_displacement()),
      depth_(model.penetration_limit()),
      v_start_(s.velocity.head<3>()),
      w_start_(s.velocity.segment<3>(3)),
      // The kinetic energy once for both (total_energy written out).
      kinetic_now_(kinetic_energy(model, s)),
      kinetic_start_(model.dof == DofPath::rigid6 ? kinetic_now_ : rigid_kinetic_energy(model, s)),
      energy_start_(kinetic_now_ + model.mass * model.settings.gravity * s.position.z() + strain_energy(model, s) +
                    s.stored_energy),
      dt_(s.dt),
      contacts_(w.handoff.contacts),
      pose_(pose_of(model, s)),
      at_(model, pose_, w.vertices, false, &w.box),
      friction_(s.friction),
      aside_scale_(w.paths.set_aside_scale) {
  arriving_ = std::none_of(s.contacts.begin(), s.contacts.end(),
                           [](const Contact& c) { return c.mode != ContactMode::open; });
  freeze_strain_ = N == 12 && !set_.impact_strains && (arriving_ || (s.episode.active && s.episode.impact));
  pass_over_ = N == 6 && model.index != nullptr && w.paths.pass_over;
  if (pass_over_) keep_carried_features();
}

// A near search passes over the candidates the step would set aside (MotionFilter), except
// the features of the last step's contacts, which may carry a state.
template <int N>
void ContactStep<N>::keep_carried_features() {
  b_.keep.clear();
  b_.keep_edges.clear();
  b_.keep_terrain.clear();
  for (const Contact& c : s_.contacts) {
    if (c.kind == ContactKind::vertex_face) b_.keep.push_back(c.block_feature);
    if (c.kind == ContactKind::edge_edge) b_.keep_edges.push_back(c.block_feature);
    if (c.kind == ContactKind::face_vertex) b_.keep_terrain.push_back(static_cast<std::int32_t>(c.terrain_feature));
  }
  std::sort(b_.keep.begin(), b_.keep.end());
  std::sort(b_.keep_edges.begin(), b_.keep_edges.end());
  std::sort(b_.keep_terrain.begin(), b_.keep_terrain.end());
  pass_.keep = &b_.keep;
  pass_.keep_edges = &b_.keep_edges;
  pass_.keep_terrain = &b_.keep_terrain;
}

// Carries the last step's contacts into `into` (`matched`: per candidate, whether it
// carries one); whether every one of them is carried.
template <int N>
bool ContactStep<N>::carry(std::vector<Contact>& into, std::vector<std::uint8_t>& matched) const {
  return carry_contacts(s_.contacts, into, pose_, friction_, model_.stiffness / set_.shear_stiffness_ratio,
                        search_reach(model_, s_, dt_), model_.radius, &matched);
}

// The search at the full distance into `into`, carried.
template <int N>
void ContactStep<N>::search_in_full(std::vector<Contact>& into, std::vector<std::uint8_t>& matched) const {
  into.clear();
  detect_contacts(at_, *ground_.surface, search_reach(model_, s_, dt_), depth_, w_.patch, into,
                  {0.0, nullptr, w_.paths.cross_every_valley});
  carry(into, matched);
}

// Whether a candidate is set aside from the solve (`carries`: it carries a contact).
template <int N>
bool ContactStep<N>::goes_aside(const Contact& c, bool carries) const {
  return !carries && c.mode == ContactMode::open && c.gap > point_reach(model_, s_, c.point, dt_, aside_scale_);
}

// Candidates farther from the ground than twice their point's motion (point_reach) stay
// open through the iteration; a solution that closes one is solved again with a wider
// margin (judge).
template <int N>
void ContactStep<N>::detect() {
  pass_.restart();
  PhaseTimer timer(timing_, s_.times.detect);
  find_candidates();
  carry_states();
  found_ = contacts_.size() + pass_.passed;
  set_candidates_aside();
}

// A detailed rigid block searches within the near distance first (near_reach), as long
// as the set-aside margin has not been widened. The flight test may have searched from
// this pose at this distance already: its candidates are taken.
template <int N>
void ContactStep<N>::find_candidates() {
  const double reach = search_reach(model_, s_, dt_);
  near_ = aside_scale_ == w_.paths.set_aside_scale ? near_reach(model_, s_, dt_, aside_scale_) : 0.0;
  const double searched = near_ > 0.0 ? near_ : reach;
  if (searched != w_.handoff.reach) {
    contacts_.clear();
    const bool passing = pass_over_ && near_ > 0.0;
    if (passing) aim_pass_over(model_, s_, pose_, dt_, aside_scale_, pass_);
    detect_contacts(at_, *ground_.surface, reach, depth_, w_.patch, contacts_,
                    {near_, passing ? &pass_ : nullptr, w_.paths.cross_every_valley});
  } else if (pass_over_ && near_ > 0.0) {
    // The flight test's search, which passed over the same candidates.
    pass_.passed = w_.handoff.passed;
    pass_.least_gap = w_.handoff.least_gap;
  }
  w_.handoff.reach = -1.0;
}

// The realization's friction until it is drawn: the mean of the first candidate's
// material. A contact of the last step that the near search did not find may lie beyond
// it, with a state to carry: then the search is made in full.
template <int N>
void ContactStep<N>::carry_states() {
  if (!s_.friction_drawn && !contacts_.empty())
    friction_ = mean_friction(material_of(ground_, contacts_.front().triangle));
  if (!carry(contacts_, b_.carried) && near_ > 0.0) {
    near_ = 0.0;
    pass_.restart();
    search_in_full(contacts_, b_.carried);
  }
}

template <int N>
void ContactStep<N>::set_candidates_aside() {
  b_.set_aside.clear();
  if (!std::isfinite(aside_scale_)) return;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    Contact& c = contacts_[i];
    if (goes_aside(c, b_.carried[i] != 0)) {
      b_.set_aside.push_back({c.point, c.normal, c.gap, c.gap_offset});
    } else {
      if (kept != i) contacts_[kept] = std::move(c);
      ++kept;
    }
  }
  contacts_.resize(kept);
}

// The contact law on the candidates kept, from their modes at the step start.
template <int N>
void ContactStep<N>::solve() {
  b_.start_modes.clear();
  for (const Contact& c : contacts_) b_.start_modes.push_back(c.mode);
  outcome_ = solve_step<N>(model_, pose_, s_, dt_, friction_, contacts_, d_, s_.times, freeze_strain_,
                           arriving_ || (s_.episode.active && s_.episode.impact));
}

// One passed over closes only if its gap is below 2E, E = |d_t − h·v| + |θ − h·ω|·radius
// (its gap exceeded twice the rest of its point's motion): if the least gap may be, solve
// with all.
template <int N>
bool ContactStep<N>::passed_over_may_close() const {
  if constexpr (N == 6) {
    if (pass_.passed > 0 && outcome_.converged && d_.allFinite()) {
      const Vec3 v = s_.velocity.template head<3>(), w = s_.velocity.template segment<3>(3);
      const double e =
          (d_.template head<3>() - dt_ * v).norm() + (d_.template segment<3>(3) - dt_ * w).norm() * model_.radius;
      return !(2.0 * e * (1.0 + 1e-9) < pass_.least_gap);
    }
  }
  return false;
}

// On the rigid path a point r moves by at most |d_t| + |θ|·|r|: a gap beyond that (1e-9 of
// it for round-off) cannot close, and the exact test is skipped.
template <int N>
template <class C>
bool ContactStep<N>::closes(const C& c) const {
  const Vec3 r = c.point - pose_.centre;
  if constexpr (N == 6) {
    const double room = (c.gap - c.gap_offset) * (1.0 - 1e-9) - shift_;
    if (room > 0.0 && room * room > turn2_ * r.squaredNorm() * (1.0 + 1e-9)) return false;
  }
  const VecN<N> gn = dof_matrix<N>(r).transpose() * c.normal;
  return c.gap - c.gap_offset + gn.dot(d_) < 0.0;
}

// After a near search, a candidate beyond the near distance closes only if some point moves
// that far (|d_t| + |θ|·radius): then the full search's set-aside candidates are checked
// too.
template <int N>
bool ContactStep<N>::set_aside_closes() {
  shift_ = d_.template head<3>().norm();
  turn2_ = N == 6 ? d_.template segment<3>(3).squaredNorm() : 0.0;
  if (!outcome_.converged) return false;
  if (std::any_of(b_.set_aside.begin(), b_.set_aside.end(), [&](const Aside& c) { return closes(c); })) return true;
  if (!(near_ > 0.0)) return false;
  PhaseTimer timer(timing_, s_.times.detect);
  const double moved = shift_ + d_.template segment<3>(3).norm() * model_.radius;
  if (moved < near_) return false;
  ++s_.counters.far_searches;
  search_in_full(b_.far, b_.far_carried);
  for (std::size_t i = 0; i < b_.far.size(); ++i)
    if (goes_aside(b_.far[i], b_.far_carried[i] != 0) && closes(b_.far[i])) return true;
  return false;
}

// The factor a step that did not converge, or moved a vertex beyond the displacement
// bound, is shortened by; 1 if neither.
template <int N>
double ContactStep<N>::shortening() const {
  if (!outcome_.converged) return 0.3;
  const double moved = max_vertex_displacement<N>(at_, d_, limit_);
  return moved > limit_ ? std::max(0.1, 0.9 * limit_ / moved) : 1.0;
}

// Nothing in the model is a source, so a solution that gains more than max_step_energy_gain
// of the kinetic energy plus m·g·radius is an error, redone with a shorter step.
template <int N>
bool ContactStep<N>::gains_energy() const {
  if (!(dt_ > set_.min_time_step && set_.max_step_energy_gain > 0.0)) return false;
  const double gain = energy_after<N>(model_, s_, pose_, contacts_, d_, dt_, freeze_strain_) - energy_start_;
  return gain > set_.max_step_energy_gain * (kinetic_now_ + model_.mass * set_.gravity * model_.radius);
}

// Whether the solution is accepted, and if not, why (Retry).
template <int N>
Retry ContactStep<N>::judge() {
  if (passed_over_may_close()) return Retry::unpass;
  s_.counters.open_close_iterations += static_cast<std::uint64_t>(outcome_.iterations);
  s_.counters.held_contacts += static_cast<std::uint64_t>(outcome_.held);
  if (!d_.allFinite()) {
    end_with(s_, EndReason::non_finite);
    return Retry::fail;
  }
  if (set_aside_closes()) return Retry::widen;
  factor_ = shortening();
  if (factor_ == 1.0 && !impact_cut_) {
    // A contact closing from a gap at an impact's speed ends the step at the moment of
    // touch, so the penalty impact starts at zero gap and the law, not a partial step,
    // decides its losses.
    touch_ = time_of_impact<N>(model_, s_, pose_, contacts_, b_.start_modes, dt_);
    impact_cut_ = true;
    if (touch_ < dt_ * (1.0 - 1e-9) && touch_ > set_.min_time_step) return Retry::cut_to_touch;
  }
  if (factor_ == 1.0 && gains_energy()) {
    factor_ = 0.3;
    ++s_.counters.energy_cuts;
  }
  if (factor_ == 1.0) return Retry::none;
  if (dt_ <= set_.min_time_step) {
    if (outcome_.converged) return Retry::none;  // accepted at the smallest step: the bound is advisory there
    end_with(s_, EndReason::no_convergence);
    return Retry::fail;
  }
  return Retry::shorten;
}

template <int N>
void ContactStep<N>::retry(Retry reason) {
  switch (reason) {
    case Retry::unpass:
      pass_over_ = false;
      ++s_.counters.unpassed_steps;
      break;
    case Retry::widen:
      aside_scale_ = aside_scale_ < 8.0 ? std::max(8.0, 4.0 * aside_scale_) : std::numeric_limits<double>::infinity();
      ++s_.counters.widened_steps;
      break;
    case Retry::cut_to_touch:
      dt_before_touch_ = dt_;
      dt_ = touch_;
      ++s_.counters.impact_cuts;
      break;
    case Retry::shorten:
      dt_ = std::max(set_.min_time_step, dt_ * factor_);
      ++s_.counters.redone_steps;
      break;
    case Retry::none:
    case Retry::fail: break;
  }
}

// The candidates of the accepted solution, and the friction the realization starts with.
template <int N>
void ContactStep<N>::count() {
  s_.counters.contacts += found_;
  s_.counters.set_aside_contacts += found_ - contacts_.size();
  if (!s_.friction_drawn) s_.friction = friction_;
}

// The kinetic energy of a point approach `speed` (m/s) along the rows gn on the rigid
// block's effective mass there (J). An impact is a rigid-body event on both DOF paths
// (the 12-DOF path holds its strains through it, and the law acts on the rigid velocity).
template <int N>
double ContactStep<N>::approach_energy(const VecN<6>& gn, double speed) {
  if (!mass_llt_) mass_llt_.emplace(current_mass<6>(model_, pose_));
  const double inverse_mass = gn.dot(mass_llt_->solve(gn));
  return inverse_mass > 0.0 ? 0.5 * speed * speed / inverse_mass : 0.0;
}

// Keeps the closed contacts in their end states and those opened by less than a micro-gap;
// notes the fastest arrival, the springs' energy and the persistent contacts. False:
// penetration.
template <int N>
bool ContactStep<N>::keep_contacts() {
  const double p = model_.stiffness;
  const double ps_end = p / set_.shear_stiffness_ratio;
  const double keep_gap = 1e-6 * model_.radius;
  s_.contacts.clear();
  // The contact closing in this step whose point approaches the ground fastest, if at an
  // impact's speed (arrival_); and the fastest of any contact closing (closing_), for an
  // episode that starts with this step.
  arrival_.speed = set_.impact_min_normal_speed;
  const VecN<6> v_start_rigid = s_.velocity.template head<6>();
  // Closed contacts at the end of the step (world point, normal): whether one still
  // approaches the ground at an impact's speed decides when an impact has rebounded.
  b_.closed_end.clear();
  // Contacts closed through the whole step: their end points (world), normals and, for
  // those that end it locked, the friction impulse they can carry (settle_contacts).
  b_.persistent.clear();
  separation_ = {};
  b_.opened.clear();
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    Contact& c = contacts_[i];
    const Vec3 du = point_displacement<N>(c.point - pose_.centre, d_);
    const double g = c.gap - c.gap_offset + c.normal.dot(du);
    if (c.mode == ContactMode::open && b_.start_modes[i] != ContactMode::open && g > 0.0) {
      b_.opened.emplace_back(g, c.normal);
      if (separation_.gap == 0.0 || g < separation_.gap) separation_ = {g, c.normal, c.point + du, dt_};
    }
    if (c.mode == ContactMode::open) {
      if (c.anchored && g < keep_gap) {
        c.normal_force = 0.0;
        s_.contacts.push_back(c);
      }
      continue;
    }
    if (c.gap + c.normal.dot(du) < -depth_) {
      end_with(s_, EndReason::penetration);
      return false;
    }
    if (c.gap < 0.0 && c.gap == c.gap_offset && c.mode != ContactMode::open) ++s_.counters.offset_contacts;
    c.normal_force = p * std::max(0.0, -g);
    c.anchor_force = c.normal_force;
    c.spring_gap = std::min(0.0, g);
    c.spring_shear = std::numeric_limits<double>::infinity();
    if (c.mode == ContactMode::locked && c.anchored) {
      const double stretch = end_springs<N>(pose_, c, d_).stretch;
      c.spring_shear = ps_end * stretch;
      spring_energy_ += 0.5 * ps_end * stretch * stretch;
    }
    if (c.mode == ContactMode::sliding) {
      const Vec3 slip = du - c.normal * c.normal.dot(du);
      if (slip.norm() > 1e-12) c.slip_direction = slip.normalized();
    }
    any_closed_ = true;
    const VecN<6> gn = dof_matrix<6>(c.point - pose_.centre).transpose() * c.normal;
    const double point_approach = -gn.dot(v_start_rigid);
    const bool arrives = b_.start_modes[i] == ContactMode::open && point_approach >= arrival_.speed;
    const bool closes_fastest = b_.start_modes[i] == ContactMode::open && point_approach > closing_.speed;
    if (arrives || closes_fastest) {
      const double energy = approach_energy(gn, point_approach);
      if (arrives) arrival_ = {point_approach, energy, c.point - pose_.centre, c.normal, c.triangle};
      if (closes_fastest) {
        closing_.speed = point_approach;
        closing_.energy = energy;
        closing_.point = c.point - pose_.centre;
      }
    }
    spring_energy_ += 0.5 * p * std::min(0.0, g) * std::min(0.0, g);
    impulse_ += c.normal_force * dt_;
    impulse_moment_ += c.normal_force * dt_ * (c.point - pose_.centre);
    // A contact whose point still approaches at an impact's speed is in an impact's
    // compression, not at rest on the ground: it is not settled.
    const Vec3 end = c.point + du;
    if (b_.start_modes[i] != ContactMode::open && point_approach < set_.impact_min_normal_speed) {
      // The rolling couple's lever: the end point's distance from the end centroid.
      const double lever = (end - pose_.centre - d_.template head<3>()).norm();
      b_.persistent.push_back({end, c.normal,
                               c.mode == ContactMode::locked ? friction_ * c.normal_force * dt_ : 0.0,
                               set_.rolling_resistance * lever * c.normal_force * dt_});
    }
    b_.closed_end.emplace_back(end, c.normal);
    s_.contacts.push_back(c);
  }
  return true;
}

// With Settings::check_invariants: the overlap of terrain and block at the step end.
template <int N>
void ContactStep<N>::check_overlap() {
  if (!set_.check_invariants) return;
  const Pose end = pose_of(model_, s_);
  const double overlap = std::max({terrain_depth_in_block(model_, end, w_.patch),
                                   block_depth_below_terrain(world_vertices(model_, s_), w_.patch, model_.radius),
                                   depth_below_ground(model_, end, *ground_.surface)});
  s_.max_depth = std::max(s_.max_depth, overlap);
  if (overlap > depth_) ++s_.counters.depth_violations;
}

// The block moved by the accepted displacement. A step whose contacts all stay open is
// free motion, and is not damped either.
template <int N>
void ContactStep<N>::move() {
  apply_displacement<N>(model_, s_, d_, dt_, freeze_strain_, any_closed_);
  s_.stored_energy = spring_energy_;
  check_overlap();
  ++s_.counters.contact_steps;
  s_.last_step_contact = true;
  s_.touched = s_.touched || any_closed_;
}

// The fastest approach of a closed contact point at the step end (m/s); only an impact in
// progress asks.
template <int N>
double ContactStep<N>::end_approach() const {
  double fastest = 0.0;
  for (const auto& [point, normal] : b_.closed_end)
    fastest = std::max(fastest, -(dof_matrix<6>(point - s_.position).transpose() * normal).dot(s_.velocity.head<6>()));
  return fastest;
}

// An episode starts with the first closed contact; a contact closing at an impact's speed
// while others are closed is an impact of its own; an impact ends once rebounded
// (rebound_complete).
template <int N>
void ContactStep<N>::update_episode() {
  // An impact in progress gathers where its contacts push (the contact-point law's point).
  if (s_.episode.active && s_.episode.impact) add_impulse(s_, impulse_, impulse_moment_);
  const bool starts = any_closed_ && !s_.episode.active;
  const bool arrives = !starts && s_.episode.active && !s_.episode.impact && arrival_.triangle >= 0;
  if (starts || arrives) {
    if (starts) start_episode(model_, ground_, s_, v_start_, kinetic_start_, {closing_.speed, closing_.energy, closing_.point});
    else
      start_episode_along(model_, ground_, s_, v_start_, kinetic_start_, arrival_.normal, arrival_.triangle,
                          {arrival_.speed, arrival_.energy, arrival_.point});
    s_.episode.spin_in = w_start_;
    add_impulse(s_, impulse_, impulse_moment_);
  } else if (!any_closed_ && s_.episode.active) {
    const Vec3 before = s_.position;
    end_episode(model_, s_, separation_);
    // The flight redone from the separation moves the block back along its path; no
    // contact that opened in the step may close by it (a tumbling block's other corners).
    const Vec3 moved = s_.position - before;
    double keep = 1.0;
    for (const auto& [gap, normal] : b_.opened) {
      const double rate = normal.dot(moved);
      if (rate < 0.0 && gap + rate < 0.0) keep = std::min(keep, gap / -rate);
    }
    s_.position = before + keep * moved;
  } else if (s_.episode.active && s_.episode.impact && end_approach() < set_.impact_min_normal_speed &&
             rebound_complete(model_, s_, spring_energy_)) {
    finish_impact(model_, s_);
  }
}

// Outside an impact the contacts closed through the step are settled; the energy limiter
// takes back any gain; then the bookkeeping of the accepted step.
template <int N>
void ContactStep<N>::settle() {
  if (!(s_.episode.active && s_.episode.impact)) settle_contacts<N>(model_, s_, b_.persistent);
  limit_energy(model_, s_, energy_start_);
  s_.clear_until = -1.0;
  finish_step(model_, ground_, s_, dt_);
}

// Grow back after a cut (×1.3), from the step a touch cut shortened (the impact gets a
// whole step); a slow or settling rigid block grows up to rest_step_ratio steps
// (docs/dda.md, Step control).
template <int N>
double ContactStep<N>::next_step_length() const {
  const bool slow = set_.slow_kinetic_energy > 0.0 && s_.kinetic < set_.slow_kinetic_energy * model_.mass &&
                    !(s_.episode.active && s_.episode.impact);
  const bool settling =
      ((s_.rest_time >= 0.2 * set_.rest_dwell && s_.rest_time > 0.0) || slow) && model_.dof == DofPath::rigid6;
  const double longest =
      settling ? std::clamp(set_.rest_dwell - s_.rest_time, set_.time_step, set_.rest_step_ratio * set_.time_step)
               : set_.time_step;
  return std::min(longest, std::max(dt_ * 1.3, dt_before_touch_));
}

}  // namespace

template <int N>
void contact_step(const Model& model, const Ground& ground, State& s, Scratch& w) {
  ContactStep<N> step(model, ground, s, w);
  for (;;) {
    step.detect();
    step.solve();
    const Retry reason = step.judge();
    if (reason == Retry::none) break;
    if (reason == Retry::fail) return;
    step.retry(reason);
  }
  step.count();
  PhaseTimer timer(model.settings.time_phases, s.times.update);
  if (!step.keep_contacts()) return;
  step.move();
  step.update_episode();
  step.settle();
  s.dt = step.next_step_length();
}

template void contact_step<6>(const Model&, const Ground&, State&, Scratch&);
template void contact_step<12>(const Model&, const Ground&, State&, Scratch&);

}  // namespace talus::dda::detail
