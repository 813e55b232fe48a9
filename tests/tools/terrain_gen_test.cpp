// End-to-end tests of the terrain-gen executable: run the built binary, check the exit
// code, the one-line message and the output files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/block/solids.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/raster.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/terrain/terrain.hpp"
#include "../support/las_writer.hpp"
#include "tool_run.hpp"

namespace talus {
namespace {

namespace fs = std::filesystem;

const std::string kSample = std::string(TALUS_SOURCE_DIR) + "/samples/bench-slope/terrain.yaml";

using testing::read_text;
using Outcome = testing::ToolOutcome;

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// A scratch directory per test (ctest runs tests in parallel), removed afterwards.
class TerrainGen : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("talus_terrain_gen_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs terrain-gen with `args` in directory `cwd` (default: the scratch directory).
  Outcome run(const std::vector<std::string>& args, const fs::path& cwd = {}) const {
    return testing::run_tool(testing::tool_path("terrain-gen"), args, cwd.empty() ? dir_ : cwd);
  }

  // Files left in the scratch directory, the captured output excluded.
  std::vector<std::string> files(const fs::path& sub = {}) const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(sub.empty() ? dir_ : sub)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  // An error run: exit `code`, one line naming the tool, and nothing written.
  void expect_error(const Outcome& r, int code, const std::string& fragment,
                    const std::string& output = "out.h5") const {
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_EQ(r.err.rfind("terrain-gen: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / output)) << output;
    EXPECT_FALSE(fs::exists(dir_ / fs::path(output).replace_extension(".xmf"))) << output;
    for (const auto& name : files()) EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
  }

  fs::path dir_;
};

// Elevation of the §6 bench profile at x (m).
double bench_z(double x) {
  const double px[] = {0, 6, 8, 14, 16, 22, 24, 36, 60};
  const double pz[] = {30, 24, 24, 18, 18, 12, 12, 0, 0};
  for (int k = 1; k < 9; ++k)
    if (x <= px[k]) return pz[k - 1] + (x - px[k - 1]) / (px[k] - px[k - 1]) * (pz[k] - pz[k - 1]);
  return 0.0;
}

TEST_F(TerrainGen, BenchSlopeSampleBuildsTheReferenceGrid) {
  const Outcome r = run({"-c", kSample, "-o", "bench.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(files(), (std::vector<std::string>{"bench.h5", "bench.xmf"}));  // no temporary left

  io::TerrainFileInfo info;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "bench.h5").string(), info);
  ASSERT_TRUE(t.grid.has_value());
  EXPECT_EQ(t.grid->nx, 31);
  EXPECT_EQ(t.grid->ny, 21);
  EXPECT_EQ(t.grid->dx, 2.0);
  EXPECT_EQ(t.mesh.vertices.size(), 651u);
  EXPECT_EQ(t.mesh.triangles.size(), 1200u);
  for (std::int32_t j = 0; j < 21; ++j)
    for (std::int32_t i = 0; i < 31; ++i) {
      // Breakpoints fall on grid points and the slopes are 1:1, so heights are exact up to
      // the rounding of one interpolation (1e-12 m).
      const auto& p = t.mesh.vertices[t.grid->index(i, j)];
      EXPECT_EQ(p.x(), 2.0 * i);
      EXPECT_EQ(p.y(), 2.0 * j);
      EXPECT_NEAR(p.z(), bench_z(2.0 * i), 1e-12) << i << ", " << j;
    }
  EXPECT_EQ(t.mesh.vertices[t.grid->index(3, 5)].z(), 24.0);   // first bench, x = 6 m
  EXPECT_EQ(t.mesh.vertices[t.grid->index(18, 0)].z(), 0.0);   // toe, x = 36 m
  // Alternating diagonals: a checkerboard.
  for (std::size_t c = 0; c < t.cell_diagonal.size(); ++c)
    EXPECT_EQ(t.cell_diagonal[c], ((c % 30) + (c / 30)) % 2) << c;
  EXPECT_EQ(t.roughness.sigma, 0.2);  // S2: R = 1/4 → σ = 0.8 R m
  EXPECT_EQ(info.roughness_index, 0.25);
  EXPECT_EQ(t.roughness.seed, 1u);
  ASSERT_EQ(t.materials.size(), 1u);
  EXPECT_EQ(t.materials[0].name, "slope");
  EXPECT_EQ(t.name, "bench-slope");
  EXPECT_EQ(info.provenance.tool, "terrain-gen");
  EXPECT_NE(info.provenance.settings_yaml.find("roughness_index: 0.25"), std::string::npos);
  EXPECT_NE(read_text(dir_ / "bench.xmf").find(">bench.h5:/trn/vertices<"), std::string::npos);
}

TEST_F(TerrainGen, TwoRunsGiveByteIdenticalFiles) {
  fs::create_directories(dir_ / "a");
  fs::create_directories(dir_ / "b");
  // The same command line (it is recorded) in two directories.
  const std::vector<std::string> args = {"-c", kSample, "--set", "triangulation=random", "-o", "t.h5"};
  ASSERT_EQ(run(args, dir_ / "a").code, 0);
  ASSERT_EQ(run(args, dir_ / "b").code, 0);
  const std::string a = read_text(dir_ / "a" / "t.h5");
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, read_text(dir_ / "b" / "t.h5"));
  EXPECT_EQ(read_text(dir_ / "a" / "t.xmf"), read_text(dir_ / "b" / "t.xmf"));
}

TEST_F(TerrainGen, PrintedConfigReadsBackToTheSameTerrain) {
  const Outcome printed = run({"-c", kSample, "--set", "seed=9", "--print-config"});
  ASSERT_EQ(printed.code, 0) << printed.err;
  write_text(dir_ / "printed.yaml", printed.out);
  ASSERT_EQ(run({"-c", kSample, "--set", "seed=9", "-o", "first.h5"}).code, 0);
  const Outcome again = run({"-c", "printed.yaml", "-o", "second.h5"});
  ASSERT_EQ(again.code, 0) << again.err;
  io::TerrainFileInfo i1, i2;
  const terrain::Terrain a = io::read_terrain_file((dir_ / "first.h5").string(), i1);
  const terrain::Terrain b = io::read_terrain_file((dir_ / "second.h5").string(), i2);
  // Everything but the recorded command line is the same.
  EXPECT_EQ(i1.provenance.settings_yaml, i2.provenance.settings_yaml);
  EXPECT_EQ(a.mesh.vertices, b.mesh.vertices);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  EXPECT_EQ(a.cell_diagonal, b.cell_diagonal);
  EXPECT_EQ(a.roughness.sigma, b.roughness.sigma);
  EXPECT_EQ(a.roughness.seed, 9u);
  EXPECT_EQ(b.roughness.seed, 9u);
  EXPECT_EQ(a.materials[0].name, b.materials[0].name);
  EXPECT_EQ(i1.roughness_index, i2.roughness_index);
}

TEST_F(TerrainGen, RoughnessLevelsAndTriangulationsBySet) {
  ASSERT_EQ(run({"-c", kSample, "--set", "roughness.roughness_index=0.125", "-o", "s1.h5"}).code, 0);
  EXPECT_EQ(io::read_terrain_file((dir_ / "s1.h5").string()).roughness.sigma, 0.1);
  ASSERT_EQ(run({"-c", kSample, "--set", "roughness.roughness_index=0.5", "-o", "s3.h5"}).code, 0);
  EXPECT_EQ(io::read_terrain_file((dir_ / "s3.h5").string()).roughness.sigma, 0.4);
  ASSERT_EQ(run({"-c", kSample, "--set", "triangulation=fixed", "-o", "fixed.h5"}).code, 0);
  const auto fixed = io::read_terrain_file((dir_ / "fixed.h5").string()).cell_diagonal;
  EXPECT_TRUE(std::all_of(fixed.begin(), fixed.end(), [](std::uint8_t d) { return d == 0; }));
  ASSERT_EQ(run({"-c", kSample, "--set", "triangulation=random", "-o", "random.h5"}).code, 0);
  const auto random = io::read_terrain_file((dir_ / "random.h5").string()).cell_diagonal;
  const auto ones = std::count(random.begin(), random.end(), 1);
  // 600 fair coin flips: 300 ± 5 standard deviations (61).
  EXPECT_GT(ones, 239);
  EXPECT_LT(ones, 361);
}

TEST_F(TerrainGen, SummaryAndMeshExportWithoutTerrainFile) {
  const Outcome r = run({"-c", kSample, "--summary", "--export-mesh", "r2.obj", "--realization", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("points: 651 (31 x 21), triangles: 1200"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("roughness: sigma 0.2 m (R = 0.25), seed 1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("z [0, 30] m"), std::string::npos) << r.out;
  EXPECT_EQ(files(), (std::vector<std::string>{"r2.obj"}));
  // The exported realization is realization 2 of the terrain the file would hold.
  ASSERT_EQ(run({"-c", kSample, "-o", "t.h5"}).code, 0);
  const terrain::Terrain t = io::read_terrain_file((dir_ / "t.h5").string());
  const terrain::Surface s = terrain::Surface::realize(t, 2u);
  std::ifstream obj(dir_ / "r2.obj");
  std::string tag;
  double x = 0, y = 0, z = 0;
  std::size_t v = 0, f = 0;
  std::string line;
  while (std::getline(obj, line)) {
    if (line.rfind("v ", 0) == 0) {
      std::sscanf(line.c_str(), "v %lf %lf %lf", &x, &y, &z);
      EXPECT_EQ(geometry::Vec3(x, y, z), s.vertex(v)) << v;  // %.17g round-trips exactly
      ++v;
    } else if (line.rfind("f ", 0) == 0) {
      ++f;
    }
  }
  EXPECT_EQ(v, 651u);
  EXPECT_EQ(f, 1200u);
  EXPECT_GT(std::abs(s.vertex(100).z() - t.mesh.vertices[100].z()), 0.0);  // rough, not the base

  // An existing terrain file is inspected the same way: same summary, same realization.
  const Outcome again = run({"t.h5", "--summary", "--export-mesh", "again.obj", "--realization", "2"});
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(again.out.substr(again.out.find('\n')), r.out.substr(r.out.find('\n')));
  EXPECT_NE(again.out.find("(grid TRN, from terrain file)"), std::string::npos) << again.out;
  EXPECT_EQ(read_text(dir_ / "again.obj"), read_text(dir_ / "r2.obj"));
  expect_error(run({"t.h5", "-o", "copy.h5"}), 2, "a terrain file input is only inspected", "copy.h5");
  // A block file given for a terrain is named as such, -o or not.
  const block::Block cube = block::make_block("cube", block::make_solid(block::SolidSpec{}, "cube"), 2650.0, "cube");
  io::write_block_file((dir_ / "lib.h5").string(), {cube}, io::Provenance{});
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"lib.h5", "-o", "copy.h5"}, std::vector<std::string>{"lib.h5", "--summary"}})
    expect_error(run(args), 3, "lib.h5: is a Talus block file, expected a terrain file", "copy.h5");
}

TEST_F(TerrainGen, DemWithNodataBorderZonesAndAutomaticOriginShift) {
  // Projected coordinates: the automatic shift subtracts the corner rounded to 1 km.
  write_text(dir_ / "dem.asc",
             "ncols 5\nnrows 4\nxllcorner 600010\nyllcorner 5100020\ncellsize 10\nNODATA_value -9999\n"
             "-9999 -9999 -9999 -9999 -9999\n"
             "100 90 80 70 -9999\n"
             "101 91 81 71 -9999\n"
             "102 92 82 72 -9999\n");
  write_text(dir_ / "t.yaml",
             "materials:\n"
             "  - {name: rock}\n"
             "  - {name: scree, restitution_mean: 0.7}\n"
             "zones:\n"
             "  - material: scree\n"
             "    polygon: [[600030, 5100000], [600100, 5100000], [600100, 5100100], [600030, 5100100]]\n");
  const Outcome r = run({"-c", "t.yaml", "dem.asc", "-o", "dem.h5", "--summary"});
  ASSERT_EQ(r.code, 0) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "dem.h5").string());
  EXPECT_EQ(t.origin_shift, geometry::Vec3(600000, 5100000, 0));
  ASSERT_TRUE(t.grid.has_value());
  EXPECT_EQ(t.grid->nx, 4);  // NODATA column and row trimmed
  EXPECT_EQ(t.grid->ny, 3);
  EXPECT_EQ(t.grid->x0, 15.0);  // cell centre 600015 minus 600000
  EXPECT_EQ(t.grid->y0, 25.0);
  EXPECT_EQ(t.mesh.vertices[t.grid->index(0, 0)].z(), 102.0);
  EXPECT_EQ(t.name, "dem");
  ASSERT_EQ(t.materials.size(), 2u);
  EXPECT_EQ(t.materials[1].restitution_mean, 0.7);
  // Cells with centroids east of x = 600030 (local 30) are scree: the last column of cells.
  for (std::size_t k = 0; k < t.mesh.triangles.size(); ++k) {
    double cx = 0;
    for (auto v : t.mesh.triangles[k]) cx += t.mesh.vertices[v].x() / 3.0;
    EXPECT_EQ(t.material_of_triangle[k], cx > 30.0 ? 1 : 0) << k;
  }
  EXPECT_NE(r.out.find("origin shift: [600000, 5100000, 0] m"), std::string::npos) << r.out;

  // Crop in input coordinates.
  ASSERT_EQ(run({"dem.asc", "--set", "crop.xmax=600040", "-o", "crop.h5"}).code, 0);
  EXPECT_EQ(io::read_terrain_file((dir_ / "crop.h5").string()).grid->nx, 3);
}

TEST_F(TerrainGen, GeoTiffInputMatchesTheSameGridAsAscii) {
  terrain::DemGrid dem;
  dem.spec = {0.5, 0.5, 1.0, 1.0, 6, 4};
  for (std::size_t k = 0; k < 24; ++k) dem.z.push_back(10.0 - 0.25 * static_cast<double>(k % 6));
  io::write_geotiff((dir_ / "dem.tif").string(), dem);
  io::write_esri_ascii((dir_ / "dem.asc").string(), dem);
  ASSERT_EQ(run({"dem.tif", "-o", "tif.h5"}).code, 0);
  ASSERT_EQ(run({"dem.asc", "-o", "asc.h5"}).code, 0);
  const terrain::Terrain a = io::read_terrain_file((dir_ / "tif.h5").string());
  const terrain::Terrain b = io::read_terrain_file((dir_ / "asc.h5").string());
  EXPECT_EQ(a.mesh.vertices, b.mesh.vertices);  // pixel-edge arithmetic is exact for these values
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

// The CRS comes from the GeoTIFF, from the .prj beside an .asc or from the setting, is
// stored in the terrain file and printed by --summary; degrees and feet are refused.
TEST_F(TerrainGen, CoordinateReferenceSystemIsReadStoredAndChecked) {
  terrain::DemGrid dem;
  dem.spec = {350002.5, 5100002.5, 5.0, 5.0, 6, 4};
  for (std::size_t k = 0; k < 24; ++k) dem.z.push_back(800.0 - 2.0 * static_cast<double>(k % 6));
  io::write_geotiff((dir_ / "utm.tif").string(), dem, -9999.0, io::resolve_crs("EPSG:32632", "test"));
  const Outcome tif = run({"utm.tif", "-o", "tif.h5", "--summary"});
  ASSERT_EQ(tif.code, 0) << tif.err;
  EXPECT_NE(tif.out.find("CRS: WGS 84 / UTM zone 32N (EPSG:32632)"), std::string::npos) << tif.out;
  EXPECT_EQ(io::crs_name(io::read_terrain_file((dir_ / "tif.h5").string()).crs_wkt),
            "WGS 84 / UTM zone 32N (EPSG:32632)");

  // An .asc with its .prj (ESRI WKT, as GIS software writes it), and without.
  io::write_esri_ascii((dir_ / "utm.asc").string(), dem);
  ASSERT_EQ(run({"utm.asc", "-o", "bare.h5"}).code, 0);
  EXPECT_EQ(io::read_terrain_file((dir_ / "bare.h5").string()).crs_wkt, "");
  io::write_prj((dir_ / "utm.prj").string(), io::resolve_crs("EPSG:32632", "test"));
  ASSERT_EQ(run({"utm.asc", "-o", "asc.h5"}).code, 0);
  EXPECT_EQ(io::crs_name(io::read_terrain_file((dir_ / "asc.h5").string()).crs_wkt),
            "WGS 84 / UTM zone 32N (EPSG:32632)");
  // The setting wins over the file's own.
  ASSERT_EQ(run({"utm.asc", "--set", "crs=EPSG:25832", "-o", "set.h5"}).code, 0);
  EXPECT_EQ(io::crs_name(io::read_terrain_file((dir_ / "set.h5").string()).crs_wkt),
            "ETRS89 / UTM zone 32N (EPSG:25832)");
  // The same grid with or without a CRS: the geometry does not change.
  EXPECT_EQ(io::read_terrain_file((dir_ / "set.h5").string()).mesh.vertices,
            io::read_terrain_file((dir_ / "bare.h5").string()).mesh.vertices);

  fs::remove(dir_ / "utm.prj");
  expect_error(run({"utm.asc", "--set", "crs=EPSG:4326", "-o", "out.h5"}), 3, "gdalwarp -t_srs");
  expect_error(run({"utm.asc", "--set", "crs=EPSG:2263", "-o", "out.h5"}), 3, "units of 0.3048");
  // A value given by --set is named by its key.
  expect_error(run({"utm.asc", "--set", "crs=EPSG:4326", "-o", "out.h5"}), 3, "--set crs: CRS WGS 84 (EPSG:4326)");
  expect_error(run({"utm.asc", "--set", "crs=EPSG:999999", "-o", "out.h5"}), 3, "not a coordinate reference system");
  write_text(dir_ / "utm.prj", "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,"
                               "298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]\n");
  expect_error(run({"utm.asc", "-o", "out.h5"}), 3, "utm.prj: CRS");
}

TEST_F(TerrainGen, MaterialRasterAssignsIdsByNearestCell) {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 5, 3};
  dem.z.assign(15, 5.0);
  io::write_esri_ascii((dir_ / "flat.asc").string(), dem);
  terrain::DemGrid ids;
  ids.spec = {0.5, 0.5, 1.0, 1.0, 4, 2};  // one id per DEM cell, at its centre
  ids.z = {0, 0, 1, 1, 0, 0, 1, 1};
  io::write_esri_ascii((dir_ / "ids.asc").string(), ids);
  const Outcome r = run({"flat.asc", "--set", "materials=[{name: a}, {name: b}]", "--set", "material_raster=ids.asc",
                     "-o", "m.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "m.h5").string());
  for (std::size_t k = 0; k < t.mesh.triangles.size(); ++k) {
    const std::size_t cell = k / 2;
    EXPECT_EQ(t.material_of_triangle[k], cell % 4 >= 2 ? 1 : 0) << k;
  }
  // An id outside the materials is bad input, named by the raster.
  const Outcome bad = run({"flat.asc", "--set", "material_raster=ids.asc", "-o", "bad.h5"});
  EXPECT_EQ(bad.code, 3);
  EXPECT_NE(bad.err.find("ids.asc: material id 1"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "bad.h5"));

  // In projected coordinates (the terrain shifted to a local frame), the raster point is
  // named in the raster's own coordinates.
  dem.spec.x0 = 2600000.0;
  dem.spec.y0 = 1200000.0;
  io::write_esri_ascii((dir_ / "far.asc").string(), dem);
  ids.spec.x0 = 2600000.5;
  ids.spec.y0 = 1200000.5;
  io::write_esri_ascii((dir_ / "far-ids.asc").string(), ids);
  const Outcome far = run({"far.asc", "--set", "material_raster=far-ids.asc", "-o", "far.h5"});
  EXPECT_EQ(far.code, 3);
  EXPECT_NE(far.err.find("far-ids.asc: material id 1 at raster point (i=2, j=0) at (x=2600002.5, y=1200000.5)"),
            std::string::npos)
      << far.err;
}

TEST_F(TerrainGen, ZoneFileGivesEachPolygonTheMaterialItNames) {
  // A 10 × 10 m flat DEM in LV95 (1 m cells) and two zones drawn in a GIS: a scree square
  // of 8 m with a 4 m hole, then a rock square that overlaps it (the later feature wins).
  terrain::DemGrid dem;
  dem.spec = {2600000.5, 1200000.5, 1.0, 1.0, 11, 11};
  dem.z.assign(121, 500.0);
  io::write_esri_ascii((dir_ / "flat.asc").string(), dem);
  const std::string crs = R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::2056"}})";
  const auto square = [](double x0, double y0, double size) {
    const auto at = [](double x, double y) { return "[" + std::to_string(x) + ", " + std::to_string(y) + "]"; };
    return "[" + at(x0, y0) + ", " + at(x0 + size, y0) + ", " + at(x0 + size, y0 + size) + ", " + at(x0, y0 + size) +
           ", " + at(x0, y0) + "]";
  };
  const auto zones = [&](const std::string& first_material, const std::string& collection_crs) {
    return R"({"type": "FeatureCollection", )" + collection_crs + R"(, "features": [
      {"type": "Feature", "properties": {"kind": ")" + first_material + R"("}, "geometry": {"type": "Polygon",
        "coordinates": [)" + square(2600001.5, 1200001.5, 8) + ", " + square(2600003.5, 1200003.5, 4) + R"(]}},
      {"type": "Feature", "properties": {"kind": "rock"}, "geometry": {"type": "MultiPolygon",
        "coordinates": [[)" + square(2600007.5, 1200007.5, 3) + R"(]]}}]})";
  };
  write_text(dir_ / "zones.geojson", zones("scree", crs));
  write_text(dir_ / "t.yaml",
             "crs: EPSG:2056\nmaterials: [{name: talus}, {name: scree}, {name: rock}]\n"
             "zone_file: {file: zones.geojson, material_field: kind}\n");
  const Outcome r = run({"flat.asc", "-c", "t.yaml", "-o", "z.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "z.h5").string());
  const auto inside = [](double x, double y, double x0, double y0, double size) {
    return x > x0 && x < x0 + size && y > y0 && y < y0 + size;
  };
  int counted[3] = {0, 0, 0};
  for (std::size_t k = 0; k < t.mesh.triangles.size(); ++k) {
    geometry::Vec3 c = geometry::Vec3::Zero();
    for (auto v : t.mesh.triangles[k]) c += t.mesh.vertices[v] / 3.0;
    const double x = c.x() + t.origin_shift.x() - 2600000.0, y = c.y() + t.origin_shift.y() - 1200000.0;
    const int expected = inside(x, y, 7.5, 7.5, 3)                                       ? 2
                         : inside(x, y, 1.5, 1.5, 8) && !inside(x, y, 3.5, 3.5, 4) ? 1
                                                                                     : 0;
    EXPECT_EQ(t.material_of_triangle[k], expected) << x << " " << y;
    ++counted[expected];
  }
  EXPECT_GT(counted[0], 0);
  EXPECT_GT(counted[1], 0);
  EXPECT_GT(counted[2], 0);

  // A material the terrain does not have, and a layer in another CRS, are refused naming
  // the file.
  write_text(dir_ / "ice.geojson", zones("ice", crs));
  expect_error(run({"flat.asc", "-c", "t.yaml", "--set", "zone_file.file=ice.geojson", "-o", "out.h5"}), 3,
               "ice.geojson: feature 0: material 'ice' (field 'kind') is not one of the materials (talus, scree, rock)");
  write_text(dir_ / "wgs.geojson",
             zones("scree", R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}})"));
  expect_error(run({"flat.asc", "-c", "t.yaml", "--set", "zone_file.file=wgs.geojson", "-o", "out.h5"}), 3,
               "wgs.geojson");
}

TEST_F(TerrainGen, SurveyedTinYUpOneFilePerMaterial) {
  // y-up OBJ files (as meshing tools write them): a ground strip and a vertical wall.
  write_text(dir_ / "ground.obj", "v 0 0 0\nv 10 0 0\nv 10 0 -4\nv 0 0 -4\nf 1 2 3\nf 1 3 4\n");
  write_text(dir_ / "wall.obj", "v 10 0 0\nv 10 5 0\nv 10 5 -4\nv 10 0 -4\nf 1 3 2\nf 1 4 3\n");
  write_text(dir_ / "t.yaml",
             "tin: {up_axis: y}\n"
             "materials:\n"
             "  - {name: wall, restitution_mean: 0.5}\n");
  const Outcome r = run({"-c", "t.yaml", "ground.obj", "wall.obj", "-o", "tin.h5", "--summary"});
  ASSERT_EQ(r.code, 0) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "tin.h5").string());
  EXPECT_FALSE(t.grid.has_value());
  EXPECT_EQ(t.mesh.triangles.size(), 4u);
  ASSERT_EQ(t.materials.size(), 2u);
  EXPECT_EQ(t.materials[0].name, "ground");
  EXPECT_EQ(t.materials[0].restitution_mean, 0.95);  // no entry named 'ground': defaults
  EXPECT_EQ(t.materials[1].name, "wall");
  EXPECT_EQ(t.materials[1].restitution_mean, 0.5);
  // y-up → z-up: the ground lies at z = 0 spanning y in [0, 4]; the wall rises to z = 5.
  const geometry::Aabb box = t.mesh.bounds();
  EXPECT_EQ(box.lo, geometry::Vec3(0, 0, 0));
  EXPECT_EQ(box.hi, geometry::Vec3(10, 4, 5));
  EXPECT_EQ(t.material_of_triangle, (std::vector<std::int32_t>{0, 0, 1, 1}));
  EXPECT_NE(r.out.find("walls and overhangs: 2 triangles steeper than 80 degrees, 0 of them facing down"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("TIN, from tin"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("up_axis"), std::string::npos) << r.err;  // upright: nothing to say

  // Read z-up, the ground strip stands on its side: all of it is wall, and terrain-gen
  // says which setting would stand it up.
  const Outcome side = run({"ground.obj", "-o", "side.h5"});
  ASSERT_EQ(side.code, 0) << side.err;
  EXPECT_NE(side.err.find("ground.obj: 100 % of the surface is steeper than 80 degrees (tin.up_axis is z"),
            std::string::npos)
      << side.err;
  // A y-up survey in projected coordinates read z-up has a northing for elevation.
  write_text(dir_ / "survey.obj", "v 2600000 700 -1200000\nv 2600010 700 -1200000\nv 2600010 701 -1200004\nf 1 2 3\n");
  const Outcome far = run({"survey.obj", "-o", "far.h5"});
  ASSERT_EQ(far.code, 0) << far.err;
  EXPECT_NE(far.err.find("survey.obj: elevations from -1200004 to -1200000 m are no terrain's (tin.up_axis is z; "
                         "meshing tools often write y up: set tin.up_axis: y"),
            std::string::npos)
      << far.err;

  // Resampled to a 1 m grid, the ground keeps its material.
  const Outcome g = run({"ground.obj", "--set", "tin.up_axis=y", "--set", "tin.mode=resample", "-o", "grid.h5"});
  ASSERT_EQ(g.code, 0) << g.err;
  const terrain::Terrain grid = io::read_terrain_file((dir_ / "grid.h5").string());
  ASSERT_TRUE(grid.grid.has_value());
  EXPECT_EQ(grid.grid->nx, 11);
  EXPECT_EQ(grid.grid->ny, 5);
}

// A TIN whose footprint is not a rectangle (an L: the quadrant x > 5, y > 5 of a 10 m
// square is missing) resamples to a TIN of the grid triangles over it: nothing is made up
// over the missing quadrant beyond the cells cut by its border.
TEST_F(TerrainGen, TinOfIrregularFootprintResamplesInsideIt) {
  std::string obj;
  for (int j = 0; j <= 2; ++j)
    for (int i = 0; i <= 2; ++i)
      obj += "v " + std::to_string(5 * i) + " " + std::to_string(5 * j) + " " + std::to_string(0.1 * 5 * i + 0.05 * 5 * j) + "\n";
  // Vertex (i, j) is 1 + i + 3j; squares (0,0), (1,0), (0,1) of 5 m.
  for (const auto& [i, j] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {0, 1}}) {
    const int a = 1 + i + 3 * j, b = a + 1, c = a + 4, d = a + 3;
    obj += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(c) + "\n";
    obj += "f " + std::to_string(a) + " " + std::to_string(c) + " " + std::to_string(d) + "\n";
  }
  write_text(dir_ / "ell.obj", obj);
  const Outcome r = run({"ell.obj", "--set", "tin.mode=resample", "--set", "tin.cell_size=1", "-o", "ell.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("footprint is not a rectangle: 25 of 121 grid points lie off it"), std::string::npos) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "ell.h5").string());
  EXPECT_FALSE(t.grid.has_value());
  // 75 whole cells (150 triangles), and of the one cell at the missing quadrant's corner
  // with three corners on the TIN, the triangle of those corners if the cut gives it.
  EXPECT_GE(t.mesh.triangles.size(), 150u);
  EXPECT_LE(t.mesh.triangles.size(), 151u);
  EXPECT_EQ(t.mesh.vertices.size(), 121u - 25u);
  double area = 0.0;
  for (const auto& tri : t.mesh.triangles) {
    const auto& a = t.mesh.vertices[tri[0]];
    const auto& b = t.mesh.vertices[tri[1]];
    const auto& c = t.mesh.vertices[tri[2]];
    area += 0.5 * ((b - a).cross(c - a)).z();
  }
  EXPECT_GE(area, 75.0 - 1e-9);
  EXPECT_LE(area, 75.5 + 1e-9);
  // Grid points, on the surveyed plane.
  for (const auto& v : t.mesh.vertices) {
    const double x = v.x() + t.origin_shift.x(), y = v.y() + t.origin_shift.y(), z = v.z() + t.origin_shift.z();
    EXPECT_EQ(x, std::round(x));
    EXPECT_EQ(y, std::round(y));
    EXPECT_NEAR(z, 0.1 * x + 0.05 * y, 1e-12);
    EXPECT_FALSE(x > 5.0 && y > 5.0) << x << " " << y;
  }
}

TEST_F(TerrainGen, PointCloudIsTriangulated) {
  write_text(dir_ / "cloud.xyz", "# x y z\n0 0 1\n4,0,2\n4 3 3 255 0 0\n0 3 4\n\n2 1.5 2.5\n");
  const Outcome r = run({"cloud.xyz", "-o", "cloud.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "cloud.h5").string());
  EXPECT_FALSE(t.grid.has_value());
  EXPECT_EQ(t.mesh.vertices.size(), 5u);
  EXPECT_EQ(t.mesh.triangles.size(), 4u);  // a centre point in a rectangle: 4 triangles
  write_text(dir_ / "bad.xyz", "0 0 1\n1 x 2\n");
  const Outcome bad = run({"bad.xyz", "-o", "bad.h5"});
  expect_error(bad, 3, "bad.xyz: line 2: expected x y z numbers", "bad.h5");
}

// A LAS 1.4 survey (format 6) in CH1903+/LV95: a 5 x 4 grid of ground returns (class 2)
// on a plane falling east, and three returns of vegetation (class 5) 15 m above it. With
// tin.las_classes [2] the TIN is the ground's alone; the WKT record gives the CRS.
TEST_F(TerrainGen, LasPointCloudBuildsTheGroundTin) {
  testing::LasTestFile f;
  f.minor = 4;
  f.format = 6;
  f.scale = {0.01, 0.01, 0.01};
  f.offset = {2601000.0, 1180000.0, 0.0};
  for (std::int32_t j = 0; j < 4; ++j)
    for (std::int32_t i = 0; i < 5; ++i) f.points.push_back({250 + 100 * i, 330 + 100 * j, 90000 - 50 * i, 2});
  for (std::int32_t k = 0; k < 3; ++k) f.points.push_back({300 + 100 * k, 380 + 100 * k, 91500 - 50 * k, 5});
  const std::string wkt = io::resolve_crs("EPSG:2056", "test");
  f.records = {{"LASF_Projection", 2112, wkt + std::string(1, '\0'), true}};
  write_text(dir_ / "survey.las", testing::las_bytes(f));

  const Outcome r = run({"survey.las", "--set", "tin.las_classes=[2]", "-o", "ground.h5", "--summary"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("CRS: " + io::crs_name(wkt)), std::string::npos) << r.out;
  io::TerrainFileInfo info;
  const terrain::Terrain t = io::read_terrain_file((dir_ / "ground.h5").string(), info);
  EXPECT_FALSE(t.grid.has_value());
  EXPECT_EQ(t.name, "survey");
  EXPECT_EQ(io::crs_name(t.crs_wkt), io::crs_name(wkt));
  // Projected coordinates: shifted by the lower-left corner rounded down to 1 km.
  EXPECT_EQ(t.origin_shift, geometry::Vec3(2601000, 1180000, 0));
  ASSERT_EQ(t.mesh.vertices.size(), 20u);
  EXPECT_EQ(t.mesh.triangles.size(), 24u);  // 4 x 3 cells, two triangles each
  for (const auto& v : t.mesh.vertices) {
    // Ground points only: x = 2.5 .. 6.5 m, z = 900 − 0.5 (x − 2.5) m.
    EXPECT_NEAR(v.z(), 900.0 - 0.5 * (v.x() - 2.5), 1e-9) << v.transpose();
    EXPECT_GE(v.x(), 2.5 - 1e-9);
    EXPECT_LE(v.x(), 6.5 + 1e-9);
  }
  EXPECT_NE(info.provenance.settings_yaml.find("las_classes: [2]"), std::string::npos)
      << info.provenance.settings_yaml;

  // Every class: the vegetation returns are vertices too.
  ASSERT_EQ(run({"survey.las", "-o", "all.h5"}).code, 0);
  EXPECT_EQ(io::read_terrain_file((dir_ / "all.h5").string()).mesh.vertices.size(), 23u);

  // Errors: one line, exit 3, nothing written.
  expect_error(run({"survey.las", "--set", "tin.las_classes=[9]", "-o", "out.h5"}), 3,
               "survey.las: no point of class 9 among its 23 points; its classes: 2 (20 points), 5 (3 points)");
  expect_error(
      run({"survey.las", "--set", "tin.las_classes=[2.5]", "-o", "out.h5"}), 3,
      "error: --set tin.las_classes: tin.las_classes: 2.5 is not a LAS classification code (an integer from 0 to "
      "255)");
  write_text(dir_ / "survey.laz", testing::las_bytes(f));
  expect_error(run({"survey.laz", "-o", "out.h5"}), 3,
               "survey.laz: LAZ is compressed LAS, which Talus does not read: decompress it first, e.g. las2las -i "
               "in.laz -o out.las (LAStools) or pdal translate in.laz out.las (PDAL)");
  fs::remove(dir_ / "survey.laz");
  std::string cut = testing::las_bytes(f);
  cut.resize(375 + 30 * 22 + 10);  // 22 whole records and a piece of the 23rd
  write_text(dir_ / "cut.las", cut);
  expect_error(run({"cut.las", "-o", "out.h5"}), 3,
               "cut.las: truncated LAS file: the header declares 23 points of 30 bytes from byte 375, the file holds 22");
  fs::remove(dir_ / "cut.las");
  // A cloud in degrees (GeoTIFF keys of WGS 84) is refused with the command that reprojects it.
  testing::LasTestFile degrees = f;
  degrees.records = {{"LASF_Projection", 34735, testing::geokey_directory({{1024, 2}, {2048, 4326}}), false}};
  write_text(dir_ / "degrees.las", testing::las_bytes(degrees));
  expect_error(run({"degrees.las", "-o", "out.h5"}), 3,
               "degrees.las: CRS WGS 84 (EPSG:4326) is geographic (degrees); Talus computes in metres: reproject the "
               "point cloud to a projected CRS in metres first, e.g. pdal translate in.las out.las reprojection "
               "--filters.reprojection.out_srs=EPSG:32632");
  // The crs setting wins over the file's own.
  ASSERT_EQ(run({"degrees.las", "--set", "crs=EPSG:2056", "-o", "set.h5"}).code, 0);
  EXPECT_EQ(io::crs_name(io::read_terrain_file((dir_ / "set.h5").string()).crs_wkt), io::crs_name(wkt));
  // Two clouds in different CRSs.
  testing::LasTestFile utm = f;
  utm.records = {{"LASF_Projection", 34735, testing::geokey_directory({{1024, 1}, {3072, 32632}}), false}};
  write_text(dir_ / "utm.las", testing::las_bytes(utm));
  expect_error(run({"survey.las", "utm.las", "-o", "out.h5"}), 3, "utm.las: CRS WGS 84 / UTM zone 32N (EPSG:32632) differs from");
}

// Text clouds with a header line: PDAL's text writer output, columns in any order.
TEST_F(TerrainGen, HeadedTextCloudsAreTriangulated) {
  write_text(dir_ / "pdal.csv", "\"X\",\"Y\",\"Z\",\"Intensity\",\"Classification\"\n0,0,1,10,2\n4,0,2,10,2\n"
                                "4,3,3,10,2\n0,3,4,10,2\n2,1.5,2.5,10,2\n");
  write_text(dir_ / "zxy.txt", "Z X Y\n1 0 0\n2 4 0\n3 4 3\n4 0 3\n2.5 2 1.5\n");
  for (const std::string input : {"pdal.csv", "zxy.txt"}) {
    const std::string output = fs::path(input).stem().string() + ".h5";
    const Outcome r = run({input, "-o", output});
    ASSERT_EQ(r.code, 0) << input << ": " << r.err;
    const terrain::Terrain t = io::read_terrain_file((dir_ / output).string());
    EXPECT_EQ(t.mesh.vertices.size(), 5u) << input;
    EXPECT_EQ(t.mesh.triangles.size(), 4u) << input;
    EXPECT_EQ(t.mesh.vertices[2], geometry::Vec3(4, 3, 3)) << input;
  }
  // The class filter is for LAS files: a text cloud is read whole, with a warning.
  const Outcome warned = run({"pdal.csv", "--set", "tin.las_classes=[2]", "-o", "warned.h5"});
  ASSERT_EQ(warned.code, 0) << warned.err;
  EXPECT_NE(warned.err.find("pdal.csv: tin.las_classes selects LAS points by class; this file has no classes and "
                            "is read whole"),
            std::string::npos) << warned.err;
  write_text(dir_ / "short.csv", "\"X\",\"Y\",\"Z\"\n0,0,1\n4,0\n");
  expect_error(run({"short.csv", "-o", "out.h5"}), 3,
               "short.csv: line 3: 2 columns, expected at least 3 (the header on line 1 puts X, Y, Z in columns 1, 2, 3)");
  write_text(dir_ / "names.csv", "E,N,H\n0,0,1\n");
  expect_error(run({"names.csv", "-o", "out.h5"}), 3,
               "names.csv: line 1: expected x y z numbers or a header naming the X, Y and Z columns, got 'E,N,H'");
}

TEST_F(TerrainGen, ExampleConfigsAreValid) {
  const fs::path configs = fs::path(TALUS_SOURCE_DIR) / "configs" / "terrain";
  std::size_t count = 0;
  for (const auto& e : fs::directory_iterator(configs)) {
    const Outcome r = run({"-c", e.path().string(), "--print-config"});
    EXPECT_EQ(r.code, 0) << e.path() << ": " << r.err;
    ++count;
  }
  EXPECT_GE(count, 4u);
  // The synthetic ones build as documented.
  ASSERT_EQ(run({"-c", (configs / "plane.yaml").string(), "-o", "plane.h5"}).code, 0);
  const terrain::Terrain plane = io::read_terrain_file((dir_ / "plane.h5").string());
  EXPECT_EQ(plane.grid->nx, 41);
  EXPECT_EQ(plane.grid->ny, 11);
  // z = (40 − x) tan 30°: the top edge at 40 tan 30° = 23.094 m (to rounding).
  EXPECT_NEAR(plane.mesh.vertices[0].z(), 40.0 * std::tan(M_PI / 6.0), 1e-9);
  // R on a 1 m grid: built, with a warning that the R → σ table is for 2 m cells.
  const Outcome r = run({"-c", (configs / "plane.yaml").string(), "--set", "roughness.roughness_index=0.25",
                         "-o", "plane-r.h5"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.err.find("warning: roughness_index maps to sigma by the reference table for 2 m cells"),
            std::string::npos) << r.err;
  ASSERT_EQ(run({"-c", (configs / "profile.yaml").string(), "-o", "profile.h5"}).code, 0);
  const terrain::Terrain profile = io::read_terrain_file((dir_ / "profile.h5").string());
  EXPECT_EQ(profile.grid->nx, 51);
  EXPECT_EQ(profile.roughness.sigma, 0.2);
}

TEST_F(TerrainGen, ErrorsExitWithOneLineAndLeaveNoOutput) {
  write_text(dir_ / "typo.yaml", "seed: 3\nroughnes:\n  sigma: 0.1\n");
  expect_error(run({"-c", "typo.yaml", "-o", "out.h5"}), 3, "typo.yaml:2: unknown key 'roughnes'");
  expect_error(run({"missing.asc", "-o", "out.h5"}), 3, "missing.asc: cannot open file");
  expect_error(run({"--set", "roughness", "-o", "out.h5"}), 2, "--set expects key=value");
  expect_error(run({"-c", kSample, "-o", "no/such/dir/out.h5"}), 1, "output directory does not exist");
  expect_error(run({"-c", kSample, "--set", "roughness.sigma=0.3", "-o", "out.h5"}), 3,
               "error: --set roughness.sigma: roughness: give sigma or roughness_index, not both");
  expect_error(run({"-c", kSample, "--set", "triangulation=diagonal", "-o", "out.h5"}), 3,
               "'diagonal' is not one of: fixed, alternating, random");
  expect_error(run({"-c", kSample, "--set", "synthetic.cell_size=-1", "-o", "out.h5"}), 3, "cell_size");
  expect_error(run({"-c", kSample}), 2, "no output file given");
  expect_error(run({"terrain.png", "-o", "out.h5"}), 2, "cannot tell the kind of input 'terrain.png'");
  expect_error(run({"-c", kSample, "--realization", "1", "-o", "out.h5"}), 2, "--realization needs --export-mesh");
  write_text(dir_ / "bad.asc", "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3\n");
  expect_error(run({"bad.asc", "-o", "out.h5"}), 3, "bad.asc:8: too few values");
  fs::remove(dir_ / "bad.asc");
  write_text(dir_ / "hole.asc", "ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -1\n"
                                "1 2 3\n4 -1 6\n7 8 9\n");
  expect_error(run({"hole.asc", "-o", "out.h5"}), 3, "hole.asc");
  fs::remove(dir_ / "hole.asc");
  write_text(dir_ / "zone.yaml", "zones:\n  - {material: ice, polygon: [[0, 0], [1, 0], [1, 1]]}\n");
  expect_error(run({"-c", "zone.yaml", "-o", "out.h5"}), 3, "unknown material 'ice'");
  fs::remove(dir_ / "zone.yaml");
  fs::remove(dir_ / "typo.yaml");
}

}  // namespace
}  // namespace talus
