// Vector files through GDAL/OGR (libs/io/src/vector.cpp): layers written by stats read
// back exactly with their CRS; release zones and barrier lines of scenes read from
// GeoPackage, GeoJSON and Shapefile files made here with OGR; features drawn in
// proportion to their weights, points inside their feature; one-line errors on bad files.
#include "talus/io/vector.hpp"

#include <gdal.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>

#include "../mc/mc_fixtures.hpp"
#include "../support/temp_path.hpp"
#include "talus/core/error.hpp"
#include "talus/io/raster.hpp"
#include "talus/mc/realization.hpp"

namespace talus::io {
namespace {

namespace fs = std::filesystem;

// The bench terrain of the mc tests at Swiss LV95 coordinates: features are given in
// input coordinates, the engine works in the local frame.
const Eigen::Vector2d kShift(2601000.0, 1180000.0);

terrain::Terrain lv95_terrain() {
  terrain::Terrain t = mc::testing::bench_terrain();
  t.origin_shift = geometry::Vec3(kShift.x(), kShift.y(), 0.0);
  t.crs_wkt = resolve_crs("EPSG:2056", "test");
  return t;
}

// WKT of a plan polygon ring in input coordinates from local corners.
std::string ring(std::initializer_list<std::array<double, 2>> local) {
  std::string out = "(";
  for (const auto& p : local) out += std::to_string(p[0] + kShift.x()) + " " + std::to_string(p[1] + kShift.y()) + ", ";
  const auto& first = *local.begin();
  return out + std::to_string(first[0] + kShift.x()) + " " + std::to_string(first[1] + kShift.y()) + ")";
}

std::string box(double x0, double y0, double x1, double y1) {
  return ring({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
}

std::string at(double x, double y) {
  return std::to_string(x + kShift.x()) + " " + std::to_string(y + kShift.y());
}

struct Row {
  std::string wkt;             ///< geometry; empty = none
  std::optional<double> weight;
  std::string name;
};

// Writes one layer with OGR: fields weight (real) and name (text), the CRS `epsg` (0 =
// none). The driver is "GPKG", "GeoJSON" or "ESRI Shapefile".
void write_layer(const std::string& path, const std::string& driver, const std::string& layer, int epsg,
                 const std::vector<Row>& rows, bool append = false, OGRwkbGeometryType type = wkbUnknown) {
  GDALAllRegister();
  GDALDatasetH ds = append ? GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_UPDATE, nullptr, nullptr, nullptr)
                           : GDALCreate(GDALGetDriverByName(driver.c_str()), path.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
  ASSERT_NE(ds, nullptr) << path;
  OGRSpatialReferenceH srs = nullptr;
  if (epsg) {
    srs = OSRNewSpatialReference(nullptr);
    OSRImportFromEPSG(srs, epsg);
    OSRSetAxisMappingStrategy(srs, OAMS_TRADITIONAL_GIS_ORDER);
  }
  OGRLayerH l = GDALDatasetCreateLayer(ds, layer.c_str(), srs, type, nullptr);
  ASSERT_NE(l, nullptr);
  for (auto [name, field] : {std::pair{"weight", OFTReal}, std::pair{"name", OFTString}}) {
    OGRFieldDefnH f = OGR_Fld_Create(name, field);
    OGR_L_CreateField(l, f, TRUE);
    OGR_Fld_Destroy(f);
  }
  for (const Row& row : rows) {
    OGRFeatureH f = OGR_F_Create(OGR_L_GetLayerDefn(l));
    if (row.weight) OGR_F_SetFieldDouble(f, 0, *row.weight);
    if (!row.name.empty()) OGR_F_SetFieldString(f, 1, row.name.c_str());
    if (!row.wkt.empty()) {
      OGRGeometryH g = nullptr;
      char* text = const_cast<char*>(row.wkt.c_str());
      ASSERT_EQ(OGR_G_CreateFromWkt(&text, srs, &g), OGRERR_NONE) << row.wkt;
      OGR_F_SetGeometryDirectly(f, g);
    }
    ASSERT_EQ(OGR_L_CreateFeature(l, f), OGRERR_NONE);
    OGR_F_Destroy(f);
  }
  if (srs) OSRDestroySpatialReference(srs);
  GDALClose(ds);
}

class VectorFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::temp_path("vector", ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name) const { return (fs::path(dir_) / name).string(); }

  // A scene on the LV95 bench terrain whose release comes from `path`.
  mc::SceneSettings release_scene(const std::string& path, const std::string& kind,
                                  const std::string& weight_field = {}) const {
    mc::SceneSettings s = mc::testing::bench_scene();
    s.outputs.barriers.clear();
    s.stop_zones.clear();
    s.release.points = mc::ReleaseSettings{}.points;  // the file instead
    s.release.file = path;
    s.release.kind = kind;
    s.release.weight_field = weight_field;
    return s;
  }
  static mc::Scene build(const mc::SceneSettings& s) {
    const terrain::Terrain t = lv95_terrain();
    const mc::SceneVectors v = read_scene_vectors(s, t);
    return mc::Scene::build(s, t, mc::testing::library({block::SolidKind::cube}), "scene.yaml", v);
  }
  // The message of the InputError that reading and building `s` throws ("" if none).
  static std::string error_of(const mc::SceneSettings& s) {
    try {
      build(s);
    } catch (const core::InputError& e) {
      return e.what();
    }
    return "";
  }

  std::string dir_;
};

TEST_F(VectorFiles, WrittenLayersReadBackExactlyWithTheirCrs) {
  const std::string crs = resolve_crs("EPSG:2056", "test");
  VectorLayer points{"stop_points", VectorGeometry::point_z, {{"realization", FieldType::integer},
                                                              {"energy", FieldType::real},
                                                              {"block", FieldType::text}}, {}};
  // Coordinates whose last bits matter: 2601000 + a third.
  const double x = 2601000.0 + 1.0 / 3.0, y = 1180000.0 + 0.1, z = 512.0 + 1e-9;
  points.features.push_back({{{x, y, z}}, {std::int64_t{7}, 1234.5678901234567, std::string("R1")}});
  points.features.push_back({{{NAN, 0.0, 0.0}}, {std::int64_t{8}, NAN, std::monostate{}}});  // failed: no geometry
  for (const char* format : {"gpkg", "geojson"}) {
    const std::string path = file(std::string("out.") + format);
    write_vector_file(path, format, {points}, crs);
    GDALDatasetH ds = GDALOpenEx(path.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
    ASSERT_NE(ds, nullptr);
    OGRLayerH l = GDALDatasetGetLayerByName(ds, "stop_points");
    ASSERT_NE(l, nullptr) << format;
    EXPECT_EQ(OGR_L_GetFeatureCount(l, TRUE), 2) << format;
    OGRSpatialReferenceH expected = OSRNewSpatialReference(nullptr);
    OSRImportFromEPSG(expected, 2056);
    ASSERT_NE(OGR_L_GetSpatialRef(l), nullptr) << format;
    EXPECT_TRUE(OSRIsSame(OGR_L_GetSpatialRef(l), expected)) << format;
    OSRDestroySpatialReference(expected);
    OGR_L_ResetReading(l);
    OGRFeatureH f = OGR_L_GetNextFeature(l);
    OGRGeometryH g = OGR_F_GetGeometryRef(f);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(OGR_G_GetX(g, 0), x) << format;
    EXPECT_EQ(OGR_G_GetY(g, 0), y) << format;
    EXPECT_EQ(OGR_G_GetZ(g, 0), z) << format;
    EXPECT_EQ(OGR_F_GetFieldAsInteger64(f, OGR_F_GetFieldIndex(f, "realization")), 7);
    EXPECT_EQ(OGR_F_GetFieldAsDouble(f, OGR_F_GetFieldIndex(f, "energy")), 1234.5678901234567) << format;
    EXPECT_STREQ(OGR_F_GetFieldAsString(f, OGR_F_GetFieldIndex(f, "block")), "R1");
    OGR_F_Destroy(f);
    f = OGR_L_GetNextFeature(l);
    EXPECT_EQ(OGR_F_GetGeometryRef(f), nullptr) << format;
    EXPECT_FALSE(OGR_F_IsFieldSetAndNotNull(f, OGR_F_GetFieldIndex(f, "energy"))) << format;
    OGR_F_Destroy(f);
    GDALClose(ds);
  }
  // No temporary is left beside the outputs.
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) files += entry.path().filename().string()[0] == '.' ? 100 : 1;
  EXPECT_EQ(files, 2u);
  // A terrain without a CRS gives layers in the GeoPackage's undefined Cartesian SRS
  // (metres in an unknown frame), not its undefined geographic one (degrees).
  write_vector_file(file("plain.gpkg"), "gpkg", {points}, "");
  GDALDatasetH ds = GDALOpenEx(file("plain.gpkg").c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
  ASSERT_NE(ds, nullptr);
  OGRSpatialReferenceH none = OGR_L_GetSpatialRef(GDALDatasetGetLayer(ds, 0));
  if (none) {
    EXPECT_STREQ(OSRGetName(none), "Undefined Cartesian SRS");
    EXPECT_FALSE(OSRIsGeographic(none));
  }
  GDALClose(ds);
}

// Which of the disjoint features (their parts' rings, local frame) holds `p`; -1 for none.
int feature_of(const mc::Scene& scene, const Eigen::Vector2d& p) {
  for (std::size_t k = 0; k < scene.release_features().size(); ++k)
    for (const auto& part : scene.release_features()[k].parts)
      if (mc::point_in_rings(part, p)) return static_cast<int>(k);
  return -1;
}

// Counts how often each feature is drawn over `n` realizations; every point must lie in
// one feature.
std::vector<int> draw_counts(const mc::Scene& scene, std::uint32_t n) {
  std::vector<int> count(scene.release_features().size(), 0);
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    const int k = feature_of(scene, p);
    EXPECT_GE(k, 0) << "realization " << i << " at " << p.transpose() << " is in no feature";
    if (k >= 0) ++count[static_cast<std::size_t>(k)];
  }
  return count;
}

// Each count within 4.5 binomial standard deviations of n·w/W (the draws are fixed by the
// seed, so this is a check of the method, not a flaky one: a 4.5σ miss has probability
// 7e-6 per count for a correct sampler).
void expect_binomial(const std::vector<int>& count, const std::vector<double>& weights, std::uint32_t n) {
  double total = 0.0;
  for (double w : weights) total += w;
  for (std::size_t k = 0; k < count.size(); ++k) {
    const double p = weights[k] / total;
    const double sd = std::sqrt(n * p * (1.0 - p));
    EXPECT_NEAR(count[k], n * p, 4.5 * sd) << "feature " << k << " (p = " << p << ")";
  }
}

TEST_F(VectorFiles, PolygonFeaturesAreDrawnInProportionToTheirWeights) {
  // Three disjoint polygons on the lower slope (local x 20–32): a plain box, a box with a
  // hole, and a MultiPolygon of two boxes; weights 1, 2, 5.
  const std::string path = file("zones.gpkg");
  write_layer(path, "GPKG", "release", 2056,
              {{"POLYGON (" + box(20, 2, 23, 5) + ")", 1.0, "a"},
               {"POLYGON (" + box(20, 8, 26, 14) + ", " + box(22, 10, 24, 12) + ")", 2.0, "b"},
               {"MULTIPOLYGON ((" + box(28, 2, 30, 4) + "), (" + box(28, 14, 32, 18) + "))", 5.0, "c"}});
  write_layer(path, "GPKG", "other", 2056, {{"POINT (" + at(25, 10) + ")", 1.0, "x"}}, true);
  mc::SceneSettings s = release_scene(path, "polygon", "weight");
  s.release.layer = "release";
  const mc::Scene scene = build(s);
  ASSERT_EQ(scene.release_features().size(), 3u);
  constexpr std::uint32_t n = 4000;
  const std::vector<int> count = draw_counts(scene, n);
  expect_binomial(count, {1.0, 2.0, 5.0}, n);
  // The same draws at every call (counter-based streams), none in the hole.
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 200; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    EXPECT_EQ(p, mc::draw_release(scene, ground, i).release.position.head<2>());
    EXPECT_FALSE(p.x() > 22.0 && p.x() < 24.0 && p.y() > 10.0 && p.y() < 12.0) << i << " in the hole";
  }
  // Without a weight field, by area: 9, 36 − 4 = 32 and 4 + 16 = 20 m².
  s.release.weight_field.clear();
  expect_binomial(draw_counts(build(s), n), {9.0, 32.0, 20.0}, n);
}

TEST_F(VectorFiles, ReleaseCellsOfARasterAreDrawnByDensityTimesArea) {
  // 2 m cells centred on local y = 0 and 2, x = 21, 23, 25 (LV95 as the terrain): values
  // 1, 0, 2 / NODATA, 1, 0. The first row's cells hang half off the terrain (y < 0) and are
  // cut to it: weights 1·2·1, 2·2·1 and 1·2·2 = 2, 4, 4.
  terrain::DemGrid cells;
  cells.spec = {21.0 + kShift.x(), 0.0 + kShift.y(), 2.0, 2.0, 3, 2};
  cells.z = {1.0, 0.0, 2.0, std::nan(""), 1.0, 0.0};
  const std::string path = file("release.asc");
  write_esri_ascii(path, cells);
  write_prj(file("release.prj"), resolve_crs("EPSG:2056", "test"));
  mc::SceneSettings s = release_scene(path, "polygon");
  const mc::Scene scene = build(s);
  ASSERT_EQ(scene.release_features().size(), 3u);
  constexpr std::uint32_t n = 4000;
  expect_binomial(draw_counts(scene, n), {2.0, 4.0, 4.0}, n);
  // Every release inside a cell of value > 0, on the terrain.
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 300; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    const bool first = p.y() >= 0.0 && p.y() <= 1.0 && ((p.x() >= 20.0 && p.x() <= 22.0) || (p.x() >= 24.0 && p.x() <= 26.0));
    const bool second = p.y() >= 1.0 && p.y() <= 3.0 && p.x() >= 22.0 && p.x() <= 24.0;
    EXPECT_TRUE(first || second) << p.transpose();
  }

