#include "talus/block/mesh_check.hpp"

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "cgal_mesh.hpp"
#include "talus/block/block.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/geometry/half_edge.hpp"

namespace talus::block {

using geometry::TriangleMesh;
using geometry::Vec3;
using cgal::from_surface_mesh;
using cgal::SurfaceMesh;
using cgal::to_surface_mesh;
namespace PMP = CGAL::Polygon_mesh_processing;

namespace {

std::uint64_t key(std::int32_t a, std::int32_t b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

std::string where(const TriangleMesh& mesh, std::int64_t vertex) {
  if (vertex < 0) return "";
  const Vec3& p = mesh.vertices[static_cast<std::size_t>(vertex)];
  return " near (" + core::format_number(p.x()) + ", " + core::format_number(p.y()) + ", " +
         core::format_number(p.z()) + ")";
}

// Flips triangles so that every shared edge is traversed in opposite directions, by a
// breadth-first walk from the first triangle of each piece. Returns the number flipped,
// or throws if the surface cannot be oriented (a Möbius-like band).
std::size_t orient_consistently(TriangleMesh& mesh, const std::string& source) {
  std::unordered_map<std::uint64_t, std::vector<std::int32_t>> edge_faces;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[f][static_cast<std::size_t>(k)];
      const std::int32_t b = mesh.triangles[f][static_cast<std::size_t>((k + 1) % 3)];
      edge_faces[key(std::min(a, b), std::max(a, b))].push_back(static_cast<std::int32_t>(f));
    }
  auto has_directed = [&](std::size_t f, std::int32_t a, std::int32_t b) {
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k)
      if (t[static_cast<std::size_t>(k)] == a && t[static_cast<std::size_t>((k + 1) % 3)] == b) return true;
    return false;
  };
  std::vector<char> done(mesh.triangles.size(), 0);
  std::size_t flipped = 0;
  std::vector<std::int32_t> queue;
  for (std::size_t seed = 0; seed < mesh.triangles.size(); ++seed) {
    if (done[seed]) continue;
    done[seed] = 1;
    queue.assign(1, static_cast<std::int32_t>(seed));
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const auto f = static_cast<std::size_t>(queue[head]);
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = mesh.triangles[f][static_cast<std::size_t>(k)];
        const std::int32_t b = mesh.triangles[f][static_cast<std::size_t>((k + 1) % 3)];
        for (std::int32_t g : edge_faces[key(std::min(a, b), std::max(a, b))]) {
          const auto gi = static_cast<std::size_t>(g);
          if (gi == f) continue;
          const bool same_direction = has_directed(gi, a, b);
          if (done[gi]) {
            if (same_direction)
              throw core::InputError(source, "non-orientable surface: faces cannot be oriented consistently");
            continue;
          }
          if (same_direction) {
            std::swap(mesh.triangles[gi][1], mesh.triangles[gi][2]);
            ++flipped;
          }
          done[gi] = 1;
          queue.push_back(g);
        }
      }
    }
  }
  return flipped;
}

// Boundary loops (holes) as lists of boundary edges' start vertices.
std::vector<std::size_t> hole_sizes(const TriangleMesh& mesh) {
  std::unordered_map<std::uint64_t, int> directed;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[key(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)])];
  std::multimap<std::int32_t, std::int32_t> next;  // boundary edge a→b, stored a → b
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      // The hole runs against the faces: its edges are the reversed boundary edges.
      if (!directed.count(key(b, a))) next.emplace(b, a);
    }
  std::vector<std::size_t> sizes;
  while (!next.empty()) {
    auto it = next.begin();
    const std::int32_t start = it->first;
    std::int32_t at = it->second;
    next.erase(it);
    std::size_t n = 1;
    while (at != start) {
      auto found = next.find(at);
      if (found == next.end()) break;
      at = found->second;
      next.erase(found);
      ++n;
    }
    sizes.push_back(n);
  }
  std::sort(sizes.begin(), sizes.end());
  return sizes;
}

}  // namespace

std::size_t self_intersections(const TriangleMesh& mesh, std::size_t& first, std::size_t& second) {
  const SurfaceMesh sm = to_surface_mesh(mesh, "");
  if (!PMP::does_self_intersect(sm)) return 0;
  std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
  PMP::self_intersections(sm, std::back_inserter(pairs));
  if (pairs.empty()) return 0;
  // The order of pairs depends on the box-intersection traversal: report the smallest.
  auto best = std::min_element(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
    return std::minmax(x.first.idx(), x.second.idx()) < std::minmax(y.first.idx(), y.second.idx());
  });
  first = std::min(best->first.idx(), best->second.idx());
  second = std::max(best->first.idx(), best->second.idx());
  return pairs.size();
}

