// SPDX-License-Identifier: MIT
// Private to libs/terrain: a compact bounding-volume hierarchy over triangle boxes.
#pragma once
#include <cstdint>
#include <vector>

#include "talus/geometry/types.hpp"

namespace talus::terrain::detail {

/// A binary BVH in flat arrays. Children of an inner node are stored next to each other,
/// so a node needs one index; a leaf lists up to kLeafSize items of `items`. Built by
/// median splits along the longest centroid axis: deterministic, depth ⌈log2(n/4)⌉ + 1.
class Bvh {
 public:
  static constexpr std::int32_t kLeafSize = 4;

  struct Node {
    geometry::Aabb box;
    std::int32_t first = 0;  ///< inner: index of the left child (right = first + 1); leaf: first item
    std::int32_t count = 0;  ///< 0 for an inner node, else the number of items in the leaf
  };

  /// Builds over `boxes` (item i has box i). An empty input gives an empty tree.
  void build(const std::vector<geometry::Aabb>& boxes);

  bool empty() const { return nodes_.empty(); }
  const std::vector<Node>& nodes() const { return nodes_; }
  /// Item ids in leaf order.
  const std::vector<std::int32_t>& items() const { return items_; }

  /// Calls visit(item) for every item of every leaf whose box overlaps `box`.
  template <class Visit>
  void overlapping(const geometry::Aabb& box, Visit&& visit) const {
    traverse([&](const geometry::Aabb& b) { return b.overlaps(box); }, visit);
  }

  /// Calls visit(item) for the items of leaves whose box contains (x, y) in plan and reaches
  /// above `z_floor()` (re-read per node, so a caller tracking the highest hit prunes).
  template <class ZFloor, class Visit>
  void vertical(double x, double y, ZFloor&& z_floor, Visit&& visit) const {
    traverse(
        [&](const geometry::Aabb& b) {
          return x >= b.lo.x() && x <= b.hi.x() && y >= b.lo.y() && y <= b.hi.y() && b.hi.z() >= z_floor();
        },
        visit);
  }

 private:
  // Depth-first walk of the nodes whose box `enter` accepts, left child first.
  template <class Enter, class Visit>
  void traverse(Enter&& enter, Visit&& visit) const {
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

  // Median splits keep the depth near log2(n / kLeafSize); 2^60 items will not happen.
  static constexpr int kMaxDepth = 128;
  std::vector<Node> nodes_;
  std::vector<std::int32_t> items_;
};

}  // namespace talus::terrain::detail
