// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/triangle_mesh.hpp"

namespace talus::block {

/// Convex hull of a point cloud (m), coplanar hull triangles merged into polygon faces.
/// Throws core::InputError(source, …) when the cloud is empty, has fewer than 4
/// distinct points, or is collinear or coplanar (no volume), or holds a non-finite point.
geometry::Polyhedron convex_hull(const std::vector<geometry::Vec3>& points, const std::string& source);

/// Parameters of the concave reconstruction (CGAL advancing-front surface
/// reconstruction, Cohen-Steiner & Da 2004), which keeps the Delaunay triangles of the
/// cloud that grow a 2-manifold front from the most plausible seed triangle.
struct ReconstructionOptions {
  /// Candidate triangles whose circumradius exceeds this multiple of their shortest edge
  /// are refused unless they close the front (−). Larger bridges wider gaps between scan
  /// points; smaller follows concavities more closely. CGAL's default is 5.
  double radius_ratio_bound = 5.0;
  /// Largest dihedral-angle deviation between a candidate and its front neighbour (deg),
  /// the sharpness of edges the surface may follow. CGAL's default is 30.
  double beta_deg = 30.0;
};

/// Concave surface through the cloud's points. The result is checked like any mesh
/// (check_mesh): an open reconstruction is an error unless holes are filled on request.
geometry::TriangleMesh reconstruct_surface(const std::vector<geometry::Vec3>& points,
                                           const ReconstructionOptions& options, const std::string& source);

/// Throws core::InputError(source, …) unless the points span a volume (see convex_hull).
void require_volume_spanning(const std::vector<geometry::Vec3>& points, const std::string& source);

}  // namespace talus::block
