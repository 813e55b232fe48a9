#include "talus/block/hull.hpp"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/convex_hull_3.h>

#include <array>
#include <cmath>

#include "cgal_mesh.hpp"
#include "talus/block/block.hpp"
#include "talus/core/error.hpp"
#include "talus/geometry/half_edge.hpp"

namespace talus::block {

using geometry::Vec3;
using cgal::Point;

namespace {

std::vector<Point> to_points(const std::vector<Vec3>& points) {
  std::vector<Point> out;
  out.reserve(points.size());
  for (const Vec3& p : points) out.emplace_back(p.x(), p.y(), p.z());
  return out;
}

double diagonal(const std::vector<Vec3>& points) {
  geometry::Aabb box;
  for (const Vec3& p : points) box.add(p);
  return box.empty() ? 0.0 : box.extent().norm();
}

}  // namespace

void require_volume_spanning(const std::vector<Vec3>& points, const std::string& source) {
  if (points.empty()) throw core::InputError(source, "empty point cloud: no points");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite()) throw core::InputError(source, "non-finite coordinate in point " + std::to_string(i));
  if (points.size() < 4)
    throw core::InputError(source, "too few points: " + std::to_string(points.size()) + " (a solid needs 4)");
  const std::vector<Point> p = to_points(points);
  // Exact predicates: a cloud is only refused when it truly spans no volume.
  std::size_t a = 1;
  while (a < p.size() && p[a] == p[0]) ++a;
  if (a == p.size()) throw core::InputError(source, "degenerate point cloud: all points coincide");
  std::size_t b = a + 1;
  while (b < p.size() && CGAL::collinear(p[0], p[a], p[b])) ++b;
  if (b == p.size()) throw core::InputError(source, "degenerate point cloud: all points are collinear");
  std::size_t c = b + 1;
  while (c < p.size() && CGAL::orientation(p[0], p[a], p[b], p[c]) == CGAL::COPLANAR) ++c;
  if (c == p.size()) throw core::InputError(source, "coplanar point cloud: all points lie in one plane (no volume)");
}

geometry::Polyhedron convex_hull(const std::vector<Vec3>& points, const std::string& source) {
  require_volume_spanning(points, source);
  const std::vector<Point> p = to_points(points);
  cgal::SurfaceMesh hull;
  CGAL::convex_hull_3(p.begin(), p.end(), hull);
  geometry::Polyhedron poly = geometry::to_polyhedron(cgal::from_surface_mesh(hull));
  // CGAL's output order follows memory addresses and the points' order: make it a
  // function of the points before the merge too, whose seeds (taken in face order)
  // decide which of several near-coplanar faces join (Hull.SameFacesWhateverThePointOrder).
  geometry::canonicalize(poly);
  geometry::Polyhedron merged = geometry::merge_coplanar_faces(poly, 1e-9 * diagonal(points));
  geometry::canonicalize(merged);
  return merged;
}

geometry::TriangleMesh reconstruct_surface(const std::vector<Vec3>& points, const ReconstructionOptions& options,
                                           const std::string& source) {
  require_volume_spanning(points, source);
  if (!(options.radius_ratio_bound > 0.0))
    throw core::InputError(source, "radius_ratio_bound must be positive, got " +
                                       core::format_number(options.radius_ratio_bound));
  if (!(options.beta_deg > 0.0 && options.beta_deg < 180.0))
    throw core::InputError(source, "beta_deg must be in (0, 180), got " + core::format_number(options.beta_deg));
  const std::vector<Point> p = to_points(points);
  std::vector<std::array<std::size_t, 3>> facets;
  const double pi = 3.14159265358979323846;
  CGAL::advancing_front_surface_reconstruction(p.begin(), p.end(), std::back_inserter(facets),
                                               options.radius_ratio_bound, options.beta_deg * pi / 180.0);
  geometry::TriangleMesh mesh;
  mesh.vertices = points;
  for (const auto& f : facets)
    mesh.triangles.push_back({static_cast<std::int32_t>(f[0]), static_cast<std::int32_t>(f[1]),
                              static_cast<std::int32_t>(f[2])});
  if (mesh.triangles.empty()) throw core::InputError(source, "surface reconstruction produced no triangles");
  // The reconstruction's global orientation is arbitrary: point it outward.
  if (exact_volume(geometry::to_polyhedron(mesh)).value < 0.0)
    for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

}  // namespace talus::block
