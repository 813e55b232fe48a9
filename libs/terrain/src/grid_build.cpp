#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/terrain/build.hpp"

namespace talus::terrain {
namespace {

using core::format_number;

std::string point_text(const GridSpec& s, std::int32_t i, std::int32_t j) {
  return "point (i=" + std::to_string(i) + ", j=" + std::to_string(j) + ") at (x=" + format_number(s.x0 + i * s.dx) +
         ", y=" + format_number(s.y0 + j * s.dy) + ")";
}

// First and last lattice index whose coordinate origin + k·step lies in [lo, hi], clamped
// to [0, n). A point on the window edge stays in despite rounding (1e-9 of a cell).
void index_range(double origin, double step, std::int32_t n, double lo, double hi, std::int32_t& first,
                 std::int32_t& last) {
  constexpr double slack = 1e-9;
  const double f = std::ceil((lo - origin) / step - slack);
  const double l = std::floor((hi - origin) / step + slack);
  first = static_cast<std::int32_t>(std::clamp(f, 0.0, static_cast<double>(n)));
  last = static_cast<std::int32_t>(std::clamp(l, -1.0, static_cast<double>(n - 1)));
}

DemGrid sub_grid(const DemGrid& dem, std::int32_t i0, std::int32_t i1, std::int32_t j0, std::int32_t j1) {
  DemGrid out;
  out.spec = dem.spec;
  if (i1 < i0 || j1 < j0) {
    out.spec.nx = 0;
    out.spec.ny = 0;
    return out;
  }
  out.spec.x0 = dem.spec.x0 + i0 * dem.spec.dx;
  out.spec.y0 = dem.spec.y0 + j0 * dem.spec.dy;
  out.spec.nx = i1 - i0 + 1;
  out.spec.ny = j1 - j0 + 1;
  out.z.reserve(out.spec.point_count());
  for (std::int32_t j = j0; j <= j1; ++j) {
    const auto row = dem.z.begin() + static_cast<std::ptrdiff_t>(dem.spec.index(0, j));
    out.z.insert(out.z.end(), row + i0, row + i1 + 1);
  }
  return out;
}

}  // namespace

void validate_dem(const DemGrid& dem, const std::string& source) {
  const GridSpec& s = dem.spec;
  if (s.nx < 2 || s.ny < 2) {
    throw core::InputError(source, "DEM needs at least 2 x 2 points, got " + std::to_string(s.nx) + " x " +
                                       std::to_string(s.ny));
  }
  if (!(std::isfinite(s.dx) && s.dx > 0.0) || !(std::isfinite(s.dy) && s.dy > 0.0)) {
    throw core::InputError(source, "DEM cell size must be finite and > 0, got dx=" + format_number(s.dx) +
                                       ", dy=" + format_number(s.dy));
  }
  if (!std::isfinite(s.x0) || !std::isfinite(s.y0)) {
    throw core::InputError(source, "DEM origin must be finite, got (" + format_number(s.x0) + ", " +
                                       format_number(s.y0) + ")");
  }
  // Vertex ids are 32-bit and a grid has 2 triangles per cell.
  if (s.point_count() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) / 2) {
    throw core::InputError(source, "DEM of " + std::to_string(s.nx) + " x " + std::to_string(s.ny) +
                                       " points is too large (at most 2^30 points)");
  }
  if (dem.z.size() != s.point_count()) {
    throw core::InputError(source, "DEM has " + std::to_string(dem.z.size()) + " elevations for " +
                                       std::to_string(s.nx) + " x " + std::to_string(s.ny) + " points");
  }
  for (std::size_t k = 0; k < dem.z.size(); ++k) {
    if (!std::isfinite(dem.z[k])) {
      const auto i = static_cast<std::int32_t>(k % static_cast<std::size_t>(s.nx));
      const auto j = static_cast<std::int32_t>(k / static_cast<std::size_t>(s.nx));
      throw core::InputError(source, "DEM " + point_text(s, i, j) +
                                         (std::isnan(dem.z[k]) ? " has no data (NODATA); crop or trim the DEM"
                                                               : " has a non-finite elevation"));
    }
  }
}

DemGrid crop_dem(const DemGrid& dem, double xmin, double ymin, double xmax, double ymax,
                 const std::string& source) {
  if (!(std::isfinite(xmin) && std::isfinite(ymin) && std::isfinite(xmax) && std::isfinite(ymax)) ||
      !(xmin < xmax && ymin < ymax)) {
    throw core::InputError(source, "crop window [" + format_number(xmin) + ", " + format_number(xmax) + "] x [" +
                                       format_number(ymin) + ", " + format_number(ymax) +
                                       "] must be finite and non-empty");
  }
  if (dem.z.size() != dem.spec.point_count()) {
    throw core::InputError(source, "DEM has " + std::to_string(dem.z.size()) + " elevations for " +
                                       std::to_string(dem.spec.point_count()) + " points");
  }
  std::int32_t i0 = 0, i1 = -1, j0 = 0, j1 = -1;
  index_range(dem.spec.x0, dem.spec.dx, dem.spec.nx, xmin, xmax, i0, i1);
  index_range(dem.spec.y0, dem.spec.dy, dem.spec.ny, ymin, ymax, j0, j1);
  if (i1 - i0 + 1 < 2 || j1 - j0 + 1 < 2) {
    throw core::InputError(source, "crop window [" + format_number(xmin) + ", " + format_number(xmax) + "] x [" +
                                       format_number(ymin) + ", " + format_number(ymax) + "] keeps " +
                                       std::to_string(std::max(0, i1 - i0 + 1)) + " x " +
                                       std::to_string(std::max(0, j1 - j0 + 1)) +
                                       " DEM points; at least 2 x 2 are needed");
  }
  return sub_grid(dem, i0, i1, j0, j1);
}

