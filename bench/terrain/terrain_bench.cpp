// A 2000 x 2000 DEM (4 M points, 8 M triangles): building the terrain, realizing all of
// a roughness realization, and the query pattern of one DDA realization, which realizes
// only the tiles near the block's path.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <vector>

#include "talus/core/random.hpp"
#include "talus/terrain/build.hpp"

namespace {

using talus::terrain::Aabb;
using talus::terrain::DemGrid;
using talus::terrain::Diagonal;
using talus::terrain::GridSpec;
using talus::terrain::Surface;
using talus::terrain::Terrain;
using talus::terrain::Vec3;

constexpr std::int32_t kSide = 2000;

double peak_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// A 2 m DEM of a 4 km slope with some relief.
DemGrid big_dem() {
  DemGrid dem;
  dem.spec = GridSpec{0.0, 0.0, 2.0, 2.0, kSide, kSide};
  dem.z.resize(dem.spec.point_count());
  for (std::int32_t j = 0; j < kSide; ++j)
    for (std::int32_t i = 0; i < kSide; ++i)
      dem.z[dem.spec.index(i, j)] = 2000.0 - 0.5 * i + 5.0 * std::sin(0.01 * i) * std::cos(0.013 * j);
  return dem;
}

// The queries of one DDA realization: `queries` height and 3 m box queries along a 600 m
// path starting at (x0, y0), drifting ±40 m sideways. Returns the triangles found.
std::size_t query_path(const Surface& s, std::int32_t queries, double x0, double y0, std::vector<std::int32_t>& out) {
  std::size_t found = 0;
  for (std::int32_t q = 0; q < queries; ++q) {
    const double f = static_cast<double>(q) / queries;
    const double x = x0 + 600.0 * f;
    const double y = y0 + 40.0 * std::sin(6.0 * f);
    const double z = s.height_at(x, y)->z;
    out.clear();
    s.triangles_in_box(Aabb{Vec3(x - 1.5, y - 1.5, z - 1.5), Vec3(x + 1.5, y + 1.5, z + 1.5)}, out);
    found += out.size();
  }
  return found;
}

const Terrain& big_terrain() {
  static const Terrain terrain = [] {
    Terrain t = talus::terrain::build_grid_terrain(big_dem(), Diagonal::random, 7, "bench");
    t.roughness.sigma = 0.2;
    return t;
  }();
  return terrain;
}

void BM_BuildGridTerrain(benchmark::State& state) {
  const DemGrid dem = big_dem();
  for (auto _ : state) {
    const Terrain t = talus::terrain::build_grid_terrain(dem, Diagonal::random, 7, "bench");
    benchmark::DoNotOptimize(t.mesh.triangles.data());
  }
  state.counters["triangles"] = 2.0 * (kSide - 1) * (kSide - 1);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_BuildGridTerrain)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_RealizeWholeSurface(benchmark::State& state) {
  const Terrain& t = big_terrain();
  std::uint32_t index = 0;
  for (auto _ : state) {
    const Surface s = Surface::realize(t, index++);
    s.realize_all();
    benchmark::DoNotOptimize(s.vertex(0));
  }
  state.counters["points"] = static_cast<double>(t.mesh.vertex_count());
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_RealizeWholeSurface)->Unit(benchmark::kMillisecond)->Iterations(5);

// One realization as the DDA engine sees it: realize, then query_path with `range(0)`
// queries; only the tiles along the path are realized.
void BM_DdaQueryPattern(benchmark::State& state) {
  const Terrain& t = big_terrain();
  const auto queries = static_cast<std::int32_t>(state.range(0));
  std::uint32_t index = 0;
  std::size_t tiles = 0, total_tiles = 0, found = 0;
  std::vector<std::int32_t> out;
  for (auto _ : state) {
    const Surface s = Surface::realize(t, index++);
    found += query_path(s, queries, 1000.0, 2000.0, out);
    tiles = s.tiles_realized();
    total_tiles = s.tile_count();
  }
  benchmark::DoNotOptimize(found);
  state.counters["tiles_realized"] = static_cast<double>(tiles);
  state.counters["tiles_total"] = static_cast<double>(total_tiles);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_DdaQueryPattern)->Arg(300)->Unit(benchmark::kMillisecond);

// A surveyed terrain: a TIN of 1000 x 1000 scattered points (about 2 M triangles) by
// Delaunay triangulation, and one realization of it (perturb every vertex, build the BVH),
// which is not lazy.
const Terrain& big_tin() {
  static const Terrain terrain = [] {
    std::vector<Vec3> points;
    const std::int32_t n = 1000;
    points.reserve(static_cast<std::size_t>(n) * n);
    const talus::core::RandomStream rng(3, talus::core::Stream::bootstrap, 0);
    for (std::int32_t j = 0; j < n; ++j)
      for (std::int32_t i = 0; i < n; ++i) {
        const auto k = static_cast<std::uint64_t>(j) * n + static_cast<std::uint64_t>(i);
        const double x = 2.0 * i + 1.6 * (rng.uniform(2 * k) - 0.5);
        const double y = 2.0 * j + 1.6 * (rng.uniform(2 * k + 1) - 0.5);
        points.emplace_back(x, y, 1000.0 - 0.5 * x + 3.0 * std::sin(0.02 * y));
      }
    Terrain t = talus::terrain::build_delaunay_terrain(points, "bench");
    t.roughness.sigma = 0.2;
    return t;
  }();
  return terrain;
}

void BM_RealizeTin(benchmark::State& state) {
  const Terrain& t = big_tin();
  std::uint32_t index = 0;
  for (auto _ : state) {
    const Surface s = Surface::realize(t, index++);
    benchmark::DoNotOptimize(s.vertex(0));
  }
  state.counters["triangles"] = static_cast<double>(t.mesh.triangle_count());
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_RealizeTin)->Unit(benchmark::kMillisecond)->Iterations(3);

// The next realization of a TIN, reusing the first one's BVH: only the perturbation.
void BM_NextTinRealization(benchmark::State& state) {
  const Surface first = Surface::realize(big_tin(), 0u);
  std::uint32_t index = 1;
  for (auto _ : state) {
    const Surface s = first.realization(index++);
    benchmark::DoNotOptimize(s.vertex(0));
  }
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_NextTinRealization)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_TinQueryPattern(benchmark::State& state) {
  const Surface s = Surface::realize(big_tin(), 0u);
  const auto queries = static_cast<std::int32_t>(state.range(0));
  std::vector<std::int32_t> out;
  std::size_t found = 0;
  for (auto _ : state) found += query_path(s, queries, 500.0, 1000.0, out);
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(state.iterations() * queries);
}
BENCHMARK(BM_TinQueryPattern)->Arg(300)->Unit(benchmark::kMillisecond);

// One TIN realization as the DDA engine sees it: the next realization, then query_path
// with `range(0)` queries; only the blocks of vertices the queries read are realized.
void BM_TinDdaQueryPattern(benchmark::State& state) {
  const Surface first = Surface::realize(big_tin(), 0u);
  const auto queries = static_cast<std::int32_t>(state.range(0));
  std::uint32_t index = 1;
  std::size_t blocks = 0, total_blocks = 0, found = 0;
  std::vector<std::int32_t> out;
  for (auto _ : state) {
    const Surface s = first.realization(index++);
    found += query_path(s, queries, 500.0, 1000.0, out);
    blocks = s.tiles_realized();
    total_blocks = s.tile_count();
  }
  benchmark::DoNotOptimize(found);
  state.counters["blocks_realized"] = static_cast<double>(blocks);
  state.counters["blocks_total"] = static_cast<double>(total_blocks);
}
BENCHMARK(BM_TinDdaQueryPattern)->Arg(300)->Unit(benchmark::kMillisecond);

}  // namespace
