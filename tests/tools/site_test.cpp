// End-to-end test of a real-site study through the four tools, as a user runs it: a
// GeoTIFF DEM in a projected CRS (CH1903+/LV95), a release zone and a barrier line drawn in
// a GIS (GeoJSON), terrain-gen → block-gen → dda-run → stats; then GDAL/OGR read back
// every raster and vector output and check that each carries the DEM's CRS, that the
// rasters lie on the DEM grid (same origin, cell and size), and that coordinates
// round-trip exactly between the run file and the vector layers.
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tool_run.hpp"
#include "talus/io/raster.hpp"
#include "talus/io/run_file.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus {
namespace {

namespace fs = std::filesystem;

// The DEM: 41 × 31 points every 5 m, the first at (2 600 002.5, 1 200 002.5) in LV95, a
// 35° slope falling towards +x onto a flat run-out beyond x = 150 m.
constexpr double kX0 = 2600002.5, kY0 = 1200002.5, kCell = 5.0;
constexpr int kNx = 41, kNy = 31;

double ground(double x_local) {
  const double slope = std::tan(35.0 * M_PI / 180.0);
  return 1200.0 - slope * std::min(x_local, 150.0);
}

// The CRS of a raster as an OGR spatial reference (null if it has none).
OGRSpatialReferenceH raster_srs(GDALDatasetH ds) {
  const char* wkt = GDALGetProjectionRef(ds);
  if (wkt == nullptr || *wkt == '\0') return nullptr;
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  char* text = const_cast<char*>(wkt);
  if (OSRImportFromWkt(srs, &text) != OGRERR_NONE) {
    OSRDestroySpatialReference(srs);
    return nullptr;
  }
  return srs;
}

bool is_lv95(OGRSpatialReferenceH srs) {
  if (srs == nullptr) return false;
  OGRSpatialReferenceH lv95 = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(lv95, 2056);
  const bool same = OSRIsSame(srs, lv95) != 0;
  OSRDestroySpatialReference(lv95);
  return same;
}

class Site : public ::testing::Test {
 protected:
  void SetUp() override {
    GDALAllRegister();
    dir_ = fs::temp_directory_path() / ("talus_site_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  testing::ToolOutcome run(const std::string& tool, const std::vector<std::string>& args) {
    return testing::run_tool(testing::tool_path(tool), args, dir_);
  }
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }

