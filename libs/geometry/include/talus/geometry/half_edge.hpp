// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/triangle_mesh.hpp"
#include "talus/geometry/types.hpp"

namespace talus::geometry {

/// What keeps a set of indexed polygon faces from being the boundary of a solid.
enum class TopologyDefect {
  none,
  empty,                     ///< no faces
  bad_index,                 ///< a face refers to a vertex that does not exist
  repeated_vertex,           ///< a face lists the same vertex twice (or has < 3 vertices)
  nonmanifold_edge,          ///< an edge is shared by more than two faces
  inconsistent_orientation,  ///< two faces traverse a shared edge in the same direction
  open_boundary,             ///< an edge belongs to one face only
  nonmanifold_vertex,        ///< the faces around a vertex form more than one fan
};

/// The first defect found, how many elements have it, and one example.
struct TopologyReport {
  TopologyDefect defect = TopologyDefect::none;
  std::size_t count = 0;       ///< edges, faces or vertices with the defect
  std::int64_t face = -1;      ///< an example face (−1 if none applies)
  std::int64_t vertex = -1;    ///< an example vertex (−1 if none applies)
  bool ok() const { return defect == TopologyDefect::none; }
  /// One line for an error message, e.g. "open surface: 12 boundary edges (e.g. at vertex 4)".
  std::string describe() const;
};

/// A half-edge structure over polygon faces: each face is a loop of half-edges, each
/// half-edge knows its twin on the neighbouring face. It only exists for closed,
/// 2-manifold, consistently oriented surfaces; build() says which defect prevents it.
class HalfEdgeMesh {
 public:
  struct HalfEdge {
    std::int32_t origin = -1;  ///< vertex the half-edge leaves
    std::int32_t twin = -1;    ///< the opposite half-edge, on the adjacent face
    std::int32_t next = -1;    ///< the next half-edge of the same face (CCW)
    std::int32_t face = -1;
  };

  /// Builds the structure from polygon faces (vertex indices CCW from outside). On a
  /// defect, returns the report and leaves `out` empty. Unreferenced vertices are allowed
  /// and keep their index.
  static TopologyReport build(const std::vector<Vec3>& vertices,
                              const std::vector<std::vector<std::int32_t>>& faces,
                              HalfEdgeMesh& out);

  const std::vector<Vec3>& vertices() const { return vertices_; }
  const std::vector<HalfEdge>& half_edges() const { return half_edges_; }
  std::size_t face_count() const { return face_edge_.size(); }
  std::size_t edge_count() const { return half_edges_.size() / 2; }
  /// Vertices used by at least one face.
  std::size_t used_vertex_count() const;
  /// One half-edge of face `f`.
  std::int32_t face_half_edge(std::size_t f) const { return face_edge_[f]; }
  /// Vertex indices of face `f`, in order.
  std::vector<std::int32_t> face_vertices(std::size_t f) const;
  /// Number of edge-connected pieces of the surface.
  std::size_t connected_components() const;
  /// V − E + F over used vertices: 2 for a surface of genus 0.
  std::int64_t euler_characteristic() const;

 private:
  std::vector<Vec3> vertices_;
  std::vector<HalfEdge> half_edges_;
  std::vector<std::int32_t> face_edge_;
};

/// Merges edge-adjacent faces lying in one plane (every vertex of the merged region
/// within `tolerance` m of the plane of its first face) into one polygon face, when the
/// region's boundary is a single convex loop; other regions keep their faces. Vertices
/// left inside merged faces are removed. The input must be closed and consistently
/// oriented (see HalfEdgeMesh::build); it is returned unchanged otherwise.
Polyhedron merge_coplanar_faces(const Polyhedron& poly, double tolerance);

/// Removes vertices no face uses, renumbering the faces; returns how many were removed.
std::size_t remove_unused_vertices(Polyhedron& poly);

/// Puts a polyhedron in a canonical order that depends only on its geometry: vertices
/// sorted by (x, y, z), each face starting at its smallest vertex index, faces sorted.
/// Used on the output of algorithms whose element order follows memory addresses.
void canonicalize(Polyhedron& poly);

/// Fan triangulation of every face (exact for the planar convex faces Talus stores).
TriangleMesh triangulate(const Polyhedron& poly);

/// The triangles of a mesh as the faces of a polyhedron (no checks).
Polyhedron to_polyhedron(const TriangleMesh& mesh);

}  // namespace talus::geometry
