// SPDX-License-Identifier: MIT
#include "talus/dda/engine.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "contacts.hpp"
#include "invariants.hpp"
#include "talus/core/error.hpp"

namespace talus::dda {

std::string_view to_string(EndReason reason) {
  switch (reason) {
    case EndReason::running: return "running";
    case EndReason::rest: return "rest";
    case EndReason::left_terrain: return "left_terrain";
    case EndReason::step_limit: return "step_limit";
    case EndReason::non_finite: return "non_finite";
    case EndReason::no_convergence: return "no_convergence";
    case EndReason::penetration: return "penetration";
  }
  return "unknown";
}

bool is_failure(EndReason reason) {
  return reason == EndReason::non_finite || reason == EndReason::no_convergence ||
         reason == EndReason::penetration;
}

namespace {

using detail::Pose;
constexpr double kPi = 3.14159265358979323846;

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

Pose pose_of(const Model& model, const State& s) {
  Pose p;
  p.centre = s.position;
  p.rotation = s.orientation.toRotationMatrix();
  if (model.dof == DofPath::rigid6) {
    p.map = p.rotation;
    p.inverse_map = p.rotation.transpose();
  } else {
    p.map = p.rotation * s.stretch;
    p.inverse_map = s.stretch.inverse() * p.rotation.transpose();
  }
  return p;
}

void update_world_vertices(const Model& model, State& s) {
  const Pose p = pose_of(model, s);
  s.world_vertices.resize(model.vertices.size());
  for (std::size_t i = 0; i < model.vertices.size(); ++i)
    s.world_vertices[i] = p.centre + p.map * model.vertices[i];
}

// ½mv² + ½ωᵀJω: the rigid part of the kinetic energy (J).
double rigid_kinetic_energy(const Model& model, const State& s) {
  const Vec3 v = s.velocity.head<3>();
  const Vec3 w = s.velocity.segment<3>(3);
  const Vec3 wb = s.orientation.conjugate() * w;  // body frame
  return 0.5 * model.mass * v.squaredNorm() + 0.5 * wb.dot(model.inertia * wb);
}

Vec3 gravity_vector(const Model& model) { return Vec3(0.0, 0.0, -model.settings.gravity); }

// Voigt (εx εy εz γyz γzx γxy) of a symmetric strain tensor.
Eigen::Matrix<double, 6, 1> voigt(const Mat3& e) {
  Eigen::Matrix<double, 6, 1> v;
  v << e(0, 0), e(1, 1), e(2, 2), 2.0 * e(1, 2), 2.0 * e(2, 0), 2.0 * e(0, 1);
  return v;
}

Mat3 strain_tensor(const Eigen::Matrix<double, 6, 1>& v) {
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
  // Each contact may visit each of its three modes once per step; a contact whose
  // re-judgement would take it back to a mode it already had in this step (open -> locked
  // -> open, locked -> sliding -> locked, ...) is held closed -- sliding if it slid -- for
  // the rest of the step, and so is every contact that changes state after
  // `max_open_close_iterations`. The iteration therefore always ends, after at most
  // max_open_close_iterations + 3·(contacts) + 1 solves; a held contact carries at most
  // the small tension or slip error of one state flip (counted in Counters::held_contacts).
  thread_local std::vector<std::uint8_t> visited;
  thread_local std::vector<std::uint8_t> held;
  visited.assign(contacts.size(), 0);
  held.assign(contacts.size(), 0);
  auto bit = [](ContactMode m) { return static_cast<std::uint8_t>(1u << static_cast<unsigned>(m)); };
  for (std::size_t i = 0; i < contacts.size(); ++i) visited[i] = bit(contacts[i].mode);
  StepOutcome out;
  const int free_iterations = static_cast<int>(set.max_open_close_iterations);
  const int max_iter = free_iterations + 4 * static_cast<int>(contacts.size()) + 1;
  for (int iter = 0; iter < max_iter; ++iter) {
    ++out.iterations;
    MatN<N> k = k0;
    VecN<N> f = f0;
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
          // ps·(P T)ᵀ(P T) with P = I − nnᵀ equals ps·(TᵀT − (Tᵀn)(Tᵀn)ᵀ).
          const VecN<N> gt = w.ta.transpose() * c.normal;
          k.noalias() += ps * (gram<N>(w.ta) - gt * gt.transpose());
          f -= ps * (w.ta.transpose() * w.s0);
        } else {
          // Sliding: Coulomb force μ·F_n against the slip, with F_n implicit in d so the
          // friction matches the normal force of this very step.
          const VecN<N> ts = w.t.transpose() * c.slip_direction;
          k.noalias() -= friction * p * ts * w.gn.transpose();
          f += friction * p * w.g0 * ts;
        }
      }
    }
    {
      PhaseTimer timer(timing, times.solve);
      // Symmetric positive definite unless a contact slides (implicit friction).
      bool sliding = false;
      for (const Contact& c : contacts) sliding = sliding || c.mode == ContactMode::sliding;
      if constexpr (N == 12) {
        if (freeze_strain) {
          // Strain increments held at zero: the rigid block of the system.
          const Mat6 k6 = k.template topLeftCorner<6, 6>();
          const Eigen::Matrix<double, 6, 1> f6 = f.template head<6>();
          d.setZero();
          if (sliding) d.template head<6>() = Eigen::PartialPivLU<Mat6>(k6).solve(f6);
          else d.template head<6>() = Eigen::LLT<Mat6>(k6).solve(f6);
        }
      }
      if (!(N == 12 && freeze_strain)) {
        if (sliding) d = Eigen::PartialPivLU<MatN<N>>(k).solve(f);
        else d = Eigen::LLT<MatN<N>>(k).solve(f);
      }
    }
    PhaseTimer timer(timing, times.open_close);
    if (!d.allFinite()) return out;
    bool changed = false;
    bool shifted = false;
    // A contact that re-sticks after slipping gets its shear spring stretched to the
    // friction force it carried, so the force is continuous and the load does not jump
    // to the other contacts (which would make a block ratchet down a slope it should
    // stick to). That stretch stores ½(μF_n)²/k_s that no force stored, negligible at
    // rest but not under an impact's forces: there the anchor starts unstretched.
    auto restick_stretch = [&](double g) { return impact_phase ? 0.0 : friction * (-p * g) / ps; };
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
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      Contact& c = contacts[i];
      Work<N>& w = work[i];
      const double g = w.g0 + w.gn.dot(d);
      if (held[i]) {
        // A held contact keeps its mode but not a force friction cannot carry: a locked
        // one has its anchor moved to the friction limit of this solution (none in
        // tension), and a sliding one may still stick once, since Coulomb friction must
        // never push along the slip.
        if (c.mode == ContactMode::locked) {
          shifted = cap_at_friction(c, w, g, 2.0) || shifted;
        } else if (held[i] == 1 && c.mode == ContactMode::sliding && g < 0.0) {
          const Vec3 du = w.t * d;
          if ((du - c.normal * c.normal.dot(du)).dot(c.slip_direction) < 0.0) {
            c.mode = ContactMode::locked;
            c.anchored = true;
            w.s0 = restick_stretch(g) * c.slip_direction;
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
          next = c.resume == ContactMode::sliding && c.slip_direction.squaredNorm() > 0.0 ? ContactMode::sliding
                                                                                          : ContactMode::locked;
        }
      } else if (g >= 0.0) {
        next = ContactMode::open;
      } else if (c.mode == ContactMode::locked) {
        const Vec3 sv = w.s0 + w.ta * d;
        const Vec3 st = sv - c.normal * c.normal.dot(sv);
        const double fs = ps * st.norm();
        if (fs > friction * (-p * g) * (1.0 + 1e-12) && st.norm() > 0.0) {
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
            shifted = cap_at_friction(c, w, g, 1.0) || shifted;
            continue;
          }
          next = ContactMode::locked;  // the re-stick below pre-stretches it to the limit
          if (!(friction > 0.0)) continue;  // nothing to stick with: it keeps sliding
        } else {
          // Cycling between open and closed: the contact carries almost no load (a closed
          // state in tension against an open one that penetrates). A contact touching at
          // the step start is held closed and sliding along its tangential motion in this
          // solution, so it bears the bounded Coulomb force; locked only if it does not
          // move tangentially at all.
          // A contact that starts the step with a gap is held open instead: closed, its
          // spring would pull with the whole gap as tension.
          if (w.g0 > 0.0) {
            if (c.mode == ContactMode::open) continue;
            next = ContactMode::open;
            restick = false;
            visited[i] |= bit(next);
            changed = true;
            c.resume = c.mode;
            c.mode = next;
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
        w.s0 = restick_stretch(g) * c.slip_direction;
        c.body_anchor = pose.inverse_map * (c.point - pose.centre);
        c.ground_anchor = c.point - c.gap * c.normal - w.s0;
        w.ta = w.t;
      }
      c.mode = next;
    }
    // Anchor moves of held contacts converge geometrically; the last iteration accepts
    // what is left of them.
    if (!changed && (!shifted || iter + 1 >= max_iter)) {
      out.converged = true;
      for (const std::uint8_t h : held) out.held += h > 0 ? 1 : 0;
      return out;
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
void carry_contacts(const std::vector<Contact>& previous, std::vector<Contact>& now, const Pose& pose,
                    double friction, double shear_stiffness, double fresh_depth, double radius) {
  std::erase_if(now, [&](const Contact& c) {
    if (c.kind != ContactKind::edge_edge || c.gap >= -fresh_depth) return false;
    return std::none_of(previous.begin(), previous.end(), [&](const Contact& old) {
      return old.kind == c.kind && old.block_feature == c.block_feature && old.terrain_feature == c.terrain_feature;
    });
  });
  for (Contact& c : now) {
    c.gap_offset = std::min(c.gap, 0.0);
    const Contact* match = nullptr;
    for (const Contact& old : previous) {
      if (old.kind != c.kind || old.block_feature != c.block_feature) continue;
      if (old.terrain_feature == c.terrain_feature) {
        match = &old;
        break;
      }
      if (c.kind == ContactKind::vertex_face && old.normal.dot(c.normal) > 1.0 - 1e-12) match = &old;
    }
    if (match == nullptr) continue;
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
}

double predicted_reach(const Model& model, const State& s, double dt) {
  const double v = s.velocity.head<3>().norm();
  const double w = s.velocity.segment<3>(3).norm();
  double strain = 0.0;
  if (model.dof == DofPath::full12) strain = s.velocity.tail<6>().cwiseAbs().maxCoeff();
  return (v + (w + strain) * model.radius) * dt + 0.5 * model.settings.gravity * dt * dt;
}

const terrain::Material& material_of(const Ground& ground, std::int32_t triangle) {
  const std::int32_t m = ground.surface->material(static_cast<std::size_t>(triangle));
  if (m < 0 || static_cast<std::size_t>(m) >= ground.materials.size())
    throw core::InputError("terrain", "triangle " + std::to_string(triangle) + " names material " +
                                          std::to_string(m) + " but only " +
                                          std::to_string(ground.materials.size()) + " are defined");
  return ground.materials[static_cast<std::size_t>(m)];
}

double mean_friction(const terrain::Material& mat) {
  return std::tan(mat.friction_angle_mean_deg * kPi / 180.0);
}

Vec3 rotate_about(const Vec3& v, const Vec3& axis, double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, axis) * v;
}

// Horizontal unit direction of travel for the lateral tilt axis.
Vec3 travel_axis(const Vec3& v_in, const Release& release) {
  Vec3 h(v_in.x(), v_in.y(), 0.0);
  if (h.norm() < 1e-9) h = Vec3(release.main_direction.x(), release.main_direction.y(), 0.0);
  return h.normalized();
}

void start_episode(const Model& model, const Ground& ground, State& s, const Vec3& v_in, double kinetic_in) {
  Episode& e = s.episode;
  e = Episode{};
  e.active = true;
  e.velocity_in = v_in;
  e.kinetic_in = kinetic_in;
  Vec3 n = Vec3::Zero();
  std::int32_t triangle = -1;
  double strongest = -1.0;
  for (const Contact& c : s.contacts) {
    if (c.mode == ContactMode::open) continue;
    const double w = std::max(c.normal_force, 1e-300);
    n += w * c.normal;
    if (w > strongest) {
      strongest = w;
      triangle = c.triangle;
    }
  }
  e.normal = n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::UnitZ();
  const double approach = -v_in.dot(e.normal);
  if (approach < model.settings.impact_min_normal_speed) return;
  const terrain::Material& mat = material_of(ground, triangle);
  // Three draws per impact, always in this order, so a setting never shifts later draws.
  const double z_r = s.impacts_rng.normal();
  const double z_f = s.impacts_rng.normal();
  const double z_t = s.impacts_rng.normal();
  e.impact = true;
  e.restitution = std::clamp(mat.restitution_mean + mat.restitution_sd * z_r, 0.0, 1.0);
  s.friction = std::max(0.0, mean_friction(mat) + mat.friction_coefficient_sd * z_f);
  s.friction_drawn = true;
  e.tilt_deg = mat.lateral_tilt_sd_deg * z_t;
  e.normal = rotate_about(e.normal, travel_axis(v_in, s.release), e.tilt_deg * kPi / 180.0);
  e.restitution_scale = mat.restitution_scale;
  ++s.impacts;
}

// Applies the restitution law to the rebound of the impact in progress; the episode
// goes on as a rolling/sliding one if contacts stay closed.
void finish_impact(const Model& model, State& s) {
  Episode& e = s.episode;
  const bool impact = e.impact;
  e.impact = false;
  if (!impact || model.restitution == RestitutionLaw::off) return;
  Vec3 v = s.velocity.head<3>();
  Vec3 w = s.velocity.segment<3>(3);
  const auto rotational = [&](const Vec3& omega) {
    const Vec3 wb = s.orientation.conjugate() * omega;
    return 0.5 * wb.dot(model.inertia * wb);
  };
  const double kinetic_out = 0.5 * model.mass * v.squaredNorm() + rotational(w);
  // The rebound's whole kinetic energy (spin included) is bounded too: a contact step
  // can turn translation into spin, which a cap on the speed alone would let through.
  double energy_ratio = 1.0;  // allowed kinetic energy over the impact's
  if (model.restitution == RestitutionLaw::scaled) {
    const double vin = e.velocity_in.norm();
    const double sf = 1.0 / (1.0 + (vin / e.restitution_scale) * (vin / e.restitution_scale));
    const double cap = e.restitution * sf * vin;
    energy_ratio = (e.restitution * sf) * (e.restitution * sf);
    const double vout = v.norm();
    double factor = vout > cap ? cap / vout : 1.0;
    if (kinetic_out * factor * factor > energy_ratio * e.kinetic_in)
      factor = std::sqrt(energy_ratio * e.kinetic_in / kinetic_out);
    if (factor < 1.0) {
      // The whole rigid velocity is scaled: rebound direction and spin-to-speed ratio
      // of the DDA rebound are kept, its kinetic energy scaled by factor².
      v *= factor;
      w *= factor;
      ++s.counters.impacts_rescaled;
    }
    // The lateral scatter turns the rebound about the horizontal travel direction. The
    // spin turns with it and keeps its energy (½ωᵀJω changes under a rotation of ω
    // unless the inertia is isotropic).
    const Vec3 axis = travel_axis(e.velocity_in, s.release);
    const double tilt = e.tilt_deg * kPi / 180.0;
    v = rotate_about(v, axis, tilt);
    const double spin_energy = rotational(w);
    w = rotate_about(w, axis, tilt);
    const double turned = rotational(w);
    if (turned > 0.0) w *= std::sqrt(spin_energy / turned);
  } else if (model.restitution == RestitutionLaw::normal_component) {
    const double vin_n = std::abs(e.velocity_in.dot(e.normal));
    const double sf = 1.0 / (1.0 + (vin_n / e.restitution_scale) * (vin_n / e.restitution_scale));
    const double cap = e.restitution * sf * vin_n;
    const double vn = v.dot(e.normal);
    if (vn > cap) {
      v -= (vn - cap) * e.normal;
      ++s.counters.impacts_rescaled;
    }
    // The tangential velocity and spin are kept, but never with more kinetic energy
    // than the block brought into the impact.
    const double now = 0.5 * model.mass * v.squaredNorm() + rotational(w);
    if (now > e.kinetic_in && now > 0.0) {
      const double factor = std::sqrt(e.kinetic_in / now);
      v *= factor;
      w *= factor;
    }
  }
  s.velocity.head<3>() = v;
  s.velocity.segment<3>(3) = w;
}

void end_episode(const Model& model, State& s) {
  finish_impact(model, s);
  s.episode.active = false;
}

// An impact whose block stays in contact (it lands and slides or rolls on) has rebounded
// once the block no longer approaches the ground along the impact normal and its
// contact springs hold less than 1 % of the impact's kinetic energy: the law applies then
// rather than never.
bool rebound_complete(const Model& model, const State& s, double spring_energy) {
  const Episode& e = s.episode;
  if (s.velocity.head<3>().dot(e.normal) < 0.0) return false;
  return spring_energy <= 0.01 * 0.5 * model.mass * e.velocity_in.squaredNorm();
}

// Nothing in the model is a source of energy, but a contact step can still gain some: a
// friction direction that a held contact could not revise, a feature pair found deep
// inside at a fast impact. Whatever the step gained beyond round-off is taken back
// from the kinetic energy (the velocity is scaled, its direction kept), and counted, so
// that a realization can never gain energy it had no source for.
void limit_energy(const Model& model, State& s, double energy_start) {
  const double potential = model.mass * model.settings.gravity * s.position.z();
  const double kinetic = kinetic_energy(model, s);
  const double scale = std::abs(energy_start) + std::abs(potential) + model.mass * model.settings.gravity * model.radius;
  const double excess = kinetic + potential + s.stored_energy - energy_start;
  if (!(excess > 1e-10 * scale)) return;
  ++s.counters.energy_limited;
  const double from_motion = std::min(excess, kinetic);
  if (kinetic > 0.0) s.velocity *= std::sqrt((kinetic - from_motion) / kinetic);
  s.energy_removed += from_motion;
  // A gain larger than the motion holds sits in the normal springs: their compression is
  // relaxed (the accepted penetration grows) until they hold no more than was there.
  const double rest = excess - from_motion;
  if (!(rest > 0.0)) return;
  const double p = model.stiffness;
  double normal_energy = 0.0;
  for (const Contact& c : s.contacts) normal_energy += 0.5 * p * c.spring_gap * c.spring_gap;
  if (!(normal_energy > 0.0)) return;
  const double keep = std::sqrt(std::max(0.0, normal_energy - rest) / normal_energy);
  for (Contact& c : s.contacts) c.spring_gap *= keep;
  const double removed = normal_energy * (1.0 - keep * keep);
  s.stored_energy -= removed;
  s.energy_removed += removed;
}

// Contacts that stay closed through a step have no normal relative velocity in the
// physics: a penalty spring at Ω = √(k/m)·Δt ≫ 1 keeps a barely damped vibration instead,
// which rocks a resting block and turns its friction forces from side to side until it
// creeps down a slope it should stick to. Outside impacts the approaching normal velocity
// of such contacts is therefore removed by non-negative impulses at the contact points
// (projected Gauss–Seidel on the block's mass metric): each impulse only removes kinetic
// energy, and a contact that separates is left to separate.
template <int N>
void settle_contacts(const Model& model, State& s, const std::vector<std::pair<Vec3, Vec3>>& persistent) {
  if (persistent.empty()) return;
  const MatN<N> m = current_mass<N>(model, pose_of(model, s));
  const Eigen::LLT<MatN<N>> llt(m);
  thread_local std::vector<VecN<N>> g, minv_g;
  thread_local std::vector<double> weight, impulse;
  const std::size_t n = persistent.size();
  g.resize(n);
  minv_g.resize(n);
  weight.assign(n, 0.0);
  impulse.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    g[i] = dof_matrix<N>(persistent[i].first - s.position).transpose() * persistent[i].second;
    minv_g[i] = llt.solve(g[i]);
    weight[i] = g[i].dot(minv_g[i]);
  }
  VecN<N> v = s.velocity.template head<N>();
  for (int sweep = 0; sweep < 16; ++sweep) {
    double largest = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!(weight[i] > 0.0)) continue;
      const double next = std::max(0.0, impulse[i] - g[i].dot(v) / weight[i]);
      const double change = next - impulse[i];
      v += change * minv_g[i];
      impulse[i] = next;
      largest = std::max(largest, std::abs(change) * std::sqrt(weight[i]));
    }
    if (largest <= 1e-12 * (1.0 + v.norm())) break;
  }
  s.velocity.template head<N>() = v;
}

