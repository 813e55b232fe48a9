// SPDX-License-Identifier: MIT
#include "talus/dda/engine.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "contact_law.hpp"
#include "contacts.hpp"
#include "episodes.hpp"
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

namespace detail {

namespace {

// The rim point nearest to (x, y) in plan, looked for within `reach` and then within
// four times as far, and so on, until one is found or the reach spans the terrain.
std::optional<terrain::Surface::RimPoint> nearest_rim_point_anywhere(const terrain::Surface& surf, double x, double y,
                                                                     double reach) {
  const geometry::Aabb& b = surf.bounds();
  const double span = (b.hi - b.lo).head<2>().norm() + std::abs(x - b.lo.x()) + std::abs(y - b.lo.y());
  for (double r = reach;; r *= 4.0) {
    if (const auto rim = surf.nearest_rim_point(x, y, std::min(r, span))) return rim;
    if (!(r < span)) return std::nullopt;
  }
}

}  // namespace

// Whether part of the block has dropped past the terrain's rim, where the surface ends
// with nothing beyond: a vertex with no ground under it lies lower than the rim's nearest
// point, and deeper under the ground continued past the rim (the plane of that rim
// point's triangle, where it faces up), by more than the penetration limit. Such a block
// has tipped or fallen over the edge of the modelled ground: it can only fall on past
// it, or swing under the sheet and come back inside the footprint below the ground,
// where nothing holds it and it would overlap the terrain beyond the limit (a cube
// tipping over the side edge of a rough bench slope did that, to 0.49 m under the
// ground). A block that overhangs the rim while resting on or moving over the ground
// lies on the continued plane, and one hanging over the crest of a slope that rises
// beyond the rim lies above the rim: both go on. The test costs nothing while the
// block's bounding sphere is clear of the rim, and near it looks only at the vertices
// lower than the rim nearby by the penetration limit (`floor`).
//
// A TIN's footprint may have holes and bays (a survey's gaps): a block whose centroid is
// over one, with its bounding sphere clear of the rim, is off the ground as a whole. The
// same rule then holds with the nearest rim point at any distance: a block flying over a
// gap goes on while it stays above the rim around it, and one that drops into it ends
// once a vertex lies lower than its nearest rim point by the limit. (Before, the test
// ended at the rim's reach: 0.1 m³ blocks rolled into an 8 m hole in a surveyed slope and
// fell 9 m through it before the depth limit under the terrain's lowest point ended
// them.)
bool hangs_past_rim(const Model& model, const terrain::Surface& surf, const State& s, bool scan) {
  // The bounding sphere with room for the 12-DOF path's strains.
  const double r = 1.25 * model.radius;
  const geometry::Aabb plan{s.position - Vec3::Constant(r), s.position + Vec3::Constant(r)};
  // How far from a vertex its rim point is looked for: 2r (the vertex lies within r of
  // the centroid, the rim within r of the centroid when near_rim), or, off the ground,
  // the centroid's distance to the rim plus 2r.
  double reach = 2.0 * r;
  if (!surf.near_rim(plan)) {
    if (!std::isnan(s.height)) return false;
    const auto centre_rim = nearest_rim_point_anywhere(surf, s.position.x(), s.position.y(), 2.0 * r);
    if (!centre_rim) return false;
    reach = (centre_rim->point - s.position).head<2>().norm() * (1.0 + 1e-9) + 2.0 * r;
    scan = true;
  }
  const double limit = model.penetration_limit();
  // A vertex's rim point lies within `reach` of it in plan, so within that of the plan
  // box, no higher than `top` (Surface::rim_top, raised by far more than the round-off of
  // the depths below): a vertex at or above `floor` lies less than the limit below it,
  // and is not past the rim. (A detailed block rolling off the end of the ground looked
  // at thousands of vertices a step, most of them far above it.)
  const double floor = surf.rim_top(plan.inflated(reach)) - limit;
  const auto past = [&](const Vec3& p) {
    if (p.z() >= floor || surf.height_at(p.x(), p.y())) return false;
    const auto rim = surf.nearest_rim_point(p.x(), p.y(), reach);
    if (!rim) return false;
    const Vec3 n = surf.normal(static_cast<std::size_t>(rim->triangle));
    const double below = rim->point.z() - p.z();
    const double depth = n.z() > 0.1 ? std::min(below, n.dot(rim->point - p)) : below;
    return depth > limit;
  };
  if (scan || model.index == nullptr || !surf.rim_bounds_footprint()) {
    const std::vector<Vec3> vertices = world_vertices(model, s);
    return std::any_of(vertices.begin(), vertices.end(), past);
  }
  // A detailed block over a grid, or a TIN without walls, overhangs or folds
  // (Surface::rim_bounds_footprint): only the vertices of the tree nodes whose plan box
  // may meet the rim or lies off the ground are looked at. The rim of such ground is the
  // whole border of the ground in plan, so a box it does not meet lies wholly on the
  // ground or wholly off it, as its centre does; every vertex of a box wholly on the
  // ground has ground under it and is passed over by the test above. (A block of 20 480
  // faces rolling along the edge of the bench slope spent a sixth of its run on the ground
  // under each vertex.) The boxes are widened by far more than the round-off of the
  // grid's own test of whether a point lies on it. (On a TIN a point within round-off of
  // an inner edge may find no ground in either triangle's test; the scan would then look
  // for the rim there, this walk does not.)
  const Pose pose = pose_of(model, s);
  thread_local std::vector<Vec3> unused;
  const PlacedBlock at(model, pose, unused, false);
  const double widening = 1e-9 * (s.position.head<2>().cwiseAbs().maxCoeff() + model.radius);
  thread_local std::vector<std::int32_t> near;
  near.clear();
  model.index->vertices.query(
      [&](const geometry::Aabb& body) {
        const geometry::Aabb w = at.world_box(body).inflated(widening);
        if (w.lo.z() >= floor) return false;
        if (surf.near_rim(w)) return true;
        const Vec3 c = w.center();
        return !surf.height_at(c.x(), c.y());
      },
      near);
  return std::any_of(near.begin(), near.end(),
                     [&](std::int32_t i) { return past(at.vertex(static_cast<std::size_t>(i))); });
}

}  // namespace detail

