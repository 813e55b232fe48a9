#include "talus/geometry/triangle_mesh.hpp"

#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace talus::geometry {

Vec3 TriangleMesh::area_normal(std::size_t t) const {
  const auto& tri = triangles[t];
  const Vec3& p0 = vertices[tri[0]];
  return (vertices[tri[1]] - p0).cross(vertices[tri[2]] - p0);
}

Aabb TriangleMesh::bounds() const {
  Aabb box;
  for (const Vec3& p : vertices) box.add(p);
  return box;
}

Aabb TriangleMesh::triangle_bounds(std::size_t t) const {
  Aabb box;
  for (std::int32_t v : triangles[t]) box.add(vertices[v]);
  return box;
}

namespace {
struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey&) const = default;
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};
}  // namespace

std::size_t weld_vertices(TriangleMesh& mesh, double tolerance) {
  const double cell = tolerance > 0.0 ? 2.0 * tolerance : 1e-12;
  std::unordered_map<CellKey, std::vector<std::int32_t>, CellHash> grid;
  std::vector<Vec3> kept;
  std::vector<std::int32_t> remap(mesh.vertices.size());
  const double tol2 = tolerance * tolerance;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& p = mesh.vertices[i];
    const CellKey base{static_cast<std::int64_t>(std::floor(p.x() / cell)),
                       static_cast<std::int64_t>(std::floor(p.y() / cell)),
                       static_cast<std::int64_t>(std::floor(p.z() / cell))};
    std::int32_t found = -1;
    for (int dx = -1; dx <= 1 && found < 0; ++dx)
      for (int dy = -1; dy <= 1 && found < 0; ++dy)
        for (int dz = -1; dz <= 1 && found < 0; ++dz) {
          auto it = grid.find({base.x + dx, base.y + dy, base.z + dz});
          if (it == grid.end()) continue;
          for (std::int32_t k : it->second) {
            if ((kept[k] - p).squaredNorm() <= tol2) {
              found = k;
              break;
            }
          }
        }
    if (found < 0) {
      found = static_cast<std::int32_t>(kept.size());
      kept.push_back(p);
      grid[base].push_back(found);
    }
    remap[i] = found;
  }
  std::vector<std::array<std::int32_t, 3>> triangles;
  triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const std::array<std::int32_t, 3> r{remap[t[0]], remap[t[1]], remap[t[2]]};
    if (r[0] != r[1] && r[1] != r[2] && r[0] != r[2]) triangles.push_back(r);
  }
  const std::size_t removed = mesh.vertices.size() - kept.size();
  mesh.vertices = std::move(kept);
  mesh.triangles = std::move(triangles);
  return removed;
}

}  // namespace talus::geometry
