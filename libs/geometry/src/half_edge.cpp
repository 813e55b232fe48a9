#include "talus/geometry/half_edge.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>
#include <unordered_map>

namespace talus::geometry {

namespace {

std::uint64_t edge_key(std::int32_t a, std::int32_t b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

// Smallest-index root with path halving: deterministic, independent of merge order.
std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

void unite(std::vector<std::int32_t>& parent, std::int32_t a, std::int32_t b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (a < b) parent[b] = a;
  else parent[a] = b;
}

}  // namespace

std::string TopologyReport::describe() const {
  const std::string n = std::to_string(count);
  const std::string at_vertex = vertex >= 0 ? " (e.g. at vertex " + std::to_string(vertex) + ")" : "";
  const std::string at_face = face >= 0 ? " (e.g. face " + std::to_string(face) + ")" : "";
  switch (defect) {
    case TopologyDefect::none: return "valid closed surface";
    case TopologyDefect::empty: return "empty: no faces";
    case TopologyDefect::bad_index: return "bad vertex index in " + n + " face(s)" + at_face;
    case TopologyDefect::repeated_vertex: return "degenerate faces: " + n + " face(s) repeat a vertex" + at_face;
    case TopologyDefect::nonmanifold_edge:
      return "non-manifold: " + n + " edge(s) shared by more than two faces" + at_vertex;
    case TopologyDefect::inconsistent_orientation:
      return "inconsistent orientation: " + n + " edge(s) traversed in the same direction by both faces" + at_vertex;
    case TopologyDefect::open_boundary: return "open surface: " + n + " boundary edge(s)" + at_vertex;
    case TopologyDefect::nonmanifold_vertex:
      return "non-manifold: " + n + " vertex/vertices joining separate fans of faces" + at_vertex;
  }
  return "unknown defect";
}

TopologyReport HalfEdgeMesh::build(const std::vector<Vec3>& vertices,
                                   const std::vector<std::vector<std::int32_t>>& faces, HalfEdgeMesh& out) {
  out = HalfEdgeMesh{};
  TopologyReport report;
  auto fail = [&](TopologyDefect d, std::size_t count, std::int64_t face, std::int64_t vertex) {
    report.defect = d;
    report.count = count;
    report.face = face;
    report.vertex = vertex;
    return report;
  };
  if (faces.empty()) return fail(TopologyDefect::empty, 0, -1, -1);

  const auto nv = static_cast<std::int64_t>(vertices.size());
  std::size_t bad = 0, repeated = 0, total = 0;
  std::int64_t bad_face = -1, repeated_face = -1;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& face = faces[f];
    total += face.size();
    bool face_bad = false, face_repeated = face.size() < 3;
    for (std::size_t k = 0; k < face.size(); ++k) {
      if (face[k] < 0 || face[k] >= nv) face_bad = true;
      for (std::size_t j = 0; j < k; ++j)
        if (face[j] == face[k]) face_repeated = true;
    }
    if (face_bad && bad++ == 0) bad_face = static_cast<std::int64_t>(f);
    if (face_repeated && repeated++ == 0) repeated_face = static_cast<std::int64_t>(f);
  }
  if (bad) return fail(TopologyDefect::bad_index, bad, bad_face, -1);
  if (repeated) return fail(TopologyDefect::repeated_vertex, repeated, repeated_face, -1);

  // Count the uses of each undirected edge and of each direction.
  std::unordered_map<std::uint64_t, std::int32_t> directed;
  std::unordered_map<std::uint64_t, int> undirected;
  directed.reserve(total);
  undirected.reserve(total);
  std::vector<HalfEdge> he(total);
  std::vector<std::int32_t> face_edge(faces.size());
  std::size_t duplicate_dir = 0;
  std::int64_t duplicate_vertex = -1;
  std::int32_t h = 0;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& face = faces[f];
    face_edge[f] = h;
    const auto n = static_cast<std::int32_t>(face.size());
    for (std::int32_t k = 0; k < n; ++k) {
      const std::int32_t a = face[k], b = face[(k + 1) % n];
      he[h + k] = HalfEdge{a, -1, h + (k + 1) % n, static_cast<std::int32_t>(f)};
      if (!directed.emplace(edge_key(a, b), h + k).second && duplicate_dir++ == 0) duplicate_vertex = a;
      ++undirected[edge_key(std::min(a, b), std::max(a, b))];
    }
    h += n;
  }
  std::size_t nonmanifold = 0, boundary = 0;
  std::int64_t nonmanifold_vertex = -1, boundary_vertex = -1;
  for (const auto& [key, uses] : undirected) {
    const auto a = static_cast<std::int64_t>(key >> 32);
    if (uses > 2 && nonmanifold++ == 0) nonmanifold_vertex = a;
    if (uses == 1 && boundary++ == 0) boundary_vertex = a;
  }
  // Unordered-map iteration order is not portable: report the smallest example vertex.
  if (nonmanifold) {
    for (const auto& [key, uses] : undirected)
      if (uses > 2) nonmanifold_vertex = std::min<std::int64_t>(nonmanifold_vertex, key >> 32);
    return fail(TopologyDefect::nonmanifold_edge, nonmanifold, -1, nonmanifold_vertex);
  }
  if (duplicate_dir) {
    for (std::int32_t i = 0; i < static_cast<std::int32_t>(he.size()); ++i)
      if (directed.at(edge_key(he[i].origin, he[he[i].next].origin)) != i)
        duplicate_vertex = std::min<std::int64_t>(duplicate_vertex, he[i].origin);
    return fail(TopologyDefect::inconsistent_orientation, duplicate_dir, -1, duplicate_vertex);
  }
  if (boundary) {
    for (const auto& [key, uses] : undirected)
      if (uses == 1) boundary_vertex = std::min<std::int64_t>(boundary_vertex, key >> 32);
    return fail(TopologyDefect::open_boundary, boundary, -1, boundary_vertex);
  }
  for (auto& e : he) e.twin = directed.at(edge_key(he[e.next].origin, e.origin));