namespace {

using namespace detail;

// ½mv² + ½ωᵀJω: the rigid part of the kinetic energy (J).
double rigid_kinetic_energy(const Model& model, const State& s) {
  const Vec3 v = s.velocity.head<3>();
  const Vec3 w = s.velocity.segment<3>(3);
  const Vec3 wb = s.orientation.conjugate() * w;  // body frame
  return 0.5 * model.mass * v.squaredNorm() + 0.5 * wb.dot(model.inertia * wb);
}

double predicted_reach(const Model& model, const State& s, double dt) {
  const double v = s.velocity.head<3>().norm();
  const double w = s.velocity.segment<3>(3).norm();
  double strain = 0.0;
  if (model.dof == DofPath::full12) strain = s.velocity.tail<6>().cwiseAbs().maxCoeff();
  return (v + (w + strain) * model.radius) * dt + 0.5 * model.settings.gravity * dt * dt;
}

// Elastic energy of the block's accumulated strain on the 12-DOF path (J): in flight
// and at contacts the strain vibrates, trading this energy with the kinetic energy of
// the strain rates, so a balance without it would see gains and losses that are neither.
double strain_energy(const Model& model, const State& s) {
  if (model.dof != DofPath::full12) return 0.0;
  const Mat3 e_body = 0.5 * (s.stretch + s.stretch.transpose()) - Mat3::Identity();
  const Mat3 r = s.orientation.toRotationMatrix();
  const Eigen::Matrix<double, 6, 1> e = voigt(r * e_body * r.transpose());
  return 0.5 * model.volume * e.dot(model.elasticity * e);
}

// Kinetic, potential (z = 0 reference), strain and contact-spring energy of the state (J).
double total_energy(const Model& model, const State& s) {
  return mechanical_energy(model, s) + strain_energy(model, s) + s.stored_energy;
}

// The size of the energy terms whose round-off bounds a step's energy balance (J).
double energy_scale(const Model& model, const State& s, double total) {
  const double weight = model.mass * model.settings.gravity;
  return std::abs(total) + std::abs(weight * s.position.z()) + weight * model.radius;
}

// Takes up to `rest` (J) out of springs that hold `energy` (J): returns the factor their
// stretch is to be scaled by (1 when there is nothing to take), books what it removes in
// the state and lowers `rest` by it.
double relax_springs(State& s, double energy, double& rest) {
  if (!(energy > 0.0) || !(rest > 0.0)) return 1.0;
  const double keep = std::sqrt(std::max(0.0, energy - rest) / energy);
  const double removed = energy * (1.0 - keep * keep);
  s.stored_energy -= removed;
  s.energy_removed += removed;
  rest -= removed;
  return keep;
}

// Nothing in the model is a source of energy, but a contact step can still gain some: a
// friction direction that a held contact could not revise, a feature pair found deep
// inside at a fast impact. Whatever the step gained beyond round-off is taken back
// from the kinetic energy (the velocity is scaled, its direction kept), and counted, so
// that a realization can never gain energy it had no source for.
void limit_energy(const Model& model, State& s, double energy_start) {
  const double kinetic = kinetic_energy(model, s);
  // total_energy(model, s), written out to reuse the kinetic energy.
  const double total =
      kinetic + model.mass * model.settings.gravity * s.position.z() + strain_energy(model, s) + s.stored_energy;
  const double excess = total - energy_start;
  const double scale = energy_scale(model, s, energy_start);
  if (!(excess > 1e-10 * scale)) return;
  ++s.counters.energy_limited;
  const double from_motion = std::min(excess, kinetic);
  if (kinetic > 0.0) s.velocity *= std::sqrt((kinetic - from_motion) / kinetic);
  s.energy_removed += from_motion;
  // A gain larger than the motion holds sits in the normal springs: their compression is
  // relaxed (the accepted penetration grows) until they hold no more than was there.
  double rest = excess - from_motion;
  if (!(rest > 0.0)) return;
  const double p = model.stiffness;
  double normal_energy = 0.0;
  for (const Contact& c : s.contacts) normal_energy += 0.5 * p * c.spring_gap * c.spring_gap;
  const double keep_normal = relax_springs(s, normal_energy, rest);
  if (keep_normal < 1.0)
    for (Contact& c : s.contacts) c.spring_gap *= keep_normal;
  // What is left sits in the shear springs of locked contacts: their anchors slip towards
  // the block (friction work) until the springs hold no more than was there.
  if (!(rest > 0.0)) return;
  const double ps = p / model.settings.shear_stiffness_ratio;
  double shear_energy = 0.0;
  for (const Contact& c : s.contacts)
    if (c.anchored && std::isfinite(c.spring_shear)) shear_energy += 0.5 * c.spring_shear * c.spring_shear / ps;
  const double keep_shear = relax_springs(s, shear_energy, rest);
  if (keep_shear < 1.0) {
    const Pose pose = pose_of(model, s);
    for (Contact& c : s.contacts) {
      if (!c.anchored || !std::isfinite(c.spring_shear)) continue;
      const Vec3 sv = pose.centre + pose.map * c.body_anchor - c.ground_anchor;
      c.ground_anchor += (1.0 - keep_shear) * (sv - c.normal * c.normal.dot(sv));
      c.spring_shear *= keep_shear;
    }
  }
  // And what is left after that raised the block: the rise is taken back (a settled
  // block's step lifted it 1.6 µm, 0.04 J, with no motion or spring left to take it
  // from). The next step's contacts take the lowered pose's extra depth as accepted
  // penetration (carry_contacts), so it is not pushed out again.
  if (!(rest > 0.0) || !(model.settings.gravity > 0.0)) return;
  s.position.z() -= rest / (model.mass * model.settings.gravity);
  s.energy_removed += rest;
}

void end_with(State& s, EndReason reason) {
  if (s.end == EndReason::running) s.end = reason;
}

// The total energy -- kinetic, potential and held by the contact springs -- never rises
// beyond round-off of its terms: nothing in the model is a source.
void check_energy(const Model& model, State& s) {
  const double total = total_energy(model, s);
  if (std::isfinite(s.checked_energy)) {
    const double gain = total - s.checked_energy;
    s.max_energy_gain = std::max(s.max_energy_gain, gain);
    if (gain > 1e-9 * energy_scale(model, s, total)) ++s.counters.energy_violations;
  }
  s.checked_energy = total;
}

// A trajectory sample at time `t` (s) if one is due: centroid position (m), velocity
// (m/s), height above the terrain (m, NaN off it) and mechanical energy (J).
void sample_trajectory(const Model& model, State& s, double t, const Vec3& p, const Vec3& v, double height,
                       double energy) {
  if (model.settings.trajectory_interval <= 0.0 || t + 1e-12 < s.next_sample_time) return;
  s.trajectory.push_back(TrajectorySample{t, p, v, height, energy});
  s.next_sample_time += model.settings.trajectory_interval;
}

// The centroid `height` (m) above the terrain triangle `triangle` below it, at the end of
// a step or at a nominal step inside a long flight step: the jump maxima.
void note_jump(const terrain::Surface& surf, State& s, double height, std::int32_t triangle) {
  // Jumps count from the first real touch of the terrain (a closed contact) on: the
  // release drop is no jump, nor is a step that only searched for contacts. Beside the
  // vertical height, the distance to the plane of the triangle below, along its normal
  // (on a slope the vertical height overstates a jump by 1/cos of the slope).
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

// Whether the block ended its last step touching the ground: a contact step with a
// closed contact.
bool touching(const State& s) {
  return s.last_step_contact && std::any_of(s.contacts.begin(), s.contacts.end(),
                                            [](const Contact& c) { return c.mode != ContactMode::open; });
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
                    s.kinetic + model.mass * model.settings.gravity * s.position.z());
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

// The contact search distance of a step of length h: twice the farthest any point of
// the block can move in it, and at least the step control's displacement bound (m).
double search_reach(const Model& model, const State& s, double h) {
  return std::max(2.0 * predicted_reach(model, s, h), model.max_step_displacement());
}

// The near search distance of a contact step of length h (m), or 0 for none: every
// candidate the full search finds beyond it is set aside (its gap is more than `scale`
// times what its point moves at the step-start motion, point_reach), so a detailed rigid
// block searches its vertex–triangle and edge–ridge pairs only within it, and the step
// looks beyond it only when its solution moves some point that far (contact_step). The
// full distance has a floor (the step control's displacement bound) that slow motion
// stays far below: for a rolling sphere of 5 120 triangles most candidates lie between
// the two. Contact points lie within the radius of the centroid, so their motion is at
// most predicted_reach; a micro-gap (1e-6 radius) carried from the last step is always
// within it. Until the realization's friction is drawn (from the first candidate of the
// full search, contact_step) the search is full.
double near_reach(const Model& model, const State& s, double h, double scale) {
  if (model.index == nullptr || model.dof != DofPath::rigid6 || !s.friction_drawn || !std::isfinite(scale) ||
      !(scale > 0.0))
    return 0.0;
  // At least twice the reach, so that the flight test's free motion keeps whatever lies
  // beyond it open too.
  const double near = std::max(std::max(2.0, scale) * predicted_reach(model, s, h) * (1.0 + 1e-6), 1e-5 * model.radius);
  return near < search_reach(model, s, h) ? near : 0.0;
}

// How far the block point x (world, m) can move in a step of length h at the step-start
// motion, `scale` times over (m): its velocity, the strain rates' bound and gravity, as
// predicted_reach for the whole block. A contact candidate further from the ground than
// this is set aside for the step; the step's solution is checked against it.
double point_reach(const Model& model, const State& s, const Vec3& x, double h, double scale) {
  const Vec3 r = x - s.position;
  const Vec3 v = s.velocity.head<3>() + s.velocity.segment<3>(3).cross(r);
  double strain = 0.0;
  if (model.dof == DofPath::full12) strain = s.velocity.tail<6>().cwiseAbs().maxCoeff();
  return scale * ((v.norm() + strain * model.radius) * h + 0.5 * model.settings.gravity * h * h);
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

// Calls visit(normal, corners, box) for every terrain triangle whose box meets `box`
// (and maybe a few more), until it returns false: from the patch under the block when
// that holds the box, else from the triangles gathered for an earlier flight box that
// holds it; a new gathering takes a margin so that the next steps' boxes fall inside.
template <class Visit>
void for_each_triangle_near(const Model& model, const Ground& ground, State& s, const geometry::Aabb& box,
                            Visit&& visit) {
  const TerrainPatch& patch = s.patch;
  if (patch.surface == ground.surface && !patch.box.empty() && patch.box.contains(box.lo) &&
      patch.box.contains(box.hi)) {
    for (const TerrainPatch::Triangle& t : patch.triangles)
      if (t.box.overlaps(box) && !visit(t.normal, t.p, t.box)) return;
    return;
  }
  FlightPatch& flight = s.flight_patch;
  if (flight.surface != ground.surface || flight.box.empty() || !flight.box.contains(box.lo) ||
      !flight.box.contains(box.hi)) {
    flight.surface = ground.surface;
    flight.box = box.inflated(std::max(model.radius, 0.5 * box.extent().maxCoeff()));
    flight.triangles.clear();
    s.scratch_triangles.clear();
    ground.surface->triangles_in_box(flight.box, s.scratch_triangles);
    for (std::int32_t t : s.scratch_triangles) {
      FlightPatch::Triangle d;
      d.p = ground.surface->triangle_vertices(static_cast<std::size_t>(t));
      for (const Vec3& p : d.p) d.box.add(p);
      d.normal = ground.surface->normal(static_cast<std::size_t>(t));
      flight.triangles.push_back(d);
    }
  }
  for (const FlightPatch::Triangle& t : flight.triangles)
    if (t.box.overlaps(box) && !visit(t.normal, t.p, t.box)) return;
}

// Whether no terrain triangle can be touched before time + h. A triangle whose box
// the swept bounding sphere misses is out of reach; one whose box it meets is still out
// of reach when every vertex of the block (`block`, world, m; null to skip this test)
// lies farther above the triangle's plane than any point of the block can move in the
// horizon: the block is the convex hull of its vertices or inside it, so nothing of it
// can cross that plane in time; or when the block and the triangle are that far apart
// along the direction from the block's centroid to the triangle (separation). The
// block test serves the 12-DOF path (the rigid path has clear_time), whose strains
// vibrate: the clearance asked is the contact search distance of the horizon (twice the
// farthest a point can move on the free parabola and spin, at least the displacement
// limit).
//
// Both horizons of the flight test are decided in one pass: `h_short` ≤ `h_long`, and the
// box of the shorter lies inside the longer's (the box of a parabola's arc is spanned by
// its ends and apex). Returns the longer horizon that passes, h_long or h_short, or 0.
double clear_horizon(const Model& model, const Ground& ground, State& s, double h_long, double h_short,
                     const std::vector<Vec3>* block) {
  const geometry::Aabb box_long = swept_sphere_box(model, s, h_long).inflated(model.max_step_displacement());
  const geometry::Aabb box_short =
      h_short == h_long ? box_long : swept_sphere_box(model, s, h_short).inflated(model.max_step_displacement());
  const double reach_long = block != nullptr ? search_reach(model, s, h_long) : 0.0;
  const double reach_short = block != nullptr && h_short != h_long ? search_reach(model, s, h_short) : reach_long;
  bool long_clear = true, short_clear = true;
  // One triangle that meets the long box: whether it is out of reach over each horizon.
  const auto judge = [&](const Vec3& normal, const std::array<Vec3, 3>& corners, const geometry::Aabb& tbox) {
    const bool in_short = tbox.overlaps(box_short);
    if (block == nullptr) {
      long_clear = false;
      short_clear = short_clear && !in_short;
      return;
    }
    // The block's least height above the triangle's plane, and (when that is not enough)
    // its separation along the direction to the triangle, both distances it cannot cover.
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vec3& v : *block) lowest = std::min(lowest, normal.dot(v - corners[0]));
    double apart = std::numeric_limits<double>::quiet_NaN();
    const auto clears = [&](double reach) {
      if (lowest > reach) return true;
      if (std::isnan(apart)) apart = separation(*block, s.position, corners);
      return apart > reach;
    };
    long_clear = long_clear && clears(reach_long);
    short_clear = short_clear && (!in_short || clears(reach_short));
  };
  for_each_triangle_near(model, ground, s, box_long, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
                                                        const geometry::Aabb& tbox) {
    judge(normal, corners, tbox);
    return long_clear || short_clear;
  });
  return long_clear ? h_long : short_clear ? h_short : 0.0;
}

// How long (s, at most h) the rigid block in free flight provably stays clear of the
// terrain: a conservative advancement (FlightBound) over the triangles that the swept
// bounding sphere of the horizon h can meet; some time below a step once one triangle
// allows less. `at`: the block at its pose (a detailed block is bounded through its
// vertex tree, FlightBound's second form).
double clear_time(const Model& model, const Ground& ground, State& s, double h, const PlacedBlock& at) {
  const geometry::Aabb box = swept_sphere_box(model, s, h).inflated(model.max_step_displacement());
  thread_local FlightBound bound;
  const double round_off = 1e-9 * (s.position.cwiseAbs().maxCoeff() + model.radius);
  // Free flight is the exact parabola whatever dynamic_coefficient is (apply_displacement).
  const bool damped = false;
  if (at.index() == nullptr)
    bound.reset(at.vertices(), s.position, s.velocity.head<3>(), s.velocity.segment<3>(3), model.settings.gravity,
                damped, round_off);
  else
    bound.reset(at, s.velocity.head<3>(), s.velocity.segment<3>(3), model.settings.gravity, damped, round_off);
  double clear = h;
  // Less than one step is no flight: the search decides (flight_step), so the triangles
  // left need no bound, and a time below it need not be exact.
  const double enough = s.dt;
  bound.settle_below(enough);
  if (at.index() == nullptr) {
    for_each_triangle_near(model, ground, s, box, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
                                                      const geometry::Aabb&) {
      clear = std::min(clear, bound.triangle_time(normal, corners, clear));
      return clear >= enough;
    });
    return clear;
  }
  // A detailed block's bound searches its vertex tree per triangle. The triangles are
  // taken in the order of a bound of their time in constant time (from the block's box),
  // the least first, and those whose quick bound already reaches the time found are not
  // searched at all: the time is the same minimum, and near the ground the triangle that
  // ends the flight is usually the first searched.
  struct Near {
    double quick;
    std::size_t order;
    Vec3 normal;
    std::array<Vec3, 3> corners;
  };
  thread_local std::vector<Near> near;
  near.clear();
  for_each_triangle_near(model, ground, s, box, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
                                                    const geometry::Aabb&) {
    const double quick = bound.quick_triangle_time(normal, corners, h);
    if (quick < h) near.push_back({quick, near.size(), normal, corners});
    return true;
  });
  std::sort(near.begin(), near.end(),
            [](const Near& a, const Near& b) { return a.quick < b.quick || (a.quick == b.quick && a.order < b.order); });
  for (const Near& t : near) {
    if (t.quick >= clear || clear < enough) break;
    clear = std::min(clear, bound.triangle_time(t.normal, t.corners, clear));
  }
  return clear;
}

