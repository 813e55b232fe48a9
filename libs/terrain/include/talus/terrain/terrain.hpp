// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"
#include "talus/geometry/triangle_mesh.hpp"
#include "talus/geometry/types.hpp"

namespace talus::geometry {
class BoxTree;
}

namespace talus::terrain {

using geometry::Aabb;
using geometry::Vec3;

/// A regular lattice of grid points: point (i, j) lies at (x0 + i·dx, y0 + j·dy),
/// i in [0, nx), j in [0, ny). Coordinates are local (after the origin shift).
struct GridSpec {
  double x0 = 0.0;  ///< m
  double y0 = 0.0;  ///< m
  double dx = 1.0;  ///< m, > 0
  double dy = 1.0;  ///< m, > 0
  std::int32_t nx = 0;  ///< grid points along x
  std::int32_t ny = 0;  ///< grid points along y
  std::size_t point_count() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
  std::size_t cell_count() const {
    return nx < 2 || ny < 2 ? 0 : static_cast<std::size_t>(nx - 1) * static_cast<std::size_t>(ny - 1);
  }
  /// Row-major index of point (i, j).
  std::size_t index(std::int32_t i, std::int32_t j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i);
  }
};

/// Elevations on a grid (m). NaN marks no data.
struct DemGrid {
  GridSpec spec;
  std::vector<double> z;  ///< point_count() values, index spec.index(i, j)
};

/// How each DEM cell is split into two triangles.
enum class Diagonal : std::uint8_t {
  fixed,        ///< reference cut: every cell along the same diagonal (biases lateral drift)
  alternating,  ///< checkerboard of the two diagonals (unbiased, the default)
  random,       ///< each cell's diagonal drawn from the seeded terrain_diagonals stream
};

/// Ground material: the distributions of SPEC §4 drawn per impact.
struct Material {
  std::string name = "default";
  /// Starting class the six parameters were set from (material_classes.hpp); "none" =
  /// the parameters as given. Parameters given beside a class override it.
  std::string class_name = "none";
  double restitution_mean = 0.95;          ///< scaled restitution R_v mean (-)
  double restitution_sd = 0.05;            ///< R_v standard deviation (-)
  double restitution_scale = 12.0;         ///< K of SF = 1/(1+(V_in/K)²) (m/s)
  double friction_angle_mean_deg = 10.0;   ///< mean friction angle (deg)
  double friction_coefficient_sd = 0.05;   ///< sd of the friction coefficient tan φ (-)
  double lateral_tilt_sd_deg = 0.0;        ///< sd of the lateral ground tilt at impact (deg)
  /// Ground that gives way under an impact resists the block's sliding beyond friction:
  /// a tangential impulse of at most this times the normal one (-), contact-point law only.
  double ploughing = 0.0;
  void visit(core::SettingsVisitor& v);

  /// Allowed values, refused outside them where they are read (terrain-gen settings and
  /// dda-run's material overrides). R_v is clamped to [0, 1] at each impact.
  struct Ranges {
    core::Range restitution_mean = core::Range::closed(0.0, 1.0);
    core::Range restitution_sd = core::Range::closed(0.0, 1.0);
    core::Range restitution_scale = core::Range::positive(1e3);  // m/s
    core::Range friction_angle_mean_deg = core::Range::right_open(0.0, 90.0);
    core::Range friction_coefficient_sd = core::Range::closed(0.0, 10.0);
    core::Range lateral_tilt_sd_deg = core::Range::right_open(0.0, 90.0);
    core::Range ploughing = core::Range::closed(0.0, 10.0);
  };
  static Ranges ranges() { return {}; }

  /// Visits the seven properties of `m` — a Material, or an override of one whose fields
  /// are optional — with their units, documentation and ranges.
  template <class Properties>
  static void visit_properties(core::SettingsVisitor& v, Properties& m) {
    const Ranges r = ranges();
    v.bounded("restitution_mean", m.restitution_mean, "-", "mean of the scaled restitution R_v", r.restitution_mean);
    v.bounded("restitution_sd", m.restitution_sd, "-", "standard deviation of R_v", r.restitution_sd);
    v.bounded("restitution_scale", m.restitution_scale, "m/s", "K in SF = 1/(1 + (V_in/K)^2)", r.restitution_scale);
    v.bounded("friction_angle_mean_deg", m.friction_angle_mean_deg, "deg", "mean friction angle",
              r.friction_angle_mean_deg);
    v.bounded("friction_coefficient_sd", m.friction_coefficient_sd, "-",
              "standard deviation of the friction coefficient tan(phi)", r.friction_coefficient_sd);
    v.bounded("lateral_tilt_sd_deg", m.lateral_tilt_sd_deg, "deg",
              "standard deviation of the lateral ground tilt drawn at each impact", r.lateral_tilt_sd_deg);
    v.bounded("ploughing", m.ploughing, "-",
              "restitution: point only; tangential impulse against the block's sliding, at most this times the "
              "normal impulse of an impact (ground that gives way)",
              r.ploughing);
  }
};