  // A manifold vertex has one fan: walking around it from one outgoing half-edge visits
  // all of its outgoing half-edges.
  std::vector<std::int32_t> outgoing_count(vertices.size(), 0), first_out(vertices.size(), -1);
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(he.size()); ++i) {
    ++outgoing_count[he[i].origin];
    if (first_out[he[i].origin] < 0) first_out[he[i].origin] = i;
  }
  std::size_t pinched = 0;
  std::int64_t pinched_vertex = -1;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    if (first_out[v] < 0) continue;
    std::int32_t walked = 0, e = first_out[v];
    do {
      ++walked;
      e = he[he[e].twin].next;
    } while (e != first_out[v] && walked <= outgoing_count[v]);
    if (walked != outgoing_count[v] && pinched++ == 0) pinched_vertex = static_cast<std::int64_t>(v);
  }
  if (pinched) return fail(TopologyDefect::nonmanifold_vertex, pinched, -1, pinched_vertex);

  out.vertices_ = vertices;
  out.half_edges_ = std::move(he);
  out.face_edge_ = std::move(face_edge);
  return report;
}

std::size_t HalfEdgeMesh::used_vertex_count() const {
  std::vector<char> used(vertices_.size(), 0);
  for (const auto& e : half_edges_) used[e.origin] = 1;
  return static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
}

std::vector<std::int32_t> HalfEdgeMesh::face_vertices(std::size_t f) const {
  std::vector<std::int32_t> out;
  std::int32_t e = face_edge_[f];
  do {
    out.push_back(half_edges_[e].origin);
    e = half_edges_[e].next;
  } while (e != face_edge_[f]);
  return out;
}

std::size_t HalfEdgeMesh::connected_components() const {
  std::vector<std::int32_t> parent(face_edge_.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& e : half_edges_) unite(parent, e.face, half_edges_[e.twin].face);
  std::size_t roots = 0;
  for (std::size_t f = 0; f < parent.size(); ++f)
    if (find_root(parent, static_cast<std::int32_t>(f)) == static_cast<std::int32_t>(f)) ++roots;
  return roots;
}

std::int64_t HalfEdgeMesh::euler_characteristic() const {
  return static_cast<std::int64_t>(used_vertex_count()) - static_cast<std::int64_t>(edge_count()) +
         static_cast<std::int64_t>(face_count());
}

namespace {

// Unit normal of a polygon by Newell's method (robust for nearly degenerate corners).
Vec3 newell_normal(const std::vector<Vec3>& v, const std::vector<std::int32_t>& face) {
  Vec3 n = Vec3::Zero();
  for (std::size_t k = 0; k < face.size(); ++k) n += v[face[k]].cross(v[face[(k + 1) % face.size()]]);
  const double len = n.norm();
  return len > 0.0 ? Vec3(n / len) : n;
}

}  // namespace

