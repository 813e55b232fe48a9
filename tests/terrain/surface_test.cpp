#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <thread>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {
namespace {

using core::RandomStream;
using core::Stream;

// A wavy DEM whose size is not a multiple of the 32-point tile, with a non-zero origin
// and unequal cell sizes, so tile edges, index arithmetic and coordinates are all tested.
DemGrid wavy_dem(std::int32_t nx, std::int32_t ny) {
  DemGrid dem;
  dem.spec = GridSpec{-10.0, 5.0, 1.5, 2.0, nx, ny};
  dem.z.resize(dem.spec.point_count());
  for (std::int32_t j = 0; j < ny; ++j)
    for (std::int32_t i = 0; i < nx; ++i)
      dem.z[dem.spec.index(i, j)] = 30.0 - 0.4 * i + 2.0 * std::sin(0.3 * i) * std::cos(0.2 * j);
  return dem;
}

// Random box inside (a margin beyond) `region`, with extents up to `size` m.
Aabb random_box(const RandomStream& rng, std::uint64_t k, const Aabb& region, double size) {
  Vec3 lo, hi;
  for (int a = 0; a < 3; ++a) {
    const double span = region.hi[a] - region.lo[a] + 2.0 * size;
    lo[a] = region.lo[a] - size + span * rng.uniform(6 * k + static_cast<std::uint64_t>(a));
    hi[a] = lo[a] + size * rng.uniform(6 * k + 3 + static_cast<std::uint64_t>(a));
  }
  return Aabb{lo, hi};
}

std::vector<Aabb> triangle_boxes(const geometry::TriangleMesh& mesh) {
  std::vector<Aabb> boxes(mesh.triangle_count());
  for (std::size_t t = 0; t < boxes.size(); ++t) boxes[t] = mesh.triangle_bounds(t);
  return boxes;
}

// Brute force: every triangle whose own box overlaps `box`.
std::set<std::int32_t> brute_in_box(const std::vector<Aabb>& boxes, const Aabb& box) {
  std::set<std::int32_t> out;
  for (std::size_t t = 0; t < boxes.size(); ++t)
    if (boxes[t].overlaps(box)) out.insert(static_cast<std::int32_t>(t));
  return out;
}

// Brute force: the highest point of any non-vertical triangle on the vertical at (x, y),
// by solving for barycentric coordinates with Eigen.
std::optional<double> brute_height(const geometry::TriangleMesh& mesh, const std::vector<Aabb>& boxes, double x,
                                   double y) {
  std::optional<double> best;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    // A cheap plan-box rejection first (tolerance as below), then the exact test.
    const Aabb& box = boxes[t];
    if (x < box.lo.x() - 1e-9 || x > box.hi.x() + 1e-9 || y < box.lo.y() - 1e-9 || y > box.hi.y() + 1e-9) continue;
    const auto& tri = mesh.triangles[t];
    const Vec3& a = mesh.vertices[tri[0]];
    const Vec3& b = mesh.vertices[tri[1]];
    const Vec3& c = mesh.vertices[tri[2]];
    Eigen::Matrix2d m;
    m << b.x() - a.x(), c.x() - a.x(), b.y() - a.y(), c.y() - a.y();
    if (std::abs(m.determinant()) < 1e-12) continue;
    const Eigen::Vector2d uv = m.inverse() * Eigen::Vector2d(x - a.x(), y - a.y());
    // 1e-12: points on a shared edge count for both triangles, as in the fast path.
    if (uv[0] < -1e-12 || uv[1] < -1e-12 || uv[0] + uv[1] > 1.0 + 1e-12) continue;
    const double z = a.z() + uv[0] * (b.z() - a.z()) + uv[1] * (c.z() - a.z());
    if (!best || z > *best) best = z;
  }
  return best;
}

bool in_plan(const std::array<Vec3, 3>& p, double x, double y, double tol) {
  double w[3];
  for (int e = 0; e < 3; ++e) {
    const Vec3& a = p[e];
    const Vec3& b = p[(e + 1) % 3];
    w[e] = (b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x());
  }
  return (w[0] >= -tol && w[1] >= -tol && w[2] >= -tol) || (w[0] <= tol && w[1] <= tol && w[2] <= tol);
}

// The fast box query against brute force over fixed-seed random boxes: never a triangle
// fewer, no duplicates, and nothing whose box misses the query box by more than `slack`.
void check_boxes(const Surface& s, std::uint64_t seed, int count, double size, double slack) {
  const std::vector<Aabb> boxes = triangle_boxes(s.to_mesh());
  const RandomStream rng(seed, Stream::bootstrap, 0);
  std::vector<std::int32_t> found;
  for (int k = 0; k < count; ++k) {
    const Aabb box = random_box(rng, static_cast<std::uint64_t>(k), s.bounds(), size);
    found.clear();
    s.triangles_in_box(box, found);
    const std::set<std::int32_t> fast(found.begin(), found.end());
    ASSERT_EQ(fast.size(), found.size()) << "duplicates in box " << k;
    for (std::int32_t t : brute_in_box(boxes, box)) ASSERT_TRUE(fast.count(t)) << "missed triangle " << t << " in box " << k;
    for (std::int32_t t : fast)
      ASSERT_TRUE(boxes[static_cast<std::size_t>(t)].overlaps(box.inflated(slack)))
          << "triangle " << t << " far from box " << k;
  }
}