/// Ground roughness: realization i shifts every grid point (or TIN vertex) vertically by
/// σ·N(0,1), the normal being draw k (point index) of stream (seed, terrain_roughness, i).
struct Roughness {
  double sigma = 0.0;         ///< m; 0 = smooth
  std::uint64_t seed = 1;     ///< terrain seed
};

/// The immutable terrain model stored in a terrain file: base geometry, materials and
/// roughness model. Either a grid-based TRN (vertex k = grid point k, triangles of cell
/// c = j·(nx−1)+i are 2c and 2c+1) or a general TIN (may have vertical walls and
/// overhangs).
struct Terrain {
  std::optional<GridSpec> grid;          ///< set for a grid-based TRN
  std::vector<std::uint8_t> cell_diagonal;  ///< grid only: per cell, 0 = (i,j)-(i+1,j+1) cut, 1 = (i+1,j)-(i,j+1) cut
  geometry::TriangleMesh mesh;           ///< base surface (m, local coordinates), triangles CCW from above/outside
  std::vector<std::int32_t> material_of_triangle;  ///< index into materials, one per triangle
  std::vector<Material> materials;
  Roughness roughness;
  Vec3 origin_shift = Vec3::Zero();      ///< add to local coordinates to get the input (projected) coordinates (m)
  std::string name;                       ///< free text (e.g. "bench-slope")
  std::string crs_wkt;                    ///< CRS of the input coordinates (WKT); empty: not known
};

/// One realization of a terrain, ready for contact queries by one realization's engine.
///
/// On a grid terrain the perturbed elevations are computed lazily, tile by tile, the first
/// time a query touches them: a block that crosses a few hundred cells of a 4-million-point
/// DEM pays for those cells only. Realization i is a pure function of (terrain seed, i), so
/// laziness never changes a value. Because of that cache, one Surface must not be queried
/// from several threads at once (each realization has its own Surface).
/// On a TIN, realize() builds a bounding-volume hierarchy and realization() reuses it for
/// the next realization; the perturbed elevations are computed lazily as well, in blocks
/// of 1024 consecutive vertex ids, the first time a query reads one of them.
class Surface {
 public:
  /// Realization `index` of `terrain` (roughness applied); nullopt = the smooth base.
  /// `terrain` must outlive the Surface. Vertex k of realization i has
  /// z = base z_k + σ·RandomStream(roughness.seed, Stream::terrain_roughness, i).normal(k).
  /// Grid: vertex k = grid point k at (x0 + i·dx, y0 + j·dy); triangles of cell
  /// c = j·(nx−1)+i are, with p00 = (i,j), p10 = (i+1,j), p01 = (i,j+1), p11 = (i+1,j+1):
  ///   cell_diagonal[c] = 0: 2c = (p00, p10, p11), 2c+1 = (p00, p11, p01);
  ///   cell_diagonal[c] = 1: 2c = (p00, p10, p01), 2c+1 = (p10, p11, p01).
  /// Cheap on a grid (nothing is realized until queried); O(n log n) on a TIN (the BVH).
  /// Throws core::InputError (source: terrain.name) when the terrain is inconsistent
  /// (array sizes, vertex ids out of range, σ negative or not finite).
  static Surface realize(const Terrain& terrain, std::optional<std::uint32_t> index);
  /// A temporary terrain would dangle: keep the Terrain alive in a variable.
  static Surface realize(Terrain&& terrain, std::optional<std::uint32_t> index) = delete;
  /// Realization `index` of this Surface's terrain, bit for bit the same as
  /// realize(terrain, index), sharing the read-only search structure: on a TIN the BVH is
  /// built once over the base triangles with boxes widened by ±8.6σ in z (valid for every
  /// realization), so a new realization costs only the perturbation of the vertices its
  /// queries read (a flag per 1024 vertices and untouched memory for the rest). On a grid
  /// it is as cheap as realize(). Only reads this Surface: several threads may call it on
  /// one Surface at once (each then queries its own result).
  Surface realization(std::optional<std::uint32_t> index) const;
  /// A TIN surface from a bare mesh (material 0 everywhere), e.g. for tests.
  static Surface from_mesh(geometry::TriangleMesh mesh);

