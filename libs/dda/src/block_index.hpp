// SPDX-License-Identifier: MIT
#pragma once
// Box trees over a block's features in its body frame, so that contact detection and the
// step control cost what the block touches, not what it has: a scanned rock of 10⁴ faces
// near a few terrain triangles is queried in logarithmic time instead of scanned.
#include <algorithm>
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

/// Marks over items 0 … n − 1, all cleared at once in constant time: each round has its
/// own number, and an item is marked when it holds the round's. For the searches that
/// visit each of a block's vertices or edges once (thread_local: one set per thread).
class RoundMarks {
 public:
  /// Starts a round over at least n items, none of them marked.
  void start(std::size_t n) {
    if (marks_.size() < n) marks_.resize(n, 0);
    if (++round_ == 0) {  // wrapped: forget every mark
      std::fill(marks_.begin(), marks_.end(), 0);
      round_ = 1;
    }
  }
  /// Marks item i; whether it was not marked yet.
  bool mark(std::int32_t i) {
    std::uint32_t& m = marks_[static_cast<std::size_t>(i)];
    if (m == round_) return false;
    m = round_;
    return true;
  }

 private:
  std::vector<std::uint32_t> marks_;
  std::uint32_t round_ = 0;
};

/// Steepest ascent over the vertex graph of a convex block (Model::convex): the vertex
/// farthest along a body direction m, max m·rᵢ, in a few steps instead of a tree search.
/// On a convex polyhedron a vertex none of whose neighbours lies farther is the farthest
/// of all (exactly; in floating point within a few ulps of |m|·radius, which the callers
/// allow for), unless it lies on a plateau: a flat face of many triangles (Model::convex
/// lets their edges be flat) across m, whose vertices are all as far. Where some neighbour
/// is as far to within kTie of |m|₁·radius, the plateau is searched for a way on
/// (beyond_plateau). The walk starts at the farthest vertex along the centre of the cell of
/// a cube map (6 faces of kCells × kCells cells, tabulated) that m points into, a few
/// degrees from m, so its result depends on m alone and it takes a few steps.
class VertexClimb {
 public:
  /// The graph of the convex `model` (vertices and edges set); empty when not convex.
  void build(const Model& model);
  bool empty() const { return offsets_.empty(); }
  /// The vertex farthest along m (body frame): from the tabulated start, or from `from`
  /// when that is a vertex (a walk of nearby directions, warm).
  std::int32_t farthest(const std::vector<Vec3>& vertices, const Vec3& m, std::int32_t from = -1) const {
    return plateaus_ ? climb<true>(vertices, m, from) : climb<false>(vertices, m, from);
  }
  /// Whether below() applies: the block is convex and every face a triangle, so that the
  /// graph is exactly the edge graph of a convex polytope.
  bool fills() const { return fills_; }
  /// The vertices v with m·r_v ≤ level (body frame, m·r_v as computed here) into `out`,
  /// and perhaps some up to `slack` above it, in no particular order; the least value of
  /// m·r_v into `lowest`. On a convex polytope the vertices under a plane are connected
  /// through the edges among them (from a vertex above the lowest, some edge leads down),
  /// so a walk from the lowest vertex over the vertices under level + slack finds them
  /// all: every vertex of a descending path from one of them lies that low, exactly, and
  /// the slack (at least a few ulps of |m|·|r|) covers the round-off. Stops and returns
  /// false, with `out` incomplete, once it has found more than `limit` vertices. With
  /// `rise`, the level is raised to at least lowest + rise first (set in `level`); the
  /// lowest vertex is then out's first.
  bool below(const std::vector<Vec3>& vertices, const Vec3& m, double& level, double slack, std::size_t limit,
             std::vector<std::int32_t>& out, double& lowest, double rise = 0.0) const;
  /// The edges at vertex v (ids into Model::edges): edge(k) for k from first(v) to
  /// first(v + 1) − 1.
  std::int32_t first(std::int32_t v) const { return offsets_[static_cast<std::size_t>(v)]; }
  std::int32_t edge(std::int32_t k) const { return edges_[static_cast<std::size_t>(k)]; }
  /// The length of vertex v's longest edge (body frame, m): every point of its edges lies
  /// within it of v.
  double longest(std::int32_t v) const { return longest_[static_cast<std::size_t>(v)]; }

