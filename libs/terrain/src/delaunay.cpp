// The only CGAL translation unit of libs/terrain.
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Projection_traits_xy_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <numeric>
#include <string>

#include "talus/core/error.hpp"
#include "talus/terrain/build.hpp"

namespace talus::terrain {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Traits = CGAL::Projection_traits_xy_3<Kernel>;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<std::int32_t, Traits>;
using FaceBase = CGAL::Triangulation_face_base_2<Traits>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Traits, Tds>;

std::string point_text(const std::vector<Vec3>& points, std::size_t k) {
  return "point " + std::to_string(k) + " (" + core::format_number(points[k].x()) + ", " +
         core::format_number(points[k].y()) + ", " + core::format_number(points[k].z()) + ")";
}

}  // namespace

Terrain build_delaunay_terrain(const std::vector<Vec3>& points, const std::string& source) {
  if (points.size() < 3) {
    throw core::InputError(source, "Delaunay terrain needs at least 3 points, got " + std::to_string(points.size()));
  }
  if (points.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max() / 2)) {
    throw core::InputError(source, "too many points for 32-bit ids");
  }
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!points[k].allFinite()) throw core::InputError(source, "point " + std::to_string(k) + " is not finite");
  }
  // Two points with one (x, y) would make the surface two-valued there; CGAL would keep
  // one silently, so find them first (sorted by x, y, then index: the message names the
  // first pair deterministically).
  std::vector<std::int32_t> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  const auto by_xy = [&](std::int32_t a, std::int32_t b) {
    const Vec3& p = points[static_cast<std::size_t>(a)];
    const Vec3& q = points[static_cast<std::size_t>(b)];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    return a < b;
  };
  std::sort(order.begin(), order.end(), by_xy);
  std::size_t dup_a = points.size(), dup_b = points.size();
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const auto a = static_cast<std::size_t>(order[k]);
    const auto b = static_cast<std::size_t>(order[k + 1]);
    if (points[a].x() == points[b].x() && points[a].y() == points[b].y() && std::min(a, b) < dup_a) {
      dup_a = std::min(a, b);
      dup_b = std::max(a, b);
    }
  }
  if (dup_a < points.size()) {
    throw core::InputError(source, point_text(points, dup_a) + " and " + point_text(points, dup_b) +
                                       " have the same (x, y)");
  }

  std::vector<std::pair<Kernel::Point_3, std::int32_t>> input;
  input.reserve(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    input.emplace_back(Kernel::Point_3(points[k].x(), points[k].y(), points[k].z()), static_cast<std::int32_t>(k));
  }
  Delaunay dt;
  dt.insert(input.begin(), input.end());
  if (dt.dimension() < 2) {
    throw core::InputError(source, "all " + std::to_string(points.size()) +
                                       " points are collinear in plan: no surface to triangulate");
  }

  Terrain terrain;
  terrain.mesh.vertices = points;
  terrain.mesh.triangles.reserve(dt.number_of_faces());
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) {
    // CGAL faces are counter-clockwise in the (x, y) projection: seen from above.
    terrain.mesh.triangles.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});
  }
  // CGAL's face order follows its memory layout; sort for a canonical triangle numbering.
  for (auto& t : terrain.mesh.triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(terrain.mesh.triangles.begin(), terrain.mesh.triangles.end());
  terrain.materials.push_back(Material{});
  terrain.material_of_triangle.assign(terrain.mesh.triangles.size(), 0);
  return terrain;
}

}  // namespace talus::terrain
