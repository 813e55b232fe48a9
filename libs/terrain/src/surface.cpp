#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/geometry/box_tree.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {
namespace {

// Largest |N| a Box–Muller draw can reach: u1 >= 2^-53 gives sqrt(-2 ln 2^-53) = 8.5716.
constexpr double kMaxNormal = 8.6;

// Tiles of kTile × kTile grid points, stored contiguously so a query near a block touches
// a handful of memory pages.
constexpr std::int32_t kTileShift = 5;
constexpr std::int32_t kTile = 1 << kTileShift;
constexpr std::int32_t kTileMask = kTile - 1;
constexpr std::size_t kTilePoints = static_cast<std::size_t>(kTile) * kTile;

std::string count_text(std::size_t n) { return std::to_string(n); }

}  // namespace

struct Surface::Impl {
  // Either a grid (height field, lazily realized tiles) or a TIN (eager, BVH).
  bool grid_mode = false;
  std::shared_ptr<const Terrain> owned;  // from_mesh keeps its own terrain (shared by realization())
  const Terrain* terrain = nullptr;
  // Bounds depend on the terrain only (base geometry and σ), not on the realization:
  // computed on first use, once for every realization that realization() makes, so a
  // realization never pays for a pass over every point of the terrain.
  struct SharedBounds {
    std::once_flag once;
    Aabb box;
  };
  std::shared_ptr<SharedBounds> bounds;
  mutable const Aabb* bounds_ready = nullptr;  // this Surface's shortcut past the once-flag

  // A TIN's rim: its edges that belong to one triangle, found on first use, once for
  // every realization (the topology does not change with roughness), with a tree of
  // their plan boxes (z = 0).
  struct SharedRim {
    std::once_flag once;
    std::vector<std::array<std::int32_t, 2>> edges;
    std::vector<std::int32_t> triangle_of_edge;
    std::vector<Aabb> boxes;  // plan box of each edge (z = 0), the tree's items
    geometry::BoxTree tree;
    bool bounds_footprint = false;  // Surface::rim_bounds_footprint
  };
  std::shared_ptr<SharedRim> rim;