// height_at against brute force at fixed-seed random points (some outside the terrain).
void check_heights(const Surface& s, std::uint64_t seed, int count) {
  const geometry::TriangleMesh mesh = s.to_mesh();
  const std::vector<Aabb> boxes = triangle_boxes(mesh);
  const RandomStream rng(seed, Stream::bootstrap, 1);
  const Aabb b = s.bounds();
  for (int k = 0; k < count; ++k) {
    const double x = b.lo.x() - 2.0 + (b.extent().x() + 4.0) * rng.uniform(2 * static_cast<std::uint64_t>(k));
    const double y = b.lo.y() - 2.0 + (b.extent().y() + 4.0) * rng.uniform(2 * static_cast<std::uint64_t>(k) + 1);
    const auto hit = s.height_at(x, y);
    const auto expected = brute_height(mesh, boxes, x, y);
    ASSERT_EQ(hit.has_value(), expected.has_value()) << "at (" << x << ", " << y << ")";
    if (!hit) continue;
    // 1e-9 m: two interpolation formulas on elevations of tens of metres agree to ~1e-14.
    EXPECT_NEAR(hit->z, *expected, 1e-9) << "at (" << x << ", " << y << ")";
    ASSERT_GE(hit->triangle, 0);
    EXPECT_TRUE(in_plan(s.triangle_vertices(static_cast<std::size_t>(hit->triangle)), x, y, 1e-9));
  }
}

Terrain rough_grid(Diagonal d, double sigma, std::uint64_t seed, std::int32_t nx = 70, std::int32_t ny = 45) {
  Terrain t = build_grid_terrain(wavy_dem(nx, ny), d, seed, "test.asc");
  t.roughness.sigma = sigma;
  return t;
}

TEST(GridSurface, TrianglesFollowTheDiagonalConventionAndFaceUp) {
  for (Diagonal d : {Diagonal::fixed, Diagonal::alternating, Diagonal::random}) {
    const Terrain t = rough_grid(d, 0.0, 7, 6, 5);
    const Surface s = Surface::realize(t, std::nullopt);
    ASSERT_EQ(s.triangle_count(), 2u * 5u * 4u);
    ASSERT_EQ(s.vertex_count(), 30u);
    for (std::size_t c = 0; c < 20; ++c) {
      const std::int32_t i = static_cast<std::int32_t>(c % 5), j = static_cast<std::int32_t>(c / 5);
      const std::int32_t p00 = j * 6 + i, p10 = p00 + 1, p01 = p00 + 6, p11 = p01 + 1;
      const auto a = s.triangle(2 * c);
      const auto b = s.triangle(2 * c + 1);
      if (t.cell_diagonal[c] == 0) {
        EXPECT_EQ(a, (std::array{p00, p10, p11}));
        EXPECT_EQ(b, (std::array{p00, p11, p01}));
      } else {
        EXPECT_EQ(a, (std::array{p00, p10, p01}));
        EXPECT_EQ(b, (std::array{p10, p11, p01}));
      }
      // The Surface and the stored mesh agree.
      EXPECT_EQ(a, t.mesh.triangles[2 * c]);
      EXPECT_EQ(b, t.mesh.triangles[2 * c + 1]);
      EXPECT_GT(s.normal(2 * c).z(), 0.0);
      EXPECT_GT(s.normal(2 * c + 1).z(), 0.0);
    }
    const Vec3 p = s.vertex(6 * 2 + 3);
    EXPECT_EQ(p, Vec3(-10.0 + 3 * 1.5, 5.0 + 2 * 2.0, t.mesh.vertices[15].z()));
  }
}

TEST(GridSurface, DiagonalModes) {
  const Terrain fixed = rough_grid(Diagonal::fixed, 0.0, 3);
  const Terrain alt = rough_grid(Diagonal::alternating, 0.0, 3);
  const Terrain rnd = rough_grid(Diagonal::random, 0.0, 3);
  const Terrain rnd_again = rough_grid(Diagonal::random, 0.0, 3);
  const Terrain rnd_other = rough_grid(Diagonal::random, 0.0, 4);
  EXPECT_TRUE(std::all_of(fixed.cell_diagonal.begin(), fixed.cell_diagonal.end(), [](auto v) { return v == 0; }));
  for (std::int32_t j = 0; j < 44; ++j)
    for (std::int32_t i = 0; i < 69; ++i) EXPECT_EQ(alt.cell_diagonal[static_cast<std::size_t>(j * 69 + i)], (i + j) % 2);
  EXPECT_EQ(rnd.cell_diagonal, rnd_again.cell_diagonal);
  EXPECT_NE(rnd.cell_diagonal, rnd_other.cell_diagonal);
  const RandomStream stream(3, Stream::terrain_diagonals, 0);
  std::size_t ones = 0;
  for (std::size_t c = 0; c < rnd.cell_diagonal.size(); ++c) {
    EXPECT_EQ(rnd.cell_diagonal[c], stream.uniform(c) < 0.5 ? 1 : 0);
    ones += rnd.cell_diagonal[c];
  }
  // 3036 fair coin flips: 5 standard deviations (5·sqrt(3036)/2 ≈ 138) around half.
  EXPECT_NEAR(static_cast<double>(ones), 3036.0 / 2.0, 138.0);
}

