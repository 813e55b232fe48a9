// SPDX-License-Identifier: MIT
#include "block_index.hpp"

#include <algorithm>
#include <cmath>

namespace talus::dda::detail {

void VertexClimb::build(const Model& model) {
  offsets_.clear();
  neighbours_.clear();
  edges_.clear();
  longest_.clear();
  fills_ = false;
  plateaus_ = false;
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
  edges_.resize(neighbours_.size());
  longest_.assign(n, 0.0);
  radius_ = model.radius;
  plateaus_ = std::any_of(model.edges.begin(), model.edges.end(), [](const BlockEdge& e) { return !e.convex; });
  std::vector<std::int32_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (std::size_t k = 0; k < model.edges.size(); ++k) {
    const BlockEdge& e = model.edges[k];
    const std::size_t at_a = static_cast<std::size_t>(fill[static_cast<std::size_t>(e.a)]++);
    const std::size_t at_b = static_cast<std::size_t>(fill[static_cast<std::size_t>(e.b)]++);
    neighbours_[at_a] = e.b;
    neighbours_[at_b] = e.a;
    edges_[at_a] = edges_[at_b] = static_cast<std::int32_t>(k);
    const double length =
        (model.vertices[static_cast<std::size_t>(e.a)] - model.vertices[static_cast<std::size_t>(e.b)]).norm();
    longest_[static_cast<std::size_t>(e.a)] = std::max(longest_[static_cast<std::size_t>(e.a)], length);
    longest_[static_cast<std::size_t>(e.b)] = std::max(longest_[static_cast<std::size_t>(e.b)], length);
  }
  // Every edge is convex (Model::convex); with triangular faces the surface is exactly a
  // convex polytope's, whose faces a polygon of more vertices need not be within round-off.
  fills_ = std::all_of(model.faces.begin(), model.faces.end(),
                       [](const BlockFace& f) { return f.vertices.size() == 3; });
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

bool VertexClimb::below(const std::vector<Vec3>& vertices, const Vec3& m, double& level, double slack,
                        std::size_t limit, std::vector<std::int32_t>& out, double& lowest, double rise) const {
  out.clear();
  const std::int32_t start = farthest(vertices, -m);
  lowest = m.dot(vertices[static_cast<std::size_t>(start)]);
  if (rise > 0.0) level = std::max(level, lowest + rise);
  const double top = level + slack;
  if (!(lowest <= top)) return true;
  std::int32_t stopped = -1;
  spread(start, vertices.size(), out, [&](std::int32_t w) {
    if (!(m.dot(vertices[static_cast<std::size_t>(w)]) <= top)) return Reach::pass;
    if (out.size() >= limit) {
      stopped = w;
      return Reach::stop;
    }
    return Reach::take;
  });
  return stopped < 0;
}

std::int32_t VertexClimb::beyond_plateau(const std::vector<Vec3>& vertices, const Vec3& m, std::int32_t at,
                                         double best, double tie) const {
  thread_local std::vector<std::int32_t> plateau;
  plateau.clear();
  std::int32_t beyond = -1;
  spread(at, vertices.size(), plateau, [&](std::int32_t w) {
    const double value = m.dot(vertices[static_cast<std::size_t>(w)]);
    if (value > best + tie) {
      beyond = w;
      return Reach::stop;
    }
    return value >= best - tie ? Reach::take : Reach::pass;
  });
  return beyond;
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