// Applies an accepted displacement d (N components) to the state.
// The velocity carried into the next step is k_d·v₁ (dynamic_coefficient) after a contact
// step, v₁ itself after a flight step (`damped` false): the coefficient damps contact
// steps only, and free flight stays the exact parabola whatever its value. (Damping
// flight too held a block released with k_d = 0 in the air, where the rest test then
// ended it, and took one factor per flight step whatever its length.)
template <int N>
void apply_displacement(const Model& model, State& s, const VecN<N>& d, double dt, bool strain_frozen = false,
                        bool damped = true) {
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
  s.velocity.template head<N>() = damped ? model.settings.dynamic_coefficient * v1 : v1;
  if constexpr (N == 12) {
    if (strain_frozen) s.velocity.template tail<6>().setZero();
  }
}

// The rigid displacement of free flight over dt: the exact parabola and the exact spin.
Eigen::Matrix<double, 6, 1> free_displacement(const Model& model, const State& s, double dt) {
  Eigen::Matrix<double, 6, 1> d;
  d.head<3>() = s.velocity.head<3>() * dt + 0.5 * gravity_vector(model) * dt * dt;
  d.tail<3>() = s.velocity.segment<3>(3) * dt;
  return d;
}

// Whether the free motion keeps every candidate in `contacts` open through a step of
// length dt. A candidate's gap on the rigid free motion, linear in the rotation as the
// contact step computes it, is g(t) = gap + (n·(v + ω × r))·t + ½(n·g)·t²: the contact
// step's own test (a step whose contacts all stay open is the free motion).
bool stays_open(const Model& model, const State& s, const std::vector<Contact>& contacts, double dt) {
  const Vec3 v = s.velocity.head<3>();
  const Vec3 w = s.velocity.segment<3>(3);
  const Vec3 g = gravity_vector(model);
  for (const Contact& c : contacts) {
    const double rate = c.normal.dot(v + w.cross(c.point - s.position));
    const double curvature = c.normal.dot(g);
    const auto gap_at = [&](double t) { return c.gap + rate * t + 0.5 * curvature * t * t; };
    double least = gap_at(dt);
    // A gap that turns back (ground facing down) is least inside the step.
    if (curvature > 0.0 && rate < 0.0 && -rate / curvature < dt) least = std::min(least, gap_at(-rate / curvature));
    if (!(least > 0.0)) return false;
  }
  return true;
}

