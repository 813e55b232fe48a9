// SPDX-License-Identifier: MIT
#include "block_index.hpp"

#include <algorithm>
#include <numeric>

namespace talus::dda::detail {

namespace {
constexpr std::size_t kLeafItems = 4;
}  // namespace

void BoxTree::build(const std::vector<geometry::Aabb>& boxes, const std::vector<std::int32_t>& ids) {
  nodes_.clear();
  ids_.clear();
  item_boxes_.clear();
  if (ids.empty()) return;
  std::vector<std::int32_t> order(ids.size());
  std::iota(order.begin(), order.end(), 0);
  nodes_.reserve(2 * ids.size() / kLeafItems + 2);
  build_node(order, 0, order.size(), boxes, 0);
  ids_.reserve(order.size());
  item_boxes_.reserve(order.size());
  for (const std::int32_t k : order) {
    ids_.push_back(ids[static_cast<std::size_t>(k)]);
    item_boxes_.push_back(boxes[static_cast<std::size_t>(k)]);
  }
}

std::int32_t BoxTree::build_node(std::vector<std::int32_t>& order, std::size_t begin, std::size_t end,
                                 const std::vector<geometry::Aabb>& boxes, int depth) {
  const auto index = static_cast<std::int32_t>(nodes_.size());
  nodes_.emplace_back();
  geometry::Aabb box, centres;
  for (std::size_t k = begin; k < end; ++k) {
    const geometry::Aabb& b = boxes[static_cast<std::size_t>(order[k])];
    box.add(b);
    centres.add(b.center());
  }
  nodes_[static_cast<std::size_t>(index)].box = box;
  if (end - begin <= kLeafItems || depth >= kMaxDepth) {
    nodes_[static_cast<std::size_t>(index)].first = static_cast<std::int32_t>(begin);
    nodes_[static_cast<std::size_t>(index)].count = static_cast<std::int32_t>(end - begin);
    return index;
  }
  int axis = 0;
  centres.extent().maxCoeff(&axis);
  const std::size_t mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(end), [&](std::int32_t a, std::int32_t b) {
                     const double ca = boxes[static_cast<std::size_t>(a)].center()[axis];
                     const double cb = boxes[static_cast<std::size_t>(b)].center()[axis];
                     return ca != cb ? ca < cb : a < b;
                   });
  const std::int32_t left = build_node(order, begin, mid, boxes, depth + 1);
  const std::int32_t right = build_node(order, mid, end, boxes, depth + 1);
  nodes_[static_cast<std::size_t>(index)].left = left;
  nodes_[static_cast<std::size_t>(index)].right = right;
  return index;
}

BlockIndex make_block_index(const Model& model, double plane_tolerance) {
  BlockIndex index;
  std::vector<geometry::Aabb> boxes;
  std::vector<std::int32_t> ids;
  for (std::size_t i = 0; i < model.vertices.size(); ++i) {
    geometry::Aabb b;
    b.add(model.vertices[i]);
    boxes.push_back(b);
    ids.push_back(static_cast<std::int32_t>(i));
  }
  index.vertices.build(boxes, ids);
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
  index.convex_edges.build(boxes, ids);
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
  index.faces.build(boxes, ids);
  return index;
}

}  // namespace talus::dda::detail
