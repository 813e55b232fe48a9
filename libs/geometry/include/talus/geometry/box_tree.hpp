// SPDX-License-Identifier: MIT
#pragma once
// A bounding-volume hierarchy of axis-aligned boxes: the terrain's triangles and a
// detailed block's vertices, edges and faces are searched through it.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "talus/geometry/types.hpp"

namespace talus::geometry {

/// A binary tree of boxes in flat arrays. Children of an inner node are stored next to
/// each other, so a node needs one index; a leaf lists up to kLeafSize items of `items()`.
/// Built by median splits along the longest centroid axis (ties broken by item id):
/// deterministic, depth ⌈log2(n/4)⌉ + 1.
class BoxTree {
 public:
  static constexpr std::int32_t kLeafSize = 4;

  struct Node {
    Aabb box;
    std::int32_t first = 0;  ///< inner: index of the left child (right = first + 1); leaf: first item
    std::int32_t count = 0;  ///< 0 for an inner node, else the number of items in the leaf
  };

  /// Builds over `boxes` (item i has box i). An empty input gives an empty tree.
  void build(const std::vector<Aabb>& boxes);

  bool empty() const { return nodes_.empty(); }
  const std::vector<Node>& nodes() const { return nodes_; }
  /// Item ids in leaf order.
  const std::vector<std::int32_t>& items() const { return items_; }

  /// Depth-first walk, left child first, of the nodes whose box `enter` accepts; calls
  /// visit(item) for each item of an accepted leaf. `enter` must be conservative: true
  /// for a node's box whenever it would be true for any item inside it.
  template <class Enter, class Visit>
  void search(Enter&& enter, Visit&& visit) const {
    if (nodes_.empty()) return;
    std::int32_t stack[kMaxDepth];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!enter(node.box)) continue;
      if (node.count > 0) {
        for (std::int32_t k = node.first; k < node.first + node.count; ++k) visit(items_[static_cast<std::size_t>(k)]);
      } else {
        stack[top++] = node.first + 1;
        stack[top++] = node.first;
      }
    }
  }

  /// Calls visit(item) for every item of every leaf whose box overlaps `box`.
  template <class Visit>
  void overlapping(const Aabb& box, Visit&& visit) const {
    search([&](const Aabb& b) { return b.overlaps(box); }, visit);
  }

  /// Calls visit(item) for the items of leaves whose box contains (x, y) in plan and reaches
  /// above `z_floor()` (re-read per node, so a caller tracking the highest hit prunes).
  template <class ZFloor, class Visit>
  void vertical(double x, double y, ZFloor&& z_floor, Visit&& visit) const {
    search(
        [&](const Aabb& b) {
          return x >= b.lo.x() && x <= b.hi.x() && y >= b.lo.y() && y <= b.hi.y() && b.hi.z() >= z_floor();
        },
        visit);
  }

  /// max(floor, the largest value(item) over all items), by branch and bound: a node is
  /// skipped when bound(box) is no more than the largest value found, so bound must be an
  /// upper bound of value over the items inside the box. Values above `floor` are exact,
  /// whatever the pruning. The child with the larger bound is visited first.
  template <class Bound, class Value>
  double maximum(const Bound& bound, const Value& value,
                 double floor = -std::numeric_limits<double>::infinity()) const {
    double best = floor;
    if (nodes_.empty()) return best;
    std::int32_t stack[kMaxDepth];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!(bound(node.box) > best)) continue;
      if (node.count > 0) {
        for (std::int32_t k = node.first; k < node.first + node.count; ++k)
          best = std::max(best, value(items_[static_cast<std::size_t>(k)]));
        continue;
      }
      const double bl = bound(nodes_[static_cast<std::size_t>(node.first)].box);
      const double br = bound(nodes_[static_cast<std::size_t>(node.first + 1)].box);
      stack[top++] = bl > br ? node.first + 1 : node.first;
      stack[top++] = bl > br ? node.first : node.first + 1;
    }
    return best;
  }

 private:
  // Median splits keep the depth near log2(n / kLeafSize), and a walk holds at most one
  // pending node per level plus one: 2^120 items will not happen.
  static constexpr int kMaxDepth = 128;
  std::vector<Node> nodes_;
  std::vector<std::int32_t> items_;
};

}  // namespace talus::geometry