TEST(GridSurface, BoxQueriesMatchBruteForce) {
  for (Diagonal d : {Diagonal::fixed, Diagonal::alternating, Diagonal::random}) {
    // 40 x 36 points: more than one 32-point tile each way.
    const Terrain t = rough_grid(d, 0.25, 11, 40, 36);
    const Surface s = Surface::realize(t, 3u);
    // Boxes from a fraction of a cell to many tiles; 1e-6 m slack covers rounding.
    check_boxes(s, 5, 100, 3.0, 1e-6);
    check_boxes(s, 6, 25, 40.0, 1e-6);
  }
}

TEST(GridSurface, BoxExactlyOnGridLinesFindsTouchingCells) {
  const Terrain t = rough_grid(Diagonal::alternating, 0.0, 1);
  const Surface s = Surface::realize(t, std::nullopt);
  // A degenerate box on the grid line x = x0 + 4 dx touches the cells on both sides.
  const Aabb box{Vec3(-10.0 + 4 * 1.5, 5.0 + 2.0, -1e9), Vec3(-10.0 + 4 * 1.5, 5.0 + 2.0, 1e9)};
  std::vector<std::int32_t> out;
  s.triangles_in_box(box, out);
  const auto brute = brute_in_box(triangle_boxes(s.to_mesh()), box);
  EXPECT_EQ(brute.size(), 8u);  // the point is a corner of 4 cells
  for (std::int32_t tri : brute) EXPECT_TRUE(std::find(out.begin(), out.end(), tri) != out.end());
}

TEST(GridSurface, HeightMatchesBruteForce) {
  for (Diagonal d : {Diagonal::fixed, Diagonal::alternating, Diagonal::random}) {
    const Terrain t = rough_grid(d, 0.25, 11, 40, 36);
    check_heights(Surface::realize(t, 9u), 21, 150);
  }
}

TEST(GridSurface, HeightAtCornersAndFarEdges) {
  const Terrain t = rough_grid(Diagonal::alternating, 0.3, 2);
  const Surface s = Surface::realize(t, 0u);
  const GridSpec& g = *t.grid;
  for (std::int32_t j : {0, g.ny - 1})
    for (std::int32_t i : {0, g.nx - 1}) {
      const Vec3 p = s.vertex(g.index(i, j));
      const auto hit = s.height_at(p.x(), p.y());
      ASSERT_TRUE(hit);
      EXPECT_EQ(hit->z, p.z());
    }
  EXPECT_FALSE(s.height_at(g.x0 - 1e-9, g.y0 + 1.0));
  EXPECT_FALSE(s.height_at(g.x0 + 1.0, g.y0 + (g.ny - 1) * g.dy + 1e-6));
  EXPECT_FALSE(s.height_at(std::nan(""), 0.0));
}

TEST(GridSurface, RealizationIsAPureFunctionOfSeedAndIndex) {
  const Terrain t = rough_grid(Diagonal::random, 0.2, 99);
  const Surface a = Surface::realize(t, 5u);
  const Surface b = Surface::realize(t, 5u);
  // a: realize tiles from a far corner first; b: from the origin.
  std::vector<std::int32_t> out;
  a.triangles_in_box(Aabb{Vec3(80, 90, -1e9), Vec3(100, 100, 1e9)}, out);
  ASSERT_GT(a.tiles_realized(), 0u);
  ASSERT_LT(a.tiles_realized(), a.tile_count());
  const std::size_t n = a.vertex_count();
  std::vector<double> zb(n);
  for (std::size_t v = 0; v < n; ++v) zb[v] = b.vertex(v).z();
  const RandomStream stream(99, Stream::terrain_roughness, 5);
  for (std::size_t v = n; v-- > 0;) {
    ASSERT_EQ(a.vertex(v).z(), zb[v]) << v;  // bit for bit
    ASSERT_EQ(a.vertex(v).z(), t.mesh.vertices[v].z() + 0.2 * stream.normal(v)) << v;
  }
  EXPECT_EQ(a.tiles_realized(), a.tile_count());

  const Surface other_index = Surface::realize(t, 6u);
  Terrain t2 = t;
  t2.roughness.seed = 100;
  const Surface other_seed = Surface::realize(t2, 5u);
  const Surface smooth = Surface::realize(t, std::nullopt);
  std::size_t same_index = 0, same_seed = 0;
  for (std::size_t v = 0; v < n; ++v) {
    same_index += other_index.vertex(v).z() == a.vertex(v).z();
    same_seed += other_seed.vertex(v).z() == a.vertex(v).z();
    ASSERT_EQ(smooth.vertex(v).z(), t.mesh.vertices[v].z());
  }
  EXPECT_EQ(same_index, 0u);
  EXPECT_EQ(same_seed, 0u);
  EXPECT_EQ(smooth.tile_count(), 0u);
}