void end_with(State& s, EndReason reason) {
  if (s.end == EndReason::running) s.end = reason;
}

// The total energy -- kinetic, potential and held by the contact springs -- never rises
// beyond round-off of its terms: nothing in the model is a source.
void check_energy(const Model& model, State& s) {
  const double potential = model.mass * model.settings.gravity * s.position.z();
  const double total = kinetic_energy(model, s) + potential + s.stored_energy;
  if (std::isfinite(s.checked_energy)) {
    const double gain = total - s.checked_energy;
    const double scale = std::abs(total) + std::abs(potential) + model.mass * model.settings.gravity * model.radius;
    s.max_energy_gain = std::max(s.max_energy_gain, gain);
    if (gain > 1e-9 * scale) ++s.counters.energy_violations;
  }
  s.checked_energy = total;
}

// Bookkeeping after an accepted step: time, maxima, rest, leaving, trajectory, limits.
void finish_step(const Model& model, const Ground& ground, State& s, double dt) {
  s.time += dt;
  ++s.counters.steps;
  if (!s.position.allFinite() || !s.velocity.allFinite() || !s.orientation.coeffs().allFinite()) {
    end_with(s, EndReason::non_finite);
    return;
  }
  if (model.settings.check_invariants) check_energy(model, s);
  const double speed = s.velocity.head<3>().norm();
  s.max_speed = std::max(s.max_speed, speed);
  const terrain::Surface& surf = *ground.surface;
  double height = std::numeric_limits<double>::quiet_NaN();
  if (const auto hit = surf.height_at(s.position.x(), s.position.y())) {
    height = s.position.z() - hit->z;
    // Jumps count from the first real touch of the terrain (a closed contact) on: the
    // release drop is no jump, nor is a step that only searched for contacts. Beside the
    // vertical height, the distance to the plane of the triangle below, along its normal
    // (on a slope the vertical height overstates a jump by 1/cos of the slope).
    if (s.touched) {
      s.max_jump_height = std::max(s.max_jump_height, height);
      const double normal_height = height * surf.normal(static_cast<std::size_t>(hit->triangle)).z();
      s.max_normal_jump_height = std::max(s.max_normal_jump_height, normal_height);
    }
  }
  if (model.settings.trajectory_interval > 0.0 && s.time + 1e-12 >= s.next_sample_time) {
    s.trajectory.push_back(TrajectorySample{s.time, s.position, s.velocity.head<3>(), height,
                                            mechanical_energy(model, s)});
    s.next_sample_time += model.settings.trajectory_interval;
  }
  const geometry::Aabb& b = surf.bounds();
  if (s.position.x() < b.lo.x() || s.position.x() > b.hi.x() || s.position.y() < b.lo.y() ||
      s.position.y() > b.hi.y() || s.position.z() < b.lo.z() - 2.0 * model.radius) {
    end_with(s, EndReason::left_terrain);
    return;
  }
  // The rigid part bounds the 12-DOF energy from below: skip the 12×12 product when it
  // already rules out rest.
  const double rest_energy = model.settings.rest_kinetic_energy * model.mass;
  if (rigid_kinetic_energy(model, s) < rest_energy && kinetic_energy(model, s) < rest_energy) {
    s.rest_time += dt;
    if (s.rest_time >= model.settings.rest_dwell) {
      end_with(s, EndReason::rest);
      return;
    }
  } else {
    s.rest_time = 0.0;
  }
  if (s.time >= s.time_limit * (1.0 - 1e-12) ||
      (model.settings.max_steps > 0 && s.counters.steps >= static_cast<std::uint64_t>(model.settings.max_steps)))
    end_with(s, EndReason::step_limit);
}