  fs::path dir_;
};

TEST_F(Site, GeoTiffAndGeoJsonInputsGiveOutputsInTheDemsCrsAndGrid) {
  terrain::DemGrid dem;
  dem.spec = {kX0, kY0, kCell, kCell, kNx, kNy};
  for (int j = 0; j < kNy; ++j)
    for (int i = 0; i < kNx; ++i) dem.z.push_back(ground(i * kCell));
  io::write_geotiff((dir_ / "dem.tif").string(), dem, -9999.0, io::resolve_crs("EPSG:2056", "test"));

  // A release zone on the upper slope and a fence across the slope below it, as a GIS
  // writes them (named CRS member).
  const std::string crs = R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::2056"}})";
  write("zone.geojson", R"({"type": "FeatureCollection", )" + crs + R"(, "features": [
    {"type": "Feature", "properties": {"name": "source"}, "geometry": {"type": "Polygon", "coordinates":
      [[[2600012, 1200050], [2600030, 1200050], [2600030, 1200100], [2600012, 1200100], [2600012, 1200050]]]}}]})");
  write("fence.geojson", R"({"type": "FeatureCollection", )" + crs + R"(, "features": [
    {"type": "Feature", "properties": {"name": "fence"}, "geometry": {"type": "LineString", "coordinates":
      [[2600090.25, 1200010.5], [2600090.25, 1200140.75]]}}]})");
  write("blocks.yaml", "density: 2700\nblocks:\n  - name: cube\n    solid: cube\n    volume: 0.5\n");
  write("scene.yaml", R"(schema_version: "1.0"
terrain: terrain.h5
block_file: blocks.h5
release:
  kind: polygon
  file: zone.geojson
  height: 1.0
  clearance: lift
  orientation: random
  main_direction_deg: 0
realizations: 24
seed: 11
engine:
  trajectory_interval: 0.05
outputs:
  hazard_cell_size: 5.0
  barriers:
    - file: fence.geojson
      name_field: name
)");

  auto ok = [](const testing::ToolOutcome& o) { return o.code == 0 ? std::string() : o.err; };
  ASSERT_EQ(ok(run("terrain-gen", {"dem.tif", "-o", "terrain.h5"})), "");
  ASSERT_EQ(ok(run("block-gen", {"-c", "blocks.yaml", "-o", "blocks.h5"})), "");
  ASSERT_EQ(ok(run("dda-run", {"-c", "scene.yaml", "-o", "run.h5"})), "");
  // With a release frequency the frequency, intensity and hazard-class rasters join the
  // others, on the same grid.
  ASSERT_EQ(ok(run("stats", {"run.h5", "-o", "out", "--set", "plots=false", "--set", "release_frequencies=[0.1]"})), "");
  for (const char* layer : {"frequency_low", "frequency_medium", "frequency_high", "intensity_T30", "intensity_T100",
                            "intensity_T300", "hazard_class"})
    for (const char* ext : {".tif", ".asc"})
      EXPECT_TRUE(fs::exists(dir_ / "out" / "hazard" / ("run-" + std::string(layer) + ext))) << layer << ext;
  ASSERT_EQ(ok(run("stats", {"run.h5", "-o", "out-geojson", "--set", "plots=false", "--set", "hazard_maps=false",
                             "--set", "vector_format=geojson"})),
            "");

  const io::RunFile runfile = io::read_run_file((dir_ / "run.h5").string());
  const auto& shift = runfile.info.origin_shift;
  ASSERT_EQ(runfile.data.records.size(), 24u);

  // The barrier line came through in input coordinates exactly.
  ASSERT_EQ(runfile.info.barrier_lines.size(), 1u);
  EXPECT_EQ(runfile.info.barrier_lines[0][0][0] + shift[0], 2600090.25);
  EXPECT_EQ(runfile.info.barrier_lines[0][1][1] + shift[1], 1200140.75);
  // Every release inside the zone.
  for (const auto& r : runfile.data.records) {
    const double x = r.release_position.x() + shift[0], y = r.release_position.y() + shift[1];
    EXPECT_TRUE(x >= 2600012 && x <= 2600030 && y >= 1200050 && y <= 1200100) << x << " " << y;
  }

  // Every hazard raster: the DEM's CRS, origin, cell and size.
  GDALDatasetH dem_ds = GDALOpen((dir_ / "dem.tif").c_str(), GA_ReadOnly);
  ASSERT_NE(dem_ds, nullptr);
  std::array<double, 6> dem_gt{};
  GDALGetGeoTransform(dem_ds, dem_gt.data());
  const int dem_nx = GDALGetRasterXSize(dem_ds), dem_ny = GDALGetRasterYSize(dem_ds);
  GDALClose(dem_ds);
  // GeoTIFFs carry the CRS; ESRI ASCII grids a .prj beside them, which GDAL reads.
  int rasters = 0, ascii = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "out" / "hazard")) {
    if (entry.path().extension() != ".tif" && entry.path().extension() != ".asc") continue;
    ++(entry.path().extension() == ".tif" ? rasters : ascii);
    GDALDatasetH ds = GDALOpen(entry.path().c_str(), GA_ReadOnly);
    ASSERT_NE(ds, nullptr) << entry.path();
    std::array<double, 6> gt{};
    GDALGetGeoTransform(ds, gt.data());
    EXPECT_EQ(gt, dem_gt) << entry.path();
    EXPECT_EQ(GDALGetRasterXSize(ds), dem_nx) << entry.path();
    EXPECT_EQ(GDALGetRasterYSize(ds), dem_ny) << entry.path();
    OGRSpatialReferenceH srs = raster_srs(ds);
    EXPECT_TRUE(is_lv95(srs)) << entry.path();
    if (srs) OSRDestroySpatialReference(srs);
    GDALClose(ds);
  }
  EXPECT_GE(rasters, 8);
  EXPECT_EQ(ascii, rasters);

  // Every vector layer: the DEM's CRS; the stop points are the run's final positions in
  // input coordinates to the last bit; the crossings lie on the fence.
  GDALDatasetH vec = GDALOpenEx((dir_ / "out" / "vector" / "run.gpkg").c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
  ASSERT_NE(vec, nullptr);
  ASSERT_GE(GDALDatasetGetLayerCount(vec), 2);
  bool trajectories = false;
  for (int l = 0; l < GDALDatasetGetLayerCount(vec); ++l) {
    OGRLayerH layer = GDALDatasetGetLayer(vec, l);
    EXPECT_TRUE(is_lv95(OGR_L_GetSpatialRef(layer))) << OGR_L_GetName(layer);
    trajectories = trajectories || std::string(OGR_L_GetName(layer)) == "trajectories";
  }
  EXPECT_TRUE(trajectories);
  // The same layers as GeoJSON files, one per layer, each in the DEM's CRS.
  int geojson = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "out-geojson" / "vector")) {
    if (entry.path().extension() != ".geojson") continue;
    ++geojson;
    GDALDatasetH ds = GDALOpenEx(entry.path().c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
    ASSERT_NE(ds, nullptr) << entry.path();
    EXPECT_TRUE(is_lv95(OGR_L_GetSpatialRef(GDALDatasetGetLayer(ds, 0)))) << entry.path();
    GDALClose(ds);
  }
  EXPECT_EQ(geojson, GDALDatasetGetLayerCount(vec));
  OGRLayerH stops = GDALDatasetGetLayerByName(vec, "stop_points");
  ASSERT_NE(stops, nullptr);
  ASSERT_EQ(OGR_L_GetFeatureCount(stops, 1), 24);
  OGR_L_ResetReading(stops);
  std::size_t k = 0;
  while (OGRFeatureH f = OGR_L_GetNextFeature(stops)) {
    const auto& r = runfile.data.records.at(k++);
    OGRGeometryH g = OGR_F_GetGeometryRef(f);
    EXPECT_EQ(OGR_G_GetX(g, 0), r.final_position.x() + shift[0]);
    EXPECT_EQ(OGR_G_GetY(g, 0), r.final_position.y() + shift[1]);
    EXPECT_EQ(OGR_G_GetZ(g, 0), r.final_position.z() + shift[2]);
    OGR_F_Destroy(f);
  }
  OGRLayerH crossings = GDALDatasetGetLayerByName(vec, "barrier_crossings");
  ASSERT_NE(crossings, nullptr);
  OGR_L_ResetReading(crossings);
  int crossed = 0;
  while (OGRFeatureH f = OGR_L_GetNextFeature(crossings)) {
    ++crossed;
    EXPECT_NEAR(OGR_G_GetX(OGR_F_GetGeometryRef(f), 0), 2600090.25, 1e-6);
    OGR_F_Destroy(f);
  }
  EXPECT_GT(crossed, 0);  // a 35° slope: blocks from the zone reach the fence
  // Every first crossing goes down the slope (+x), and the fence, drawn from south to
  // north, faces downslope on its right.
  OGR_L_ResetReading(crossings);
  while (OGRFeatureH f = OGR_L_GetNextFeature(crossings)) {
    EXPECT_EQ(OGR_F_GetFieldAsInteger(f, OGR_F_GetFieldIndex(f, "direction")), 1);
    OGR_F_Destroy(f);
  }
  OGRLayerH fences = GDALDatasetGetLayerByName(vec, "barriers");
  ASSERT_NE(fences, nullptr);
  OGR_L_ResetReading(fences);
  OGRFeatureH fence = OGR_L_GetNextFeature(fences);
  ASSERT_NE(fence, nullptr);
  EXPECT_STREQ(OGR_F_GetFieldAsString(fence, OGR_F_GetFieldIndex(fence, "downslope_side")), "right");
  EXPECT_EQ(OGR_F_GetFieldAsInteger(fence, OGR_F_GetFieldIndex(fence, "crossings")), crossed);
  EXPECT_EQ(OGR_G_GetY(OGR_F_GetGeometryRef(fence), 1), 1200140.75);
  OGR_F_Destroy(fence);
  // The release zone as drawn in the GIS, in its coordinates.
  OGRLayerH zones = GDALDatasetGetLayerByName(vec, "release");
  ASSERT_NE(zones, nullptr);
  ASSERT_EQ(OGR_L_GetFeatureCount(zones, 1), 1);
  OGR_L_ResetReading(zones);
  OGRFeatureH zone = OGR_L_GetNextFeature(zones);
  ASSERT_NE(zone, nullptr);
  OGREnvelope box;
  OGR_G_GetEnvelope(OGR_F_GetGeometryRef(zone), &box);
  EXPECT_EQ(box.MinX, 2600012.0);
  EXPECT_EQ(box.MaxX, 2600030.0);
  EXPECT_EQ(box.MinY, 1200050.0);
  EXPECT_EQ(box.MaxY, 1200100.0);
  EXPECT_EQ(OGR_F_GetFieldAsDouble(zone, OGR_F_GetFieldIndex(zone, "probability")), 1.0);
  OGR_F_Destroy(zone);
  GDALClose(vec);
}

}  // namespace
}  // namespace talus
