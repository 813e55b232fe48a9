// SPDX-License-Identifier: MIT
#pragma once
// Box trees over a block's features in its body frame, so that contact detection and the
// step control cost what the block touches, not what it has: a scanned rock of 10⁴ faces
// near a few terrain triangles is queried in logarithmic time instead of scanned.
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "talus/dda/model.hpp"
#include "talus/geometry/box_tree.hpp"
#include "talus/geometry/types.hpp"

namespace talus::dda::detail {

/// Blocks with more vertices than this get a BlockIndex; fewer are scanned feature by
/// feature, which is faster for them (docs/benchmarks.md, "Block detail").
constexpr std::size_t kScannedVertices = 32;

/// A box tree over some of a block's features (vertices, edges or faces): the feature
/// ids of the items and their boxes, for a test on each item's own box.
class FeatureTree {
 public:
  /// Builds the tree over the features `ids` with their boxes `boxes` (same length).
  void build(std::vector<geometry::Aabb> boxes, std::vector<std::int32_t> ids) {
    tree_.build(boxes);
    boxes_ = std::move(boxes);
    ids_ = std::move(ids);
  }
  bool empty() const { return tree_.empty(); }

  /// Appends the id of every feature whose box passes `test` (in tree order). `test`
  /// must be conservative: true for a node's box whenever it is true for any box inside.
  template <class Test>
  void query(const Test& test, std::vector<std::int32_t>& out) const {
    tree_.search(test, [&](std::int32_t item) {
      if (test(boxes_[static_cast<std::size_t>(item)])) out.push_back(ids_[static_cast<std::size_t>(item)]);
    });
  }

  /// max(floor, the largest value(id) over the features), by branch and bound over the
  /// boxes (geometry::BoxTree::maximum): bound(box) bounds value over the features inside.
  template <class Bound, class Value>
  double maximum(const Bound& bound, const Value& value,
                 double floor = -std::numeric_limits<double>::infinity()) const {
    return tree_.maximum(bound, [&](std::int32_t item) { return value(ids_[static_cast<std::size_t>(item)]); }, floor);
  }

 private:
  geometry::BoxTree tree_;
  std::vector<geometry::Aabb> boxes_;  ///< of item i
  std::vector<std::int32_t> ids_;      ///< feature id of item i
};

/// The block's box trees (body frame): its vertices, its convex edges and its faces.
struct BlockIndex {
  /// The box of the block's body-frame vertices (m).
  geometry::Aabb body_box;
  FeatureTree vertices;
  FeatureTree convex_edges;
  /// Each face's box holds its polygon and everything within the face's out-of-plane
  /// tolerance of it, so a point whose foot lies inside the polygon is inside the box
  /// inflated by its distance to the plane.
  FeatureTree faces;
};

/// The index of the features of `model` (its vertices, faces and edges must be set),
/// whose faces lie within `plane_tolerance` (m) of their planes.
BlockIndex make_block_index(const Model& model, double plane_tolerance);

}  // namespace talus::dda::detail