// The swept box of the block's bounding sphere over [t, t+h] on its free parabola.
geometry::Aabb swept_sphere_box(const Model& model, const State& s, double h) {
  const Vec3 v = s.velocity.head<3>();
  const double g = model.settings.gravity;
  geometry::Aabb box;
  box.add(s.position);
  box.add(s.position + v * h + 0.5 * gravity_vector(model) * h * h);
  // The apex may lie inside the interval.
  if (g > 0.0 && v.z() > 0.0 && v.z() / g < h) {
    const double ta = v.z() / g;
    box.add(s.position + v * ta + 0.5 * gravity_vector(model) * ta * ta);
  }
  return box.inflated(model.radius);
}

// True when no terrain triangle can be touched before time + h.
bool clear_of_terrain(const Model& model, const Ground& ground, State& s, double h) {
  const geometry::Aabb box = swept_sphere_box(model, s, h).inflated(model.max_step_displacement());
  const TerrainPatch& patch = s.patch;
  if (patch.surface == ground.surface && !patch.box.empty() && patch.box.contains(box.lo) && patch.box.contains(box.hi)) {
    // The patch under the block holds every triangle that can meet the box.
    for (const TerrainPatch::Triangle& t : patch.triangles)
      if (t.box.overlaps(box)) return false;
    return true;
  }
  s.scratch_triangles.clear();
  ground.surface->triangles_in_box(box, s.scratch_triangles);
  for (std::int32_t t : s.scratch_triangles) {
    geometry::Aabb tb;
    for (const Vec3& p : ground.surface->triangle_vertices(static_cast<std::size_t>(t))) tb.add(p);
    if (tb.overlaps(box)) return false;
  }
  return true;
}