TEST(GridSurface, QueriesTouchOnlyNearbyTiles) {
  const Terrain t = rough_grid(Diagonal::alternating, 0.1, 1, 200, 150);
  const Surface s = Surface::realize(t, 1u);
  EXPECT_EQ(s.tile_count(), 7u * 5u);
  EXPECT_EQ(s.tiles_realized(), 0u);
  ASSERT_TRUE(s.height_at(-10.0 + 1.5 * 40.5, 5.0 + 2.0 * 40.5));
  EXPECT_EQ(s.tiles_realized(), 1u);
  std::vector<std::int32_t> out;
  // A box over 2 x 2 cells well inside tile (1, 1) stays in it.
  s.triangles_in_box(Aabb{Vec3(-10.0 + 1.5 * 45.2, 5.0 + 2.0 * 45.2, -1e9),
                          Vec3(-10.0 + 1.5 * 46.8, 5.0 + 2.0 * 46.8, 1e9)},
                     out);
  EXPECT_EQ(out.size(), 2u * 2u * 2u);
  EXPECT_EQ(s.tiles_realized(), 1u);
}

TEST(GridSurface, PerturbationsHaveStandardDeviationSigma) {
  const double sigma = 0.4;
  const Terrain t = rough_grid(Diagonal::alternating, sigma, 123, 250, 200);
  const Surface s = Surface::realize(t, 17u);
  const std::size_t n = s.vertex_count();
  double sum = 0.0, sum2 = 0.0, max_abs = 0.0;
  for (std::size_t v = 0; v < n; ++v) {
    const double e = (s.vertex(v).z() - t.mesh.vertices[v].z()) / sigma;
    sum += e;
    sum2 += e * e;
    max_abs = std::max(max_abs, std::abs(e));
  }
  const double mean = sum / static_cast<double>(n);
  const double sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  // n = 50000 draws: the standard error of the mean is 1/sqrt(n) = 0.0045 and of the sd
  // 1/sqrt(2n) = 0.0032; allow 5 standard errors.
  EXPECT_NEAR(mean, 0.0, 5 * 0.0045);
  EXPECT_NEAR(sd, 1.0, 5 * 0.0032);
  EXPECT_LT(max_abs, 8.6);
  // Bounds: x, y exact; z covers the realization.
  const Aabb& b = s.bounds();
  EXPECT_EQ(b.lo.x(), -10.0);
  EXPECT_EQ(b.hi.x(), -10.0 + 249 * 1.5);
  EXPECT_EQ(b.lo.y(), 5.0);
  EXPECT_EQ(b.hi.y(), 5.0 + 199 * 2.0);
  const Aabb base = t.mesh.bounds();
  EXPECT_DOUBLE_EQ(b.lo.z(), base.lo.z() - 8.6 * sigma);
  EXPECT_DOUBLE_EQ(b.hi.z(), base.hi.z() + 8.6 * sigma);
}

TEST(GridSurface, ToMeshMaterializesTheRealization) {
  const Terrain t = rough_grid(Diagonal::random, 0.1, 5, 40, 35);
  const Surface s = Surface::realize(t, 2u);
  const auto mesh = s.to_mesh();
  ASSERT_EQ(mesh.vertex_count(), s.vertex_count());
  ASSERT_EQ(mesh.triangle_count(), s.triangle_count());
  EXPECT_EQ(mesh.triangles, t.mesh.triangles);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_EQ(mesh.vertices[v].x(), t.mesh.vertices[v].x());
    EXPECT_EQ(mesh.vertices[v].y(), t.mesh.vertices[v].y());
  }
}

TEST(GridSurface, InconsistentTerrainIsAnInputError) {
  Terrain t = rough_grid(Diagonal::fixed, 0.0, 1, 5, 5);
  t.cell_diagonal.pop_back();
  EXPECT_THROW(Surface::realize(t, 0u), core::InputError);
  t = rough_grid(Diagonal::fixed, 0.0, 1, 5, 5);
  t.roughness.sigma = -1.0;
  EXPECT_THROW(Surface::realize(t, 0u), core::InputError);
  t = rough_grid(Diagonal::fixed, 0.0, 1, 5, 5);
  t.material_of_triangle.pop_back();
  EXPECT_THROW(Surface::realize(t, 0u), core::InputError);
}

// A TIN with a jittered height field, a vertical wall standing on it and an overhanging
// roof (clockwise from above) over part of it: the cases a height field cannot have.
geometry::TriangleMesh general_tin() {
  geometry::TriangleMesh m;
  const RandomStream rng(77, Stream::bootstrap, 2);
  const int n = 25;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::uint64_t k = static_cast<std::uint64_t>(j * n + i);
      const double jx = (i > 0 && i < n - 1) ? 0.3 * (rng.uniform(3 * k) - 0.5) : 0.0;
      const double jy = (j > 0 && j < n - 1) ? 0.3 * (rng.uniform(3 * k + 1) - 0.5) : 0.0;
      m.vertices.emplace_back(i + jx, j + jy, 5.0 * rng.uniform(3 * k + 2) - 0.1 * i);
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::int32_t p = j * n + i;
      m.triangles.push_back({p, p + 1, p + n + 1});
      m.triangles.push_back({p, p + n + 1, p + n});
    }
  const auto add = [&](Vec3 a, Vec3 b, Vec3 c) {
    const auto v = static_cast<std::int32_t>(m.vertices.size());
    m.vertices.insert(m.vertices.end(), {a, b, c});
    m.triangles.push_back({v, v + 1, v + 2});
  };
  add({5, 5, 0}, {5, 15, 0}, {5, 15, 20});  // a vertical wall
  add({5, 5, 0}, {5, 15, 20}, {5, 5, 20});
  add({3, 3, 30}, {12, 12, 32}, {12, 3, 31});  // a roof facing down
  return m;
}

