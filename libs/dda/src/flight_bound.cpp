// SPDX-License-Identifier: MIT
// The conservative advancement of a rigid block in free flight (contacts.hpp, FlightBound)
// and the separation of a block from a triangle.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "contacts.hpp"

namespace talus::dda::detail {


// How far apart the hull of the world vertices `block` and the triangle `corners` lie (m)
// along the direction from `centre` to the triangle's nearest point: a lower bound of their
// distance.
namespace {

// The unit direction from centre to the triangle's point nearest to it into u; false
// when centre lies on the triangle.
bool towards_triangle(const Vec3& centre, const std::array<Vec3, 3>& corners, Vec3& u) {
  // The triangle's point nearest to centre (Ericson, Real-Time Collision Detection 5.1.5).
  const Vec3& a = corners[0];
  const Vec3& b = corners[1];
  const Vec3& c = corners[2];
  const Vec3 ab = b - a, ac = c - a, ap = centre - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  Vec3 nearest;
  if (d1 <= 0.0 && d2 <= 0.0) {
    nearest = a;
  } else {
    const Vec3 bp = centre - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    const Vec3 cp = centre - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d3 >= 0.0 && d4 <= d3) {
      nearest = b;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      nearest = a + (d1 / (d1 - d3)) * ab;
    } else if (d6 >= 0.0 && d5 <= d6) {
      nearest = c;
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      nearest = a + (d2 / (d2 - d6)) * ac;
    } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
      nearest = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    } else {
      const double inverse = 1.0 / (va + vb + vc);
      nearest = a + ab * (vb * inverse) + ac * (vc * inverse);
    }
  }
  const Vec3 towards = nearest - centre;
  const double length = towards.norm();
  if (!(length > 0.0)) return false;
  u = towards / length;
  return true;
}

// The triangle's least extent along u from centre.
double triangle_from(const Vec3& centre, const std::array<Vec3, 3>& corners, const Vec3& u) {
  return std::min({u.dot(corners[0] - centre), u.dot(corners[1] - centre), u.dot(corners[2] - centre)});
}

}  // namespace

double separation(const std::vector<Vec3>& block, const Vec3& centre, const std::array<Vec3, 3>& corners,
                  Vec3* direction) {
  Vec3 u;
  if (!towards_triangle(centre, corners, u)) return -std::numeric_limits<double>::infinity();
  if (direction != nullptr) *direction = u;
  double block_to = -std::numeric_limits<double>::infinity();
  for (const Vec3& v : block) block_to = std::max(block_to, u.dot(v - centre));
  return triangle_from(centre, corners, u) - block_to;
}

double separation(const PlacedBlock& at, const std::array<Vec3, 3>& corners, Vec3* direction) {
  const Vec3& centre = at.pose().centre;
  Vec3 u;
  if (!towards_triangle(centre, corners, u)) return -std::numeric_limits<double>::infinity();
  if (direction != nullptr) *direction = u;
  return triangle_from(centre, corners, u) - at.support(u);
}

void FlightBound::reset(const std::vector<Vec3>& vertices, const Vec3& centre, const Vec3& velocity, const Vec3& spin,
                        double gravity, bool damped, double round_off, double spin_curvature) {
  vertices_ = &vertices;
  placed_ = nullptr;
  centre_ = centre;
  velocity_ = velocity;
  gravity_ = gravity;
  damped_ = damped;
  round_off_ = round_off;
  enough_ = 0.0;
  rates_.resize(vertices.size());
  curvature_.resize(vertices.size());
  turning_ = std::max(0.0, spin_curvature - spin.squaredNorm());
  const double spin2 = spin.squaredNorm() + turning_;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Vec3 r = vertices[i] - centre;
    rates_[i] = damped ? spin.cross(r) : Vec3(velocity + spin.cross(r));
    curvature_[i] = spin2 * r.norm();
  }
}

void FlightBound::reset(const PlacedBlock& at, const Vec3& velocity, const Vec3& spin, double gravity, bool damped,
                        double round_off, double spin_curvature) {
  turning_ = std::max(0.0, spin_curvature - spin.squaredNorm());
  vertices_ = nullptr;
  placed_ = &at;
  centre_ = at.pose().centre;
  velocity_ = velocity;
  gravity_ = gravity;
  damped_ = damped;
  // The support's own round-off comes on top of the caller's.
  round_off_ = round_off + 4.0 * at.round_off();
  enough_ = 0.0;
  spin_ = spin.norm();
  spin_vector_ = spin;
  radius_ = at.model().radius * (1.0 + 1e-12);
}