DemGrid trim_nodata(const DemGrid& dem) {
  const GridSpec& s = dem.spec;
  if (dem.z.size() != s.point_count()) return dem;  // validate_dem reports it
  std::int32_t i0 = s.nx, i1 = -1, j0 = s.ny, j1 = -1;
  for (std::int32_t j = 0; j < s.ny; ++j) {
    for (std::int32_t i = 0; i < s.nx; ++i) {
      if (std::isnan(dem.z[s.index(i, j)])) continue;
      i0 = std::min(i0, i);
      i1 = std::max(i1, i);
      j0 = std::min(j0, j);
      j1 = std::max(j1, j);
    }
  }
  return sub_grid(dem, i0, i1, j0, j1);
}

Terrain build_grid_terrain(const DemGrid& dem, Diagonal diagonal, std::uint64_t seed, const std::string& source) {
  validate_dem(dem, source);
  const GridSpec& s = dem.spec;
  Terrain terrain;
  terrain.grid = s;
  terrain.roughness.seed = seed;
  terrain.materials.push_back(Material{});

  auto& vertices = terrain.mesh.vertices;
  vertices.resize(s.point_count());
  for (std::int32_t j = 0; j < s.ny; ++j) {
    const double y = s.y0 + j * s.dy;
    for (std::int32_t i = 0; i < s.nx; ++i) {
      const std::size_t k = s.index(i, j);
      vertices[k] = Vec3(s.x0 + i * s.dx, y, dem.z[k]);
    }
  }

  const std::size_t cells = s.cell_count();
  terrain.cell_diagonal.resize(cells);
  switch (diagonal) {
    case Diagonal::fixed:
      std::fill(terrain.cell_diagonal.begin(), terrain.cell_diagonal.end(), std::uint8_t{0});
      break;
    case Diagonal::alternating:
      for (std::int32_t j = 0; j + 1 < s.ny; ++j)
        for (std::int32_t i = 0; i + 1 < s.nx; ++i)
          terrain.cell_diagonal[static_cast<std::size_t>(j) * static_cast<std::size_t>(s.nx - 1) +
                                static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((i + j) % 2);
      break;
    case Diagonal::random: {
      const core::RandomStream stream(seed, core::Stream::terrain_diagonals, 0);
      for (std::size_t c = 0; c < cells; ++c) terrain.cell_diagonal[c] = stream.uniform(c) < 0.5 ? 1 : 0;
      break;
    }
  }

  // The same vertex order as Surface computes from the index arithmetic.
  auto& triangles = terrain.mesh.triangles;
  triangles.resize(2 * cells);
  for (std::int32_t j = 0; j + 1 < s.ny; ++j) {
    for (std::int32_t i = 0; i + 1 < s.nx; ++i) {
      const std::size_t c = static_cast<std::size_t>(j) * static_cast<std::size_t>(s.nx - 1) +
                            static_cast<std::size_t>(i);
      const auto p00 = static_cast<std::int32_t>(s.index(i, j));
      const std::int32_t p10 = p00 + 1;
      const std::int32_t p01 = p00 + s.nx;
      const std::int32_t p11 = p01 + 1;
      if (terrain.cell_diagonal[c] == 0) {
        triangles[2 * c] = {p00, p10, p11};
        triangles[2 * c + 1] = {p00, p11, p01};
      } else {
        triangles[2 * c] = {p00, p10, p01};
        triangles[2 * c + 1] = {p10, p11, p01};
      }
    }
  }
  terrain.material_of_triangle.assign(2 * cells, 0);
  return terrain;
}

Terrain build_grid_tin(const DemGrid& dem, Diagonal diagonal, std::uint64_t seed, const std::string& source) {
  // The full grid's triangles (NODATA filled with 0 only to build them), then the ones
  // with data at every corner.
  DemGrid filled = dem;
  for (double& z : filled.z)
    if (std::isnan(z)) z = 0.0;
  const Terrain grid = build_grid_terrain(filled, diagonal, seed, source);
  std::vector<std::int32_t> renumbered(dem.z.size(), -1);
  geometry::TriangleMesh mesh;
  for (std::size_t k = 0; k < dem.z.size(); ++k)
    if (!std::isnan(dem.z[k])) {
      renumbered[k] = static_cast<std::int32_t>(mesh.vertices.size());
      mesh.vertices.push_back(grid.mesh.vertices[k]);
    }
  for (const auto& t : grid.mesh.triangles) {
    const std::int32_t a = renumbered[static_cast<std::size_t>(t[0])], b = renumbered[static_cast<std::size_t>(t[1])],
                       c = renumbered[static_cast<std::size_t>(t[2])];
    if (a >= 0 && b >= 0 && c >= 0) mesh.triangles.push_back({a, b, c});
  }
  if (mesh.triangles.empty()) throw core::InputError(source, "no grid cell has data at three corners");
  return build_tin_terrain({mesh}, {"ground"}, source);
}

DemGrid resample_to_grid(const Surface& surface, const GridSpec& spec) {
  DemGrid out;
  out.spec = spec;
  out.z.resize(spec.point_count());
  for (std::int32_t j = 0; j < spec.ny; ++j) {
    for (std::int32_t i = 0; i < spec.nx; ++i) {
      const auto hit = surface.height_at(spec.x0 + i * spec.dx, spec.y0 + j * spec.dy);
      out.z[spec.index(i, j)] = hit ? hit->z : std::numeric_limits<double>::quiet_NaN();
    }
  }
  return out;
}

}  // namespace talus::terrain
