// SPDX-License-Identifier: MIT
// The search distances of a step and the bookkeeping of an accepted step (step.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "invariants.hpp"
#include "step.hpp"

namespace talus::dda::detail {

double predicted_reach(const Model& model, const State& s, double dt) {
  const double v = s.velocity.head<3>().norm();
  const double w = s.velocity.segment<3>(3).norm();
  double strain = 0.0;
  if (model.dof == DofPath::full12) strain = s.velocity.tail<6>().cwiseAbs().maxCoeff();
  return (v + (w + strain) * model.radius) * dt + 0.5 * model.settings.gravity * dt * dt;
}

// The contact search distance of a step of length h: twice the farthest any point of
// the block can move in it, and at least the step control's displacement bound (m).
double search_reach(const Model& model, const State& s, double h) {
  return std::max(2.0 * predicted_reach(model, s, h), model.max_step_displacement()) + model.rounding_reach;
}

// The near search distance (m), or 0: every candidate the full search finds beyond it is
// set aside (its gap exceeds `scale` times its point's motion), so a detailed rigid block
// need not search there.
double near_reach(const Model& model, const State& s, double h, double scale) {
  if (model.index == nullptr || model.dof != DofPath::rigid6 || !s.friction_drawn || !std::isfinite(scale) ||
      !(scale > 0.0))
    return 0.0;
  // At least twice the reach, so that the flight test's free motion keeps whatever lies
  // beyond it open too.
  const double near = std::max(std::max(2.0, scale) * predicted_reach(model, s, h) * (1.0 + 1e-6), 1e-5 * model.radius) +
                      model.rounding_reach;
  return near < search_reach(model, s, h) ? near : 0.0;
}

// How far the block point x (world, m) can move in a step of length h at the step-start
// motion, `scale` times over (m): velocity, the strain rates' bound and gravity.
double point_reach(const Model& model, const State& s, const Vec3& x, double h, double scale) {
  const Vec3 r = x - s.position;
  const Vec3 v = s.velocity.head<3>() + s.velocity.segment<3>(3).cross(r);
  double strain = 0.0;
  if (model.dof == DofPath::full12) strain = s.velocity.tail<6>().cwiseAbs().maxCoeff();
  return scale * ((v.norm() + strain * model.radius) * h + 0.5 * model.settings.gravity * h * h);
}

// Aims `pass` at a rigid detailed block's near search from `pose` for a step of length h
// with the set-aside scale `scale` (MotionFilter): the step-start motion in the body frame,
// the fall and the round-off allowance. The keep lists are left as they are.
void aim_pass_over(const Model& model, const State& s, const Pose& pose, double h, double scale,
                   MotionFilter& pass) {
  pass.velocity = pose.map.transpose() * s.velocity.head<3>();
  pass.spin = pose.map.transpose() * s.velocity.segment<3>(3);
  pass.h = h;
  pass.fall = 0.5 * model.settings.gravity * h * h;
  pass.scale = scale;
  pass.allowance = scale * h * s.velocity.segment<3>(3).norm() * 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius) +
                   model.rounding_reach;
}

void end_with(State& s, EndReason reason) {
  if (s.end == EndReason::running) s.end = reason;
}

// A trajectory sample at time `t` (s) if one is due: centroid position (m), velocity
// (m/s), height above the terrain (m, NaN off it) and mechanical energy (J).
void sample_trajectory(const Model& model, State& s, double t, const Vec3& p, const Vec3& v, double height,
                       double energy, const Eigen::Quaterniond& orientation, const Vec3& omega, Motion motion) {
  if (model.settings.trajectory_interval <= 0.0 || t + 1e-12 < s.next_sample_time) return;
  s.trajectory.push_back(TrajectorySample{t, p, v, height, energy, orientation, omega, motion});
  s.next_sample_time += model.settings.trajectory_interval;
}