  const SharedRim& shared_rim() const {
    std::call_once(rim->once, [this] {
      // (lower vertex, higher vertex, triangle) of every triangle's edges.
      std::vector<std::array<std::int32_t, 3>> all;
      all.reserve(3 * terrain->mesh.triangles.size());
      for (std::size_t t = 0; t < terrain->mesh.triangles.size(); ++t) {
        const auto& tri = terrain->mesh.triangles[t];
        for (int k = 0; k < 3; ++k)
          all.push_back({std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3]),
                         static_cast<std::int32_t>(t)});
      }
      // The rim bounds the footprint when every triangle faces up (counter-clockwise in
      // plan) and every edge has at most two triangles, which then run along it in
      // opposite directions: they lie on the two sides of it in plan, so no inner edge is
      // a border of the footprint.
      bool simple = true;
      for (const auto& tri : terrain->mesh.triangles) {
        const Vec3& p0 = terrain->mesh.vertices[static_cast<std::size_t>(tri[0])];
        const Vec3& p1 = terrain->mesh.vertices[static_cast<std::size_t>(tri[1])];
        const Vec3& p2 = terrain->mesh.vertices[static_cast<std::size_t>(tri[2])];
        simple = simple && (p1.x() - p0.x()) * (p2.y() - p0.y()) - (p2.x() - p0.x()) * (p1.y() - p0.y()) > 0.0;
      }
      const auto runs_up = [&](const std::array<std::int32_t, 3>& e) {  // the triangle's edge runs from low to high id
        const auto& tri = terrain->mesh.triangles[static_cast<std::size_t>(e[2])];
        for (int k = 0; k < 3; ++k)
          if (tri[k] == e[0] && tri[(k + 1) % 3] == e[1]) return true;
        return false;
      };
      std::sort(all.begin(), all.end());
      for (std::size_t a = 0; a < all.size();) {
        std::size_t b = a + 1;
        while (b < all.size() && all[b][0] == all[a][0] && all[b][1] == all[a][1]) ++b;
        simple = simple && (b - a == 1 || (b - a == 2 && runs_up(all[a]) != runs_up(all[a + 1])));
        if (b - a == 1) {
          rim->edges.push_back({all[a][0], all[a][1]});
          rim->triangle_of_edge.push_back(all[a][2]);
          Aabb box;
          for (const std::int32_t v : rim->edges.back()) {
            const Vec3& p = terrain->mesh.vertices[static_cast<std::size_t>(v)];
            box.add(Vec3(p.x(), p.y(), 0.0));
          }
          rim->boxes.push_back(box);
        }
        a = b;
      }
      rim->tree.build(rim->boxes);
      rim->bounds_footprint = simple;
    });
    return *rim;
  }

  const Aabb& shared_bounds() const {
    if (bounds_ready) return *bounds_ready;
    std::call_once(bounds->once, [this] { bounds->box = grid_mode ? grid_bounds() : tin_bounds(); });
    bounds_ready = &bounds->box;
    return bounds->box;
  }

  Aabb grid_bounds() const {
    Aabb box;
    for (const Vec3& p : terrain->mesh.vertices) {
      box.lo.z() = std::min(box.lo.z(), p.z());
      box.hi.z() = std::max(box.hi.z(), p.z());
    }
    box.lo.x() = spec.x0;
    box.lo.y() = spec.y0;
    box.hi.x() = spec.x0 + (spec.nx - 1) * spec.dx;
    box.hi.y() = spec.y0 + (spec.ny - 1) * spec.dy;
    box.lo.z() -= kMaxNormal * sigma;
    box.hi.z() += kMaxNormal * sigma;
    return box;
  }

  Aabb tin_bounds() const {
    Aabb box = terrain->mesh.bounds();
    if (!box.empty()) {
      box.lo.z() -= kMaxNormal * terrain->roughness.sigma;
      box.hi.z() += kMaxNormal * terrain->roughness.sigma;
    }
    return box;
  }

  // --- grid ---
  GridSpec spec;
  bool perturbed = false;
  double sigma = 0.0;
  core::RandomStream stream{0, core::Stream::terrain_roughness, 0};
  std::int32_t tiles_x = 0;
  std::int32_t tiles_y = 0;
  mutable std::unique_ptr<double[]> tile_z;       // tiles_x·tiles_y·kTilePoints, written on demand
  mutable std::vector<std::uint8_t> tile_ready;   // one flag per tile
  mutable std::size_t tiles_done = 0;

  // --- TIN ---
  // Realized elevations, computed lazily in blocks of kTilePoints consecutive vertex ids
  // (perturbed TINs only; a smooth one reads the base vertices): a realization costs the
  // vertices its queries touch, not the whole TIN.
  std::size_t vertex_total = 0;
  mutable std::unique_ptr<double[]> vertex_z;      // vertex_total, written on demand
  mutable std::vector<std::uint8_t> block_ready;   // one flag per block
  // Built over the base triangles with z widened by ±kMaxNormal·σ: valid for every
  // realization, so realization() shares it.
  std::shared_ptr<const geometry::BoxTree> bvh;

  std::size_t triangle_count() const {
    return grid_mode ? 2 * spec.cell_count() : terrain->mesh.triangles.size();
  }

  // Realized elevation of grid point (i, j).
  double z(std::int32_t i, std::int32_t j) const {
    if (!perturbed) return terrain->mesh.vertices[spec.index(i, j)].z();
    const auto tile = static_cast<std::size_t>((j >> kTileShift) * tiles_x + (i >> kTileShift));
    if (!tile_ready[tile]) realize_tile(tile);
    return tile_z[tile * kTilePoints + static_cast<std::size_t>((j & kTileMask) * kTile + (i & kTileMask))];
  }

  void realize_tile(std::size_t tile) const {
    const auto tx = static_cast<std::int32_t>(tile % static_cast<std::size_t>(tiles_x));
    const auto ty = static_cast<std::int32_t>(tile / static_cast<std::size_t>(tiles_x));
    const std::int32_t i0 = tx * kTile;
    const std::int32_t j0 = ty * kTile;
    const std::int32_t i1 = std::min(i0 + kTile, spec.nx);
    const std::int32_t j1 = std::min(j0 + kTile, spec.ny);
    double normals[kTile];
    double* out = tile_z.get() + tile * kTilePoints;
    for (std::int32_t j = j0; j < j1; ++j) {
      const std::size_t first = spec.index(i0, j);
      const auto n = static_cast<std::size_t>(i1 - i0);
      // Draw k of the stream belongs to point k whatever the tiling: laziness never
      // changes a value.
      stream.normals(first, normals, n);
      double* row = out + static_cast<std::size_t>(j - j0) * kTile;
      for (std::size_t a = 0; a < n; ++a) row[a] = terrain->mesh.vertices[first + a].z() + sigma * normals[a];
    }
    tile_ready[tile] = 1;
    ++tiles_done;
  }

  Vec3 grid_point(std::int32_t i, std::int32_t j) const {
    return {spec.x0 + i * spec.dx, spec.y0 + j * spec.dy, z(i, j)};
  }

  std::array<std::int32_t, 3> grid_triangle(std::size_t t) const {
    const std::size_t c = t / 2;
    const auto cells_x = static_cast<std::size_t>(spec.nx - 1);
    const auto i = static_cast<std::int32_t>(c % cells_x);
    const auto j = static_cast<std::int32_t>(c / cells_x);
    const auto p00 = static_cast<std::int32_t>(spec.index(i, j));
    const std::int32_t p10 = p00 + 1;
    const std::int32_t p01 = p00 + spec.nx;
    const std::int32_t p11 = p01 + 1;
    const bool second = (t % 2) == 1;
    if (terrain->cell_diagonal[c] == 0) {
      // Cut (i,j)–(i+1,j+1): lower-right then upper-left triangle.
      return second ? std::array{p00, p11, p01} : std::array{p00, p10, p11};
    }
    // Cut (i+1,j)–(i,j+1): lower-left then upper-right triangle.
    return second ? std::array{p10, p11, p01} : std::array{p00, p10, p01};
  }

  void realize_block(std::size_t block) const {
    const std::size_t first = block * kTilePoints;
    const std::size_t n = std::min(kTilePoints, vertex_total - first);
    double normals[kTilePoints];
    // Draw k of the stream belongs to vertex k whatever the blocks.
    stream.normals(first, normals, n);
    for (std::size_t a = 0; a < n; ++a) vertex_z[first + a] = terrain->mesh.vertices[first + a].z() + sigma * normals[a];
    block_ready[block] = 1;
    ++tiles_done;
  }

  Vec3 tin_vertex(std::size_t v) const {
    const Vec3& base = terrain->mesh.vertices[v];
    if (!perturbed) return base;
    const std::size_t block = v / kTilePoints;
    if (!block_ready[block]) realize_block(block);
    return {base.x(), base.y(), vertex_z[v]};
  }

  Vec3 vertex(std::size_t v) const {
    if (!grid_mode) return tin_vertex(v);
    const auto nx = static_cast<std::size_t>(spec.nx);
    return grid_point(static_cast<std::int32_t>(v % nx), static_cast<std::int32_t>(v / nx));
  }

  std::array<std::int32_t, 3> triangle(std::size_t t) const {
    return grid_mode ? grid_triangle(t) : terrain->mesh.triangles[t];
  }

  std::array<Vec3, 3> triangle_vertices(std::size_t t) const {
    const auto tri = triangle(t);
    return {vertex(static_cast<std::size_t>(tri[0])), vertex(static_cast<std::size_t>(tri[1])),
            vertex(static_cast<std::size_t>(tri[2]))};
  }

  void grid_in_box(const Aabb& box, std::vector<std::int32_t>& out) const {
    // Cell i spans [x0 + i dx, x0 + (i+1) dx]; it overlaps [lo, hi] iff
    // (lo − x0)/dx − 1 <= i <= (hi − x0)/dx. The 1e-9 cell slack keeps cells that touch the
    // box exactly despite rounding (a few more, never fewer).
    constexpr double slack = 1e-9;
    const double fx_lo = (box.lo.x() - spec.x0) / spec.dx - 1.0 - slack;
    const double fx_hi = (box.hi.x() - spec.x0) / spec.dx + slack;
    const double fy_lo = (box.lo.y() - spec.y0) / spec.dy - 1.0 - slack;
    const double fy_hi = (box.hi.y() - spec.y0) / spec.dy + slack;
    const double max_i = spec.nx - 2;
    const double max_j = spec.ny - 2;
    if (!(fx_hi >= 0.0 && fy_hi >= 0.0 && fx_lo <= max_i && fy_lo <= max_j)) return;  // also NaN
    const auto i_lo = static_cast<std::int32_t>(std::max(0.0, std::ceil(fx_lo)));
    const auto i_hi = static_cast<std::int32_t>(std::min(max_i, std::floor(fx_hi)));
    const auto j_lo = static_cast<std::int32_t>(std::max(0.0, std::ceil(fy_lo)));
    const auto j_hi = static_cast<std::int32_t>(std::min(max_j, std::floor(fy_hi)));
    const double zlo = box.lo.z();
    const double zhi = box.hi.z();
    for (std::int32_t j = j_lo; j <= j_hi; ++j) {
      for (std::int32_t i = i_lo; i <= i_hi; ++i) {
        const double z00 = z(i, j);
        const double z10 = z(i + 1, j);
        const double z01 = z(i, j + 1);
        const double z11 = z(i + 1, j + 1);
        const std::size_t c = static_cast<std::size_t>(j) * static_cast<std::size_t>(spec.nx - 1) +
                              static_cast<std::size_t>(i);
        // The two triangles' vertex elevations, in the order of grid_triangle.
        double a0, a1, a2, b0, b1, b2;
        if (terrain->cell_diagonal[c] == 0) {
          a0 = z00, a1 = z10, a2 = z11, b0 = z00, b1 = z11, b2 = z01;
        } else {
          a0 = z00, a1 = z10, a2 = z01, b0 = z10, b1 = z11, b2 = z01;
        }
        const auto t0 = static_cast<std::int32_t>(2 * c);
        if (std::min({a0, a1, a2}) <= zhi && std::max({a0, a1, a2}) >= zlo) out.push_back(t0);
        if (std::min({b0, b1, b2}) <= zhi && std::max({b0, b1, b2}) >= zlo) out.push_back(t0 + 1);
      }
    }
  }

  std::optional<Hit> grid_height(double x, double y) const {
    const double fx = (x - spec.x0) / spec.dx;
    const double fy = (y - spec.y0) / spec.dy;
    const double max_i = spec.nx - 1;
    const double max_j = spec.ny - 1;
    if (!(fx >= 0.0 && fy >= 0.0 && fx <= max_i && fy <= max_j)) return std::nullopt;  // also NaN
    // The last row/column of points belongs to the last cell.
    const auto i = static_cast<std::int32_t>(std::min(std::floor(fx), max_i - 1.0));
    const auto j = static_cast<std::int32_t>(std::min(std::floor(fy), max_j - 1.0));
    const double u = fx - i;
    const double v = fy - j;
    const std::size_t c = static_cast<std::size_t>(j) * static_cast<std::size_t>(spec.nx - 1) +
                          static_cast<std::size_t>(i);
    const double z00 = z(i, j);
    const double z10 = z(i + 1, j);
    const double z01 = z(i, j + 1);
    const double z11 = z(i + 1, j + 1);
    const auto t0 = static_cast<std::int32_t>(2 * c);
    if (terrain->cell_diagonal[c] == 0) {
      if (u >= v) return Hit{z00 + u * (z10 - z00) + v * (z11 - z10), t0};
      return Hit{z00 + v * (z01 - z00) + u * (z11 - z01), t0 + 1};
    }
    if (u + v <= 1.0) return Hit{z00 + u * (z10 - z00) + v * (z01 - z00), t0};
    return Hit{z11 + (1.0 - u) * (z01 - z11) + (1.0 - v) * (z10 - z11), t0 + 1};
  }

  std::optional<Hit> tin_height(double x, double y) const {
    double best = -std::numeric_limits<double>::infinity();
    std::int32_t best_t = -1;
    bvh->vertical(
        x, y, [&] { return best; },
        [&](std::int32_t t) {
          const auto p = triangle_vertices(static_cast<std::size_t>(t));
          // Signed doubled areas of the sub-triangles in plan; the point is inside when
          // none has the opposite sign of the whole (either orientation: an overhang's
          // underside is clockwise from above).
          const double area = (p[1].x() - p[0].x()) * (p[2].y() - p[0].y()) -
                              (p[2].x() - p[0].x()) * (p[1].y() - p[0].y());
          if (area == 0.0) return;  // a vertical wall: its top edge belongs to a neighbour
          const double w0 = (p[1].x() - x) * (p[2].y() - y) - (p[2].x() - x) * (p[1].y() - y);
          const double w1 = (p[2].x() - x) * (p[0].y() - y) - (p[0].x() - x) * (p[2].y() - y);
          const double w2 = area - w0 - w1;
          const bool inside = area > 0.0 ? (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0)
                                         : (w0 <= 0.0 && w1 <= 0.0 && w2 <= 0.0);
          if (!inside) return;
          const double zh = (w0 * p[0].z() + w1 * p[1].z() + w2 * p[2].z()) / area;
          if (zh > best || (zh == best && t < best_t)) {
            best = zh;
            best_t = t;
          }
        });
    if (best_t < 0) return std::nullopt;
    return Hit{best, best_t};
  }
};

