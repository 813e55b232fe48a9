// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "talus/geometry/types.hpp"

namespace talus::geometry {

/// An indexed triangle mesh (vertices in m). Triangles are counter-clockwise seen from
/// the side their normal points to.
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::int32_t, 3>> triangles;

  std::size_t vertex_count() const { return vertices.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
  /// Unnormalised normal (p1-p0)x(p2-p0); its length is twice the triangle's area.
  Vec3 area_normal(std::size_t t) const;
  Aabb bounds() const;
  Aabb triangle_bounds(std::size_t t) const;
};

/// Merges vertices closer than `tolerance` (m) and drops triangles that become
/// degenerate; returns the number of vertices removed. Used for STL-like input that
/// stores no shared vertices. Deterministic: the first occurrence of a vertex is kept.
std::size_t weld_vertices(TriangleMesh& mesh, double tolerance);

}  // namespace talus::geometry
