#include "talus/block/simplify.hpp"

#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <cstdio>

#include "cgal_mesh.hpp"
#include "talus/block/hull.hpp"
#include "talus/block/mesh_check.hpp"
#include "talus/core/error.hpp"
#include "talus/geometry/half_edge.hpp"

namespace talus::block {

using cgal::SurfaceMesh;
namespace SMS = CGAL::Surface_mesh_simplification;

std::string SimplifyReport::describe() const {
  char line[256];
  std::snprintf(line, sizeof line, "simplified %zu -> %zu faces: volume %+.3e, inertia %.3e (relative), sphericity %+.4f",
                faces_before, faces_after, volume_change, inertia_change, sphericity_change);
  return line;
}

geometry::Polyhedron simplify_to_faces(const geometry::Polyhedron& poly, std::size_t target_faces,
                                       const std::string& source) {
  if (target_faces < 4)
    throw core::InputError(source, "simplify.target_faces must be at least 4, got " + std::to_string(target_faces));
  const geometry::TriangleMesh tri = geometry::triangulate(poly);
  if (tri.triangles.size() <= target_faces) return poly;
  SurfaceMesh sm = cgal::to_surface_mesh(tri, source);
  // A closed triangle mesh has 3F/2 edges.
  SMS::Count_stop_predicate<SurfaceMesh> stop(target_faces * 3 / 2);
  SMS::edge_collapse(sm, stop);
  sm.collect_garbage();
  geometry::TriangleMesh out = cgal::from_surface_mesh(sm);
  try {
    geometry::Polyhedron result = check_mesh(std::move(out), RepairOptions{}, source).polyhedron;
    geometry::canonicalize(result);
    return result;
  } catch (const core::InputError& e) {
    throw core::InputError(source, "simplification to " + std::to_string(target_faces) +
                                       " faces broke the surface (" + e.detail() + "); ask for more faces");
  }
}

geometry::Polyhedron simplify_to_hull(const geometry::Polyhedron& poly, const std::string& source) {
  return convex_hull(poly.vertices, source);
}

SimplifyReport compare(const Block& before, const Block& after) {
  SimplifyReport r;
  r.faces_before = before.polyhedron.faces.size();
  r.faces_after = after.polyhedron.faces.size();
  r.volume_change = (after.volume_exact - before.volume_exact) / before.volume_exact;
  r.inertia_change =
      (after.inertia_per_density - before.inertia_per_density).norm() / before.inertia_per_density.norm();
  r.sphericity_change = after.sphericity - before.sphericity;
  return r;
}

}  // namespace talus::block