CheckedMesh check_mesh(TriangleMesh mesh, const RepairOptions& repair, const std::string& source) {
  CheckedMesh out;
  if (mesh.triangles.empty()) throw core::InputError(source, "empty mesh: no triangles");
  for (const Vec3& p : mesh.vertices)
    if (!p.allFinite()) throw core::InputError(source, "non-finite vertex coordinate");
  const double diag = mesh.bounds().extent().norm();

  if (repair.stitch) {
    const double tol = repair.stitch_tolerance > 0.0 ? repair.stitch_tolerance : 1e-6 * diag;
    const std::size_t before = mesh.triangles.size();
    const std::size_t merged = geometry::weld_vertices(mesh, tol);
    if (merged > 0)
      out.repairs.push_back("stitched: merged " + std::to_string(merged) + " vertices closer than " +
                            core::format_number(tol) + " m (" + std::to_string(before - mesh.triangles.size()) +
                            " triangles collapsed)");
  }

  // Degenerate triangles: a repeated vertex or three collinear points (exact predicate).
  std::size_t degenerate = 0;
  std::size_t example = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const bool bad = t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
                     CGAL::collinear(cgal::point(a), cgal::point(b), cgal::point(c));
    if (bad && degenerate++ == 0) example = f;
  }
  if (degenerate)
    throw core::InputError(source, "degenerate faces: " + std::to_string(degenerate) +
                                       " zero-area triangle(s) (e.g. triangle " + std::to_string(example) + where(mesh, mesh.triangles[example][0]) + ")");

  // Edge topology first: non-manifold edges cannot be oriented or repaired.
  {
    std::unordered_map<std::uint64_t, int> uses;
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
        ++uses[key(std::min(a, b), std::max(a, b))];
      }
    std::size_t nonmanifold = 0;
    std::int64_t at = -1;
    for (const auto& [k, n] : uses)
      if (n > 2) {
        ++nonmanifold;
        const auto v = static_cast<std::int64_t>(k >> 32);
        at = at < 0 ? v : std::min(at, v);
      }
    if (nonmanifold)
      throw core::InputError(source, "non-manifold: " + std::to_string(nonmanifold) +
                                         " edge(s) shared by more than two faces" + where(mesh, at));
  }

  geometry::HalfEdgeMesh he;
  geometry::TopologyReport topo = geometry::HalfEdgeMesh::build(mesh.vertices, geometry::to_polyhedron(mesh).faces, he);
  if (topo.defect == geometry::TopologyDefect::inconsistent_orientation) {
    if (!repair.orient)
      throw core::InputError(source, topo.describe() + where(mesh, topo.vertex) +
                                         "; set " + repair.settings_key + ".orient to re-orient");
    const std::size_t flipped = orient_consistently(mesh, source);
    out.repairs.push_back("oriented: flipped " + std::to_string(flipped) + " triangle(s) to agree with their neighbours");
    topo = geometry::HalfEdgeMesh::build(mesh.vertices, geometry::to_polyhedron(mesh).faces, he);
  }
  if (topo.defect == geometry::TopologyDefect::open_boundary) {
    const std::vector<std::size_t> holes = hole_sizes(mesh);
    const std::size_t largest = holes.empty() ? 0 : holes.back();
    const std::string detail = "open surface: " + std::to_string(topo.count) + " boundary edge(s) in " +
                               std::to_string(holes.size()) + " hole(s), the largest of " +
                               std::to_string(largest) + " edges" + where(mesh, topo.vertex);
    if (!repair.fill_holes) throw core::InputError(source, detail + "; set " + repair.settings_key + ".fill_holes to close small holes");
    if (largest > repair.max_hole_edges)
      throw core::InputError(source, detail + ", larger than " + repair.settings_key + ".max_hole_edges = " +
                                         std::to_string(repair.max_hole_edges));
    SurfaceMesh sm = to_surface_mesh(mesh, source);
    std::vector<SurfaceMesh::Halfedge_index> borders;
    PMP::extract_boundary_cycles(sm, std::back_inserter(borders));
    std::size_t added = 0;
    for (auto h : borders) {
      std::vector<SurfaceMesh::Face_index> patch;
      PMP::triangulate_hole(sm, h, std::back_inserter(patch));
      added += patch.size();
    }
    mesh = from_surface_mesh(sm);
    out.repairs.push_back("filled " + std::to_string(holes.size()) + " hole(s) (" + std::to_string(topo.count) +
                          " boundary edges) with " + std::to_string(added) + " triangle(s)");
    topo = geometry::HalfEdgeMesh::build(mesh.vertices, geometry::to_polyhedron(mesh).faces, he);
  }
  if (!topo.ok()) throw core::InputError(source, topo.describe() + where(mesh, topo.vertex));
  const std::size_t pieces = he.connected_components();
  if (pieces > 1)
    throw core::InputError(source, "several pieces: the surface has " + std::to_string(pieces) +
                                       " separate closed parts (one block per file)");

  std::size_t first = 0, second = 0;
  const std::size_t crossings = self_intersections(mesh, first, second);
  if (crossings)
    throw core::InputError(source, "self-intersecting: " + std::to_string(crossings) +
                                       " pair(s) of triangles intersect (e.g. triangles " + std::to_string(first) +
                                       " and " + std::to_string(second) + where(mesh, mesh.triangles[first][0]) + ")");

  geometry::Polyhedron poly = geometry::to_polyhedron(mesh);
  geometry::remove_unused_vertices(poly);
  const ExactVolume signed_volume = exact_volume(poly);
  if (signed_volume.value == 0.0 && signed_volume.rational == "0")
    throw core::InputError(source, "zero volume: the closed surface encloses nothing");
  if (signed_volume.value < 0.0) {
    if (!repair.orient)
      throw core::InputError(source, "inside-out: faces are oriented inward (signed volume " +
                                         core::format_number(signed_volume.value) + " m^3); set " + repair.settings_key + ".orient to flip");
    for (auto& face : poly.faces) std::reverse(face.begin(), face.end());
    out.repairs.push_back("turned inside-out surface outward (" + std::to_string(poly.faces.size()) + " faces flipped)");
  }
  out.polyhedron = geometry::merge_coplanar_faces(poly, 1e-9 * diag);
  return out;
}

}  // namespace talus::block