TEST(TinSurface, BoxQueriesMatchBruteForce) {
  const Surface s = Surface::from_mesh(general_tin());
  EXPECT_FALSE(s.is_height_field());
  check_boxes(s, 8, 150, 4.0, 0.0);
  check_boxes(s, 9, 40, 30.0, 0.0);
}

TEST(TinSurface, HeightIsTheHighestHit) {
  const Surface s = Surface::from_mesh(general_tin());
  check_heights(s, 31, 200);
  // Under the roof the roof is the highest hit.
  const auto hit = s.height_at(10.0, 5.0);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->triangle, static_cast<std::int32_t>(s.triangle_count() - 1));
  EXPECT_GT(s.normal(s.triangle_count() - 1).z(), -1.0);
  EXPECT_LT(s.normal(s.triangle_count() - 1).z(), 0.0);
}

TEST(TinSurface, RoughnessPerturbsEveryVertex) {
  Terrain t;
  t.mesh = general_tin();
  t.materials.push_back(Material{});
  t.material_of_triangle.assign(t.mesh.triangle_count(), 0);
  t.roughness = Roughness{0.15, 4242};
  const Surface a = Surface::realize(t, 12u);
  const Surface base = Surface::realize(t, std::nullopt);
  const RandomStream stream(4242, Stream::terrain_roughness, 12);
  for (std::size_t v = 0; v < t.mesh.vertex_count(); ++v) {
    ASSERT_EQ(a.vertex(v).z(), t.mesh.vertices[v].z() + 0.15 * stream.normal(v));
    ASSERT_EQ(base.vertex(v), t.mesh.vertices[v]);
  }
  check_boxes(a, 10, 100, 4.0, 0.0);
  check_heights(a, 32, 100);
  const Aabb mb = t.mesh.bounds();
  EXPECT_EQ(a.bounds().lo.x(), mb.lo.x());
  EXPECT_DOUBLE_EQ(a.bounds().hi.z(), mb.hi.z() + 8.6 * 0.15);
}

TEST(TinSurface, RealizationSharesTheTreeAndEqualsRealize) {
  Terrain t;
  t.mesh = general_tin();
  t.roughness = Roughness{0.3, 99};
  const Surface first = Surface::realize(t, 0u);
  const Surface next = first.realization(5u);
  const Surface direct = Surface::realize(t, 5u);
  for (std::size_t v = 0; v < t.mesh.vertex_count(); ++v) ASSERT_EQ(next.vertex(v), direct.vertex(v));
  // The shared tree was built for realization 0; it must serve realization 5 as well.
  check_boxes(next, 12, 100, 4.0, 0.0);
  check_heights(next, 33, 100);
  EXPECT_EQ(first.realization(std::nullopt).vertex(7), t.mesh.vertices[7]);
  // from_mesh keeps its mesh alive for the realizations made from it.
  const Surface from_mesh = Surface::from_mesh(general_tin()).realization(1u);
  EXPECT_EQ(from_mesh.vertex(3), general_tin().vertices[3]);
}

// A perturbed TIN realizes only the blocks of 1024 vertex ids that its queries read, and
// those hold the same elevations as a whole realization.
TEST(TinSurface, QueriesRealizeOnlyTheVerticesTheyRead) {
  Terrain t;
  const int n = 100;  // 10 000 vertices: 10 blocks, row j of the lattice in block ⌊100j/1024⌋
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) t.mesh.vertices.emplace_back(i, j, 0.05 * i);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::int32_t p = j * n + i;
      t.mesh.triangles.push_back({p, p + 1, p + n + 1});
      t.mesh.triangles.push_back({p, p + n + 1, p + n});
    }
  t.roughness = Roughness{0.2, 21};
  const Surface base = Surface::realize(t, std::nullopt);
  EXPECT_EQ(base.tile_count(), 0u);
  const Surface s = base.realization(3u);
  EXPECT_EQ(s.tile_count(), 10u);
  EXPECT_EQ(s.tiles_realized(), 0u);
  const auto hit = s.height_at(50.3, 3.6);  // rows 3 and 4: block 0
  ASSERT_TRUE(hit);
  EXPECT_EQ(s.tiles_realized(), 1u);
  const RandomStream stream(21, Stream::terrain_roughness, 3);
  for (std::size_t v : {std::size_t{0}, std::size_t{350}, std::size_t{1023}, std::size_t{1024}, std::size_t{9999}})
    EXPECT_EQ(s.vertex(v).z(), t.mesh.vertices[v].z() + 0.2 * stream.normal(v)) << v;
  EXPECT_EQ(s.tiles_realized(), 3u);
  s.realize_all();
  EXPECT_EQ(s.tiles_realized(), 10u);
  const Surface direct = Surface::realize(t, 3u);
  direct.realize_all();
  for (std::size_t v = 0; v < t.mesh.vertex_count(); ++v) ASSERT_EQ(s.vertex(v), direct.vertex(v));
}

