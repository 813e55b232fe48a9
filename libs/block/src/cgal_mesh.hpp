// SPDX-License-Identifier: MIT
// Private to talus_block: conversions between Talus meshes and CGAL's Surface_mesh, for
// the few translation units that use CGAL.
#pragma once
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/geometry/triangle_mesh.hpp"

namespace talus::block::cgal {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

inline Point point(const geometry::Vec3& p) { return Point(p.x(), p.y(), p.z()); }

/// A Surface_mesh of the triangles; throws InputError(source, …) when a face cannot be
/// added (the faces around a vertex do not form one fan).
inline SurfaceMesh to_surface_mesh(const geometry::TriangleMesh& mesh, const std::string& source) {
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> v;
  v.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) v.push_back(sm.add_vertex(point(p)));
  for (const auto& t : mesh.triangles)
    if (sm.add_face(v[t[0]], v[t[1]], v[t[2]]) == SurfaceMesh::null_face())
      throw core::InputError(source, "non-manifold: faces around a vertex do not form one fan");
  return sm;
}

/// The live vertices and triangles of a Surface_mesh (removed elements skipped).
inline geometry::TriangleMesh from_surface_mesh(const SurfaceMesh& sm) {
  geometry::TriangleMesh mesh;
  std::vector<std::int32_t> index(sm.number_of_vertices() + sm.number_of_removed_vertices(), -1);
  for (auto v : sm.vertices()) {
    index[v.idx()] = static_cast<std::int32_t>(mesh.vertices.size());
    const Point& p = sm.point(v);
    mesh.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (auto f : sm.faces()) {
    std::array<std::int32_t, 3> t{};
    std::size_t k = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (k < 3) t[k] = index[v.idx()];
      ++k;
    }
    if (k == 3) mesh.triangles.push_back(t);
  }
  return mesh;
}

}  // namespace talus::block::cgal