// Aims `pass` at a rigid detailed block's near search from `pose` for a step of length h
// with the set-aside scale `scale` (PassOver): the step-start motion in the body frame,
// the fall and the round-off allowance. The keep lists are left as they are.
void aim_pass_over(const Model& model, const State& s, const Pose& pose, double h, double scale,
                   detail::PassOver& pass) {
  pass.velocity = pose.map.transpose() * s.velocity.head<3>();
  pass.spin = pose.map.transpose() * s.velocity.segment<3>(3);
  pass.h = h;
  pass.fall = 0.5 * model.settings.gravity * h * h;
  pass.scale = scale;
  pass.allowance = scale * h * s.velocity.segment<3>(3).norm() * 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius);
}

// Whether no contact can close in the next step of length dt, by the contact search a
// contact step would make from the block placed at its pose (`at`): it finds no
// candidate, or (rigid path, no contact carried from the last step) the free motion
// keeps all it finds open. The candidates stay in
// scratch_contacts, and a contact step from this pose reuses them.
//
// A detailed rigid block with no contact carried searches only within the near distance
// (near_reach): a candidate beyond it stays open through the step on the free motion,
// which moves no point by more than half of it, so the answer is the same.
//
// That near search passes over the candidates a contact step from this pose would set
// aside (PassOver; none is kept, as no contact is carried). The answer is the same: the
// gap of each is more than set_aside_scale (at least 1) times its point's motion at the
// step-start motion, which the free motion's gap (stays_open) takes off at most once. A
// contact step from this pose takes what was passed over (scratch_passed) for its check
// of them, as if its own search had passed over them.
bool beyond_contact_reach(const Model& model, const Ground& ground, State& s, const PlacedBlock& at, double dt) {
  s.scratch_contacts.clear();
  const double reach = search_reach(model, s, dt);
  const double near = s.contacts.empty() ? near_reach(model, s, dt, set_aside_scale) : 0.0;
  detail::PassOver pass;
  const bool passing = near > 0.0 && detail::pass_over_set_aside && set_aside_scale >= 1.0;
  if (passing) {
    static const std::vector<std::int32_t> none;
    pass.keep = pass.keep_edges = pass.keep_terrain = &none;
    aim_pass_over(model, s, at.pose(), dt, set_aside_scale, pass);
  }
  detect_contacts(at, *ground.surface, reach, model.penetration_limit(), s.patch, s.scratch_contacts, near,
                  passing ? &pass : nullptr);
  s.scratch_reach = near > 0.0 ? near : reach;
  s.scratch_passed = pass.passed;
  s.scratch_least_gap = pass.least_gap;
  s.counters.flight_passed += pass.passed;
  if (s.scratch_contacts.empty()) return true;
  // A contact carried from the last step (anchored, a micro-gap open) keeps its shear
  // spring's memory only through a contact step.
  return model.dof == DofPath::rigid6 && s.contacts.empty() && stays_open(model, s, s.scratch_contacts, dt);
}