  // Refused, naming the file: another CRS (with the command that reprojects it), a
  // negative density, another release kind, no release cell.
  write_prj(file("release.prj"), resolve_crs("EPSG:32632", "test"));
  EXPECT_NE(error_of(s).find(path + ": is in CRS WGS 84 / UTM zone 32N (EPSG:32632), not in the terrain's CRS"),
            std::string::npos)
      << error_of(s);
  EXPECT_NE(error_of(s).find("gdalwarp -t_srs EPSG:2056"), std::string::npos) << error_of(s);
  fs::remove(file("release.prj"));
  cells.z[4] = -1.0;
  write_esri_ascii(path, cells);
  EXPECT_NE(error_of(s).find(path + ": cell (i=1, j=1) at (x=2601023, y=1180002) has value -1"), std::string::npos)
      << error_of(s);
  cells.z = {0.0, 0.0, 0.0, std::nan(""), 0.0, 0.0};
  write_esri_ascii(path, cells);
  EXPECT_NE(error_of(s).find(path + ": holds no release cell"), std::string::npos) << error_of(s);
  EXPECT_NE(error_of(release_scene(path, "line")).find("set release.kind: polygon"), std::string::npos);
}

TEST_F(VectorFiles, OverlappingPartsOfAMultiPolygonAreOneZone) {
  // Two boxes of 36 m² that share 18 m² (local x 23–26): their union, 54 m², drawn with
  // uniform density, so a third of the draws fall in the shared strip (counted twice, it
  // would get half of them).
  const std::string path = file("overlap.geojson");
  write_layer(path, "GeoJSON", "overlap", 2056,
              {{"MULTIPOLYGON ((" + box(20, 2, 26, 8) + "), (" + box(23, 2, 29, 8) + "))", {}, ""},
               {"MULTIPOLYGON ((" + box(20, 12, 24, 16) + "), (" + box(24, 12, 28, 16) + "))", {}, ""}});
  const mc::Scene scene = build(release_scene(path, "polygon"));
  ASSERT_EQ(scene.release_features().size(), 2u);
  const mc::ReleaseFeature& merged = scene.release_features()[0];
  ASSERT_EQ(merged.parts.size(), 1u);
  EXPECT_NEAR(merged.part_sizes[0], 54.0, 1e-6);  // coordinates near 2.6e6 m: 1e-6 m² of round-off
  EXPECT_NEAR(merged.weight, 54.0, 1e-6);
  // Parts that only touch along an edge stay two parts (nothing is drawn twice).
  EXPECT_EQ(scene.release_features()[1].parts.size(), 2u);
  EXPECT_NEAR(scene.release_features()[1].weight, 32.0, 1e-6);
  constexpr std::uint32_t n = 4000;
  std::vector<int> count(3, 0);  // first feature: shared strip, the rest; second feature
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    if (p.y() >= 2.0 && p.y() <= 8.0 && p.x() >= 20.0 && p.x() <= 29.0)
      ++count[p.x() > 23.0 && p.x() < 26.0 ? 0 : 1];
    else if (p.y() >= 12.0 && p.y() <= 16.0 && p.x() >= 20.0 && p.x() <= 28.0)
      ++count[2];
    else
      ADD_FAILURE() << "realization " << i << " at " << p.transpose() << " is in no feature";
  }
  expect_binomial(count, {18.0, 36.0, 32.0}, n);
}

