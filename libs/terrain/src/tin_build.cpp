#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/terrain/build.hpp"

namespace talus::terrain {
namespace {

using core::format_number;

std::string part_text(std::size_t p, const std::vector<std::string>& names) {
  std::string text = "part " + std::to_string(p);
  if (p < names.size() && !names[p].empty()) text += " ('" + names[p] + "')";
  return text;
}

// One directed edge of a triangle, keyed by its undirected vertex pair.
struct EdgeUse {
  std::uint64_t key;
  std::int32_t triangle;
  bool forward;  // the triangle runs the edge from the smaller vertex id to the larger
};

// Makes each edge-connected component consistently oriented and facing up on average.
// flip[t] = 1 when triangle t must be reversed.
void orient(const geometry::TriangleMesh& mesh, std::vector<std::uint8_t>& flip, TinReport& report) {
  const std::size_t nt = mesh.triangle_count();
  std::vector<EdgeUse> uses;
  uses.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    for (int e = 0; e < 3; ++e) {
      const auto a = static_cast<std::uint32_t>(tri[e]);
      const auto b = static_cast<std::uint32_t>(tri[(e + 1) % 3]);
      const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
      uses.push_back({key, static_cast<std::int32_t>(t), a < b});
    }
  }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key < y.key || (x.key == y.key && x.triangle < y.triangle);
  });
  // Adjacency in CSR form: for each triangle, (neighbour, same_direction) pairs.
  std::vector<std::int32_t> offsets(nt + 1, 0);
  struct Link {
    std::int32_t other;
    bool same_direction;  // both run the shared edge the same way: one must be reversed
  };
  std::vector<std::pair<std::int32_t, Link>> links;
  for (std::size_t a = 0; a < uses.size();) {
    std::size_t b = a;
    while (b < uses.size() && uses[b].key == uses[a].key) ++b;
    for (std::size_t u = a; u < b; ++u)
      for (std::size_t w = a; w < b; ++w)
        if (u != w) links.push_back({uses[u].triangle, {uses[w].triangle, uses[u].forward == uses[w].forward}});
    a = b;
  }
  std::stable_sort(links.begin(), links.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& l : links) ++offsets[static_cast<std::size_t>(l.first) + 1];
  for (std::size_t t = 0; t < nt; ++t) offsets[t + 1] += offsets[t];

  flip.assign(nt, 0);
  std::vector<std::uint8_t> seen(nt, 0);
  std::vector<std::int32_t> component;
  for (std::size_t start = 0; start < nt; ++start) {
    if (seen[start]) continue;
    ++report.components;
    component.clear();
    component.push_back(static_cast<std::int32_t>(start));
    seen[start] = 1;
    for (std::size_t q = 0; q < component.size(); ++q) {
      const auto t = static_cast<std::size_t>(component[q]);
      for (auto k = offsets[t]; k < offsets[t + 1]; ++k) {
        const Link& link = links[static_cast<std::size_t>(k)].second;
        const auto n = static_cast<std::size_t>(link.other);
        const std::uint8_t wanted = static_cast<std::uint8_t>(flip[t] ^ (link.same_direction ? 1 : 0));
        if (!seen[n]) {
          seen[n] = 1;
          flip[n] = wanted;
          component.push_back(link.other);
        } else if (flip[n] != wanted) {
          ++report.orientation_conflicts;  // counted from both sides
        }
      }
    }
    Vec3 sum = Vec3::Zero();
    for (std::int32_t t : component) {
      const Vec3 n = mesh.area_normal(static_cast<std::size_t>(t));
      sum += flip[static_cast<std::size_t>(t)] ? Vec3(-n) : n;
    }
    if (sum.z() < 0.0) {
      ++report.components_flipped;
      for (std::int32_t t : component) flip[static_cast<std::size_t>(t)] ^= 1;
    }
  }
  report.orientation_conflicts /= 2;
  report.triangles_flipped = static_cast<std::size_t>(std::count(flip.begin(), flip.end(), 1));
}

// Refuses a face given twice (the same three corners, in either order): a closed
// zero-volume mesh or a doubled export is no sheet of ground, and two parts sharing a face
// give it two materials. `origin[t]` is the part and input index of kept triangle t.
void refuse_doubled_faces(const geometry::TriangleMesh& mesh,
                          const std::vector<std::pair<std::size_t, std::size_t>>& origin,
                          const std::vector<std::string>& part_names, const std::string& source) {
  using Key = std::array<double, 9>;
  std::vector<std::pair<Key, std::size_t>> keys(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    std::array<std::array<double, 3>, 3> corners;
    for (int k = 0; k < 3; ++k) {
      const Vec3& v = mesh.vertices[static_cast<std::size_t>(mesh.triangles[t][static_cast<std::size_t>(k)])];
      corners[static_cast<std::size_t>(k)] = {v.x(), v.y(), v.z()};
    }
    std::sort(corners.begin(), corners.end());
    for (std::size_t k = 0; k < 3; ++k)
      for (std::size_t c = 0; c < 3; ++c) keys[t].first[3 * k + c] = corners[k][c];
    keys[t].second = t;
  }
  std::sort(keys.begin(), keys.end());
  for (std::size_t i = 1; i < keys.size(); ++i) {
    if (keys[i].first != keys[i - 1].first) continue;
    const auto [pa, ta] = origin[std::min(keys[i - 1].second, keys[i].second)];
    const auto [pb, tb] = origin[std::max(keys[i - 1].second, keys[i].second)];
    throw core::InputError(source, part_text(pa, part_names) + ": triangle " + std::to_string(ta) + " and " +
                                       (pb == pa ? "" : part_text(pb, part_names) + ": ") + "triangle " +
                                       std::to_string(tb) +
                                       " have the same three corners: a terrain surface holds each face once");
  }
}

}  // namespace