 private:
  static constexpr int kCells = 32;
  /// The cube-map cell m points into: face (axis of |m|'s largest coordinate and its
  /// sign) and the cell of the other two coordinates over it.
  static int cell(const Vec3& m);
  std::int32_t start(const Vec3& m) const { return starts_[static_cast<std::size_t>(cell(m))]; }

  std::vector<std::int32_t> offsets_, neighbours_;  ///< the graph, compressed rows
  std::vector<std::int32_t> edges_;                  ///< the edge to each neighbour
  std::vector<double> longest_;                      ///< of each vertex (m)
  double radius_ = 0.0;                              ///< the largest |r| of a vertex (m)
  /// What spread() does with a vertex it meets: passes over it, takes it (and goes on
  /// from it), or stops.
  enum class Reach { pass, take, stop };
  /// Breadth first over the graph from `start` (appended to `out`, which must not hold
  /// it): each vertex met once (of n), judged by reach(w); the vertices taken are
  /// appended to `out`, which is the walk's queue too.
  template <class Judge>
  void spread(std::int32_t start, std::size_t n, std::vector<std::int32_t>& out, const Judge& reach) const {
    thread_local RoundMarks met;
    met.start(n);
    met.mark(start);
    out.push_back(start);
    for (std::size_t next = 0; next < out.size(); ++next) {
      const std::int32_t v = out[next];
      const std::int32_t end = offsets_[static_cast<std::size_t>(v) + 1];
      for (std::int32_t k = offsets_[static_cast<std::size_t>(v)]; k < end; ++k) {
        const std::int32_t w = neighbours_[static_cast<std::size_t>(k)];
        if (!met.mark(w)) continue;
        const Reach r = reach(w);
        if (r == Reach::stop) return;
        if (r == Reach::take) out.push_back(w);
      }
    }
  }
  bool plateaus_ = false;                            ///< some edge is flat (not convex)
  /// farthest(), on a graph with flat edges (kPlateaus) or with none: a block whose
  /// edges are all convex has no flat region, and its climbs skip the plateau test.
  template <bool kPlateaus>
  std::int32_t climb(const std::vector<Vec3>& vertices, const Vec3& m, std::int32_t from) const {
    std::int32_t at = from >= 0 ? from : start(m);
    double best = m.dot(vertices[static_cast<std::size_t>(at)]);
    for (;;) {
      std::int32_t next = -1;
      double nearest = -std::numeric_limits<double>::infinity();  // the neighbours' largest value
      const std::int32_t end = offsets_[static_cast<std::size_t>(at) + 1];
      for (std::int32_t k = offsets_[static_cast<std::size_t>(at)]; k < end; ++k) {
        const std::int32_t j = neighbours_[static_cast<std::size_t>(k)];
        const double value = m.dot(vertices[static_cast<std::size_t>(j)]);
        if constexpr (kPlateaus) nearest = std::max(nearest, value);
        if (value > best) {
          best = value;
          next = j;
        }
      }
      if (next < 0) {
        if constexpr (!kPlateaus) return at;
        const double tie = kTie * radius_ * m.cwiseAbs().sum();
        if (!(nearest >= best - tie)) return at;
        next = beyond_plateau(vertices, m, at, best, tie);
        if (next < 0) return at;
        best = m.dot(vertices[static_cast<std::size_t>(next)]);
      }
      at = next;
    }
  }
  static constexpr double kTie = 1e-12;              ///< a plateau's spread, of |m|₁·radius
  /// From vertex `at` (value `best` along m, no neighbour beyond it): through the
  /// vertices connected to it within `tie` of that value, a vertex more than `tie` beyond
  /// it, or −1 when there is none (`at` is then the farthest, to within the plateau's
  /// spread).
  std::int32_t beyond_plateau(const std::vector<Vec3>& vertices, const Vec3& m, std::int32_t at, double best,
                              double tie) const;
  bool fills_ = false;
  std::vector<std::int32_t> starts_;                ///< farthest vertex along each cell's centre
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
  /// A convex block's vertex graph for support queries (empty when it is concave).
  VertexClimb climb;
};

/// The index of the features of `model` (its vertices, faces and edges must be set),
/// whose faces lie within `plane_tolerance` (m) of their planes.
BlockIndex make_block_index(const Model& model, double plane_tolerance);

}  // namespace talus::dda::detail