TEST_F(VectorFiles, LineAndPointFeaturesAreDrawnInProportionToTheirWeights) {
  const std::string lines = file("lines.geojson");
  write_layer(lines, "GeoJSON", "lines", 2056,
              {{"LINESTRING (" + at(20, 2) + ", " + at(20, 6) + ")", 3.0, "a"},
               {"MULTILINESTRING ((" + at(24, 2) + ", " + at(24, 4) + "), (" + at(26, 10) + ", " + at(26, 16) + "))",
                1.0, "b"}});
  constexpr std::uint32_t n = 4000;
  const auto on_lines = [](const mc::Scene& scene) {
    std::vector<int> count(2, 0);
    const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
    for (std::uint32_t i = 0; i < n; ++i) {
      const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
      if (p.x() == 20.0 && p.y() >= 2.0 && p.y() <= 6.0)
        ++count[0];
      else if ((p.x() == 24.0 && p.y() >= 2.0 && p.y() <= 4.0) || (p.x() == 26.0 && p.y() >= 10.0 && p.y() <= 16.0))
        ++count[1];
      else
        ADD_FAILURE() << "realization " << i << " at " << p.transpose() << " is on no line";
    }
    return count;
  };
  mc::SceneSettings s = release_scene(lines, "line", "weight");
  expect_binomial(on_lines(build(s)), {3.0, 1.0}, n);
  s.release.weight_field.clear();  // by length: 4 m and 2 + 6 m
  expect_binomial(on_lines(build(s)), {4.0, 8.0}, n);

  // Points from a Shapefile (of type MultiPoint): one point and three points, equal
  // weights by count.
  const std::string points = file("points.shp");
  write_layer(points, "ESRI Shapefile", "points", 2056,
              {{"MULTIPOINT ((" + at(20, 2) + "))", 1.0, "a"},
               {"MULTIPOINT ((" + at(22, 2) + "), (" + at(22, 4) + "), (" + at(22, 6) + "))", 1.0, "b"}},
              false, wkbMultiPoint);
  s = release_scene(points, "point");
  const mc::Scene scene = build(s);
  std::map<std::pair<double, double>, int> seen;
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    ++seen[{p.x(), p.y()}];
  }
  ASSERT_EQ(seen.size(), 4u);
  std::vector<int> count;
  for (const auto& [p, c] : seen) count.push_back(c);
  expect_binomial(count, {1.0, 1.0, 1.0, 1.0}, n);
}