// Applies an accepted displacement d (N components) to the state.
template <int N>
void apply_displacement(const Model& model, State& s, const VecN<N>& d, double dt, bool strain_frozen = false) {
  const Mat3 r_old = s.orientation.toRotationMatrix();
  const Vec3 theta = d.template segment<3>(3);
  s.position += d.template head<3>();
  const double angle = theta.norm();
  if (angle > 0.0) s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle)) * s.orientation;
  s.orientation.normalize();
  if constexpr (N == 12) {
    const Mat3 e = strain_tensor(d.template tail<6>());
    s.stretch = s.stretch + r_old.transpose() * e * r_old * s.stretch;
  }
  const VecN<N> v1 = (2.0 / dt) * d - s.velocity.template head<N>();
  s.velocity.template head<N>() = model.settings.dynamic_coefficient * v1;
  if constexpr (N == 12) {
    if (strain_frozen) s.velocity.template tail<6>().setZero();
  }
  update_world_vertices(model, s);
}

bool flight_step(const Model& model, const Ground& ground, State& s) {
  const double dt = s.dt;
  if (s.time + dt > s.clear_until) {
    // Look ahead over a long horizon first, then shorter ones.
    bool clear = false;
    for (const double h : {64.0 * dt, 8.0 * dt, dt}) {
      // Right after contact the long horizons would fail anyway: test one step.
      if (h > dt && s.counters.steps > 0 && s.last_step_contact) continue;
      if (clear_of_terrain(model, ground, s, h)) {
        s.clear_until = s.time + h;
        clear = true;
        break;
      }
    }
    if (!clear) return false;
  }
  if (model.dof == DofPath::rigid6) {
    // The exact parabola (Shi's scheme reproduces it to round-off) and the exact spin.
    const Vec3 g = gravity_vector(model);
    Eigen::Matrix<double, 6, 1> d;
    d.head<3>() = s.velocity.head<3>() * dt + 0.5 * g * dt * dt;
    d.tail<3>() = s.velocity.segment<3>(3) * dt;
    apply_displacement<6>(model, s, d, dt);
  } else {
    // Strains keep oscillating in flight: solve the contact-free 12-DOF step.
    std::vector<Contact> none;
    VecN<12> d;
    solve_step<12>(model, pose_of(model, s), s, dt, 0.0, none, d, s.times);
    apply_displacement<12>(model, s, d, dt);
  }
  ++s.counters.flight_steps;
  s.last_step_contact = false;
  s.stored_energy = 0.0;
  return true;
}

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