// Realizations made and queried on several threads at once give the same bits as
// made one after the other on one thread.
TEST(TinSurface, RealizationsOnThreadsMatchSerial) {
  Terrain t;
  t.mesh = general_tin();
  t.roughness = Roughness{0.2, 5};
  const Surface first = Surface::realize(t, 0u);
  const auto sample = [&first](std::uint32_t index) {
    const Surface s = first.realization(index);
    std::vector<double> z;
    for (int k = 0; k < 50; ++k) z.push_back(s.height_at(0.5 + 0.47 * k, 12.0 + 0.2 * k)->z);
    return z;
  };
  std::vector<std::vector<double>> serial, threaded(4);
  for (std::uint32_t i = 0; i < 4; ++i) serial.push_back(sample(10 + i));
  std::vector<std::thread> threads;
  for (std::uint32_t i = 0; i < 4; ++i) threads.emplace_back([&, i] { threaded[i] = sample(10 + i); });
  for (auto& th : threads) th.join();
  EXPECT_EQ(threaded, serial);
  EXPECT_NE(serial[0], serial[1]);
}

TEST(GridSurface, RealizationEqualsRealize) {
  const Terrain t = rough_grid(Diagonal::random, 0.2, 8, 40, 36);
  const Surface base = Surface::realize(t, std::nullopt);
  const Surface a = base.realization(4u);
  const Surface b = Surface::realize(t, 4u);
  for (std::size_t v = 0; v < t.mesh.vertex_count(); ++v) ASSERT_EQ(a.vertex(v), b.vertex(v));
}

// The bounds of every realization are one object, computed once from the base terrain,
// and equal to those of a surface realized on its own: a realization never re-scans the
// points for them.
TEST(GridSurface, RealizationsShareTheBounds) {
  const Terrain t = rough_grid(Diagonal::random, 0.2, 8, 40, 36);
  const Surface base = Surface::realize(t, std::nullopt);
  const Surface a = base.realization(4u);
  const Surface b = base.realization(5u);
  EXPECT_EQ(&a.bounds(), &b.bounds());
  EXPECT_EQ(&a.bounds(), &base.bounds());
  const Surface alone = Surface::realize(t, 4u);
  EXPECT_NE(&alone.bounds(), &a.bounds());
  EXPECT_EQ(alone.bounds().lo, a.bounds().lo);
  EXPECT_EQ(alone.bounds().hi, a.bounds().hi);
  EXPECT_EQ(a.tiles_realized(), 0u);  // bounds need no realized tile
}

TEST(TinSurface, RealizationsShareTheBounds) {
  Terrain t;
  t.mesh = general_tin();
  t.roughness = Roughness{0.15, 3};
  const Surface base = Surface::realize(t, std::nullopt);
  const Surface a = base.realization(2u);
  EXPECT_EQ(&a.bounds(), &base.bounds());
  const Surface alone = Surface::realize(t, 2u);
  EXPECT_EQ(alone.bounds().lo, a.bounds().lo);
  EXPECT_EQ(alone.bounds().hi, a.bounds().hi);
}

TEST(TinSurface, BadIndexIsAnInputError) {
  geometry::TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 3}};
  EXPECT_THROW(Surface::from_mesh(m), core::InputError);
}

TEST(TinSurface, EmptyMeshAnswersNothing) {
  const Surface s = Surface::from_mesh({});
  std::vector<std::int32_t> out;
  s.triangles_in_box(Aabb{Vec3(-1, -1, -1), Vec3(1, 1, 1)}, out);
  EXPECT_TRUE(out.empty());
  EXPECT_FALSE(s.height_at(0.0, 0.0));
}

namespace talus::terrain {
namespace {

// FNV-1a over the bit patterns of every realized vertex and the triangle list.
std::uint64_t surface_hash(const Surface& s) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  const auto mix = [&h](std::uint64_t word) {
    for (int b = 0; b < 8; ++b) {
      h ^= (word >> (8 * b)) & 0xffu;
      h *= 0x100000001b3ull;
    }
  };
  for (std::size_t v = 0; v < s.vertex_count(); ++v)
    for (int a = 0; a < 3; ++a) mix(std::bit_cast<std::uint64_t>(s.vertex(v)[a]));
  for (std::size_t t = 0; t < s.triangle_count(); ++t)
    for (std::int32_t id : s.triangle(t)) mix(static_cast<std::uint64_t>(id));
  return h;
}

// Golden hash: realization 3 of a fixed terrain must keep the same bits on every
// platform and in every future version (terrain files store only seed and σ). Changing
// it breaks the reproducibility of every earlier run.
TEST(GridSurface, GoldenRealizationHash) {
  // Base elevations from exact arithmetic only (no libm), so the hash is portable.
  DemGrid dem;
  dem.spec = GridSpec{-10.0, 5.0, 1.5, 2.0, 40, 35};
  for (std::int32_t j = 0; j < 35; ++j)
    for (std::int32_t i = 0; i < 40; ++i) dem.z.push_back(0.375 * i - 0.125 * j + 0.25 * ((i * j) % 7));
  Terrain t = build_grid_terrain(dem, Diagonal::random, 2024, "golden");
  t.roughness.sigma = 0.1;
  EXPECT_EQ(surface_hash(Surface::realize(t, 3u)), 14531317782559436885ull);
}

}  // namespace
}  // namespace talus::terrain