TEST_F(VectorFiles, CurvedZonesBecomeLineSegments) {
  // A circle of radius 3 m around local (24, 10) drawn as a CurvePolygon: every point lies
  // in it, and in its 90-gon inscribed in the circle.
  const std::string path = file("circle.gpkg");
  write_layer(path, "GPKG", "circle", 2056,
              {{"CURVEPOLYGON (CIRCULARSTRING (" + at(21, 10) + ", " + at(27, 10) + ", " + at(21, 10) + "))", {}, ""}});
  const mc::Scene scene = build(release_scene(path, "polygon"));
  ASSERT_EQ(scene.release_features().size(), 1u);
  EXPECT_GE(scene.release_features()[0].parts[0][0].size(), 90u);
  const terrain::Surface ground = scene.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 200; ++i) {
    const Eigen::Vector2d p = mc::draw_release(scene, ground, i).release.position.head<2>();
    EXPECT_LE((p - Eigen::Vector2d(24.0, 10.0)).norm(), 3.0) << i;
  }
}

TEST_F(VectorFiles, OneFeatureDrawsAsTheSameInlineZone) {
  // A file holding the inline polygon of a scene gives the same release of every
  // realization, bit for bit: one feature of one part draws as the inline zone does.
  const std::string path = file("one.geojson");
  write_layer(path, "GeoJSON", "one", 2056, {{"POLYGON (" + ring({{20, 4}, {27, 5}, {25, 15}, {21, 12}}) + ")", {}, ""}});
  mc::SceneSettings inline_scene = mc::testing::bench_scene();
  // The bench scene's lines and zones are in the local frame: not this test's business.
  inline_scene.outputs.barriers.clear();
  inline_scene.stop_zones.clear();
  inline_scene.release.kind = "polygon";
  inline_scene.release.points = {{20.0 + kShift.x(), 4.0 + kShift.y()},
                                 {27.0 + kShift.x(), 5.0 + kShift.y()},
                                 {25.0 + kShift.x(), 15.0 + kShift.y()},
                                 {21.0 + kShift.x(), 12.0 + kShift.y()}};
  mc::SceneSettings file_scene = inline_scene;
  file_scene.release.points = mc::ReleaseSettings{}.points;
  file_scene.release.file = path;
  const mc::Scene a = build(inline_scene), b = build(file_scene);
  ASSERT_EQ(a.release_features()[0].parts, b.release_features()[0].parts);
  const terrain::Surface ground = a.base_surface().realization(std::nullopt);
  for (std::uint32_t i = 0; i < 100; ++i)
    EXPECT_EQ(mc::draw_release(a, ground, i).release.position, mc::draw_release(b, ground, i).release.position) << i;
}

