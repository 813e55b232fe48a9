// SPDX-License-Identifier: MIT
// The engine's private workspace: what a step keeps from one step to the next only to go
// faster -- the terrain features near the block and the feature pairs gathered from them,
// the flight test's triangles, the block's box at an earlier pose, the flight test's
// candidates handed to the contact step of the same pose, and scratch buffers. No result
// depends on it: a state stepped with a fresh workspace gives the same bits.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "talus/dda/engine.hpp"
#include "talus/geometry/types.hpp"

namespace talus::dda::detail {

/// A detailed block's box (the box of its world vertices) at the pose it was computed at,
/// reused at later poses close to it (scratch: the contacts never depend on it).
struct BlockBox {
  const void* model = nullptr;  ///< the Model it was computed for; null: none
  Vec3 centre = Vec3::Zero();   ///< the pose: x = centre + map·r
  Mat3 map = Mat3::Identity();
  geometry::Aabb box;           ///< m
  bool rigid = false;           ///< map is a rotation (the 6-DOF path)
};

/// The terrain features near the block, gathered once and reused by the contact search
/// of the following steps while the block's search box stays inside `box` (scratch: the
/// result never depends on it).
struct TerrainPatch {
  const void* surface = nullptr;     ///< the Surface it was gathered from
  geometry::Aabb box;                ///< the queried box (m)
  struct Triangle {
    std::int32_t index = -1;
    std::array<std::int32_t, 3> ids{};
    std::array<Vec3, 3> p;           ///< corners (m)
    Vec3 normal = Vec3::UnitZ();     ///< unit, up / outward
    geometry::Aabb box;
  };
  struct Vertex {
    std::int32_t id = -1;
    std::int32_t triangle = -1;      ///< one triangle using it (material)
    Vec3 p = Vec3::Zero();
    /// Its neighbours: unit directions towards the other corners of its triangles, in
    /// `neighbours` from `first` (count `count`).
    std::int32_t first = 0, count = 0;
  };
  /// An edge between two non-coplanar triangles (a crest or a valley), or on the patch
  /// border.
  struct Ridge {
    std::int32_t a = -1, b = -1;     ///< vertex ids, a < b
    Vec3 pa = Vec3::Zero(), pb = Vec3::Zero();
    Vec3 normal_sum = Vec3::Zero();  ///< sum of the adjacent triangles' normals
    std::array<Vec3, 2> normals{Vec3::Zero(), Vec3::Zero()};  ///< the first two of those normals
    std::int32_t normal_count = 0;   ///< the number of adjacent triangles (in the patch)
    /// Two triangles that bend down from each other across the edge (a crest): the ground
    /// there is under both planes, not under either as in a valley.
    bool convex = false;
    std::int32_t triangle = -1;
    geometry::Aabb box;
    /// The unit direction of normal_sum across the edge (its part along the edge taken
    /// out; zero where it has none): a block edge with both ends more than a distance
    /// above the edge along it crosses the edge's line no nearer (contacts.cpp,
    /// detect_indexed).
    Vec3 out = Vec3::Zero();
    double out_allowance = 0.0;  ///< round-off of values along `out` (m): 1e-9 of the coordinates
    /// Two triangles that bend up from each other across the edge (a valley): only a
    /// block that crosses valleys (Model::crosses_valleys) searches it.
    bool valley() const { return normal_count == 2 && !convex; }
    /// The edge as an edge–edge contact's terrain feature: its vertex ids a and b.
    std::int64_t key() const { return (static_cast<std::int64_t>(a) << 32) | static_cast<std::int64_t>(b); }
  };
  std::vector<Triangle> triangles;
  std::vector<Vertex> vertices;
  std::vector<Vec3> neighbours;      ///< see Vertex::first
  std::vector<Ridge> ridges;
  std::vector<std::int32_t> query;   ///< scratch for Surface::triangles_in_box
  /// The feature pairs a block of few vertices may form contacts with, gathered at one
  /// pose with wider distances than a step asks, and tested afresh at every step while the
  /// block has moved less than the difference: every pair the step's search would find
  /// is among them, in the order it would find them (docs/dda.md, Detection). A detailed
  /// block's are gathered per terrain triangle and ridge (Pairs; docs/dda.md, "Reusing the
  /// pairs"). Indices into the lists above and into the block's features.
  struct Candidates {
    /// The pose and distances pairs were gathered at.
    struct Gathering {
      const void* model = nullptr;       ///< the Model they were gathered for; null: none
      Vec3 centre = Vec3::Zero();        ///< the pose they were gathered at: x = centre + map·r
      Mat3 map = Mat3::Identity();
      bool rigid = false;                ///< map is a rotation (the 6-DOF path)
      double ds = 0.0, depth = 0.0;      ///< search distance and depth limit gathered with (m)
      /// A detailed block's: how far its points may move from that pose (m) while the
      /// pairs serve (their prism and plane tests were widened by it); ∞ for a scanned one.
      double motion = std::numeric_limits<double>::infinity();
      /// A detailed block's triangles or ridges were taken by their boxes within this of
      /// its box (m): they serve while that distance, less its motion, holds the search's.
      double box_margin = 0.0;
    };
    /// A detailed convex block's vertex walk that pairs came from (docs/dda.md, "Reusing
    /// the pairs"). Every vertex the walk under a plane left out lies above that plane by
    /// at least `rise` times its body-frame distance from `pivot` over `reach`, so while
    /// the block turns by less than rise/reach the walk's pairs serve as long as the
    /// points within `reach` of `pivot` move by no more than the gathering's motion.
    struct Cap {
      Vec3 pivot = Vec3::Zero();  ///< the walk's lowest vertex (body frame, m)
      double reach = 0.0;         ///< every vertex walked and its edges lie within it of pivot (m)
      double rise = 0.0;          ///< the plane's level over the pivot (m)
    };
    /// A detailed block's pairs with one triangle (its vertices) or one ridge (its convex
    /// edges), gathered on their own, and what their reuse rests on.
    struct Pairs : Gathering {
      enum class Basis : std::uint8_t {
        none,     ///< not gathered yet
        above,    ///< the block lies wholly above the triangle's plane, by `room` (m)
        beside,   ///< the block lies wholly beside the triangle's prisms, by `room` (m)
        apart,    ///< the block lies apart from the ridge, `room` (m) for margin and motion
        walked,   ///< found by the walk of `cap`
        queried,  ///< found by a tree query: every point's motion counts
      };
      Basis basis = Basis::none;
      std::uint64_t search = 0;  ///< the search that gathered them (Candidates::searches)
      double travelled = 0.0;    ///< Candidates::travelled then (m)
      double room = 0.0;
      /// The last search that tested their reuse on the two poses (detect_contacts): the
      /// motion since they were gathered it found, that of the walk's pivot and the turn
      /// (m, m, -; Motion), with Candidates::travelled and turned then. Later searches bound
      /// these by adding what the sums grew by since, and test on the poses only when
      /// that bound does not show them to serve.
      struct Checked {
        double moved = std::numeric_limits<double>::infinity();
        double pivot = 0.0, turn = 0.0;
        double travelled = 0.0, turned = 0.0;
      };
      Checked checked;
      Cap cap;
      std::vector<std::int32_t> features;  ///< block vertices or edges, ascending
      /// The features' body-frame points by coordinate, for the search's first tests in
      /// one pass each (m): of vertices x of each, then y, then z; of edges the same for
      /// their ends a, then for their ends b.
      std::vector<double> coordinates;
    };
    /// Of all the pairs of a scanned block; of a detailed block's triangles, by their boxes.
    Gathering gathering;
    /// Of a detailed block's ridges, by their boxes.
    Gathering ridge_gathering;
    std::vector<std::int32_t> triangles;                          ///< may meet the block's box
    /// A scanned block's (triangle, block vertex) pairs.
    std::vector<std::pair<std::int32_t, std::int32_t>> vertex_triangle;
    std::vector<std::int32_t> vertices;                           ///< a scanned block's terrain vertices
    std::vector<std::int32_t> ridges;                             ///< may meet the block's box
    std::vector<std::pair<std::int32_t, std::int32_t>> edge_ridge;  ///< a scanned block's (block edge, ridge)
    /// A detailed block's pairs with each of `triangles` and of `ridges` (at the same place).
    std::vector<Pairs> triangle_pairs, ridge_pairs;
    /// A detailed block's searches so far: pairs gathered in one search share its pose.
    std::uint64_t searches = 0;
    /// The sum, over a detailed block's searches, of how far its points moved at most
    /// since the search before (m), and the pose of the last search: the difference of
    /// two sums bounds every point's motion between those searches.
    double travelled = 0.0;
    /// The same sum of how far the block turned at most since the search before (the
    /// bound ‖ΔF‖ of Motion::turn), which bounds its turn between those searches.
    double turned = 0.0;
    Gathering last_search;
  };
  Candidates candidates;
};

/// The terrain triangles the flight test last gathered from the surface (when the block's
/// swept box lies outside the contact search's patch), with what the test reads of each.
struct FlightPatch {
  const void* surface = nullptr;     ///< the Surface it was gathered from
  geometry::Aabb box;                ///< the queried box (m)
  struct Triangle {
    geometry::Aabb box;              ///< of its corners (m)
    Vec3 normal = Vec3::UnitZ();     ///< Surface::normal
    std::array<Vec3, 3> p;           ///< corners (m)
  };
  std::vector<Triangle> triangles;
};

/// The flight test's contact search from the pose of a step, handed to the contact step
/// that follows from the same pose with the same distance (which then need not search).
struct Handoff {
  std::vector<Contact> contacts;  ///< the candidates found
  /// The search distance (m) of that search, or a negative value when it holds none.
  double reach = -1.0;
  /// What the search passed over (MotionFilter): how many candidates, and the least bound
  /// of their gaps (m).
  std::size_t passed = 0;
  double least_gap = std::numeric_limits<double>::infinity();
};

/// The workspace of one realization (dda::Workspace holds one).
struct Scratch {
  ReferencePaths paths;
  TerrainPatch patch;
  FlightPatch flight_patch;
  std::vector<std::int32_t> triangles;  ///< scratch for Surface::triangles_in_box
  Handoff handoff;
  std::vector<Vec3> vertices;  ///< world vertices of a scanned block (m)
  BlockBox box;                ///< a detailed block's box at an earlier pose
};

}  // namespace talus::dda::detail