// The rim is where the surface ends. On a grid it is the border: a box strictly inside is
// clear of it; a point outside meets it at its clamp onto the grid, at the realized
// elevation there; a point inside at the nearest side.
TEST(GridSurface, RimIsTheBorderOfTheGrid) {
  const Terrain t = rough_grid(Diagonal::random, 0.2, 8, 40, 36);
  const Surface s = Surface::realize(t, 3u);
  const Aabb& b = s.bounds();  // x in [-10, 48.5], y in [5, 75]
  EXPECT_FALSE(s.near_rim(Aabb{Vec3(0, 10, -1e3), Vec3(5, 15, 1e3)}));
  EXPECT_TRUE(s.near_rim(Aabb{Vec3(-10.5, 10, 0), Vec3(-9, 15, 0)}));
  EXPECT_TRUE(s.near_rim(Aabb{Vec3(0, 74, 0), Vec3(5, 75, 0)}));
  const auto beside = s.nearest_rim_point(20.0, 4.2, 1.0);
  ASSERT_TRUE(beside);
  EXPECT_EQ(beside->point.x(), 20.0);
  EXPECT_EQ(beside->point.y(), b.lo.y());
  EXPECT_EQ(beside->point.z(), s.height_at(20.0, b.lo.y())->z);
  EXPECT_EQ(beside->triangle, s.height_at(20.0, b.lo.y())->triangle);
  const auto corner = s.nearest_rim_point(49.0, 76.0, 2.0);
  ASSERT_TRUE(corner);
  EXPECT_EQ(corner->point.head<2>(), Eigen::Vector2d(b.hi.x(), b.hi.y()));
  EXPECT_EQ(corner->point.z(), s.vertex(s.vertex_count() - 1).z());
  EXPECT_EQ(corner->triangle, s.height_at(b.hi.x(), b.hi.y())->triangle);  // the last cell's
  EXPECT_GE(corner->triangle, static_cast<std::int32_t>(s.triangle_count() - 2));
  EXPECT_FALSE(s.nearest_rim_point(20.0, 3.0, 1.0));  // 2 m away
  const auto inside = s.nearest_rim_point(48.0, 40.0, 1.0);
  ASSERT_TRUE(inside);
  EXPECT_EQ(inside->point.x(), b.hi.x());
  EXPECT_EQ(inside->point.y(), 40.0);
  EXPECT_TRUE(s.rim_bounds_footprint());
}

// The rim bounds a TIN's footprint when its triangles all face up and each edge has at
// most two, running along it in opposite directions: a square of two triangles does; so
// does a fan of four around a raised centre; not when a triangle faces down (reversed),
// when a third triangle shares an edge, or when two share one in the same direction (a
// fold).
TEST(TinSurface, RimBoundsTheFootprintOfAPlainSheet) {
  const auto bounds = [](std::vector<Vec3> vertices, std::vector<std::array<std::int32_t, 3>> triangles) {
    Terrain t;
    t.mesh.vertices = std::move(vertices);
    t.mesh.triangles = std::move(triangles);
    return Surface::realize(t, std::nullopt).rim_bounds_footprint();
  };
  const std::vector<Vec3> square = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0.5), Vec3(0, 1, 0.5)};
  EXPECT_TRUE(bounds(square, {{0, 1, 2}, {0, 2, 3}}));
  EXPECT_FALSE(bounds(square, {{0, 2, 1}, {0, 2, 3}}));  // the first faces down
  std::vector<Vec3> fan = square;
  fan.emplace_back(0.5, 0.5, 1.0);
  EXPECT_TRUE(bounds(fan, {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}}));
  EXPECT_FALSE(bounds(fan, {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {0, 1, 4}}));  // three on an edge
  std::vector<Vec3> folded = square, beside = square;
  folded.emplace_back(0.5, 0.3, 1.0);  // a flap on edge 0-1 over the first triangle, facing up
  EXPECT_FALSE(bounds(folded, {{0, 1, 2}, {0, 2, 3}, {0, 1, 4}}));
  beside.emplace_back(0.5, -0.5, 1.0);  // a flap on edge 0-1 beside the square: no fold
  EXPECT_TRUE(bounds(beside, {{0, 1, 2}, {0, 2, 3}, {1, 0, 4}}));
}