Surface::Surface(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Surface::Surface(Surface&&) noexcept = default;
Surface& Surface::operator=(Surface&&) noexcept = default;
Surface::~Surface() = default;

namespace {

void check_tin(const Terrain& terrain) {
  const std::string source = terrain.name.empty() ? "terrain" : terrain.name;
  const auto nv = static_cast<std::int64_t>(terrain.mesh.vertices.size());
  for (std::size_t t = 0; t < terrain.mesh.triangles.size(); ++t) {
    for (std::int32_t v : terrain.mesh.triangles[t]) {
      if (v < 0 || v >= nv) {
        throw core::InputError(source, "triangle " + count_text(t) + " refers to vertex " + std::to_string(v) +
                                           " of " + count_text(terrain.mesh.vertices.size()));
      }
    }
  }
}

}  // namespace

namespace {

// Throws unless `terrain` is consistent enough to query.
void check_terrain(const Terrain& terrain) {
  const std::string source = terrain.name.empty() ? "terrain" : terrain.name;
  const double sigma = terrain.roughness.sigma;
  if (!(sigma >= 0.0 && std::isfinite(sigma))) {
    throw core::InputError(source, "roughness sigma must be finite and >= 0, got " + core::format_number(sigma));
  }
  const std::size_t triangles =
      terrain.grid ? 2 * terrain.grid->cell_count() : terrain.mesh.triangles.size();
  if (!terrain.material_of_triangle.empty() && terrain.material_of_triangle.size() != triangles) {
    throw core::InputError(source, "material_of_triangle has " + count_text(terrain.material_of_triangle.size()) +
                                       " entries for " + count_text(triangles) + " triangles");
  }
  if (!terrain.grid) {
    check_tin(terrain);
    return;
  }
  const GridSpec& spec = *terrain.grid;
  if (spec.nx < 2 || spec.ny < 2) throw core::InputError(source, "grid needs at least 2 x 2 points");
  if (terrain.mesh.vertices.size() != spec.point_count()) {
    throw core::InputError(source, "grid terrain has " + count_text(terrain.mesh.vertices.size()) +
                                       " vertices for " + count_text(spec.point_count()) + " grid points");
  }
  if (terrain.cell_diagonal.size() != spec.cell_count()) {
    throw core::InputError(source, "grid terrain has " + count_text(terrain.cell_diagonal.size()) +
                                       " cell diagonals for " + count_text(spec.cell_count()) + " cells");
  }
  if (!terrain.mesh.triangles.empty() && terrain.mesh.triangles.size() != 2 * spec.cell_count()) {
    throw core::InputError(source, "grid terrain has " + count_text(terrain.mesh.triangles.size()) +
                                       " triangles for " + count_text(2 * spec.cell_count()) + " expected");
  }
  if (spec.point_count() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) / 2) {
    throw core::InputError(source, "grid too large for 32-bit triangle ids");
  }
}

}  // namespace