TEST_F(VectorFiles, BarrierLinesComeFromAFile) {
  const std::string path = file("barriers.gpkg");
  write_layer(path, "GPKG", "barriers", 2056,
              {{"LINESTRING (" + at(30, 0) + ", " + at(30, 20) + ")", {}, "lower slope"},
               {"MULTILINESTRING ((" + at(36, 0) + ", " + at(36, 10) + "), (" + at(36, 10) + ", " + at(36, 20) + "))",
                {}, "toe"}});
  mc::SceneSettings s = mc::testing::bench_scene();
  for (auto& p : s.release.points) p = {p[0] + kShift.x(), p[1] + kShift.y()};
  s.stop_zones.clear();
  s.outputs.barriers = {{"", {}, path, "", "name"}};
  mc::Scene scene = build(s);
  ASSERT_EQ(scene.barriers().size(), 3u);
  EXPECT_EQ(scene.barriers()[0].name, "lower slope");
  EXPECT_EQ(scene.barriers()[0].line, (std::vector<Eigen::Vector2d>{{30.0, 0.0}, {30.0, 20.0}}));  // local frame
  EXPECT_EQ(scene.barriers()[0].offsets, (std::vector<double>{0.0, 20.0}));
  EXPECT_EQ(scene.barriers()[1].name, "toe-1");
  EXPECT_EQ(scene.barriers()[2].name, "toe-2");
  // Without a name field: the entry's name, numbered by feature.
  s.outputs.barriers = {{"fence", {}, path, "barriers", ""}};
  scene = build(s);
  EXPECT_EQ(scene.barriers()[0].name, "fence 1");
  EXPECT_EQ(scene.barriers()[2].name, "fence 2-2");
  // Names must differ: an inline barrier of the same name as a file's line is refused.
  s.outputs.barriers = {{"lower slope", {{30.0 + kShift.x(), kShift.y()}, {30.0 + kShift.x(), 20.0 + kShift.y()}}},
                        {"", {}, path, "", "name"}};
  EXPECT_NE(error_of(s).find("barrier name 'lower slope' is taken"), std::string::npos) << error_of(s);
}

