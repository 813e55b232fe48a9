// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "talus/geometry/triangle_mesh.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

/// Checks a DEM before it becomes a terrain: at least 2 × 2 points, dx and dy finite and
/// > 0, finite origin, nx·ny elevations, every elevation finite (NaN = NODATA; crop or
/// trim first). Throws core::InputError(source, …) naming the first bad point by its
/// (i, j) and its coordinates.
void validate_dem(const DemGrid& dem, const std::string& source);

/// The points of `dem` inside the window [xmin, xmax] × [ymin, ymax] (m, local
/// coordinates; boundaries included). Throws core::InputError(source, …) when fewer than
/// 2 × 2 points remain or the window is empty or not finite.
DemGrid crop_dem(const DemGrid& dem, double xmin, double ymin, double xmax, double ymax,
                 const std::string& source);

/// Drops the border rows and columns that hold only NODATA (NaN). A DEM that is all
/// NODATA comes back with nx = ny = 0; validate_dem then rejects it.
DemGrid trim_nodata(const DemGrid& dem);

/// The grid TRN of a DEM: vertex k = grid point k, triangles 2c and 2c+1 for cell
/// c = j·(nx−1)+i (see Surface for their vertex order), cell_diagonal by `diagonal`:
///   fixed: all 0, the (i,j)–(i+1,j+1) cut (the reference model's bias, for comparison);
///   alternating: (i + j) % 2;
///   random: 1 when uniform draw c of stream (seed, terrain_diagonals, realization 0) is
///           < 0.5, else 0.
/// One default material; every triangle material 0; roughness σ = 0 with `seed` as the
/// terrain seed. Validates first (validate_dem). A 2000 × 2000 DEM takes about 0.3 s and
/// 250 MiB peak (terrain plus DEM; see docs/benchmarks.md).
Terrain build_grid_terrain(const DemGrid& dem, Diagonal diagonal, std::uint64_t seed,
                           const std::string& source);

/// What build_tin_terrain repaired (also reported with core::log_warn).
struct TinReport {
  std::size_t degenerate_dropped = 0;     ///< zero-area triangles removed
  std::size_t components = 0;             ///< edge-connected components
  std::size_t triangles_flipped = 0;      ///< triangles whose vertex order was reversed
  std::size_t components_flipped = 0;     ///< components turned over to face up
  std::size_t orientation_conflicts = 0;  ///< shared edges that no orientation makes consistent
};

/// A TIN terrain from one mesh per ground material: part p gets material p, named
/// part_names[p] ("part<p>" when the list is shorter). Vertices are not merged across
/// parts. Throws core::InputError(source, …) for no parts, an empty part, a non-finite
/// vertex or a vertex index out of range (naming the part and the vertex or triangle).
/// Zero-area triangles (|(b−a)×(c−a)| <= 1e-12·(longest edge)²) are dropped and counted.
/// Orientation: each edge-connected component is made consistent (neighbours traverse
/// their shared edge in opposite directions, starting from its first triangle) and then
/// turned over as a whole when its area-weighted mean normal points down (z < 0), so a
/// height-field TIN faces up. Walls and overhangs are kept. Repairs go to `report`.
/// Orientation follows shared vertex ids: weld STL-like input first (geometry::
/// weld_vertices; io::import_mesh does by default), or every triangle is its own
/// component and an overhang's underside would be turned up.
Terrain build_tin_terrain(const std::vector<geometry::TriangleMesh>& parts,
                          const std::vector<std::string>& part_names, const std::string& source,
                          TinReport* report = nullptr);

/// A TIN terrain from scattered (x, y, z) points (m) by the 2-D Delaunay triangulation of
/// their plan positions (CGAL), triangles counter-clockwise from above, one default
/// material. Throws core::InputError(source, …) for fewer than 3 points, non-finite
/// coordinates, points sharing the same (x, y) (naming both) or all points collinear.
Terrain build_delaunay_terrain(const std::vector<geometry::Vec3>& points, const std::string& source);

/// A DEM with NODATA (NaN) points, e.g. a TIN of irregular footprint sampled on a grid, as
/// a TIN of its grid triangles: the triangles of build_grid_terrain (the same cut by
/// `diagonal` and `seed`) whose three corners have data, the points without data and
/// every triangle touching one left out (vertices renumbered in grid order). One default
/// material. Throws core::InputError(source, …) when no triangle remains.
Terrain build_grid_tin(const DemGrid& dem, Diagonal diagonal, std::uint64_t seed, const std::string& source);

/// Samples `surface` on the lattice `spec`: z = height_at(x, y), NaN where the vertical
/// misses the surface (so trim_nodata / crop_dem can clean the border).
DemGrid resample_to_grid(const Surface& surface, const GridSpec& spec);

}  // namespace talus::terrain
