// SPDX-License-Identifier: MIT
// The flight step: the block's motion on its exact parabola and spin for as long as the
// flight test proves it clear of the terrain (docs/dda.md, "The step"; step.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "contact_law.hpp"
#include "episodes.hpp"
#include "rotation.hpp"
#include "step.hpp"
#include "workspace.hpp"

namespace talus::dda::detail {

namespace {

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

// Calls visit(normal, corners, box) for every terrain triangle whose box meets `box` (and
// maybe a few more) until it returns false: from the contact patch if it holds the box,
// else the flight's own.
template <class Visit>
void for_each_triangle_near(const Model& model, const Ground& ground, Scratch& w, const geometry::Aabb& box,
                            Visit&& visit) {
  const TerrainPatch& patch = w.patch;
  if (patch.surface == ground.surface && !patch.box.empty() && patch.box.contains(box.lo) &&
      patch.box.contains(box.hi)) {
    for (const TerrainPatch::Triangle& t : patch.triangles)
      if (t.box.overlaps(box) && !visit(t.normal, t.p, t.box)) return;
    return;
  }
  FlightPatch& flight = w.flight_patch;
  if (flight.surface != ground.surface || flight.box.empty() || !flight.box.contains(box.lo) ||
      !flight.box.contains(box.hi)) {
    flight.surface = ground.surface;
    flight.box = box.inflated(std::max(model.radius, 0.5 * box.extent().maxCoeff()));
    flight.triangles.clear();
    w.triangles.clear();
    ground.surface->triangles_in_box(flight.box, w.triangles);
    for (std::int32_t t : w.triangles) {
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

// Whether no triangle can be touched before time + h: the swept bounding sphere misses its
// box, or (`block` given, 12-DOF) every vertex lies farther above its plane, or apart from
// it, than the search distance.
double clear_horizon(const Model& model, const Ground& ground, State& s, Scratch& w, double h_long, double h_short,
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
  for_each_triangle_near(model, ground, w, box_long, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
                                                        const geometry::Aabb& tbox) {
    judge(normal, corners, tbox);
    return long_clear || short_clear;
  });
  return long_clear ? h_long : short_clear ? h_short : 0.0;
}

// How long (s, at most h) the rigid block in free flight provably stays clear of the
// terrain (FlightBound over the triangles the swept sphere can meet); some time below a
// step once one allows less.
double clear_time(const Model& model, const Ground& ground, State& s, Scratch& w, double h, const PlacedBlock& at) {
  const geometry::Aabb box = swept_sphere_box(model, s, h).inflated(model.max_step_displacement());
  thread_local FlightBound bound;
  // The smooth surface lies up to rounding_reach outside the vertices.
  const double round_off = 1e-9 * (s.position.cwiseAbs().maxCoeff() + model.radius) + model.rounding_reach;
  // Free flight is the exact parabola whatever dynamic_coefficient is (apply_displacement).
  const bool damped = false;
  // Points accelerate by the spin's change too when ω turns (Euler's equations).
  const double curvature = rotation_curvature(model, at.pose().rotation, s.velocity.segment<3>(3));
  if (at.index() == nullptr)
    bound.reset(at.vertices(), s.position, s.velocity.head<3>(), s.velocity.segment<3>(3), model.settings.gravity,
                damped, round_off, curvature);
  else
    bound.reset(at, s.velocity.head<3>(), s.velocity.segment<3>(3), model.settings.gravity, damped, round_off,
                curvature);
  double clear = h;
  // Less than one step is no flight: the search decides (flight_step), so the triangles
  // left need no bound, and a time below it need not be exact.
  const double enough = s.dt;
  bound.settle_below(enough);
  if (at.index() == nullptr) {
    for_each_triangle_near(model, ground, w, box, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
                                                      const geometry::Aabb&) {
      clear = std::min(clear, bound.triangle_time(normal, corners, clear));
      return clear >= enough;
    });
    return clear;
  }
  // A detailed block's triangles in the order of a constant-time bound of their time, least
  // first; those whose quick bound already reaches the time found need no search (the same
  // minimum).
  struct Near {
    double quick;
    std::size_t order;
    Vec3 normal;
    std::array<Vec3, 3> corners;
  };
  thread_local std::vector<Near> near;
  near.clear();
  for_each_triangle_near(model, ground, w, box, [&](const Vec3& normal, const std::array<Vec3, 3>& corners,
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

// The rigid displacement of free flight over dt: the exact parabola and the exact spin.
Eigen::Matrix<double, 6, 1> free_displacement(const Model& model, const State& s, double dt) {
  Eigen::Matrix<double, 6, 1> d;
  d.head<3>() = s.velocity.head<3>() * dt + 0.5 * gravity_vector(model) * dt * dt;
  d.tail<3>() = s.velocity.segment<3>(3) * dt;
  return d;
}

// Whether the free motion keeps every candidate open through the step: the gap on the rigid
// free motion as the contact step computes it, g(t) = gap + (n·(v + ω × r))·t + ½(n·g)·t².
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

// Whether no contact can close in the next step, by the search a contact step would make
// from this pose (handed to it); a rigid detailed block's near search passes over what that
// step would set aside.
bool beyond_contact_reach(const Model& model, const Ground& ground, State& s, Scratch& w, const PlacedBlock& at, double dt) {
  w.handoff.contacts.clear();
  const double reach = search_reach(model, s, dt);
  const double near = s.contacts.empty() ? near_reach(model, s, dt, w.paths.set_aside_scale) : 0.0;
  MotionFilter pass;
  const bool passing = near > 0.0 && w.paths.pass_over && w.paths.set_aside_scale >= 1.0;
  if (passing) {
    static const std::vector<std::int32_t> none;
    pass.keep = pass.keep_edges = pass.keep_terrain = &none;
    aim_pass_over(model, s, at.pose(), dt, w.paths.set_aside_scale, pass);
  }
  detect_contacts(at, *ground.surface, reach, model.penetration_limit(), w.patch, w.handoff.contacts,
                  {near, passing ? &pass : nullptr, w.paths.cross_every_valley});
  w.handoff.reach = near > 0.0 ? near : reach;
  w.handoff.passed = pass.passed;
  w.handoff.least_gap = pass.least_gap;
  s.counters.flight_passed += pass.passed;
  if (w.handoff.contacts.empty()) return true;
  // A contact carried from the last step (anchored, a micro-gap open) keeps its shear
  // spring's memory only through a contact step.
  return model.dof == DofPath::rigid6 && s.contacts.empty() && stays_open(model, s, w.handoff.contacts, dt);
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
  Eigen::Quaterniond q = s.orientation;
  Vec3 omega = s.velocity.segment<3>(3);
  for (int j = 1; j < k; ++j) {
    const double tau = j * dt;
    const double t = s.time + tau;
    const Vec3 p = p0 + v0 * tau + 0.5 * g * tau * tau;
    const auto hit = surf.height_at(p.x(), p.y());
    const double height = hit ? p.z() - hit->z : std::numeric_limits<double>::quiet_NaN();
    if (hit) note_jump(surf, s, height, hit->triangle);
    if (!trajectory) continue;
    rotate_free(model, q, omega, dt);
    sample_trajectory(model, s, t, p, v0 + g * tau, height, energy, q, omega, Motion::flight);
  }
}

}  // namespace

// A flight step, if the block is clear of the terrain for at least one step: returns its
// length (s), 0 if the block needs a contact step.
double flight_step(const Model& model, const Ground& ground, State& s, Scratch& w) {
  const double dt = s.dt;
  w.handoff.reach = -1.0;
  if (s.time + dt > s.clear_until) {
    // A test that passes for a horizon passes for any shorter one: of 64, 8 and 1 steps, 8
    // is tested first; right after contact, only one step.
    const bool after_contact = s.counters.steps > 0 && s.last_step_contact;
    const double first = after_contact ? dt : 8.0 * dt;
    // The swept sphere against the triangles' boxes; then the block against the triangles
    // it meets (rigid: FlightBound, up to 64 steps; 12-DOF: vertex heights); then, near the
    // ground, the contact search.
    double horizon = clear_horizon(model, ground, s, w, first, dt, nullptr);
    if (horizon == 8.0 * dt && clear_horizon(model, ground, s, w, 64.0 * dt, 64.0 * dt, nullptr) > 0.0)
      horizon = 64.0 * dt;
    std::optional<Pose> pose;
    std::optional<PlacedBlock> at;
    if (horizon == 0.0 && (model.index == nullptr || model.dof == DofPath::rigid6)) {
      pose = pose_of(model, s);
      at.emplace(model, *pose, w.vertices, false, &w.box);
      if (model.dof == DofPath::rigid6) {
        const double clear = clear_time(model, ground, s, w, 64.0 * dt, *at);
        if (clear >= dt) horizon = clear;
      } else {
        horizon = clear_horizon(model, ground, s, w, first, dt, &w.vertices);
      }
    }
    // The search sees a vertex only against the triangles it lies over, so near a concave
    // kink a flight it decides lasts one step, bounded as a contact step's displacement is.
    if (horizon == 0.0 && predicted_reach(model, s, dt) <= model.max_step_displacement()) {
      if (!at) {
        pose = pose_of(model, s);
        at.emplace(model, *pose, w.vertices, false, &w.box);
      }
      if (beyond_contact_reach(model, ground, s, w, *at, dt)) horizon = dt;
    }
    if (horizon == 0.0) return 0.0;
    s.clear_until = s.time + horizon;
  }
  double h = dt;
  if (model.dof == DofPath::rigid6) {
    // The exact parabola and spin whatever the step: whole nominal steps, up to
    // flight_step_ratio, within the proven clear time; what nominal steps would sample
    // comes from sample_flight.
    const double whole = std::floor((std::min(s.clear_until, s.time_limit) - s.time) / dt);
    const int k = static_cast<int>(std::clamp(whole, 1.0, std::floor(model.settings.flight_step_ratio)));
    h = k * dt;
    if (k > 1) sample_flight(model, ground, s, dt, k);
    if (model.isotropic) {
      apply_displacement<6>(model, s, free_displacement(model, s, h), h, false, false);
    } else {
      // The parabola, and Euler's equations for the spin (ω turns, L stays).
      s.position += s.velocity.head<3>() * h + 0.5 * gravity_vector(model) * h * h;
      s.velocity.head<3>() += gravity_vector(model) * h;
      Vec3 omega = s.velocity.segment<3>(3);
      rotate_free(model, s.orientation, omega, h);
      s.velocity.segment<3>(3) = omega;
    }
  } else {
    // Strains keep oscillating in flight: the contact-free 12-DOF solve; the stretch update
    // is not linear in the step, so a small energy gain is taken back as a contact step's.
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

}  // namespace talus::dda::detail
