// SPDX-License-Identifier: MIT
#include "talus/dda/engine.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "episodes.hpp"
#include "invariants.hpp"
#include "step.hpp"
#include "workspace.hpp"
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

using namespace detail;

Workspace::Workspace(const ReferencePaths& paths) : impl_(std::make_unique<Scratch>()) { impl_->paths = paths; }
Workspace::~Workspace() = default;
Workspace::Workspace(Workspace&&) noexcept = default;
Workspace& Workspace::operator=(Workspace&&) noexcept = default;

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
  s.kinetic = kinetic_energy(model, s);
  s.max_speed = release.velocity.norm();
  if (model.settings.trajectory_interval > 0.0) s.next_sample_time = 0.0;
  return s;
}

namespace {

// The first step's start: the trajectory's first sample and the simulated-time limit.
void begin(const Model& model, const Ground& ground, State& s) {
  if (model.settings.trajectory_interval > 0.0 && s.trajectory.empty()) {
    double height = std::numeric_limits<double>::quiet_NaN();
    if (const auto hit = ground.surface->height_at(s.position.x(), s.position.y())) height = s.position.z() - hit->z;
    s.trajectory.push_back(TrajectorySample{s.time, s.position, s.velocity.head<3>(), height,
                                            mechanical_energy(model, s), s.orientation, s.velocity.segment<3>(3),
                                            motion_of(s)});
    s.next_sample_time = model.settings.trajectory_interval;
  }
  s.time_limit = time_limit(model, *ground.surface);
}

// A flight step when the flight test is on, no contact is closed and the block is clear
// of the terrain for a step: true if it flew (the step is done).
bool fly(const Model& model, const Ground& ground, State& s, Scratch& w) {
  if (!model.settings.flight_test ||
      std::any_of(s.contacts.begin(), s.contacts.end(), [](const Contact& c) { return c.mode != ContactMode::open; }))
    return false;
  PhaseTimer timer(model.settings.time_phases, s.times.flight);
  const double h = flight_step(model, ground, s, w);
  if (!(h > 0.0)) return false;
  s.contacts.clear();
  if (s.episode.active) end_episode(model, s);
  finish_step(model, ground, s, h);
  return true;
}

}  // namespace

void step(const Model& model, const Ground& ground, State& s, Workspace& workspace) {
  if (s.end != EndReason::running) return;
  if (ground.surface == nullptr) throw core::InputError("terrain", "no terrain surface given");
  if (s.counters.steps == 0) begin(model, ground, s);
  // The last step ends exactly at the time limit.
  if (s.time + s.dt > s.time_limit) s.dt = std::max(s.time_limit - s.time, 1e-3 * model.settings.min_time_step);
  Scratch& w = workspace.scratch();
  if (!fly(model, ground, s, w)) {
    if (model.dof == DofPath::rigid6) contact_step<6>(model, ground, s, w);
    else contact_step<12>(model, ground, s, w);
  }
  // A block that ends on the ground is checked once, exactly, for lying below it (a
  // terrain feature through it that no contact held): it is not at rest but a failure.
  if (s.end == EndReason::rest || s.end == EndReason::step_limit) {
    const double depth = depth_below_ground(model, pose_of(model, s), *ground.surface);
    s.max_depth = std::max(s.max_depth, depth);
    if (depth > model.penetration_limit()) s.end = EndReason::penetration;
  }
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
  Workspace workspace;
  while (s.end == EndReason::running) step(model, ground, s, workspace);
  return summarize(s);
}

std::vector<Vec3> world_vertices(const Model& model, const State& s) {
  const Pose pose = pose_of(model, s);
  std::vector<Vec3> out;
  const PlacedBlock scanned(model, pose, out, /*scan=*/true);  // fills `out`
  return out;
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