std::unique_ptr<Surface::Impl> Surface::make_impl(const Terrain& terrain, std::optional<std::uint32_t> index,
                                                  std::shared_ptr<const geometry::BoxTree> shared_bvh) {
  auto impl = std::make_unique<Impl>();
  impl->terrain = &terrain;
  const double sigma = terrain.roughness.sigma;
  if (terrain.grid) {
    const GridSpec& spec = *terrain.grid;
    impl->grid_mode = true;
    impl->spec = spec;
    impl->sigma = sigma;
    impl->perturbed = index.has_value() && sigma > 0.0;
    if (impl->perturbed) {
      impl->stream = core::RandomStream(terrain.roughness.seed, core::Stream::terrain_roughness, *index);
      impl->tiles_x = (spec.nx + kTile - 1) / kTile;
      impl->tiles_y = (spec.ny + kTile - 1) / kTile;
      const auto tiles = static_cast<std::size_t>(impl->tiles_x) * static_cast<std::size_t>(impl->tiles_y);
      // Left uninitialised: the pages of tiles never touched are never committed.
      impl->tile_z = std::make_unique_for_overwrite<double[]>(tiles * kTilePoints);
      impl->tile_ready.assign(tiles, 0);
    }
    return impl;
  }

  impl->vertex_total = terrain.mesh.vertices.size();
  impl->sigma = sigma;
  impl->perturbed = index.has_value() && sigma > 0.0;
  if (impl->perturbed) {
    impl->stream = core::RandomStream(terrain.roughness.seed, core::Stream::terrain_roughness, *index);
    // Left uninitialised: the pages of blocks never touched are never committed.
    impl->vertex_z = std::make_unique_for_overwrite<double[]>(impl->vertex_total);
    impl->block_ready.assign((impl->vertex_total + kTilePoints - 1) / kTilePoints, 0);
  }
  const double widen = kMaxNormal * sigma;
  if (!shared_bvh) {
    std::vector<Aabb> boxes(terrain.mesh.triangles.size());
    for (std::size_t t = 0; t < boxes.size(); ++t) {
      for (std::int32_t v : terrain.mesh.triangles[t]) boxes[t].add(terrain.mesh.vertices[static_cast<std::size_t>(v)]);
      boxes[t].lo.z() -= widen;
      boxes[t].hi.z() += widen;
    }
    auto bvh = std::make_shared<geometry::BoxTree>();
    bvh->build(boxes);
    shared_bvh = std::move(bvh);
  }
  impl->bvh = std::move(shared_bvh);
  return impl;
}