// The centroid `height` (m) above the terrain triangle `triangle` below it, at the end of
// a step or at a nominal step inside a long flight step: the jump maxima.
void note_jump(const terrain::Surface& surf, State& s, double height, std::int32_t triangle) {
  // Jumps count from the first closed contact on; beside the vertical height, the distance
  // to the plane of the triangle below along its normal (the vertical overstates a jump on
  // a slope).
  if (!s.touched) return;
  s.max_jump_height = std::max(s.max_jump_height, height);
  // On a height field the normal's z is in (0, 1] (to round-off): the normal height is at
  // most the vertical one, and is not looked at while that cannot raise the maximum
  // (which starts at 0).
  if (!surf.is_height_field() || height * (1.0 + 1e-9) > s.max_normal_jump_height) {
    const double normal_height = height * surf.normal(static_cast<std::size_t>(triangle)).z();
    s.max_normal_jump_height = std::max(s.max_normal_jump_height, normal_height);
  }
}

namespace {

// Whether the block ended its last step touching the ground: a contact step with a
// closed contact.
bool touching(const State& s) {
  return s.last_step_contact && std::any_of(s.contacts.begin(), s.contacts.end(),
                                            [](const Contact& c) { return c.mode != ContactMode::open; });
}

}  // namespace

// What the block does at the end of a step: an impact lasts until the law has set the
// rebound, and its velocity until then is the penalty springs', not the rebound.
Motion motion_of(const State& s) {
  if (s.episode.active && s.episode.impact) return Motion::impact;
  for (const Contact& c : s.contacts)
    if (c.mode != ContactMode::open) return Motion::contact;
  return Motion::flight;
}

// Bookkeeping after an accepted step: time, kinetic energy, height, maxima, rest,
// leaving, trajectory, limits. Each is computed once here and kept in the state for
// whoever else needs it (the rest test, the trajectory, the driver's observers).
void finish_step(const Model& model, const Ground& ground, State& s, double dt) {
  s.time += dt;
  ++s.counters.steps;
  s.kinetic = kinetic_energy(model, s);
  const terrain::Surface& surf = *ground.surface;
  const auto hit = surf.height_at(s.position.x(), s.position.y());
  s.height = hit ? s.position.z() - hit->z : std::numeric_limits<double>::quiet_NaN();
  if (!s.position.allFinite() || !s.velocity.allFinite() || !s.orientation.coeffs().allFinite()) {
    end_with(s, EndReason::non_finite);
    return;
  }
  if (model.settings.check_invariants) check_energy(model, s);
  const double speed = s.velocity.head<3>().norm();
  s.max_speed = std::max(s.max_speed, speed);
  const double height = s.height;
  if (hit) note_jump(surf, s, height, hit->triangle);
  sample_trajectory(model, s, s.time, s.position, s.velocity.head<3>(), height,
                    s.kinetic + model.mass * model.settings.gravity * s.position.z(), s.orientation,
                    s.velocity.segment<3>(3), motion_of(s));
  const geometry::Aabb& b = surf.bounds();
  if (s.position.x() < b.lo.x() || s.position.x() > b.hi.x() || s.position.y() < b.lo.y() ||
      s.position.y() > b.hi.y() || s.position.z() < b.lo.z() - 2.0 * model.radius) {
    end_with(s, EndReason::left_terrain);
    return;
  }
  if (hangs_past_rim(model, surf, s)) {
    end_with(s, EndReason::left_terrain);
    return;
  }
  const double rest_energy = model.settings.rest_kinetic_energy * model.mass;
  const bool slow = model.dof == DofPath::rigid6 ? s.kinetic < rest_energy
                                                  : rigid_kinetic_energy(model, s) < rest_energy && s.kinetic < rest_energy;
  if (slow) {
    s.rest_time += dt;
    // At rest on the ground: a block at the top of a throw is slow too, in the air.
    if (s.rest_time >= model.settings.rest_dwell && touching(s)) {
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

}  // namespace talus::dda::detail