namespace {

// The earliest time (s, at most `limit`) a point `height` (m) above a plane approaching at
// `rate` (m/s), accelerating at `a` (m/s²) at most, may reach it: the stable smaller root,
// or `limit`.
double reach_time(double height, double rate, double a, double limit) {
  // It cannot come that close before `limit`: no root to find.
  if (height > (std::max(0.0, rate) + 0.5 * std::max(0.0, a) * limit) * limit) return limit;
  // None when the approach turns back before reaching it.
  const double disc = rate * rate + 2.0 * a * height;
  if (disc < 0.0) return limit;
  const double den = rate + std::sqrt(disc);
  return den > 0.0 ? std::min(limit, 2.0 * height / den) : limit;
}

}  // namespace

double FlightBound::plane_time(const Vec3& n, double offset, double limit) const {
  const double translation = damped_ ? std::max(0.0, -n.dot(velocity_)) : 0.0;
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  if (placed_ != nullptr) {
    // The block's box first (a lower height, in constant time): a plane it keeps clear
    // of for the whole limit needs no search of the vertex tree.
    if (box_plane_time(n, offset, limit) >= limit) return limit;
    if (!placed_->index()->climb.empty()) return climb_plane_time(n, offset, limit);
    // Then each vertex's own time by branch and bound over the vertex tree: over a body box
    // the height, approach and curvature are bounded by its centre and half-sizes (F a
    // rotation).
    const Pose& pose = placed_->pose();
    const Model& model = placed_->model();
    const Vec3 m = pose.map.transpose() * n;
    const Vec3 k = pose.map.transpose() * n.cross(spin_vector_);
    const Vec3 m_abs = m.cwiseAbs(), k_abs = k.cwiseAbs();
    const double spin2 = spin_vector_.squaredNorm() + turning_;
    const double base = n.dot(centre_) - offset - round_off_;
    // The round-off of a vertex's computed height and approach against these bounds.
    const double slack_height = 4.0 * placed_->round_off() + 1e-12 * (std::abs(base) + model.radius);
    const double slack_rate = 1e-12 * (velocity_.norm() + spin_ * model.radius);
    const double earliest = placed_->index()->vertices.maximum(
        [&](const geometry::Aabb& b) {
          const Vec3 c = b.center();
          const Vec3 h = 0.5 * b.extent();
          const double height = base + m.dot(c) - m_abs.dot(h) - slack_height;
          if (!(height > 0.0)) return 0.0;
          const double spin_part = -k.dot(c) + k_abs.dot(h) + slack_rate;
          const double approach = damped_ ? translation + std::max(0.0, spin_part) : -n.dot(velocity_) + spin_part;
          const double curvature = fall + spin2 * (c.norm() + h.norm()) * (1.0 + 1e-12);
          return -reach_time(height, approach, curvature, limit);
        },
        [&](std::int32_t i) {
          const Vec3 x = world_point(pose, model.vertices[static_cast<std::size_t>(i)]);
          const double height = n.dot(x) - offset - round_off_;
          if (!(height > 0.0)) return 0.0;
          const Vec3 r = x - centre_;
          const Vec3 w = damped_ ? Vec3(spin_vector_.cross(r)) : Vec3(velocity_ + spin_vector_.cross(r));
          const double rate_i = damped_ ? translation + std::max(0.0, -n.dot(w)) : -n.dot(w);
          return -reach_time(height, rate_i, fall + spin2 * r.norm(), limit);
        },
        -limit);
    return -earliest;
  }
  const std::vector<Vec3>& vertices = *vertices_;
  double earliest = limit;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const double height = n.dot(vertices[i]) - offset - round_off_;
    if (!(height > 0.0)) return 0.0;
    const double rate = damped_ ? translation + std::max(0.0, -n.dot(rates_[i])) : -n.dot(rates_[i]);
    earliest = reach_time(height, rate, fall + curvature_[i], earliest);
  }
  return earliest;
}