Surface Surface::realize(const Terrain& terrain, std::optional<std::uint32_t> index) {
  check_terrain(terrain);
  auto impl = make_impl(terrain, index, nullptr);
  impl->bounds = std::make_shared<Impl::SharedBounds>();
  impl->rim = std::make_shared<Impl::SharedRim>();
  return Surface(std::move(impl));
}

Surface Surface::realization(std::optional<std::uint32_t> index) const {
  auto impl = make_impl(*impl_->terrain, index, impl_->bvh);
  impl->owned = impl_->owned;
  impl->bounds = impl_->bounds;
  impl->rim = impl_->rim;
  return Surface(std::move(impl));
}

Surface Surface::from_mesh(geometry::TriangleMesh mesh) {
  auto owned = std::make_shared<Terrain>();
  owned->mesh = std::move(mesh);
  owned->materials.push_back(Material{});
  owned->name = "mesh";
  Surface s = realize(*owned, std::nullopt);
  s.impl_->owned = std::move(owned);
  return s;
}

std::size_t Surface::triangle_count() const { return impl_->triangle_count(); }

std::size_t Surface::vertex_count() const {
  return impl_->grid_mode ? impl_->spec.point_count() : impl_->vertex_total;
}

std::array<std::int32_t, 3> Surface::triangle(std::size_t t) const { return impl_->triangle(t); }