  Surface(Surface&&) noexcept;
  Surface& operator=(Surface&&) noexcept;
  ~Surface();

  std::size_t triangle_count() const;
  std::size_t vertex_count() const;
  /// Vertex indices of triangle t, counter-clockwise seen from above (grid) or outside.
  std::array<std::int32_t, 3> triangle(std::size_t t) const;
  /// Realized position of vertex v (m).
  Vec3 vertex(std::size_t v) const;
  std::array<Vec3, 3> triangle_vertices(std::size_t t) const;
  /// Unit normal of triangle t (pointing up on a grid, outward on a TIN).
  Vec3 normal(std::size_t t) const;
  std::int32_t material(std::size_t t) const;
  /// Bounds (m): x and y exact; z covers every realization (base ± 8.6σ, the largest
  /// value a Box–Muller draw from 53-bit uniforms can take). The same for every
  /// realization: computed on the first call (a pass over the base points) and shared
  /// with every Surface that realization() makes, so a realization never pays for it.
  const Aabb& bounds() const;
  /// True for a grid-based TRN (a height field); a TIN may have walls and overhangs.
  bool is_height_field() const;
  /// With roughness only: the number of tiles (grid: 32 × 32 points; TIN: 1024
  /// consecutive vertex ids) realized so far and in all; 0 when nothing is perturbed
  /// (σ = 0 or the smooth base). For tests and benchmarks of the laziness.
  std::size_t tiles_realized() const;
  std::size_t tile_count() const;
  /// Realizes every tile now (before export, or to time a whole realization); a no-op
  /// when nothing is lazy. Values are the same as when realized on demand.
  void realize_all() const;

  /// Appends to `out` the triangles whose bounding boxes may overlap `box` (a few more,
  /// never fewer; each once). O(cells under the box) on a grid, by index arithmetic,
  /// realizing the tiles under the box; O(log n + k) on a TIN.
  void triangles_in_box(const Aabb& box, std::vector<std::int32_t>& out) const;
  /// The highest surface point on the vertical through (x, y): elevation (m) and its
  /// triangle; nullopt where the vertical misses the terrain (outside the grid or TIN).
  /// O(1) on a grid (the cell, then the triangle by the diagonal); on a TIN a vertical
  /// ray through the BVH, keeping the highest hit (vertical triangles are skipped: their
  /// top edge belongs to a neighbour).
  struct Hit {
    double z = 0.0;
    std::int32_t triangle = -1;
  };
  std::optional<Hit> height_at(double x, double y) const;
  /// The rim is where the surface ends, with nothing beyond it: the border of a grid, the
  /// edges of a TIN that belong to one triangle (found on first use, once for every
  /// realization). True when the rim may pass through the plan box (x and y of `box`;
  /// a grid: the box is not strictly inside the grid).
  bool near_rim(const Aabb& box) const;
  /// True when the rim is the whole border of the ground in plan, so that a plan box
  /// near_rim() rejects lies wholly on the ground or wholly off it: a grid, and a TIN
  /// whose triangles all face up with each edge shared by at most two triangles in
  /// opposite directions (no wall, overhang or fold; roughness moves vertices only in z).
  bool rim_bounds_footprint() const;
  /// The rim's point nearest to (x, y) in plan, with its realized elevation (m), and the
  /// triangle it belongs to, when one lies within `reach` (m); ties go to the higher
  /// point, then the lower edge id.
  struct RimPoint {
    Vec3 point = Vec3::Zero();
    std::int32_t triangle = -1;
  };
  std::optional<RimPoint> nearest_rim_point(double x, double y, double reach) const;
  /// An upper bound of the realized elevation (m) of the rim's points within the plan box
  /// (x and y of `box`), −∞ when no rim point can lie in it: on a grid the highest of the
  /// two rows of points along each border side the box meets, over the cells it spans;
  /// on a TIN the highest end of a rim edge whose plan box meets it; raised by 1e-9 of
  /// the elevations (far more than the round-off of a point interpolated between them).
  double rim_top(const Aabb& box) const;
  /// Every triangle, realized (for export and tests; costs the whole terrain).
  geometry::TriangleMesh to_mesh() const;

 private:
  struct Impl;
  explicit Surface(std::unique_ptr<Impl> impl);
  static std::unique_ptr<Impl> make_impl(const Terrain& terrain, std::optional<std::uint32_t> index,
                                         std::shared_ptr<const geometry::BoxTree> shared_bvh);
  std::unique_ptr<Impl> impl_;
};

}  // namespace talus::terrain
