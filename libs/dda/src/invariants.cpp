// SPDX-License-Identifier: MIT
// The physical invariants a run can be checked against at every step (Settings::
// check_invariants): how deep the terrain and the block are inside each other (slow
// reference code, written for clarity); and the rim test that ends a block dropped past
// the terrain's edge.
#include "invariants.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "kinematics.hpp"

namespace talus::dda::detail {

namespace {

// Point in polygon (crossing number) in the face's (u, v) coordinates.
bool inside_face(const BlockFace& face, const Eigen::Vector2d& uv) {
  bool inside = false;
  const std::size_t n = face.polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = face.polygon[i];
    const Eigen::Vector2d& b = face.polygon[j];
    if ((a.y() > uv.y()) != (b.y() > uv.y()) &&
        uv.x() < a.x() + (uv.y() - a.y()) / (b.y() - a.y()) * (b.x() - a.x()))
      inside = !inside;
  }
  return inside;
}

// Squared distance from q to the polygon of `face` (all in the body frame).
double face_distance2(const BlockFace& face, const Vec3& q) {
  const double h = face.normal.dot(q) - face.offset;
  const Eigen::Vector2d uv(face.u.dot(q), face.v.dot(q));
  const std::size_t n = face.polygon.size();
  const bool inside = inside_face(face, uv);
  double edge2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = face.polygon[i];
    const Eigen::Vector2d& b = face.polygon[j];
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((uv - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    edge2 = std::min(edge2, (uv - (a + t * ab)).squaredNorm());
  }
  return h * h + (inside ? 0.0 : edge2);
}

// Ray parity along a fixed, generic body-frame direction (no face or edge is parallel to it
// by accident of a symmetric shape).
bool inside_block(const Model& model, const Vec3& q) {
  const Vec3 dir = Vec3(0.3141592653589793, 0.2718281828459045, 0.9101).normalized();
  int crossings = 0;
  for (const BlockFace& face : model.faces) {
    const double denom = face.normal.dot(dir);
    if (std::abs(denom) < 1e-14) continue;
    const double t = (face.offset - face.normal.dot(q)) / denom;
    if (t <= 0.0) continue;
    const Vec3 x = q + t * dir;
    if (inside_face(face, Eigen::Vector2d(face.u.dot(x), face.v.dot(x)))) ++crossings;
  }
  return crossings % 2 == 1;
}

}  // namespace

double terrain_depth_in_block(const Model& model, const Pose& pose, const TerrainPatch& patch) {
  double deepest = 0.0;
  for (const TerrainPatch::Vertex& tv : patch.vertices) {
    if ((tv.p - pose.centre).norm() >= model.radius) continue;
    const Vec3 q = pose.inverse_map * (tv.p - pose.centre);
    if (!inside_block(model, q)) continue;
    double d2 = std::numeric_limits<double>::infinity();
    for (const BlockFace& face : model.faces) d2 = std::min(d2, face_distance2(face, q));
    deepest = std::max(deepest, std::sqrt(d2));
  }
  return deepest;
}

double block_depth_below_terrain(const std::vector<Vec3>& world, const TerrainPatch& patch, double radius) {
  double deepest = 0.0;
  for (const Vec3& p : world) {
    for (const TerrainPatch::Triangle& tri : patch.triangles) {
      if (tri.normal.z() <= 0.0) continue;  // walls and overhangs: no vertical projection
      const Eigen::Vector2d q(p.x(), p.y());
      bool outside = false;
      for (int k = 0; k < 3 && !outside; ++k) {
        const Eigen::Vector2d a = tri.p[k].head<2>(), b = tri.p[(k + 1) % 3].head<2>();
        outside = (b - a).x() * (q - a).y() - (b - a).y() * (q - a).x() < 0.0;
      }
      if (outside) continue;
      const double depth = -(p - tri.p[0]).dot(tri.normal);
      // Deeper than the block is wide: the vertex is on the far side of a thin feature.
      if (depth > 0.0 && depth < 2.0 * radius) deepest = std::max(deepest, depth);
    }
  }
  return deepest;
}


double depth_below_ground(const Model& model, const Pose& pose, const terrain::Surface& surf) {
  if (!surf.is_height_field()) return 0.0;
  std::vector<Vec3> world;
  world.reserve(model.vertices.size());
  geometry::Aabb box;
  for (const Vec3& r : model.vertices) {
    world.push_back(pose.centre + pose.map * r);
    box.add(world.back());
  }
  double deepest = 0.0;
  // Block vertices against the ground under them.
  for (const Vec3& p : world)
    if (const auto hit = surf.height_at(p.x(), p.y())) deepest = std::max(deepest, hit->z - p.z());
  // The terrain under the block's plan box: its vertices and edges.
  geometry::Aabb plan = box;
  plan.lo.z() = -std::numeric_limits<double>::infinity();
  plan.hi.z() = std::numeric_limits<double>::infinity();
  std::vector<std::int32_t> triangles;
  surf.triangles_in_box(plan, triangles);
  const auto in_plan = [&](const Vec3& q) {
    return q.x() >= box.lo.x() && q.x() <= box.hi.x() && q.y() >= box.lo.y() && q.y() <= box.hi.y();
  };
  for (std::int32_t t : triangles) {
    const std::array<Vec3, 3> tri = surf.triangle_vertices(static_cast<std::size_t>(t));
    for (const Vec3& q : tri) {
      if (!in_plan(q)) continue;
      // The block's lowest point on the vertical line through q: its faces' planes there,
      // for the faces q lies over or under in plan.
      double lowest = std::numeric_limits<double>::infinity();
      for (const BlockFace& f : model.faces) {
        const Vec3 n = pose.inverse_map.transpose() * f.normal;
        if (std::abs(n.z()) < 1e-12 * n.norm()) continue;
        bool inside = false;
        const std::size_t m = f.vertices.size();
        for (std::size_t a = 0, b = m - 1; a < m; b = a++) {
          const Vec3& pa = world[static_cast<std::size_t>(f.vertices[a])];
          const Vec3& pb = world[static_cast<std::size_t>(f.vertices[b])];
          if ((pa.y() > q.y()) != (pb.y() > q.y()) &&
              q.x() < (pb.x() - pa.x()) * (q.y() - pa.y()) / (pb.y() - pa.y()) + pa.x())
            inside = !inside;
        }
        if (!inside) continue;
        const Vec3& p0 = world[static_cast<std::size_t>(f.vertices[0])];
        lowest = std::min(lowest, p0.z() - (n.x() * (q.x() - p0.x()) + n.y() * (q.y() - p0.y())) / n.z());
      }
      if (std::isfinite(lowest)) deepest = std::max(deepest, q.z() - lowest);
    }
    // Block edges crossing the triangle's edges in plan.
    for (int k = 0; k < 3; ++k) {
      const Vec3& a = tri[k];
      const Vec3& b = tri[(k + 1) % 3];
      const Eigen::Vector2d d2 = (b - a).head<2>();
      for (const BlockEdge& e : model.edges) {
        const Vec3& p = world[static_cast<std::size_t>(e.a)];
        const Vec3& q = world[static_cast<std::size_t>(e.b)];
        const Eigen::Vector2d d1 = (q - p).head<2>();
        const double den = d1.x() * d2.y() - d1.y() * d2.x();
        if (std::abs(den) < 1e-300) continue;
        const Eigen::Vector2d r = (a - p).head<2>();
        const double u = (r.x() * d2.y() - r.y() * d2.x()) / den;  // along the block edge
        const double v = (r.x() * d1.y() - r.y() * d1.x()) / den;  // along the terrain edge
        if (u < 0.0 || u > 1.0 || v < 0.0 || v > 1.0) continue;
        deepest = std::max(deepest, (a.z() + v * (b.z() - a.z())) - (p.z() + u * (q.z() - p.z())));
      }
    }
  }
  return deepest;
}


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

// Whether part of the block has dropped past the terrain's rim: a vertex with no ground
// under it lower than its nearest rim point, and under the ground continued past it, by the
// penetration limit.
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
  // A vertex at or above `floor` (the rim's top within reach less the limit) is not past
  // the rim: near the rim only the vertices below it are looked at.
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
  // Over ground whose rim bounds its footprint, only the vertices of tree nodes that may
  // meet the rim or lie off the ground are looked at; the others have ground under them.
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

}  // namespace talus::dda::detail