Vec3 Surface::vertex(std::size_t v) const { return impl_->vertex(v); }

std::array<Vec3, 3> Surface::triangle_vertices(std::size_t t) const { return impl_->triangle_vertices(t); }

Vec3 Surface::normal(std::size_t t) const {
  const auto p = impl_->triangle_vertices(t);
  return (p[1] - p[0]).cross(p[2] - p[0]).normalized();
}

std::int32_t Surface::material(std::size_t t) const {
  const auto& m = impl_->terrain->material_of_triangle;
  return m.empty() ? 0 : m[t];
}

const Aabb& Surface::bounds() const { return impl_->shared_bounds(); }

bool Surface::is_height_field() const { return impl_->grid_mode; }

std::size_t Surface::tiles_realized() const { return impl_->tiles_done; }

std::size_t Surface::tile_count() const {
  if (!impl_->grid_mode) return impl_->block_ready.size();
  return static_cast<std::size_t>(impl_->tiles_x) * static_cast<std::size_t>(impl_->tiles_y);
}

void Surface::realize_all() const {
  for (std::size_t t = 0; t < impl_->tile_ready.size(); ++t)
    if (!impl_->tile_ready[t]) impl_->realize_tile(t);
  for (std::size_t k = 0; k < impl_->block_ready.size(); ++k)
    if (!impl_->block_ready[k]) impl_->realize_block(k);
}