// What nominal flight steps sample, at the k − 1 nominal steps of length dt inside a long
// one, on the exact parabola: the jump maxima and the trajectory. The records are those
// of nominal steps whether or not a trajectory is asked for.
void sample_flight(const Model& model, const Ground& ground, State& s, double dt, int k) {
  const bool trajectory = model.settings.trajectory_interval > 0.0;
  if (!s.touched && !trajectory) return;
  const terrain::Surface& surf = *ground.surface;
  const Vec3 g = gravity_vector(model);
  const Vec3 p0 = s.position;
  const Vec3 v0 = s.velocity.head<3>();
  const double energy = trajectory ? mechanical_energy(model, s) : 0.0;  // constant in flight
  for (int j = 1; j < k; ++j) {
    const double tau = j * dt;
    const double t = s.time + tau;
    const Vec3 p = p0 + v0 * tau + 0.5 * g * tau * tau;
    const auto hit = surf.height_at(p.x(), p.y());
    const double height = hit ? p.z() - hit->z : std::numeric_limits<double>::quiet_NaN();
    if (hit) note_jump(surf, s, height, hit->triangle);
    sample_trajectory(model, s, t, p, v0 + g * tau, height, energy);
  }
}

// A flight step, if the block is clear of the terrain for at least one step: returns its
// length (s), 0 if the block needs a contact step.
double flight_step(const Model& model, const Ground& ground, State& s) {
  const double dt = s.dt;
  s.scratch_reach = -1.0;
  if (s.time + dt > s.clear_until) {
    // Every test below passes for a horizon only if it passes for any shorter one (the
    // boxes and distances grow with it): the longest that passes of 64, 8 and 1 steps
    // is found by testing 8 first. Right after contact the long horizons would fail
    // anyway: one step is tested.
    const bool after_contact = s.counters.steps > 0 && s.last_step_contact;
    const double first = after_contact ? dt : 8.0 * dt;
    // First the swept bounding sphere against the terrain's triangle boxes (no geometry
    // of the block); then the block against the triangles whose boxes it meets: on the
    // rigid path for as long as FlightBound proves it clear of each (up to 64 steps; the
    // flight then runs to the last step that ends before that time; a detailed block
    // through its vertex tree), on the 12-DOF path, for a block of few vertices (a
    // detailed one is left to the search), whether its vertices lie farther above their
    // planes than the contact search distance of 8 or 1 steps; then, near the ground, the
    // contact search itself (one step, below).
    double horizon = clear_horizon(model, ground, s, first, dt, nullptr);
    if (horizon == 8.0 * dt && clear_horizon(model, ground, s, 64.0 * dt, 64.0 * dt, nullptr) > 0.0)
      horizon = 64.0 * dt;
    std::optional<Pose> pose;
    std::optional<PlacedBlock> at;
    if (horizon == 0.0 && (model.index == nullptr || model.dof == DofPath::rigid6)) {
      pose = pose_of(model, s);
      at.emplace(model, *pose, s.scratch_vertices, false, &s.scratch_box);
      if (model.dof == DofPath::rigid6) {
        const double clear = clear_time(model, ground, s, 64.0 * dt, *at);
        if (clear >= dt) horizon = clear;
      } else {
        horizon = clear_horizon(model, ground, s, first, dt, &s.scratch_vertices);
      }
    }
    // The search sees a block vertex only against the triangles it lies over (in plan or
    // along their normals): near a concave kink a vertex moving over the rising side is
    // found only once it is there. A contact step therefore searches again at every
    // step and moves no vertex farther than the step control's bound, and so does a
    // flight that the search decides: one step, in which no point of the block can move
    // farther. (Over 8 steps, a 1 m³ cube rolling slowly on the roughest bench slope let
    // such vertices in by up to a few centimetres, which the next contact step then
    // accepted as penetration: its overlap grew step by step to 0.7 m.)
    if (horizon == 0.0 && predicted_reach(model, s, dt) <= model.max_step_displacement()) {
      if (!at) {
        pose = pose_of(model, s);
        at.emplace(model, *pose, s.scratch_vertices, false, &s.scratch_box);
      }
      if (beyond_contact_reach(model, ground, s, *at, dt)) horizon = dt;
    }
    if (horizon == 0.0) return 0.0;
    s.clear_until = s.time + horizon;
  }
  double h = dt;
  if (model.dof == DofPath::rigid6) {
    // The exact parabola (Shi's scheme reproduces it to round-off) and the exact spin,
    // whatever the step: within the time the block is proven clear it takes whole
    // nominal steps of up to flight_step_ratio at once, ending no later than that time or
    // the time limit (trajectory samples inside it come from sample_flight, so asking for
    // a trajectory does not change the steps).
    const double whole = std::floor((std::min(s.clear_until, s.time_limit) - s.time) / dt);
    const int k = static_cast<int>(std::clamp(whole, 1.0, std::floor(model.settings.flight_step_ratio)));
    h = k * dt;
    if (k > 1) sample_flight(model, ground, s, dt, k);
    apply_displacement<6>(model, s, free_displacement(model, s, h), h, false, false);
  } else {
    // Strains keep oscillating in flight: solve the contact-free 12-DOF step. The
    // stretch update is not linear in the step, so the vibration's energy drifts by a
    // few 1e-9 of the block's potential energy per step; like a contact step's, a gain
    // is taken back.
    const double energy_start = mechanical_energy(model, s) + strain_energy(model, s);
    std::vector<Contact> none;
    VecN<12> d;
    solve_step<12>(model, pose_of(model, s), s, dt, 0.0, none, d, s.times);
    apply_displacement<12>(model, s, d, dt, false, false);
    s.stored_energy = 0.0;
    limit_energy(model, s, energy_start);
  }
  ++s.counters.flight_steps;
  s.last_step_contact = false;
  s.stored_energy = 0.0;
  // Grow back towards the nominal step after a cut, as a contact step does.
  s.dt = std::min(model.settings.time_step, dt * 1.3);
  return h;
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

template <int N>
void contact_step(const Model& model, const Ground& ground, State& s) {
  const Settings& set = model.settings;
  const bool timing = set.time_phases;
  const double limit = model.max_step_displacement();
  const double depth = model.penetration_limit();
  const Vec3 v_start = s.velocity.head<3>();
  // The kinetic energy once for both (total_energy written out).
  const double kinetic_now = kinetic_energy(model, s);
  const double kinetic_start = model.dof == DofPath::rigid6 ? kinetic_now : rigid_kinetic_energy(model, s);
  const double energy_start =
      kinetic_now + model.mass * model.settings.gravity * s.position.z() + strain_energy(model, s) + s.stored_energy;
  double dt = s.dt;
  std::vector<Contact>& contacts = s.scratch_contacts;
  const Pose pose = pose_of(model, s);
  const PlacedBlock at(model, pose, s.scratch_vertices, false, &s.scratch_box);
  double friction = s.friction;
  VecN<N> d;
  bool impact_cut = false;
  double dt_before_touch = 0.0;  // the step a cut to the moment of touch shortened (s)
  // full12: the constant-strain mode cannot carry an impact (it would keep most of the
  // impact energy as an undamped vibration, docs/dda.md), so unless asked its increments
  // are held at zero while the block arrives from flight and during impact episodes;
  // the restitution law accounts for the impact's losses, as on the rigid path.
  const bool arriving = std::none_of(s.contacts.begin(), s.contacts.end(),
                                     [](const Contact& c) { return c.mode != ContactMode::open; });
  const bool freeze_strain = N == 12 && !set.impact_strains && (arriving || (s.episode.active && s.episode.impact));
  thread_local std::vector<ContactMode> start_modes;
  // Candidates within the search distance whose gap is more than twice what their point
  // moves at the step-start motion (point_reach; set_aside_scale) are set aside, unless
  // they carry a state from the last step: they stay open through the open–close
  // iteration and cost only the check of the solution below. A solution that would
  // close one of them is solved again with the margin widened (8 times the motion, then
  // every candidate in the solve), so the step accepts only solutions in which every
  // candidate found is in a consistent state. A fine mesh near the ground has most of
  // its candidates out of such reach: a rolling sphere of 5 120 triangles solves with a
  // third of them.
  // What the check after the solve reads of a candidate set aside (a contact is some 200
  // bytes, and most candidates of a fine mesh are set aside).
  struct Aside {
    Vec3 point, normal;
    double gap, gap_offset;
  };
  thread_local std::vector<Aside> set_aside;
  thread_local std::vector<std::uint8_t> carried;
  double aside_scale = set_aside_scale;
  std::size_t found = 0;
  double near = 0.0;
  thread_local std::vector<Contact> far;
  thread_local std::vector<std::uint8_t> far_carried;
  // Carries the last step's contacts into `into` (`matched`: per candidate, whether it
  // carries one); whether every one of them is carried.
  const auto carry = [&](std::vector<Contact>& into, std::vector<std::uint8_t>& matched) {
    return carry_contacts(s.contacts, into, pose, friction, model.stiffness / set.shear_stiffness_ratio,
                          search_reach(model, s, dt), model.radius, &matched);
  };
  // The search at the full distance into `into`, carried.
  const auto search_in_full = [&](std::vector<Contact>& into, std::vector<std::uint8_t>& matched) {
    into.clear();
    detail::detect_contacts(at, *ground.surface, search_reach(model, s, dt), depth, s.patch, into);
    carry(into, matched);
  };
  // Whether a candidate is set aside from the solve (`carries`: it carries a contact).
  const auto goes_aside = [&](const Contact& c, bool carries) {
    return !carries && c.mode == ContactMode::open && c.gap > point_reach(model, s, c.point, dt, aside_scale);
  };
  // A near search passes over the vertex–triangle, edge–ridge and terrain vertex
  // candidates the step would set aside (PassOver): most of a fine mesh's candidates near
  // the ground. The vertices, edges and terrain vertices of the last step's contacts are
  // never passed over (they may carry a state). Off after a solve whose check of them as a
  // group fails: the step is then solved again with every candidate, as if they had never
  // been passed over.
  thread_local std::vector<std::int32_t> keep, keep_edges, keep_terrain;
  bool pass_over = N == 6 && model.index != nullptr && detail::pass_over_set_aside;
  detail::PassOver pass;
  if (pass_over) {
    keep.clear();
    keep_edges.clear();
    keep_terrain.clear();
    for (const Contact& c : s.contacts) {
      if (c.kind == ContactKind::vertex_face) keep.push_back(c.block_feature);
      if (c.kind == ContactKind::edge_edge) keep_edges.push_back(c.block_feature);
      if (c.kind == ContactKind::face_vertex) keep_terrain.push_back(static_cast<std::int32_t>(c.terrain_feature));
    }
    std::sort(keep.begin(), keep.end());
    std::sort(keep_edges.begin(), keep_edges.end());
    std::sort(keep_terrain.begin(), keep_terrain.end());
    pass.keep = &keep;
    pass.keep_edges = &keep_edges;
    pass.keep_terrain = &keep_terrain;
  }
  for (;;) {
    pass.restart();
    {
      PhaseTimer timer(timing, s.times.detect);
      const double reach = search_reach(model, s, dt);
      // A detailed rigid block searches within the near distance first (near_reach), as
      // long as the set-aside margin has not been widened.
      near = aside_scale == set_aside_scale ? near_reach(model, s, dt, aside_scale) : 0.0;
      const double searched = near > 0.0 ? near : reach;
      // The flight test may have searched from this pose at this distance already.
      if (searched != s.scratch_reach) {
        contacts.clear();
        const bool passing = pass_over && near > 0.0;
        if (passing) aim_pass_over(model, s, pose, dt, aside_scale, pass);
        detail::detect_contacts(at, *ground.surface, reach, depth, s.patch, contacts, near, passing ? &pass : nullptr);
      } else if (pass_over && near > 0.0) {
        // The flight test's search, which passed over the same candidates.
        pass.passed = s.scratch_passed;
        pass.least_gap = s.scratch_least_gap;
      }
      s.scratch_reach = -1.0;
      if (!s.friction_drawn && !contacts.empty())
        friction = mean_friction(material_of(ground, contacts.front().triangle));
      if (!carry(contacts, carried) && near > 0.0) {
        // A contact of the last step that the near search did not find may lie beyond
        // it, with a state to carry: search in full.
        near = 0.0;
        pass.restart();
        search_in_full(contacts, carried);
      }
      found = contacts.size() + pass.passed;
      set_aside.clear();
      if (std::isfinite(aside_scale)) {
        std::size_t kept = 0;
        for (std::size_t i = 0; i < contacts.size(); ++i) {
          Contact& c = contacts[i];
          if (goes_aside(c, carried[i] != 0)) {
            set_aside.push_back({c.point, c.normal, c.gap, c.gap_offset});
          } else {
            if (kept != i) contacts[kept] = std::move(c);
            ++kept;
          }
        }
        contacts.resize(kept);
      }
    }
    start_modes.clear();
    for (const Contact& c : contacts) start_modes.push_back(c.mode);
    const StepOutcome outcome = solve_step<N>(model, pose, s, dt, friction, contacts, d, s.times, freeze_strain,
                                                  arriving || (s.episode.active && s.episode.impact));
    if constexpr (N == 6) {
      if (pass.passed > 0 && outcome.converged && d.allFinite()) {
        // The candidates passed over, as a group: a point r moves by at most h·|v + ω × r|
        // + E, E = |d_t − h·v| + |θ − h·ω|·radius, and one passed over had a gap beyond
        // twice the first term, so it closes only if its gap is below 2E. If the least of
        // their gaps is not beyond that, the step is solved again without passing over,
        // and each is checked on its own below, as it would have been.
        const Vec3 v = s.velocity.template head<3>(), w = s.velocity.template segment<3>(3);
        const double e = (d.template head<3>() - dt * v).norm() + (d.template segment<3>(3) - dt * w).norm() * model.radius;
        if (!(2.0 * e * (1.0 + 1e-9) < pass.least_gap)) {
          pass_over = false;
          ++s.counters.unpassed_steps;
          continue;
        }
      }
    }
    s.counters.open_close_iterations += static_cast<std::uint64_t>(outcome.iterations);
    s.counters.held_contacts += static_cast<std::uint64_t>(outcome.held);
    if (!d.allFinite()) {
      end_with(s, EndReason::non_finite);
      return;
    }
    // The open–close iteration's own test of an open contact (solve_step). On the rigid
    // path a point r from the centre moves by at most |d_t| + |θ|·|r|, and a gap beyond
    // that (with 1e-9 of it for the round-off of the test's six products) cannot close:
    // most candidates set aside are passed over so, without the test.
    const double shift = d.template head<3>().norm();
    const double turn2 = N == 6 ? d.template segment<3>(3).squaredNorm() : 0.0;
    const auto closes = [&](const auto& c) {
      const Vec3 r = c.point - pose.centre;
      if constexpr (N == 6) {
        const double room = (c.gap - c.gap_offset) * (1.0 - 1e-9) - shift;
        if (room > 0.0 && room * room > turn2 * r.squaredNorm() * (1.0 + 1e-9)) return false;
      }
      const VecN<N> gn = dof_matrix<N>(r).transpose() * c.normal;
      return c.gap - c.gap_offset + gn.dot(d) < 0.0;
    };
    bool widen = outcome.converged && std::any_of(set_aside.begin(), set_aside.end(), closes);
    if (outcome.converged && !widen && near > 0.0) {
      // After a near search: a candidate beyond the near distance (open, uncarried, gap ≥
      // near) closes only if its point moves by more than that; no point of the rigid
      // block moves by more than |d_t| + |θ|·radius. If some may, the full search finds
      // them, and those it sets aside are checked as above (the kept ones are those of
      // the near search), exactly as if it had been searched in the first place.
      PhaseTimer timer(timing, s.times.detect);
      const double moved = shift + d.template segment<3>(3).norm() * model.radius;
      if (!(moved < near)) {
        ++s.counters.far_searches;
        search_in_full(far, far_carried);
        for (std::size_t i = 0; i < far.size() && !widen; ++i)
          widen = goes_aside(far[i], far_carried[i] != 0) && closes(far[i]);
      }
    }
    if (widen) {
      aside_scale = aside_scale < 8.0 ? std::max(8.0, 4.0 * aside_scale) : std::numeric_limits<double>::infinity();
      ++s.counters.widened_steps;
      continue;
    }
    double factor = 1.0;
    if (!outcome.converged) {
      factor = 0.3;
    } else {
      const double moved = max_vertex_displacement<N>(at, d, limit);
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
        dt_before_touch = dt;
        dt = toi;
        ++s.counters.impact_cuts;
        continue;
      }
    }
    if (factor == 1.0 && dt > set.min_time_step && set.max_step_energy_gain > 0.0) {
      // The step's energy balance is its error estimate: nothing in the model is a source,
      // so a solution that gains more than `max_step_energy_gain` (1 %) of the kinetic
      // energy plus m·g·radius is wrong -- an open–close iteration that never settled, a
      // feature pair crossing a terrain edge deep inside -- and is redone with a shorter
      // step; only at the smallest one does the energy limiter take the gain back.
      const double gain = energy_after<N>(model, s, pose, contacts, d, dt, freeze_strain) - energy_start;
      if (gain > set.max_step_energy_gain * (kinetic_now + model.mass * set.gravity * model.radius)) {
        factor = 0.3;
        ++s.counters.energy_cuts;
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
  s.counters.contacts += found;
  s.counters.set_aside_contacts += found - contacts.size();
  if (!s.friction_drawn) s.friction = friction;

  PhaseTimer timer(timing, s.times.update);
  // Keep the closed contacts with the state they end the step in, and the memory of
  // those that opened by less than a micro-gap (the penalty spring's own oscillation).
  const double p = model.stiffness;
  const double ps_end = p / set.shear_stiffness_ratio;
  const double keep_gap = 1e-6 * model.radius;
  s.contacts.clear();
  bool any_closed = false;
  // The contact closing in this step whose point approaches the ground fastest (along
  // its normal, translation and spin, at the step start), if that is at an impact's
  // speed: its approach (m/s), the kinetic energy of that approach on the block's
  // effective mass at the point (J), normal and triangle.
  double arrival_speed = set.impact_min_normal_speed;
  double arrival_energy = 0.0;
  Vec3 arrival_normal = Vec3::Zero();
  std::int32_t arrival_triangle = -1;
  // The fastest point approach of any contact closing in this step (m/s) and its energy
  // (J), for an episode that starts with this step.
  double closing_speed = 0.0;
  double closing_energy = 0.0;
  // An impact is a rigid-body event on both DOF paths (the 12-DOF path holds its strains
  // through it, and the law acts on the rigid velocity): approaches and the effective
  // mass at a point are those of the rigid block.
  std::optional<Cholesky6> mass_llt;
  const auto approach_energy = [&](const VecN<6>& gn, double speed) {
    if (!mass_llt) mass_llt.emplace(current_mass<6>(model, pose));
    const double inverse_mass = gn.dot(mass_llt->solve(gn));
    return inverse_mass > 0.0 ? 0.5 * speed * speed / inverse_mass : 0.0;
  };
  const VecN<6> v_start_rigid = s.velocity.head<6>();
  // Closed contacts at the end of the step (world point, normal): whether one still
  // approaches the ground at an impact's speed decides when an impact has rebounded.
  thread_local std::vector<std::pair<Vec3, Vec3>> closed_end;
  closed_end.clear();
  double spring_energy = 0.0;
  // Contacts closed through the whole step: their end points (world), normals and, for
  // those that end it locked, the friction impulse they can carry (settle_contacts).
  thread_local std::vector<Persistent> persistent;
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
      const double stretch = end_springs<N>(pose, c, d).stretch;
      c.spring_shear = ps_end * stretch;
      spring_energy += 0.5 * ps_end * stretch * stretch;
    }
    if (c.mode == ContactMode::sliding) {
      const Vec3 slip = du - c.normal * c.normal.dot(du);
      if (slip.norm() > 1e-12) c.slip_direction = slip.normalized();
    }
    any_closed = true;
    const VecN<6> gn = dof_matrix<6>(c.point - pose.centre).transpose() * c.normal;
    const double point_approach = -gn.dot(v_start_rigid);
    const bool arrives = start_modes[i] == ContactMode::open && point_approach >= arrival_speed;
    const bool closes_fastest = start_modes[i] == ContactMode::open && point_approach > closing_speed;
    if (arrives || closes_fastest) {
      const double energy = approach_energy(gn, point_approach);
      if (arrives) {
        arrival_speed = point_approach;
        arrival_energy = energy;
        arrival_normal = c.normal;
        arrival_triangle = c.triangle;
      }
      if (closes_fastest) {
        closing_speed = point_approach;
        closing_energy = energy;
      }
    }
    spring_energy += 0.5 * p * std::min(0.0, g) * std::min(0.0, g);
    // A contact whose point still approaches at an impact's speed is in an impact's
    // compression, not at rest on the ground: it is not settled.
    if (start_modes[i] != ContactMode::open && point_approach < set.impact_min_normal_speed)
      persistent.push_back({c.point + du, c.normal,
                            c.mode == ContactMode::locked ? friction * c.normal_force * dt : 0.0});
    closed_end.emplace_back(c.point + du, c.normal);
    s.contacts.push_back(c);
  }
  // A step whose contacts all stay open is free motion, and is not damped either.
  apply_displacement<N>(model, s, d, dt, freeze_strain, any_closed);
  s.stored_energy = spring_energy;
  // The fastest approach of a closed contact point at the step end (m/s); only an impact
  // in progress asks.
  const auto end_approach = [&] {
    double fastest = 0.0;
    for (const auto& [point, normal] : closed_end)
      fastest = std::max(fastest, -(dof_matrix<6>(point - s.position).transpose() * normal)
                                       .dot(s.velocity.head<6>()));
    return fastest;
  };
  if (set.check_invariants) {
    const double overlap = std::max(terrain_depth_in_block(model, pose_of(model, s), s.patch),
                                    block_depth_below_terrain(world_vertices(model, s), s.patch, model.radius));
    s.max_depth = std::max(s.max_depth, overlap);
    if (overlap > depth) ++s.counters.depth_violations;
  }
  ++s.counters.contact_steps;
  s.last_step_contact = true;
  s.touched = s.touched || any_closed;
  if (any_closed && !s.episode.active) {
    start_episode(model, ground, s, v_start, kinetic_start, {closing_speed, closing_energy});
  } else if (s.episode.active && !s.episode.impact && arrival_triangle >= 0) {
    // A contact that closes at an impact's approach speed while others are closed (a
    // block sliding down the slope face at 13 m/s that reaches the flat toe hits it at 9
    // m/s along its normal): an impact along that contact's normal, not part of the
    // rolling or sliding episode, which has no law. Left in it, the stiff spring sent a
    // tetrahedron back up from the toe at 9.5 m/s (S1, realization 312).
    start_episode_along(model, ground, s, v_start, kinetic_start, arrival_normal, arrival_triangle,
                        {arrival_speed, arrival_energy});
  } else if (!any_closed && s.episode.active) end_episode(model, s);
  else if (s.episode.active && s.episode.impact && end_approach() < set.impact_min_normal_speed &&
           rebound_complete(model, s, spring_energy))
    finish_impact(model, s);
  if (!(s.episode.active && s.episode.impact)) settle_contacts<N>(model, s, persistent);
  limit_energy(model, s, energy_start);
  s.clear_until = -1.0;
  finish_step(model, ground, s, dt);
  // Grow back towards the nominal step after a cut. A step cut to end at the moment of
  // touch is not a cut for accuracy: the impact that follows gets the step it was cut
  // from. Grown back from the touch instead (×1.3 from a fraction of the step), the
  // impact was spread over many short steps at Ω = √(k/m)·Δt ≈ 0.1–5, where Shi's
  // scheme damps a spring most, and the contact, closed through them, was settled as
  // persistent: a tetrahedron's vertex striking at 2.5 m/s left with 2 % of its
  // approach at Δt = 1 ms (docs/dda.md, Step control).
  // A rigid block that is slow (below slow_kinetic_energy, ½·(0.5 m/s)² per unit mass by
  // default: no approach of it is an impact's) outside an impact, or that has stayed
  // below the rest threshold for a fifth of the rest dwell (settling, creeping, at rest),
  // grows its steps further: two thirds of a bench-slope realization's contact steps were
  // those of blocks rocking and sliding to a stop below 0.5 m/s, and a block in the dwell
  // moves by micrometres. The displacement limit and the energy check cut these steps as
  // any other. Measured (docs/dda.md, Step control): a cube sliding to a stop lands within
  // 0.13 µm of where nominal steps stop it; a faceted sphere rolling from rest on 20° is
  // 1.0–1.4 % short after 1 s against 1.1–1.2 % with nominal steps; the reference study's
  // distributions move by a KS distance of at most 0.012. (The 12-DOF path's
  // strain mode, at Ω ≈ 3 for a 1 m block at 1 ms, keeps the nominal step: at 4 ms a cube
  // at rest on flat ground drifted by 3 nm in 2 s against 1 nm.)
  // The dwell still ends when it did: its last step is cut to end it.
  const bool slow = set.slow_kinetic_energy > 0.0 && s.kinetic < set.slow_kinetic_energy * model.mass &&
                    !(s.episode.active && s.episode.impact);
  const bool settling =
      ((s.rest_time >= 0.2 * set.rest_dwell && s.rest_time > 0.0) || slow) && model.dof == DofPath::rigid6;
  const double longest =
      settling ? std::clamp(set.rest_dwell - s.rest_time, set.time_step, set.rest_step_ratio * set.time_step)
               : set.time_step;
  s.dt = std::min(longest, std::max(dt * 1.3, dt_before_touch));
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
  s.kinetic = kinetic_energy(model, s);
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
  if (model.settings.flight_test && std::none_of(s.contacts.begin(), s.contacts.end(),
                   [](const Contact& c) { return c.mode != ContactMode::open; })) {
    PhaseTimer timer(model.settings.time_phases, s.times.flight);
    const double h = flight_step(model, ground, s);
    flew = h > 0.0;
    if (flew) {
      s.contacts.clear();
      if (s.episode.active) end_episode(model, s);
      finish_step(model, ground, s, h);
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
