// SPDX-License-Identifier: MIT
// The physical invariants a run can be checked against at every step (Settings::
// check_invariants): how deep the terrain and the block are inside each other. Slow
// reference code, written for clarity, not used by the step itself.
#include "invariants.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

}  // namespace talus::dda::detail