Polyhedron merge_coplanar_faces(const Polyhedron& poly, double tolerance) {
  HalfEdgeMesh mesh;
  if (!HalfEdgeMesh::build(poly.vertices, poly.faces, mesh).ok()) return poly;
  const auto& he = mesh.half_edges();
  const auto& v = poly.vertices;
  const std::size_t nf = poly.faces.size();

  // Grow regions face by face: a neighbour joins when all its vertices lie on the plane
  // of the region's seed face.
  std::vector<Vec3> normal(nf);
  for (std::size_t f = 0; f < nf; ++f) normal[f] = newell_normal(v, poly.faces[f]);
  std::vector<std::int32_t> region(nf, -1);
  std::vector<std::int32_t> stack;
  std::int32_t regions = 0;
  for (std::size_t seed = 0; seed < nf; ++seed) {
    if (region[seed] >= 0) continue;
    const Vec3 n = normal[seed];
    const Vec3 p = v[poly.faces[seed][0]];
    region[seed] = regions;
    stack.assign(1, static_cast<std::int32_t>(seed));
    while (!stack.empty()) {
      const std::int32_t f = stack.back();
      stack.pop_back();
      std::int32_t e = mesh.face_half_edge(f);
      do {
        const std::int32_t g = he[he[e].twin].face;
        if (region[g] < 0 && normal[g].dot(n) > 0.0) {
          bool on_plane = true;
          for (std::int32_t q : poly.faces[g]) on_plane = on_plane && std::abs((v[q] - p).dot(n)) <= tolerance;
          if (on_plane) {
            region[g] = regions;
            stack.push_back(g);
          }
        }
        e = he[e].next;
      } while (e != mesh.face_half_edge(f));
    }
    ++regions;
  }

  // Boundary loop of each region: follow boundary half-edges, turning around each vertex
  // through interior edges of the region.
  std::vector<std::int32_t> region_size(regions, 0), region_first_face(regions, -1);
  for (std::size_t f = 0; f < nf; ++f) {
    if (region_size[region[f]]++ == 0) region_first_face[region[f]] = static_cast<std::int32_t>(f);
  }
  std::vector<std::int32_t> boundary_count(regions, 0), boundary_start(regions, -1);
  for (std::int32_t e = 0; e < static_cast<std::int32_t>(he.size()); ++e) {
    const std::int32_t r = region[he[e].face];
    if (region[he[he[e].twin].face] != r) {
      if (boundary_count[r]++ == 0) boundary_start[r] = e;
    }
  }
  Polyhedron out;
  out.vertices = poly.vertices;
  std::vector<char> keep(static_cast<std::size_t>(regions), 0);
  for (std::int32_t r = 0; r < regions; ++r) {
    std::vector<std::int32_t> loop;
    bool merged = false;
    if (region_size[r] > 1 && boundary_start[r] >= 0) {
      std::int32_t e = boundary_start[r];
      bool simple = true;
      do {
        loop.push_back(he[e].origin);
        std::int32_t next = he[e].next;
        while (region[he[he[next].twin].face] == r) next = he[he[next].twin].next;
        e = next;
      } while (e != boundary_start[r] && loop.size() <= static_cast<std::size_t>(boundary_count[r]));
      if (loop.size() != static_cast<std::size_t>(boundary_count[r])) simple = false;
      std::vector<std::int32_t> sorted = loop;
      std::sort(sorted.begin(), sorted.end());
      if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) simple = false;
      // Convex: every corner turns the same way as the face normal (collinear allowed).
      const Vec3 n = normal[region_first_face[r]];
      bool convex = simple;
      for (std::size_t k = 0; convex && k < loop.size(); ++k) {
        const Vec3& a = v[loop[k]];
        const Vec3& b = v[loop[(k + 1) % loop.size()]];
        const Vec3& c = v[loop[(k + 2) % loop.size()]];
        convex = (b - a).cross(c - b).dot(n) >= -tolerance * ((b - a).norm() + (c - b).norm());
      }
      merged = convex;
    }
    if (merged) out.faces.push_back(std::move(loop));
    else keep[static_cast<std::size_t>(r)] = 1;
  }
  // Regions left as they were keep their faces, in input order.
  for (std::size_t f = 0; f < nf; ++f)
    if (keep[static_cast<std::size_t>(region[f])]) out.faces.push_back(poly.faces[f]);
  remove_unused_vertices(out);
  return out;
}

std::size_t remove_unused_vertices(Polyhedron& poly) {
  std::vector<std::int32_t> remap(poly.vertices.size(), -1);
  for (const auto& face : poly.faces)
    for (std::int32_t q : face) remap[q] = 0;
  std::vector<Vec3> kept;
  for (std::size_t i = 0; i < remap.size(); ++i) {
    if (remap[i] < 0) continue;
    remap[i] = static_cast<std::int32_t>(kept.size());
    kept.push_back(poly.vertices[i]);
  }
  const std::size_t removed = poly.vertices.size() - kept.size();
  for (auto& face : poly.faces)
    for (auto& q : face) q = remap[q];
  poly.vertices = std::move(kept);
  return removed;
}

void canonicalize(Polyhedron& poly) {
  std::vector<std::int32_t> order(poly.vertices.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
    const Vec3 &p = poly.vertices[a], &q = poly.vertices[b];
    return std::tie(p.x(), p.y(), p.z()) < std::tie(q.x(), q.y(), q.z());
  });
  std::vector<std::int32_t> rank(order.size());
  std::vector<Vec3> sorted(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    rank[order[i]] = static_cast<std::int32_t>(i);
    sorted[i] = poly.vertices[order[i]];
  }
  poly.vertices = std::move(sorted);
  for (auto& face : poly.faces) {
    for (auto& q : face) q = rank[q];
    std::rotate(face.begin(), std::min_element(face.begin(), face.end()), face.end());
  }
  std::sort(poly.faces.begin(), poly.faces.end());
}

TriangleMesh triangulate(const Polyhedron& poly) {
  TriangleMesh mesh;
  mesh.vertices = poly.vertices;
  for (const auto& face : poly.faces)
    for (std::size_t k = 1; k + 1 < face.size(); ++k) mesh.triangles.push_back({face[0], face[k], face[k + 1]});
  return mesh;
}

Polyhedron to_polyhedron(const TriangleMesh& mesh) {
  Polyhedron poly;
  poly.vertices = mesh.vertices;
  poly.faces.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) poly.faces.push_back({t[0], t[1], t[2]});
  return poly;
}

}  // namespace talus::geometry
