#include "talus/io/raster.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "talus/core/error.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

namespace fs = std::filesystem;

std::string temp_file(const std::string& name) {
  return talus::testing::temp_path("raster_test", name);
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = temp_file(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The message of the InputError `read` throws, or a failure note.
template <class F>
std::string input_error(F&& read) {
  try {
    read();
  } catch (const core::InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("wrong exception type: ") + e.what();
  }
  return "no error";
}

TEST(EsriAscii, ReadsCornerHeaderAsCellCentresNorthRowFirst) {
  const std::string path = write_file("corner.asc", R"(NCOLS 3
nrows 2
xllcorner 100
YLLCORNER 200
cellsize 2
nodata_value -9999
1 2 3
4 -9999 6.5
)");
  const terrain::DemGrid dem = read_esri_ascii(path);
  EXPECT_EQ(dem.spec.nx, 3);
  EXPECT_EQ(dem.spec.ny, 2);
  // Corner + half a cell is exact in binary here, so equality is the right check.
  EXPECT_EQ(dem.spec.x0, 101.0);
  EXPECT_EQ(dem.spec.y0, 201.0);
  EXPECT_EQ(dem.spec.dx, 2.0);
  EXPECT_EQ(dem.spec.dy, 2.0);
  // The first file row is the northernmost: grid row j = 1.
  EXPECT_EQ(dem.z[dem.spec.index(0, 1)], 1.0);
  EXPECT_EQ(dem.z[dem.spec.index(2, 1)], 3.0);
  EXPECT_EQ(dem.z[dem.spec.index(0, 0)], 4.0);
  EXPECT_TRUE(std::isnan(dem.z[dem.spec.index(1, 0)]));
  EXPECT_EQ(dem.z[dem.spec.index(2, 0)], 6.5);
  fs::remove(path);
}

TEST(EsriAscii, ReadsCentreHeaderDxDyAndWrappedRows) {
  // Rows need not be one per line: values are read in order whatever the layout.
  const std::string path = write_file("centre.asc",
                                      "ncols 2\r\nnrows 3\r\nxllcenter -5.5\r\nyllcenter 0\r\n"
                                      "dx 0.5\r\ndy 0.25\r\n1 2 3\r\n4\r\n5 +6e0\r\n");
  const terrain::DemGrid dem = read_esri_ascii(path);
  EXPECT_EQ(dem.spec.x0, -5.5);
  EXPECT_EQ(dem.spec.y0, 0.0);
  EXPECT_EQ(dem.spec.dx, 0.5);
  EXPECT_EQ(dem.spec.dy, 0.25);
  EXPECT_EQ(dem.z, (std::vector<double>{5, 6, 3, 4, 1, 2}));
  fs::remove(path);
}

struct MalformedCase {
  const char* name;
  const char* text;
  const char* message;  // expected after "<path>:"
};

class EsriAsciiMalformed : public ::testing::TestWithParam<MalformedCase> {};

TEST_P(EsriAsciiMalformed, IsOneLineInputErrorNamingFileAndLine) {
  const MalformedCase& c = GetParam();
  const std::string path = write_file(std::string(c.name) + ".asc", c.text);
  const std::string message = input_error([&] { read_esri_ascii(path); });
  EXPECT_EQ(message, path + ":" + c.message);
  EXPECT_EQ(message.find('\n'), std::string::npos);
  fs::remove(path);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, EsriAsciiMalformed,
    ::testing::Values(
        MalformedCase{"missing_nrows", "ncols 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n",
                      "5: missing header key nrows"},
        MalformedCase{"missing_x", "ncols 2\nnrows 1\nyllcorner 0\ncellsize 1\n1 2\n",
                      "5: missing header key xllcorner (or xllcenter)"},
        MalformedCase{"missing_cellsize", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\n1 2\n",
                      "5: missing header key cellsize (or dx and dy)"},
        MalformedCase{"dx_without_dy", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ndx 1\n1 2\n",
                      "6: missing header key dy (with dx)"},
        MalformedCase{"duplicate", "ncols 2\nnrows 1\nNCOLS 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n",
                      "3: duplicate header key 'NCOLS' (first on line 1)"},
        MalformedCase{"unknown", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncelsize 1\n1 2\n",
                      "5: unknown header key 'celsize'"},
        MalformedCase{"corner_and_centre",
                      "ncols 2\nnrows 1\nxllcorner 0\nxllcenter 0.5\nyllcorner 0\ncellsize 1\n1 2\n",
                      "4: both xllcorner and xllcenter are given"},
        MalformedCase{"cellsize_and_dx", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\ndx 1\n1 2\n",
                      "6: both cellsize and dx/dy are given"},
        MalformedCase{"header_not_number", "ncols two\nnrows 1\n", "1: header key 'ncols': 'two' is not a number"},
        MalformedCase{"header_no_value", "ncols\nnrows 1\n", "1: header key 'ncols' has no value"},
        MalformedCase{"zero_cellsize", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 0\n1 2\n",
                      "5: cellsize must be positive, got 0"},
        MalformedCase{"negative_cellsize", "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize -2\n1 2\n",
                      "5: cellsize must be positive, got -2"},
        MalformedCase{"zero_ncols", "ncols 0\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\n",
                      "1: ncols must be a positive integer, got 0"},
        MalformedCase{"fractional_nrows", "ncols 2\nnrows 1.5\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n",
                      "2: nrows must be a positive integer, got 1.5"},
        MalformedCase{"infinite_corner", "ncols 2\nnrows 1\nxllcorner inf\n", "3: header key 'xllcorner' is not finite"},
        MalformedCase{"value_not_number", "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 x4\n",
                      "7: 'x4' is not a number"},
        MalformedCase{"nan_value", "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\nnan 4\n",
                      "7: non-finite value 'nan'"},
        MalformedCase{"too_few", "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3\n",
                      "8: too few values: expected 4 (ncols 2 x nrows 2), found 3"},
        MalformedCase{"too_many", "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n5\n",
                      "8: too many values: expected 4 (ncols 2 x nrows 2), extra value '5'"},
        MalformedCase{"blank", "  \n\n", " empty file"},
        // Bytes of a binary file are shown escaped and cut, never raw.
        MalformedCase{"binary", "nc\x01\xff\xfe\x80\x81\x82\x83\x84\x85\x86\x87\x88\x89\x8a\x8b\x8c\x8d\x8e\x8f"
                                "\x90\x91\x92\x93\x94\x95\x96\x97\x98\x99\x9a\x9b 2\n",
                      "1: unknown header key 'nc\\x01\\xff\\xfe\\x80\\x81\\x82\\x83\\x84\\x85\\x86\\x87\\x88\\x89"
                      "\\x8a\\x8b\\x8c\\x8d\\x8e\\x8f\\x90\\x91\\x92\\x93\\x94\\x95\\x96\\x97\\x98\\x99\\x9a...'"}),
    [](const ::testing::TestParamInfo<MalformedCase>& param) { return std::string(param.param.name); });

TEST(EsriAscii, UtfByteOrderMarkIsSkipped) {
  const std::string path = write_file("bom.asc", "\xEF\xBB\xBFncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n");
  const terrain::DemGrid dem = read_esri_ascii(path);
  EXPECT_EQ(dem.spec.nx, 2);
  EXPECT_EQ(dem.z[dem.spec.index(1, 0)], 2.0);
  fs::remove(path);
}

TEST(EsriAscii, EmptyAndMissingFilesNameTheFile) {
  const std::string missing = temp_file("does_not_exist.asc");
  EXPECT_EQ(input_error([&] { read_esri_ascii(missing); }),
            missing + ": cannot open file (missing or not a regular file)");
  const std::string empty = write_file("empty_file.asc", "");
  EXPECT_EQ(input_error([&] { read_esri_ascii(empty); }), empty + ": empty file");
  fs::remove(empty);
}

terrain::DemGrid sample_dem() {
  terrain::DemGrid dem;
  dem.spec = {123456.7, -0.1, 0.3, 0.7, 4, 3};
  for (std::int32_t j = 0; j < 3; ++j)
    for (std::int32_t i = 0; i < 4; ++i) dem.z.push_back(100.0 / 3.0 + i * 1.1 - j * 0.01);
  dem.z[5] = std::numeric_limits<double>::quiet_NaN();
  return dem;
}

// Same lattice (origin within `origin_tolerance` m, spacing and sizes exact) and the same
// elevations bit for bit, NaN included.
void expect_same_grid(const terrain::DemGrid& a, const terrain::DemGrid& b, double origin_tolerance) {
  EXPECT_EQ(a.spec.nx, b.spec.nx);
  EXPECT_EQ(a.spec.ny, b.spec.ny);
  EXPECT_EQ(a.spec.dx, b.spec.dx);
  EXPECT_EQ(a.spec.dy, b.spec.dy);
  EXPECT_NEAR(a.spec.x0, b.spec.x0, origin_tolerance);
  EXPECT_NEAR(a.spec.y0, b.spec.y0, origin_tolerance);
  ASSERT_EQ(a.z.size(), b.z.size());
  for (std::size_t k = 0; k < a.z.size(); ++k) {
    if (std::isnan(a.z[k])) EXPECT_TRUE(std::isnan(b.z[k])) << k;
    else EXPECT_EQ(a.z[k], b.z[k]) << k;
  }
}

TEST(EsriAscii, WriteReadRoundTripIsExact) {
  const terrain::DemGrid dem = sample_dem();
  const std::string path = temp_file("roundtrip.asc");
  write_esri_ascii(path, dem);
  // Centre keys and shortest round-trip digits: every number comes back bit for bit.
  expect_same_grid(dem, read_esri_ascii(path), 0.0);
  fs::remove(path);
}

TEST(EsriAscii, WriterIsAtomicAndRefusesMissingDirectory) {
  const std::string path = (fs::temp_directory_path() / "talus_no_such_dir" / "x.asc").string();
  EXPECT_THROW(write_esri_ascii(path, sample_dem()), core::RuntimeError);
  EXPECT_FALSE(fs::exists(path));
}

TEST(GeoTiff, WriteReadRoundTrip) {
  const terrain::DemGrid dem = sample_dem();
  const std::string path = temp_file("roundtrip.tif");
  write_geotiff(path, dem);
  // The geotransform stores pixel edges: centre = edge + half a pixel may round by an ulp
  // of the coordinate (1.5e-11 m at 1.2e5 m). Float64 pixels: elevations are exact.
  expect_same_grid(dem, read_geotiff(path), 1e-9);
  EXPECT_EQ(read_dem(path).z.size(), dem.z.size());
  fs::remove(path);
}

TEST(GeoTiff, ErrorsNameTheFile) {
  const std::string missing = temp_file("missing.tif");
  EXPECT_EQ(input_error([&] { read_geotiff(missing); }),
            missing + ": cannot open file (missing or not a regular file)");
  const std::string junk = write_file("junk.tif", "this is not a tiff");
  const std::string message = input_error([&] { read_geotiff(junk); });
  EXPECT_EQ(message.rfind(junk + ": cannot read raster", 0), 0u) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  fs::remove(junk);
  EXPECT_EQ(input_error([&] { read_dem(temp_file("x.png")); }),
            temp_file("x.png") + ": unknown DEM format '.png' (expected .asc, .tif or .tiff)");
}

TEST(GeoTiff, AsciiGridThroughGdalMatchesOwnReader) {
  // GDAL reads .asc too; its georeferencing of a corner file must agree with ours.
  const std::string path = write_file("gdal.asc", "ncols 3\nnrows 2\nxllcorner 10\nyllcorner 20\ncellsize 2\n"
                                                  "NODATA_value -1\n1 2 3\n4 -1 6\n");
  expect_same_grid(read_esri_ascii(path), read_geotiff(path), 0.0);
  fs::remove(path);
}

// A VRT (GDAL's XML raster) over an .asc sets any geotransform without a GDAL dependency
// in the test.
std::string write_vrt(const std::string& name, const std::string& source, const std::string& geotransform) {
  return write_file(name, "<VRTDataset rasterXSize=\"3\" rasterYSize=\"2\">\n  <GeoTransform>" + geotransform +
                              "</GeoTransform>\n  <VRTRasterBand dataType=\"Float64\" band=\"1\">\n"
                              "    <SimpleSource><SourceFilename relativeToVRT=\"0\">" + source +
                              "</SourceFilename><SourceBand>1</SourceBand></SimpleSource>\n"
                              "  </VRTRasterBand>\n</VRTDataset>\n");
}

TEST(GeoTiff, RotatedTransformIsRefusedAndSouthUpIsFlipped) {
  const std::string asc = write_file("vrt_source.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n"
                                                       "1 2 3\n4 5 6\n");
  const std::string rotated = write_vrt("rotated.vrt", asc, "0, 1, 0.5, 10, 0.2, -1");
  EXPECT_EQ(input_error([&] { read_geotiff(rotated); }),
            rotated + ": rotated or sheared geotransform is not supported (rotation terms 0.5, 0.2)");
  // Positive pixel height: the first raster row is the southernmost.
  const std::string south_up = write_vrt("south_up.vrt", asc, "100, 2, 0, 50, 0, 2");
  const terrain::DemGrid dem = read_geotiff(south_up);
  EXPECT_EQ(dem.spec.x0, 101.0);
  EXPECT_EQ(dem.spec.y0, 51.0);
  EXPECT_EQ(dem.spec.dy, 2.0);
  EXPECT_EQ(dem.z, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  const std::string no_size = write_vrt("zero_dx.vrt", asc, "0, 0, 0, 10, 0, -1");
  EXPECT_EQ(input_error([&] { read_geotiff(no_size); }), no_size + ": pixel width must be positive, got 0");
  for (const auto& p : {asc, rotated, south_up, no_size}) fs::remove(p);
}

TEST(Crs, ProjectedInMetresIsAcceptedAndNamed) {
  EXPECT_EQ(crs_name(resolve_crs("EPSG:32632", "s")), "WGS 84 / UTM zone 32N (EPSG:32632)");
  EXPECT_EQ(crs_name(resolve_crs("EPSG:2056", "s")), "CH1903+ / LV95 (EPSG:2056)");
  // WKT and PROJ strings too; the EPSG code is found where the definition matches one.
  EXPECT_EQ(crs_name(resolve_crs(resolve_crs("EPSG:25833", "s"), "s")), "ETRS89 / UTM zone 33N (EPSG:25833)");
  EXPECT_NE(crs_name(resolve_crs("+proj=utm +zone=32 +datum=WGS84 +units=m +no_defs", "s")), "unreadable");
  EXPECT_EQ(crs_name(""), "none");
}

TEST(Crs, DegreesFeetAndUnknownDefinitionsAreRefusedWithTheFix) {
  const std::string degrees = input_error([] { resolve_crs("EPSG:4326", "dem.tif"); });
  EXPECT_EQ(degrees.rfind("dem.tif: CRS WGS 84 (EPSG:4326) is geographic (degrees)", 0), 0u) << degrees;
  EXPECT_NE(degrees.find("gdalwarp -t_srs EPSG:"), std::string::npos) << degrees;
  EXPECT_EQ(degrees.find('\n'), std::string::npos);
  EXPECT_NE(input_error([] { resolve_crs("EPSG:2263", "s"); }).find("measures in units of 0.3048"),
            std::string::npos);
  EXPECT_NE(input_error([] { resolve_crs("no such crs", "s"); }).find("not a coordinate reference system"),
            std::string::npos);
}

TEST(Crs, TravelsWithGeoTiffAndPrjFiles) {
  const std::string wkt = resolve_crs("EPSG:32632", "s");
  const std::string tif = temp_file("crs.tif");
  write_geotiff(tif, sample_dem(), -9999.0, wkt);
  EXPECT_EQ(crs_name(dem_crs(tif).text), "WGS 84 / UTM zone 32N (EPSG:32632)");
  EXPECT_EQ(dem_crs(tif).file, tif);
  const std::string asc = temp_file("crs.asc");
  write_esri_ascii(asc, sample_dem());
  EXPECT_EQ(dem_crs(asc).text, "");  // no .prj beside it
  const std::string prj = temp_file("crs.prj");
  write_prj(prj, wkt);
  // ESRI's WKT, as GIS software reads it beside an .asc; the .prj named as its source.
  EXPECT_EQ(dem_crs(asc).text.rfind("PROJCS[\"WGS_1984_UTM_Zone_32N\"", 0), 0u) << dem_crs(asc).text;
  EXPECT_EQ(dem_crs(asc).file, prj);
  EXPECT_EQ(crs_name(resolve_crs(dem_crs(asc).text, asc)), "WGS 84 / UTM zone 32N (EPSG:32632)");
  // gdalsrsinfo -o wkt_esri writes a blank line before the WKT.
  const std::string esri = [&] {
    std::ifstream in(prj);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }();
  write_file("crs.prj", "\n" + esri + "\n");
  EXPECT_EQ(crs_name(resolve_crs(dem_crs(asc).text, asc)), "WGS 84 / UTM zone 32N (EPSG:32632)");
  // Text that is no CRS is shown on one line.
  const std::string bad = input_error([] { resolve_crs("not a\ncrs at all\n", "x.prj"); });
  EXPECT_NE(bad.find("x.prj: CRS 'not a crs at all' is not"), std::string::npos) << bad;
  EXPECT_EQ(bad.find('\n'), std::string::npos) << bad;
  write_file("crs.prj", "  \n");
  EXPECT_NE(input_error([&] { dem_crs(asc); }).find("crs.prj: is empty"), std::string::npos);
  for (const auto& path : {tif, asc, prj}) fs::remove(path);
}

TEST(DemPath, RecognisesRasterExtensions) {
  EXPECT_TRUE(is_dem_path("a/b.asc"));
  EXPECT_TRUE(is_dem_path("B.TIF"));
  EXPECT_TRUE(is_dem_path("c.tiff"));
  EXPECT_FALSE(is_dem_path("d.stl"));
  EXPECT_FALSE(is_dem_path("asc"));
}

}  // namespace
}  // namespace talus::io
