// SPDX-License-Identifier: MIT
#include "block_index.hpp"

namespace talus::dda::detail {

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
  return index;
}

}  // namespace talus::dda::detail