template <int N>
void contact_step(const Model& model, const Ground& ground, State& s) {
  const Settings& set = model.settings;
  const bool timing = set.time_phases;
  const double limit = model.max_step_displacement();
  const double depth = model.penetration_limit();
  const Vec3 v_start = s.velocity.head<3>();
  const double kinetic_start = rigid_kinetic_energy(model, s);
  const double energy_start = kinetic_energy(model, s) + model.mass * set.gravity * s.position.z() + s.stored_energy;
  double dt = s.dt;
  std::vector<Contact>& contacts = s.scratch_contacts;
  const Pose pose = pose_of(model, s);
  double friction = s.friction;
  VecN<N> d;
  bool impact_cut = false;
  // full12: the constant-strain mode cannot carry an impact (it would keep most of the
  // impact energy as an undamped vibration, docs/dda.md), so unless asked its increments
  // are held at zero while the block arrives from flight and during impact episodes;
  // the restitution law accounts for the impact's losses, as on the rigid path.
  const bool arriving = std::none_of(s.contacts.begin(), s.contacts.end(),
                                     [](const Contact& c) { return c.mode != ContactMode::open; });
  const bool freeze_strain = N == 12 && !set.impact_strains && (arriving || (s.episode.active && s.episode.impact));
  thread_local std::vector<ContactMode> start_modes;
  for (;;) {
    {
      PhaseTimer timer(timing, s.times.detect);
      contacts.clear();
      const double reach = std::max(2.0 * predicted_reach(model, s, dt), limit);
      detail::detect_contacts(model, *ground.surface, pose, s.world_vertices, reach, depth, s.patch, contacts);
      if (!s.friction_drawn && !contacts.empty())
        friction = mean_friction(material_of(ground, contacts.front().triangle));
      carry_contacts(s.contacts, contacts, pose, friction, model.stiffness / set.shear_stiffness_ratio, reach,
                     model.radius);
    }
    start_modes.clear();
    for (const Contact& c : contacts) start_modes.push_back(c.mode);
    const StepOutcome outcome = solve_step<N>(model, pose, s, dt, friction, contacts, d, s.times, freeze_strain,
                                                  arriving || (s.episode.active && s.episode.impact));
    s.counters.open_close_iterations += static_cast<std::uint64_t>(outcome.iterations);
    s.counters.held_contacts += static_cast<std::uint64_t>(outcome.held);
    if (!d.allFinite()) {
      end_with(s, EndReason::non_finite);
      return;
    }
    double factor = 1.0;
    if (!outcome.converged) {
      factor = 0.3;
    } else {
      double moved = 0.0;
      for (const Vec3& x : s.world_vertices) {
        const Vec3 u = point_displacement<N>(x - pose.centre, d);
        moved = std::max(moved, u.norm());
      }
      if (moved > limit) factor = std::max(0.1, 0.9 * limit / moved);
    }
    if (factor == 1.0 && !impact_cut) {
      // A contact that closes from a gap with a real approach speed: end the step at
      // the moment of touch (on the free motion). The penalty impact then starts at
      // zero gap; a spring force spread over a whole step of which the contact only saw
      // a part would dissipate energy the restitution law should decide about.
      const double toi = time_of_impact<N>(model, s, pose, contacts, start_modes, dt);
      impact_cut = true;
      if (toi < dt * (1.0 - 1e-9) && toi > set.min_time_step) {
        dt = toi;
        ++s.counters.impact_cuts;
        continue;
      }
    }
    if (factor == 1.0) break;
    if (dt <= set.min_time_step) {
      if (!outcome.converged) {
        end_with(s, EndReason::no_convergence);
        return;
      }
      break;  // accepted at the smallest step: the displacement bound is advisory there
    }
    dt = std::max(set.min_time_step, dt * factor);
    ++s.counters.redone_steps;
  }
  s.counters.contacts += contacts.size();
  if (!s.friction_drawn) s.friction = friction;

  PhaseTimer timer(timing, s.times.update);
  // Keep the closed contacts with the state they end the step in, and the memory of
  // those that opened by less than a micro-gap (the penalty spring's own oscillation).
  const double p = model.stiffness;
  const double ps_end = p / set.shear_stiffness_ratio;
  const double keep_gap = 1e-6 * model.radius;
  s.contacts.clear();
  bool any_closed = false;
  double spring_energy = 0.0;
  // Contacts closed through the whole step: their end points (world) and normals.
  thread_local std::vector<std::pair<Vec3, Vec3>> persistent;
  persistent.clear();
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    Contact& c = contacts[i];
    const Vec3 du = point_displacement<N>(c.point - pose.centre, d);
    const double g = c.gap - c.gap_offset + c.normal.dot(du);
    if (c.mode == ContactMode::open) {
      if (c.anchored && g < keep_gap) {
        c.normal_force = 0.0;
        s.contacts.push_back(c);
      }
      continue;
    }
    if (c.gap + c.normal.dot(du) < -depth) {
      end_with(s, EndReason::penetration);
      return;
    }
    if (c.gap < 0.0 && c.gap == c.gap_offset && c.mode != ContactMode::open) ++s.counters.offset_contacts;
    c.normal_force = p * std::max(0.0, -g);
    c.anchor_force = c.normal_force;
    c.spring_gap = std::min(0.0, g);
    c.spring_shear = std::numeric_limits<double>::infinity();
    if (c.mode == ContactMode::locked && c.anchored) {
      const Vec3 xa = pose.centre + pose.map * c.body_anchor;
      const Vec3 sv = xa + point_displacement<N>(xa - pose.centre, d) - c.ground_anchor;
      const double stretch = (sv - c.normal * c.normal.dot(sv)).norm();
      c.spring_shear = ps_end * stretch;
      spring_energy += 0.5 * ps_end * stretch * stretch;
    }
    if (c.mode == ContactMode::sliding) {
      const Vec3 slip = du - c.normal * c.normal.dot(du);
      if (slip.norm() > 1e-12) c.slip_direction = slip.normalized();
    }
    any_closed = true;
    spring_energy += 0.5 * p * std::min(0.0, g) * std::min(0.0, g);
    if (start_modes[i] != ContactMode::open) persistent.emplace_back(c.point + du, c.normal);
    s.contacts.push_back(c);
  }
  apply_displacement<N>(model, s, d, dt, freeze_strain);
  {
    const Pose now = pose_of(model, s);
    s.stored_energy = spring_energy;
    if (set.check_invariants) {
      const double overlap = std::max(detail::terrain_depth_in_block(model, now, s.patch),
                                      detail::block_depth_below_terrain(s.world_vertices, s.patch, model.radius));
      s.max_depth = std::max(s.max_depth, overlap);
      if (overlap > depth) ++s.counters.depth_violations;
    }
  }
  ++s.counters.contact_steps;
  s.last_step_contact = true;
  s.touched = s.touched || any_closed;
  if (any_closed && !s.episode.active) start_episode(model, ground, s, v_start, kinetic_start);
  else if (!any_closed && s.episode.active) end_episode(model, s);
  else if (s.episode.active && s.episode.impact && rebound_complete(model, s, spring_energy)) finish_impact(model, s);
  if (!(s.episode.active && s.episode.impact)) settle_contacts<N>(model, s, persistent);
  limit_energy(model, s, energy_start);
  s.clear_until = -1.0;
  finish_step(model, ground, s, dt);
  // Grow back towards the nominal step after a cut.
  s.dt = std::min(set.time_step, dt * 1.3);
}

}  // namespace