// On a TIN the rim is every edge of one triangle, whatever the footprint's shape (the
// general TIN: a square sheet with a free-standing wall and roof): the nearest rim point
// matches a brute-force scan of the edges, on a rough realization made from the base
// (whose rim it shares).
TEST(TinSurface, RimIsTheEdgesOfOneTriangleAndMatchesBruteForce) {
  Terrain t;
  t.mesh = general_tin();
  t.roughness = Roughness{0.2, 5};
  const Surface base = Surface::realize(t, std::nullopt);
  const Surface s = base.realization(6u);
  std::map<std::pair<std::int32_t, std::int32_t>, int> count;
  for (const auto& tri : t.mesh.triangles)
    for (int k = 0; k < 3; ++k) ++count[{std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])}];
  std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> owner;
  for (std::size_t f = 0; f < t.mesh.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& tri = t.mesh.triangles[f];
      owner[{std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])}] = static_cast<std::int32_t>(f);
    }
  std::vector<std::pair<std::int32_t, std::int32_t>> rim;
  for (const auto& [e, n] : count)
    if (n == 1) rim.push_back(e);
  // The sheet's border, the wall's two triangles (their vertices are not shared), the roof.
  ASSERT_EQ(rim.size(), 4u * 24u + 6u + 3u);
  const RandomStream rng(41, Stream::bootstrap, 0);
  int found = 0;
  for (std::uint64_t k = 0; k < 300; ++k) {
    const double x = -3.0 + 30.0 * rng.uniform(2 * k), y = -3.0 + 30.0 * rng.uniform(2 * k + 1);
    double best = 2.5, best_z = 0.0;
    std::int32_t best_t = -1;
    for (const auto& [i, j] : rim) {
      const Vec3 a = s.vertex(static_cast<std::size_t>(i)), c = s.vertex(static_cast<std::size_t>(j));
      const Eigen::Vector2d u = (c - a).head<2>();
      const double f = std::clamp((Eigen::Vector2d(x, y) - a.head<2>()).dot(u) / u.squaredNorm(), 0.0, 1.0);
      const Vec3 p = a + f * (c - a);
      const double d = std::hypot(p.x() - x, p.y() - y);
      if (d < best - 1e-12 || (d < best + 1e-12 && p.z() > best_z))
        best = std::min(best, d), best_z = p.z(), best_t = owner[{i, j}];
    }
    const auto got = s.nearest_rim_point(x, y, 2.5);
    ASSERT_EQ(got.has_value(), best < 2.5) << x << " " << y;
    if (!got) continue;
    ++found;
    EXPECT_NEAR(std::hypot(got->point.x() - x, got->point.y() - y), best, 1e-12);
    EXPECT_NEAR(got->point.z(), best_z, 1e-9);
    EXPECT_EQ(got->triangle, best_t);
    EXPECT_TRUE(s.near_rim(Aabb{Vec3(x - 2.5, y - 2.5, 0), Vec3(x + 2.5, y + 2.5, 0)}));
  }
  EXPECT_GT(found, 100);
  EXPECT_FALSE(s.near_rim(Aabb{Vec3(15.5, 18.5, -1e3), Vec3(17.5, 20.5, 1e3)}));
  EXPECT_FALSE(s.nearest_rim_point(16.5, 19.5, 1.0));
  EXPECT_FALSE(s.rim_bounds_footprint());  // the wall and the roof
}

// rim_top bounds the realized elevation of every rim point in a plan box: at random
// points in random boxes on a rough grid and on the rough general TIN (wall and roof
// included), the rim point nearest to each (within the box's reach) lies no higher than
// the top of the box widened by that reach. A box clear of the rim has none: −∞.
TEST(TinSurface, RimTopBoundsTheRimPointsInABox) {
  Terrain tin;
  tin.mesh = general_tin();
  tin.roughness = Roughness{0.2, 5};
  const Terrain grid = rough_grid(Diagonal::random, 0.3, 8, 40, 36);
  for (const Terrain* t : std::array<const Terrain*, 2>{&grid, &tin}) {
    const Surface s = Surface::realize(*t, 7u);
    const Aabb& b = s.bounds();
    const RandomStream rng(t == &grid ? 42 : 43, Stream::bootstrap, 0);
    int with_rim = 0;
    for (std::uint64_t k = 0; k < 400; ++k) {
      const auto u = [&](std::uint64_t j) { return rng.uniform(8 * k + j); };
      const Vec3 centre(b.lo.x() - 3.0 + (b.hi.x() - b.lo.x() + 6.0) * u(0),
                        b.lo.y() - 3.0 + (b.hi.y() - b.lo.y() + 6.0) * u(1), 0.0);
      const Vec3 half(0.2 + 2.0 * u(2), 0.2 + 2.0 * u(3), 1.0);
      const double reach = 0.5 + 2.0 * u(4);
      const Aabb box{centre - half, centre + half};
      const double top = s.rim_top(box.inflated(reach));
      double highest = -std::numeric_limits<double>::infinity();
      for (std::uint64_t j = 0; j < 40; ++j) {
        const double x = box.lo.x() + (box.hi.x() - box.lo.x()) * rng.uniform(1000 * k + 2 * j + 100000);
        const double y = box.lo.y() + (box.hi.y() - box.lo.y()) * rng.uniform(1000 * k + 2 * j + 100001);
        const auto rim = s.nearest_rim_point(x, y, reach);
        if (!rim) continue;
        EXPECT_LE(rim->point.z(), top) << "box " << k;
        highest = std::max(highest, rim->point.z());
      }
      if (std::isfinite(highest)) ++with_rim;
    }
    EXPECT_GT(with_rim, 100);
  }
  const Surface s = Surface::realize(grid, 7u);
  const Aabb& b = s.bounds();
  const Vec3 middle = 0.5 * (b.lo + b.hi);
  EXPECT_EQ(s.rim_top(Aabb{middle - Vec3(2, 2, 1), middle + Vec3(2, 2, 1)}), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(s.rim_top(Aabb{b.lo - Vec3(9, 9, 1), b.lo - Vec3(1, 1, 0)}), -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isfinite(s.rim_top(Aabb{b.lo - Vec3(1, 1, 1), b.lo + Vec3(1, 1, 1)})));
}

}  // namespace
}  // namespace talus::terrain
