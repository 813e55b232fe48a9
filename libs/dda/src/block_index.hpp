// SPDX-License-Identifier: MIT
#pragma once
// Box trees over a block's features in its body frame, so that contact detection and the
// step control cost what the block touches, not what it has: a scanned rock of 10⁴ faces
// near a few terrain triangles is queried in logarithmic time instead of scanned.
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "talus/dda/model.hpp"
#include "talus/geometry/types.hpp"

namespace talus::dda::detail {

/// Blocks with more vertices than this get a BlockIndex; fewer are scanned feature by
/// feature, which is faster for them (docs/benchmarks.md, "Block detail").
constexpr std::size_t kScannedVertices = 32;

/// A bounding-volume hierarchy of axis-aligned boxes (median split on the longest axis,
/// up to four items per leaf).
class BoxTree {
 public:
  /// Builds the tree over the items `ids` with their boxes `boxes` (same length).
  void build(const std::vector<geometry::Aabb>& boxes, const std::vector<std::int32_t>& ids);
  bool empty() const { return nodes_.empty(); }

  /// Appends the id of every item whose box passes `test` (in tree order). `test` must
  /// be conservative: true for a node's box whenever it is true for any box inside it.
  template <class Test>
  void query(const Test& test, std::vector<std::int32_t>& out) const {
    if (nodes_.empty()) return;
    std::array<std::int32_t, 2 * kMaxDepth + 4> stack{};
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!test(node.box)) continue;
      if (node.count > 0) {
        for (std::int32_t k = node.first; k < node.first + node.count; ++k)
          if (test(item_boxes_[static_cast<std::size_t>(k)])) out.push_back(ids_[static_cast<std::size_t>(k)]);
        continue;
      }
      stack[top++] = node.right;
      stack[top++] = node.left;
    }
  }

  /// max(floor, the largest value(id) over all items), pruning every node whose
  /// bound(box) is no more than the largest value found: bound must be an upper bound of
  /// value over the items inside the box. Values above `floor` are exact, whatever the
  /// pruning.
  template <class Bound, class Value>
  double maximum(const Bound& bound, const Value& value,
                 double floor = -std::numeric_limits<double>::infinity()) const {
    double best = floor;
    if (nodes_.empty()) return best;
    std::array<std::int32_t, 2 * kMaxDepth + 4> stack{};
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!(bound(node.box) > best)) continue;
      if (node.count > 0) {
        for (std::int32_t k = node.first; k < node.first + node.count; ++k)
          best = std::max(best, value(ids_[static_cast<std::size_t>(k)]));
        continue;
      }
      // The child with the larger bound is visited first (pushed last).
      const double bl = bound(nodes_[static_cast<std::size_t>(node.left)].box);
      const double br = bound(nodes_[static_cast<std::size_t>(node.right)].box);
      if (bl > br) {
        stack[top++] = node.right;
        stack[top++] = node.left;
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
    return best;
  }

 private:
  static constexpr int kMaxDepth = 48;  // far beyond log2 of any block's feature count
  struct Node {
    geometry::Aabb box;
    std::int32_t left = -1, right = -1;  ///< children (inner nodes)
    std::int32_t first = 0, count = 0;   ///< items ids_[first, first + count) (leaves)
  };
  std::int32_t build_node(std::vector<std::int32_t>& order, std::size_t begin, std::size_t end,
                          const std::vector<geometry::Aabb>& boxes, int depth);
  std::vector<Node> nodes_;
  std::vector<std::int32_t> ids_;
  std::vector<geometry::Aabb> item_boxes_;  ///< in the order of ids_
};

/// The block's box trees (body frame): its vertices, its convex edges and its faces.
struct BlockIndex {
  BoxTree vertices;
  BoxTree convex_edges;
  /// Each face's box holds its polygon and everything within the face's out-of-plane
  /// tolerance of it, so a point whose foot lies inside the polygon is inside the box
  /// inflated by its distance to the plane.
  BoxTree faces;
};

/// The index of the features of `model` (its vertices, faces and edges must be set),
/// whose faces lie within `plane_tolerance` (m) of their planes.
BlockIndex make_block_index(const Model& model, double plane_tolerance);

}  // namespace talus::dda::detail