TEST_F(VectorFiles, BadFilesAreRefusedWithOneLineNamingTheFile) {
  const std::string good = file("good.gpkg");
  write_layer(good, "GPKG", "release", 2056, {{"POLYGON (" + box(20, 2, 23, 5) + ")", 1.0, "a"}});
  write_layer(good, "GPKG", "lines", 2056, {{"LINESTRING (" + at(20, 2) + ", " + at(20, 6) + ")", 1.0, "a"}}, true);
  write_layer(good, "GPKG", "empty", 2056, {}, true);
  write_layer(good, "GPKG", "nogeometry", 2056, {{"", 1.0, "a"}}, true);
  write_layer(good, "GPKG", "negative", 2056,
              {{"POLYGON (" + box(20, 2, 23, 5) + ")", 1.0, "a"}, {"POLYGON (" + box(24, 2, 26, 5) + ")", -1.0, "b"}},
              true);
  write_layer(good, "GPKG", "noweight", 2056, {{"POLYGON (" + box(20, 2, 23, 5) + ")", {}, "a"}}, true);
  write_layer(good, "GPKG", "emptygeometry", 2056, {{"POLYGON EMPTY", 1.0, "a"}}, true);
  write_layer(good, "GPKG", "outside", 2056, {{"POLYGON (" + box(20, 2, 70, 5) + ")", 1.0, "a"}}, true);
  write_layer(good, "GPKG", "utm", 32632, {{"POLYGON (" + box(20, 2, 23, 5) + ")", 1.0, "a"}}, true);
  // GeoJSON written by hand in LV95 without a "crs" member: WGS 84 by RFC 7946.
  const std::string bare = file("bare.geojson");
  std::ofstream(bare) << R"({"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
    "geometry": {"type": "Polygon", "coordinates": [[[2601020, 1180002], [2601023, 1180002], [2601023, 1180005],
    [2601020, 1180002]]]}}]})";
  std::ofstream(file("junk.gpkg")) << "not a GeoPackage\n";

  const std::vector<std::tuple<std::string, std::string, std::string, std::string, std::string>> cases = {
      // file, layer, kind, weight field, expected message
      {file("missing.gpkg"), "", "polygon", "", "missing.gpkg: cannot open file (missing or not a regular file; named by release.file)"},
      {file("junk.gpkg"), "", "polygon", "", "junk.gpkg: cannot be read as a vector file"},
      {good, "", "polygon", "", "good.gpkg: holds 9 layers (release, lines, empty, nogeometry, negative, noweight, "
                                "emptygeometry, outside, utm): name one with the layer key beside release.file"},
      {good, "nowhere", "polygon", "", "good.gpkg: has no layer 'nowhere' (it has: release, lines,"},
      {good, "empty", "polygon", "", "good.gpkg: layer 'empty' holds no features"},
      {good, "nogeometry", "polygon", "", "good.gpkg: layer 'nogeometry', feature 1 has no geometry"},
      {good, "emptygeometry", "polygon", "", "good.gpkg: layer 'emptygeometry', feature 1 has an empty geometry"},
      {good, "lines", "polygon", "", "good.gpkg: layer 'lines', feature 1 is a Line String, not a Polygon or "
                                     "MultiPolygon (release.file takes Polygon or MultiPolygon features)"},
      {good, "release", "polygon", "w", "good.gpkg: layer 'release' has no field 'w' (its fields: weight, name)"},
      {good, "release", "polygon", "name", "good.gpkg: field 'name' of layer 'release' is not numeric (it holds String)"},
      {good, "negative", "polygon", "weight", "good.gpkg: layer 'negative', feature 2 has weight -1 in field 'weight': "
                                              "weights must be finite and >= 0"},
      {good, "noweight", "polygon", "weight", "good.gpkg: layer 'noweight', feature 1 has no value in the weight field 'weight'"},
      {good, "outside", "polygon", "", "good.gpkg: release feature 1: point (2601070, 1180002) is outside the terrain "
                                       "(input coordinates: x in [2601000, 2601060], y in [1180000, 1180020])"},
      {good, "utm", "polygon", "", "good.gpkg: layer 'utm' is in CRS WGS 84 / UTM zone 32N (EPSG:32632), not in the "
                                   "terrain's CRS CH1903+ / LV95 (EPSG:2056): reproject it, e.g. ogr2ogr -t_srs "
                                   "EPSG:2056 out.gpkg "},
      {bare, "", "polygon", "", "(its coordinates are not degrees: if they are in the terrain's CRS already, assign it "
                                "with ogr2ogr -a_srs EPSG:2056 out.gpkg "},
  };
  for (const auto& [path, layer, kind, weight, expected] : cases) {
    mc::SceneSettings s = release_scene(path, kind, weight);
    s.release.layer = layer;
    const std::string message = error_of(s);
    EXPECT_NE(message.find(expected), std::string::npos) << "got: " << message << "\nexpected: " << expected;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  // Points and a file together are refused; so is a layer without a file.
  mc::SceneSettings s = release_scene(good, "polygon");
  s.release.layer = "release";
  s.release.points = {{1.0, 2.0}};
  EXPECT_NE(error_of(s).find("scene.yaml: release: give release.points or release.file, not both"), std::string::npos);
  s = mc::testing::bench_scene();
  s.release.layer = "release";
  EXPECT_NE(error_of(s).find("release.layer and release.weight_field need release.file"), std::string::npos);
  // A terrain without a CRS takes a file in any CRS (nothing to compare).
  s = release_scene(good, "polygon");
  s.release.layer = "utm";
  terrain::Terrain t = lv95_terrain();
  t.crs_wkt.clear();
  EXPECT_NO_THROW(mc::Scene::build(s, t, mc::testing::library({block::SolidKind::cube}), "s", read_scene_vectors(s, t)));
  // Nor does a GeoPackage layer in its "Undefined Cartesian SRS" (as stats writes for a
  // terrain without a CRS) against a terrain with one.
  VectorLayer line{"line", VectorGeometry::line_string_z, {}, {}};
  line.features.push_back({{{20.0 + kShift.x(), 2.0 + kShift.y(), 0.0}, {20.0 + kShift.x(), 6.0 + kShift.y(), 0.0}}, {}});
  write_vector_file(file("undefined.gpkg"), "gpkg", {line}, "");
  EXPECT_EQ(error_of(release_scene(file("undefined.gpkg"), "line")), "");
}

}  // namespace
}  // namespace talus::io