void Surface::triangles_in_box(const Aabb& box, std::vector<std::int32_t>& out) const {
  if (impl_->grid_mode) {
    impl_->grid_in_box(box, out);
    return;
  }
  const Impl& s = *impl_;
  s.bvh->overlapping(box, [&](std::int32_t t) {
    // The leaf box is a union; keep only triangles whose own box overlaps.
    Aabb tb;
    for (const Vec3& p : s.triangle_vertices(static_cast<std::size_t>(t))) tb.add(p);
    if (tb.overlaps(box)) out.push_back(t);
  });
}

std::optional<Surface::Hit> Surface::height_at(double x, double y) const {
  return impl_->grid_mode ? impl_->grid_height(x, y) : impl_->tin_height(x, y);
}

bool Surface::near_rim(const Aabb& box) const {
  if (impl_->grid_mode) {
    const Aabb& b = bounds();
    return box.lo.x() <= b.lo.x() || box.lo.y() <= b.lo.y() || box.hi.x() >= b.hi.x() || box.hi.y() >= b.hi.y();
  }
  const Aabb plan{Vec3(box.lo.x(), box.lo.y(), -1.0), Vec3(box.hi.x(), box.hi.y(), 1.0)};
  const Impl::SharedRim& rim = impl_->shared_rim();
  bool found = false;
  rim.tree.search([&](const Aabb& b) { return !found && b.overlaps(plan); },
                  [&](std::int32_t e) { found = found || rim.boxes[static_cast<std::size_t>(e)].overlaps(plan); });
  return found;
}

bool Surface::rim_bounds_footprint() const { return impl_->grid_mode || impl_->shared_rim().bounds_footprint; }

