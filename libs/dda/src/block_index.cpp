// SPDX-License-Identifier: MIT
#include "block_index.hpp"

#include <algorithm>
#include <cmath>

namespace talus::dda::detail {

void VertexClimb::build(const Model& model) {
  offsets_.clear();
  neighbours_.clear();
  if (!model.convex) return;
  const std::size_t n = model.vertices.size();
  std::vector<std::int32_t> degree(n, 0);
  for (const BlockEdge& e : model.edges) {
    ++degree[static_cast<std::size_t>(e.a)];
    ++degree[static_cast<std::size_t>(e.b)];
  }
  offsets_.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) offsets_[i + 1] = offsets_[i] + degree[i];
  neighbours_.resize(static_cast<std::size_t>(offsets_[n]));
  std::vector<std::int32_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (const BlockEdge& e : model.edges) {
    neighbours_[static_cast<std::size_t>(fill[static_cast<std::size_t>(e.a)]++)] = e.b;
    neighbours_[static_cast<std::size_t>(fill[static_cast<std::size_t>(e.b)]++)] = e.a;
  }
  // Each cell's centre direction; its farthest vertex by climbing from the last cell's
  // (the graph is that of a convex polyhedron: the same vertex a scan finds).
  starts_.assign(6 * kCells * kCells, 0);
  std::int32_t from = 0;
  for (int face = 0; face < 6; ++face)
    for (int i = 0; i < kCells; ++i)
      for (int j = 0; j < kCells; ++j) {
        const int axis = face / 2;
        Vec3 d = Vec3::Zero();
        d[axis] = face % 2 == 0 ? 1.0 : -1.0;
        d[(axis + 1) % 3] = -1.0 + (2.0 * i + 1.0) / kCells;
        d[(axis + 2) % 3] = -1.0 + (2.0 * j + 1.0) / kCells;
        from = farthest(model.vertices, d, from);
        starts_[static_cast<std::size_t>(cell(d))] = from;
      }
}

int VertexClimb::cell(const Vec3& m) {
  const Vec3 a = m.cwiseAbs();
  const int axis = a.x() >= a.y() && a.x() >= a.z() ? 0 : a.y() >= a.z() ? 1 : 2;
  const double top = a[axis];
  if (!(top > 0.0) || !std::isfinite(top)) return 0;  // no direction: any start will do
  const int face = 2 * axis + (m[axis] >= 0.0 ? 0 : 1);
  const auto index = [&](double c) {
    const double x = (c / top + 1.0) * 0.5 * kCells;  // in [0, kCells] unless c is NaN
    return x >= 1.0 ? std::min(static_cast<int>(x), kCells - 1) : 0;
  };
  return (face * kCells + index(m[(axis + 1) % 3])) * kCells + index(m[(axis + 2) % 3]);
}

BlockIndex make_block_index(const Model& model, double plane_tolerance) {
  BlockIndex index;
  std::vector<geometry::Aabb> boxes;
  std::vector<std::int32_t> ids;
  for (std::size_t i = 0; i < model.vertices.size(); ++i) {
    geometry::Aabb b;
    b.add(model.vertices[i]);
    index.body_box.add(model.vertices[i]);
    boxes.push_back(b);
    ids.push_back(static_cast<std::int32_t>(i));
  }
  index.vertices.build(std::move(boxes), std::move(ids));
  boxes.clear();
  ids.clear();
  for (std::size_t e = 0; e < model.edges.size(); ++e) {
    if (!model.edges[e].convex) continue;
    geometry::Aabb b;
    b.add(model.vertices[static_cast<std::size_t>(model.edges[e].a)]);
    b.add(model.vertices[static_cast<std::size_t>(model.edges[e].b)]);
    boxes.push_back(b);
    ids.push_back(static_cast<std::int32_t>(e));
  }
  index.convex_edges.build(std::move(boxes), std::move(ids));
  boxes.clear();
  ids.clear();
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    const BlockFace& face = model.faces[f];
    geometry::Aabb b;
    // The vertices and the polygon's corners on the plane: a foot inside the polygon
    // (on the plane) lies in the box of the latter.
    for (const std::int32_t v : face.vertices) b.add(model.vertices[static_cast<std::size_t>(v)]);
    for (const Eigen::Vector2d& q : face.polygon) b.add(face.u * q.x() + face.v * q.y() + face.normal * face.offset);
    boxes.push_back(b.inflated(plane_tolerance));
    ids.push_back(static_cast<std::int32_t>(f));
  }
  index.faces.build(std::move(boxes), std::move(ids));
  index.climb.build(model);
  return index;
}

}  // namespace talus::dda::detail