// The simulated-time limit: the setting, or 60 s plus the time to cross the terrain's
// plan diagonal at 1 m/s (a block that averages less than that is creeping, not falling).
static double time_limit(const Model& model, const terrain::Surface& surface) {
  if (model.settings.max_time > 0.0) return model.settings.max_time;
  const geometry::Aabb& b = surface.bounds();
  const double diagonal = std::hypot(b.hi.x() - b.lo.x(), b.hi.y() - b.lo.y());
  return 60.0 + diagonal / 1.0;
}

State start(const Model& model, const Release& release, core::RandomStream impact_stream) {
  if (!release.position.allFinite() || !release.velocity.allFinite() ||
      !release.angular_velocity.allFinite() || !release.orientation.coeffs().allFinite())
    throw core::InputError("release", "non-finite release position, orientation or velocity");
  if (!(release.orientation.norm() > 0.0))
    throw core::InputError("release", "orientation quaternion is zero");
  if (!(release.main_direction.norm() > 0.0) || !release.main_direction.allFinite())
    throw core::InputError("release", "main direction must be a non-zero horizontal vector");
  State s;
  s.release = release;
  s.release.orientation.normalize();
  s.release.main_direction.normalize();
  s.position = release.position;
  s.orientation = s.release.orientation;
  s.velocity.setZero();
  s.velocity.head<3>() = release.velocity;
  s.velocity.segment<3>(3) = release.angular_velocity;
  s.dt = model.settings.time_step;
  s.impacts_rng = core::RandomSequence(impact_stream);
  update_world_vertices(model, s);
  s.max_speed = release.velocity.norm();
  if (model.settings.trajectory_interval > 0.0) s.next_sample_time = 0.0;
  return s;
}