std::optional<Surface::RimPoint> Surface::nearest_rim_point(double x, double y, double reach) const {
  if (!(reach >= 0.0) || !std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  if (impl_->grid_mode) {
    const Aabb& b = bounds();
    double cx = std::clamp(x, b.lo.x(), b.hi.x());
    double cy = std::clamp(y, b.lo.y(), b.hi.y());
    if (cx == x && cy == y) {
      // Inside: the nearest of the four sides.
      const double d[4] = {x - b.lo.x(), b.hi.x() - x, y - b.lo.y(), b.hi.y() - y};
      const int k = static_cast<int>(std::min_element(d, d + 4) - d);
      if (k == 0) cx = b.lo.x();
      if (k == 1) cx = b.hi.x();
      if (k == 2) cy = b.lo.y();
      if (k == 3) cy = b.hi.y();
    }
    if (std::hypot(cx - x, cy - y) > reach) return std::nullopt;
    const auto hit = impl_->grid_height(cx, cy);
    if (!hit) return std::nullopt;
    return RimPoint{Vec3(cx, cy, hit->z), hit->triangle};
  }
  const Impl::SharedRim& rim = impl_->shared_rim();
  const Aabb plan{Vec3(x - reach, y - reach, -1.0), Vec3(x + reach, y + reach, 1.0)};
  double best = reach;
  std::int32_t best_e = -1;
  Vec3 best_p = Vec3::Zero();
  rim.tree.overlapping(plan, [&](std::int32_t e) {
    const auto& edge = rim.edges[static_cast<std::size_t>(e)];
    const Vec3 a = impl_->vertex(static_cast<std::size_t>(edge[0]));
    const Vec3 b = impl_->vertex(static_cast<std::size_t>(edge[1]));
    const double ux = b.x() - a.x(), uy = b.y() - a.y();
    const double len2 = ux * ux + uy * uy;
    const double t = len2 > 0.0 ? std::clamp(((x - a.x()) * ux + (y - a.y()) * uy) / len2, 0.0, 1.0) : 0.0;
    const Vec3 p = a + t * (b - a);
    const double d = std::hypot(p.x() - x, p.y() - y);
    // Nearest first, then the higher point (the top of a vertical rim), then the lower
    // edge id: the same answer whatever the tree's order.
    if (best_e < 0 ? d <= best
                   : (d < best || (d == best && (p.z() > best_p.z() || (p.z() == best_p.z() && e < best_e))))) {
      best = d;
      best_e = e;
      best_p = p;
    }
  });
  if (best_e < 0) return std::nullopt;
  return RimPoint{best_p, rim.triangle_of_edge[static_cast<std::size_t>(best_e)]};
}

double Surface::rim_top(const Aabb& box) const {
  double top = -std::numeric_limits<double>::infinity();
  double magnitude = 0.0;
  const auto take = [&](double z) {
    top = std::max(top, z);
    magnitude = std::max(magnitude, std::abs(z));
  };
  if (impl_->grid_mode) {
    const Aabb& b = bounds();
    if (box.hi.x() < b.lo.x() || box.lo.x() > b.hi.x() || box.hi.y() < b.lo.y() || box.lo.y() > b.hi.y() ||
        !near_rim(box))
      return top;
    const auto& spec = impl_->spec;
    // The range of point indices whose cells the box spans along an axis, one wider on
    // each side.
    const auto span = [](double lo, double hi, double origin, double step, std::int32_t count) {
      const double first = std::floor((lo - origin) / step) - 1.0;
      const double last = std::ceil((hi - origin) / step) + 1.0;
      return std::pair{static_cast<std::int32_t>(std::clamp(first, 0.0, count - 1.0)),
                       static_cast<std::int32_t>(std::clamp(last, 0.0, count - 1.0))};
    };
    const auto [i0, i1] = span(box.lo.x(), box.hi.x(), spec.x0, spec.dx, spec.nx);
    const auto [j0, j1] = span(box.lo.y(), box.hi.y(), spec.y0, spec.dy, spec.ny);
    // A side's two rows of points, over the range (a point clamped to a side may round
    // into the cell's inner half).
    const auto column = [&](std::int32_t i) {
      for (std::int32_t j = j0; j <= j1; ++j) take(impl_->z(i, j));
    };
    const auto row = [&](std::int32_t j) {
      for (std::int32_t i = i0; i <= i1; ++i) take(impl_->z(i, j));
    };
    if (box.lo.x() <= b.lo.x()) column(0), column(std::min(1, spec.nx - 1));
    if (box.hi.x() >= b.hi.x()) column(spec.nx - 1), column(std::max(0, spec.nx - 2));
    if (box.lo.y() <= b.lo.y()) row(0), row(std::min(1, spec.ny - 1));
    if (box.hi.y() >= b.hi.y()) row(spec.ny - 1), row(std::max(0, spec.ny - 2));
  } else {
    const Impl::SharedRim& rim = impl_->shared_rim();
    const Aabb plan{Vec3(box.lo.x(), box.lo.y(), -1.0), Vec3(box.hi.x(), box.hi.y(), 1.0)};
    rim.tree.overlapping(plan, [&](std::int32_t e) {
      const auto& edge = rim.edges[static_cast<std::size_t>(e)];
      take(impl_->vertex(static_cast<std::size_t>(edge[0])).z());
      take(impl_->vertex(static_cast<std::size_t>(edge[1])).z());
    });
  }
  return top + 1e-9 * (1.0 + magnitude);
}

geometry::TriangleMesh Surface::to_mesh() const {
  geometry::TriangleMesh mesh;
  const std::size_t nv = vertex_count();
  const std::size_t nt = triangle_count();
  mesh.vertices.reserve(nv);
  mesh.triangles.reserve(nt);
  for (std::size_t v = 0; v < nv; ++v) mesh.vertices.push_back(impl_->vertex(v));
  for (std::size_t t = 0; t < nt; ++t) mesh.triangles.push_back(impl_->triangle(t));
  return mesh;
}

}  // namespace talus::terrain
