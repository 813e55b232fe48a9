// SPDX-License-Identifier: MIT
#include "block_index.hpp"

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
  std::size_t k = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        directions_[k] = Vec3(x, y, z).normalized();
        std::int32_t best = 0;
        for (std::size_t i = 1; i < n; ++i)
          if (directions_[k].dot(model.vertices[i]) > directions_[k].dot(model.vertices[static_cast<std::size_t>(best)]))
            best = static_cast<std::int32_t>(i);
        starts_[k++] = best;
      }
}

std::int32_t VertexClimb::start(const Vec3& m) const {
  std::size_t best = 0;
  double value = directions_[0].dot(m);
  for (std::size_t k = 1; k < directions_.size(); ++k) {
    const double v = directions_[k].dot(m);
    if (v > value) {
      value = v;
      best = k;
    }
  }
  return starts_[best];
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