double FlightBound::box_plane_time(const Vec3& n, double offset, double limit) const {
  const double translation = damped_ ? std::max(0.0, -n.dot(velocity_)) : 0.0;
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  const double rate = (damped_ ? translation : -n.dot(velocity_)) + spin_ * radius_;
  const double height = n.dot(centre_) - placed_->support_bound(-n) - offset - round_off_;
  if (!(height > 0.0)) return 0.0;
  return reach_time(height, rate, fall + (spin_ * spin_ + turning_) * radius_, limit);
}

// On a convex block the least gap after t is at least the concave G(t) = n·c − offset +
// (n·v)·t − ½A·t² − S(−(n + t·k)) (docs/dda.md, The flight step): Newton from above, chords
// from below.
double FlightBound::climb_plane_time(const Vec3& n, double offset, double limit) const {
  const Vec3 k = n.cross(spin_vector_);
  const double base = n.dot(centre_) - offset - round_off_;
  const double lift = damped_ ? -std::max(0.0, -n.dot(velocity_)) : n.dot(velocity_);
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  const double a = std::max(0.0, fall + (spin_ * spin_ + turning_) * radius_);
  std::int32_t from = -1;
  Vec3 lever = Vec3::Zero();  // xᵢ − c of the last support vertex
  const auto extent = [&](const Vec3& u) { return placed_->climbed_support(u, from, lever); };
  const double floor_extent = damped_ ? extent(-n) : -std::numeric_limits<double>::infinity();
  // G(t), and its slope there (the support vertex's, a supergradient).
  const auto gap = [&](double t, double& slope) {
    const double s = extent(-(n + t * k));
    const double free = base + lift * t - 0.5 * a * t * t;
    if (s >= floor_extent) {
      slope = lift - a * t + k.dot(lever);
      return free - s;
    }
    slope = lift - a * t;
    return free - floor_extent;
  };
  double slope_lo = 0.0, slope_hi = 0.0;
  double g_lo = gap(0.0, slope_lo);
  if (!(g_lo > 0.0)) return 0.0;
  double g_hi = gap(limit, slope_hi);
  if (g_hi > 0.0) return limit;
  double t_lo = 0.0, t_hi = limit;
  const double tolerance = 1e-3 * limit;
  const auto take = [&](double t) {
    double slope = 0.0;
    const double g = gap(t, slope);
    // G(t) = 0 (a Newton step onto a straight piece): the first reach is t itself.
    if (g >= 0.0) {
      t_lo = t;
      g_lo = g;
    } else {
      t_hi = t;
      g_hi = g;
      slope_hi = slope;
    }
  };
  // Below `enough_` the time need not be exact (settle_below): once a time there is shown
  // not to be clear, so is the answer.
  for (int iteration = 0; iteration < 16 && t_hi - t_lo > tolerance && t_hi > enough_; ++iteration) {
    if (slope_hi < 0.0) {
      const double t = t_hi - g_hi / slope_hi;
      if (t > t_lo && t < t_hi) take(t);
      if (t_hi - t_lo <= tolerance || t_hi <= enough_) break;
    }
    if (!(g_lo > 0.0)) break;
    const double chord = t_lo + g_lo * (t_hi - t_lo) / (g_lo - g_hi);
    take(chord > t_lo && chord < t_hi ? chord : 0.5 * (t_lo + t_hi));
  }
  return t_lo;
}

double FlightBound::quick_triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const {
  if (placed_ == nullptr) return triangle_time(normal, corners, limit);
  return box_plane_time(normal, normal.dot(corners[0]), limit);
}

double FlightBound::triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const {
  const double below = plane_time(normal, normal.dot(corners[0]), limit);
  if (below >= limit) return limit;
  Vec3 u = Vec3::Zero();
  const double apart =
      placed_ != nullptr ? separation(*placed_, corners, &u) : separation(*vertices_, centre_, corners, &u);
  if (!(apart > 0.0)) return below;
  const double from = std::min({u.dot(corners[0]), u.dot(corners[1]), u.dot(corners[2])});
  return std::max(below, plane_time(-u, -from, limit));
}

}  // namespace talus::dda::detail