void step(const Model& model, const Ground& ground, State& s) {
  if (s.end != EndReason::running) return;
  if (ground.surface == nullptr) throw core::InputError("terrain", "no terrain surface given");
  if (s.counters.steps == 0 && model.settings.trajectory_interval > 0.0 && s.trajectory.empty()) {
    double height = std::numeric_limits<double>::quiet_NaN();
    if (const auto hit = ground.surface->height_at(s.position.x(), s.position.y())) height = s.position.z() - hit->z;
    s.trajectory.push_back(TrajectorySample{s.time, s.position, s.velocity.head<3>(), height, mechanical_energy(model, s)});
    s.next_sample_time = model.settings.trajectory_interval;
  }
  if (s.counters.steps == 0) s.time_limit = time_limit(model, *ground.surface);
  // The last step ends exactly at the time limit.
  if (s.time + s.dt > s.time_limit) s.dt = std::max(s.time_limit - s.time, 1e-3 * model.settings.min_time_step);
  bool flew = false;
  if (std::none_of(s.contacts.begin(), s.contacts.end(),
                   [](const Contact& c) { return c.mode != ContactMode::open; })) {
    PhaseTimer timer(model.settings.time_phases, s.times.flight);
    const double dt = s.dt;
    flew = flight_step(model, ground, s);
    if (flew) {
      s.contacts.clear();
      if (s.episode.active) end_episode(model, s);
      finish_step(model, ground, s, dt);
    }
  }
  if (flew) return;
  if (model.dof == DofPath::rigid6) contact_step<6>(model, ground, s);
  else contact_step<12>(model, ground, s);
}