Terrain build_tin_terrain(const std::vector<geometry::TriangleMesh>& parts, const std::vector<std::string>& part_names,
                          const std::string& source, TinReport* report_out) {
  if (parts.empty()) throw core::InputError(source, "no terrain mesh parts given");
  Terrain terrain;
  TinReport report;
  auto& mesh = terrain.mesh;
  std::size_t total_vertices = 0, total_triangles = 0;
  for (const auto& part : parts) {
    total_vertices += part.vertex_count();
    total_triangles += part.triangle_count();
  }
  if (total_vertices > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) ||
      total_triangles > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw core::InputError(source, "terrain mesh too large for 32-bit ids");
  }
  mesh.vertices.reserve(total_vertices);
  mesh.triangles.reserve(total_triangles);
  terrain.material_of_triangle.reserve(total_triangles);
  std::vector<std::pair<std::size_t, std::size_t>> origin;  // part and input index of each kept triangle
  origin.reserve(total_triangles);

  for (std::size_t p = 0; p < parts.size(); ++p) {
    const auto& part = parts[p];
    if (part.triangles.empty() || part.vertices.empty()) {
      throw core::InputError(source, part_text(p, part_names) + " has no triangles");
    }
    for (std::size_t v = 0; v < part.vertices.size(); ++v) {
      if (!part.vertices[v].allFinite()) {
        throw core::InputError(source, part_text(p, part_names) + ": vertex " + std::to_string(v) +
                                           " has a non-finite coordinate");
      }
    }
    const auto offset = static_cast<std::int32_t>(mesh.vertices.size());
    const auto nv = static_cast<std::int64_t>(part.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (std::size_t t = 0; t < part.triangles.size(); ++t) {
      const auto& tri = part.triangles[t];
      for (std::int32_t v : tri) {
        if (v < 0 || v >= nv) {
          throw core::InputError(source, part_text(p, part_names) + ": triangle " + std::to_string(t) +
                                             " refers to vertex " + std::to_string(v) + " of " +
                                             std::to_string(nv));
        }
      }
      const Vec3& a = part.vertices[static_cast<std::size_t>(tri[0])];
      const Vec3& b = part.vertices[static_cast<std::size_t>(tri[1])];
      const Vec3& c = part.vertices[static_cast<std::size_t>(tri[2])];
      const double longest2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
      // Relative test: collinear up to round-off, or repeated vertices (longest2 may be 0).
      if ((b - a).cross(c - a).norm() <= 1e-12 * longest2) {
        ++report.degenerate_dropped;
        continue;
      }
      mesh.triangles.push_back({tri[0] + offset, tri[1] + offset, tri[2] + offset});
      terrain.material_of_triangle.push_back(static_cast<std::int32_t>(p));
      origin.emplace_back(p, t);
    }
    Material m;
    m.name = p < part_names.size() && !part_names[p].empty() ? part_names[p] : "part" + std::to_string(p);
    terrain.materials.push_back(m);
  }
  if (mesh.triangles.empty()) throw core::InputError(source, "every terrain triangle is degenerate (zero area)");
  refuse_doubled_faces(mesh, origin, part_names, source);

  std::vector<std::uint8_t> flip;
  orient(mesh, flip, report);
  for (std::size_t t = 0; t < flip.size(); ++t)
    if (flip[t]) std::swap(mesh.triangles[t][1], mesh.triangles[t][2]);

  if (report.degenerate_dropped > 0) {
    core::log_warn(source + ": dropped " + std::to_string(report.degenerate_dropped) +
                   " degenerate (zero-area) triangles");
  }
  if (report.triangles_flipped > 0) {
    core::log_warn(source + ": reversed " + std::to_string(report.triangles_flipped) + " triangles (" +
                   std::to_string(report.components_flipped) + " of " + std::to_string(report.components) +
                   " components turned over) so that the surface is consistent and faces up");
  }
  if (report.orientation_conflicts > 0) {
    core::log_warn(source + ": " + std::to_string(report.orientation_conflicts) +
                   " shared edges cannot be oriented consistently (non-manifold or non-orientable mesh)");
  }
  if (report_out) *report_out = report;
  return terrain;
}

}  // namespace talus::terrain
