// block-gen's heavy paths on a scanned-like rock of 100 820 faces: load, validate and
// compute properties; the exact volume beside the double one; simplification to 500
// faces with the changes it makes. See docs/benchmarks.md, "Blocks".
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <filesystem>
#include <string>

#include "talus/block/block.hpp"
#include "talus/block/mesh_check.hpp"
#include "talus/block/simplify.hpp"
#include "talus/block/solids.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/io/mesh_io.hpp"
#include "talus/io/point_cloud.hpp"

namespace {

using namespace talus;

// The rough ellipsoid block-gen makes with resolution 71 (20·71² faces).
const geometry::Polyhedron& scan() {
  static const geometry::Polyhedron poly = [] {
    block::SolidSpec spec;
    spec.kind = block::SolidKind::ellipsoid;
    spec.volume = 0.0;
    spec.dimensions = geometry::Vec3(2.0, 1.3, 0.8);
    spec.resolution = 71;
    spec.roughness = 0.1;
    spec.seed = 7;
    return block::make_solid(spec, "bench");
  }();
  return poly;
}

// The scan as a binary PLY file, written once.
const std::string& scan_file() {
  static const std::string path = [] {
    const std::string p = (std::filesystem::temp_directory_path() / "talus_block_bench_scan.ply").string();
    io::export_mesh(p, geometry::triangulate(scan()));
    return p;
  }();
  return path;
}

double peak_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

void BM_LoadValidateProperties(benchmark::State& state) {
  const std::string& file = scan_file();
  std::size_t faces = 0;
  for (auto _ : state) {
    io::ImportedMesh mesh = io::import_mesh(file);
    block::CheckedMesh checked = block::check_mesh(std::move(mesh.mesh), block::RepairOptions{}, file);
    const block::Block b = block::make_block("scan", checked.polyhedron, 2800.0, file);
    faces = b.polyhedron.faces.size();
    benchmark::DoNotOptimize(b.volume_exact);
  }
  state.counters["faces"] = static_cast<double>(faces);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_LoadValidateProperties)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ExactVolume(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(block::exact_volume(scan()).value);
  const double exact = block::exact_volume(scan()).value;
  state.counters["rel_diff_double"] = std::abs(geometry::mass_properties(scan()).volume - exact) / exact;
}
BENCHMARK(BM_ExactVolume)->Unit(benchmark::kMillisecond);

void BM_DoubleMassProperties(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(geometry::mass_properties(scan()).volume);
}
BENCHMARK(BM_DoubleMassProperties)->Unit(benchmark::kMillisecond);

void BM_SimplifyTo500(benchmark::State& state) {
  const block::Block fine = block::make_block("scan", scan(), 2800.0, "bench");
  block::SimplifyReport report;
  for (auto _ : state) {
    const block::Block coarse =
        block::make_block("coarse", block::simplify_to_faces(fine.polyhedron, 500, "bench"), 2800.0, "bench");
    report = block::compare(fine, coarse);
  }
  state.counters["faces_after"] = static_cast<double>(report.faces_after);
  state.counters["volume_change"] = report.volume_change;
  state.counters["inertia_change"] = report.inertia_change;
  state.counters["sphericity_change"] = report.sphericity_change;
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}
BENCHMARK(BM_SimplifyTo500)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_SimplifyToHull(benchmark::State& state) {
  const block::Block fine = block::make_block("scan", scan(), 2800.0, "bench");
  block::SimplifyReport report;
  for (auto _ : state) {
    const block::Block hull = block::make_block("hull", block::simplify_to_hull(fine.polyhedron, "bench"), 2800.0, "bench");
    report = block::compare(fine, hull);
  }
  state.counters["faces_after"] = static_cast<double>(report.faces_after);
  state.counters["volume_change"] = report.volume_change;
  state.counters["inertia_change"] = report.inertia_change;
  state.counters["sphericity_change"] = report.sphericity_change;
}
BENCHMARK(BM_SimplifyToHull)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