Summary summarize(const State& s) {
  Summary out;
  out.end = s.end;
  out.time = s.time;
  out.steps = s.counters.steps;
  out.final_position = s.position;
  const Eigen::Vector2d delta(s.position.x() - s.release.position.x(), s.position.y() - s.release.position.y());
  const Eigen::Vector2d dir = s.release.main_direction;
  out.runout = delta.dot(dir);
  out.lateral = dir.x() * delta.y() - dir.y() * delta.x();
  out.max_speed = s.max_speed;
  out.max_jump_height = s.max_jump_height;
  out.max_normal_jump_height = s.max_normal_jump_height;
  out.impacts = s.impacts;
  out.max_energy_gain = s.max_energy_gain;
  out.max_depth = s.max_depth;
  out.energy_removed = s.energy_removed;
  out.counters = s.counters;
  out.times = s.times;
  out.trajectory = s.trajectory;
  return out;
}

Summary run(const Model& model, const Ground& ground, const Release& release, core::RandomStream impact_stream) {
  State s = start(model, release, impact_stream);
  while (s.end == EndReason::running) step(model, ground, s);
  return summarize(s);
}

double kinetic_energy(const Model& model, const State& s) {
  double e = rigid_kinetic_energy(model, s);
  if (model.dof == DofPath::full12) {
    const Mat3 r = s.orientation.toRotationMatrix();
    const Mat3 map = r * s.stretch;
    const Mat12 m = mass_matrix(model.settings.density, model.volume, map * model.second_moments * map.transpose());
    e = 0.5 * s.velocity.dot(m * s.velocity);
  }
  return e;
}

double mechanical_energy(const Model& model, const State& s) {
  return kinetic_energy(model, s) + model.mass * model.settings.gravity * s.position.z();
}

}  // namespace talus::dda
