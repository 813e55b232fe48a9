// SPDX-License-Identifier: MIT
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/triangle_mesh.hpp"

namespace talus::block {

/// Repairs made only when asked. Each repair made is reported.
struct RepairOptions {
  bool orient = false;             ///< make face orientation consistent and outward
  bool stitch = false;             ///< merge boundary vertices closer than stitch_tolerance
  double stitch_tolerance = 0.0;   ///< m; 0 = 1e-6 × bounding-box diagonal
  bool fill_holes = false;         ///< close holes of at most max_hole_edges boundary edges
  std::size_t max_hole_edges = 16; ///< largest hole (boundary edges) filled
  /// Where these options are set, for the hints of messages ("inputs.repair" gives
  /// "set inputs.repair.fill_holes").
  std::string settings_key = "repair";
};

struct CheckedMesh {
  /// Closed, 2-manifold, one piece, outward, no self-intersection; coplanar adjacent
  /// triangles merged into convex polygon faces.
  geometry::Polyhedron polyhedron;
  std::vector<std::string> repairs;  ///< one line per repair made
};

/// Validates a triangle mesh as the boundary of one solid, in this order: empty,
/// non-finite, (stitching, when asked), degenerate (zero-area) triangles, non-manifold
/// edges, inconsistent orientation, open boundary, non-manifold vertices, several
/// pieces, self-intersection, zero volume, inside-out. The first defect not repaired
/// throws core::InputError(source, "<defect>: <detail>"); docs/block.md lists them.
CheckedMesh check_mesh(geometry::TriangleMesh mesh, const RepairOptions& repair, const std::string& source);

/// The self-intersection test alone (CGAL, exact predicates): returns the number of
/// intersecting triangle pairs and one example pair.
std::size_t self_intersections(const geometry::TriangleMesh& mesh, std::size_t& first, std::size_t& second);

}  // namespace talus::block
