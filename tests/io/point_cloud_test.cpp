// Point clouds read by terrain-gen and block-gen: text clouds with and without a header
// line, and LAS files (written here byte by byte: tests/support/las_writer.hpp).
#include "talus/io/point_cloud.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "../support/las_writer.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

using geometry::Vec3;
using testing::LasTestFile;
using testing::LasTestPoint;
using testing::LasTestRecord;

// A scratch file removed at the end of the test.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& name) : path_(talus::testing::temp_path("point_cloud_test", name)) {}
  ~ScratchFile() { std::filesystem::remove(path_); }
  const std::string& path() const { return path_; }
  void write(const std::string& bytes) const { write_text_file(path_, bytes); }

 private:
  std::string path_;
};

// The message of the InputError `read` throws ("" when it throws none).
template <class F>
std::string error_of(F read) {
  try {
    read();
  } catch (const core::InputError& e) {
    return e.what();
  }
  return "";
}

std::string cloud_error(const std::string& path, const PointCloudOptions& options = {}) {
  return error_of([&] { read_point_cloud(path, options); });
}

// --- text clouds with a header line -------------------------------------------------------

TEST(HeadedTextCloud, PdalHeaderWithExtraColumns) {
  // What PDAL's text writer gives by default: quoted names, commas, every dimension.
  ScratchFile f("pdal.csv");
  f.write("\"X\",\"Y\",\"Z\",\"Intensity\",\"Classification\"\n"
          "2601282.920,1180360.020,877.560,143,2\n"
          "2601301.900,1180341.440,864.270,88,5\n");
  const auto pts = read_point_cloud(f.path());
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0], Vec3(2601282.92, 1180360.02, 877.56));
  EXPECT_EQ(pts[1], Vec3(2601301.9, 1180341.44, 864.27));
}

TEST(HeadedTextCloud, ColumnsInAnyOrderAndLetterCase) {
  ScratchFile f("zxy.txt");
  f.write("\"Z\",\"X\",\"Y\"\n3,1,2\n6,4,5\n");
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1, 2, 3}, {4, 5, 6}}));
  // Columns after X, Y and Z and before them; lower case; tabs.
  f.write("intensity\tz\ty\tx\tred\n7\t3\t2\t1\t255\n");
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1, 2, 3}}));
}

TEST(HeadedTextCloud, UnquotedHeadersCommentsAndByteOrderMark) {
  ScratchFile f("plain.xyz");
  f.write("x y z\n1 2 3\n\n4 5 6 extra words\n");
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1, 2, 3}, {4, 5, 6}}));
  f.write("# exported cloud\n\nX,Y,Z,R,G,B\r\n1.5,2.5,3.5,9,9,9\r\n");
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1.5, 2.5, 3.5}}));
  f.write("\xEF\xBB\xBFX,Y,Z\n1,2,3\n");  // the mark before the first line
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1, 2, 3}}));
  // Scale and up axis apply as to any cloud.
  f.write("Y Z X\n2 3 1\n");
  PointCloudOptions o;
  o.scale = 2.0;
  o.up = UpAxis::y;
  EXPECT_EQ(read_point_cloud(f.path(), o), (std::vector<Vec3>{{2, -6, 4}}));
}

TEST(HeadedTextCloud, WithoutHeaderTheFirstThreeNumbersAsBefore) {
  ScratchFile f("bare.pts");
  f.write("// comment\n1 2 3 200 100 50\n4,5,6\n7\t8\t9\n");
  EXPECT_EQ(read_point_cloud(f.path()), (std::vector<Vec3>{{1, 2, 3}, {4, 5, 6}, {7, 8, 9}}));
  f.write("1 2 3\nX Y Z\n");  // a header after data is no header
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 2: expected x y z numbers");
}

TEST(HeadedTextCloud, ErrorsNameFileAndLine) {
  ScratchFile f("bad.csv");
  f.write("# survey\nEasting,Northing,Height\n1,2,3\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 2: expected x y z numbers or a header naming the X, Y and Z "
                                               "columns, got 'Easting,Northing,Height'");
  f.write("\"X\",\"Y\",\"Elevation\"\n1,2,3\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 1: the header '\"X\",\"Y\",\"Elevation\"' names no Z column");
  f.write("x,y\n1,2\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 1: the header 'x,y' names no Z column");
  f.write("N,E\n1,2\n");
  EXPECT_EQ(cloud_error(f.path()),
            f.path() + ": line 1: expected x y z numbers or a header naming the X, Y and Z columns, got 'N,E'");
  f.write("X,Y,Z,x\n1,2,3,4\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 1: the header names column X twice (columns 1 and 4)");
  // A row with too few columns for the header.
  f.write("\"X\",\"Y\",\"Z\",\"Intensity\"\n1,2,3,4\n5,6\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 3: 2 columns, expected at least 3 (the header on line 1 puts "
                                               "X, Y, Z in columns 1, 2, 3)");
  f.write("\"Z\",\"Intensity\",\"X\",\"Y\"\n3,0,1\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 2: 3 columns, expected at least 4 (the header on line 1 puts "
                                               "X, Y, Z in columns 3, 4, 1)");
  // A value that is not a number, or not finite; extra columns are not read.
  f.write("X Y Z Class\n1 2 3 ground\n1 two 3 ground\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 3: Y (column 2) is not a number: 'two'");
  f.write("X Y Z\n1 2 inf\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 2: non-finite coordinate");
  f.write("X,Y,Z\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": empty point cloud: no points");
}

// --- LAS ------------------------------------------------------------------------------------

// LAS 1.2, format 1 (GPS time), survey-like scale and offset; the class byte carries flags.
LasTestFile las12() {
  LasTestFile f;
  f.minor = 2;
  f.format = 1;
  f.scale = {0.01, 0.01, 0.001};
  f.offset = {2600000.0, 1200000.0, 0.0};
  f.points = {{128292, 36002, 877560, 2},
              {130190, 34144, 864270, 2 | 0x20},  // ground, synthetic flag set
              {-5, -7, -9, 5},
              {2147483647, -2147483647 - 1, 0, 1 | 0x80}};  // unclassified, withheld flag set
  return f;
}

// LAS 1.4, format 6: 64-bit count, the class in byte 16 (codes above 31 possible).
LasTestFile las14() {
  LasTestFile f;
  f.minor = 4;
  f.format = 6;
  f.scale = {0.001, 0.001, 0.001};
  f.offset = {350000.0, 5100000.0, 100.0};
  f.points = {{1000, 2000, 3000, 2}, {4000, 5000, 6000, 200}, {7000, 8000, 9000, 2}, {1, 2, 3, 7}};
  return f;
}

// The coordinates of point `p` of `f`, computed as the reader must: integer × scale + offset.
Vec3 expected(const LasTestFile& f, const LasTestPoint& p) {
  return {static_cast<double>(p.x) * f.scale[0] + f.offset[0], static_cast<double>(p.y) * f.scale[1] + f.offset[1],
          static_cast<double>(p.z) * f.scale[2] + f.offset[2]};
}

TEST(LasCloud, Version12Format1CoordinatesAreExact) {
  ScratchFile file("survey.las");
  const LasTestFile f = las12();
  file.write(testing::las_bytes(f));
  const auto pts = read_point_cloud(file.path());
  ASSERT_EQ(pts.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(pts[k], expected(f, f.points[k])) << k;
  EXPECT_EQ(pts[0], Vec3(128292 * 0.01 + 2600000.0, 36002 * 0.01 + 1200000.0, 877560 * 0.001));
  EXPECT_EQ(pts[2].z(), -9 * 0.001);
  EXPECT_TRUE(is_point_cloud_file(file.path()));
}

TEST(LasCloud, Version14Format6CoordinatesAreExact) {
  ScratchFile file("scan.las");
  const LasTestFile f = las14();
  file.write(testing::las_bytes(f));
  const auto pts = read_point_cloud(file.path());
  ASSERT_EQ(pts.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(pts[k], expected(f, f.points[k])) << k;
  EXPECT_EQ(pts[0], Vec3(350001.0, 5100002.0, 103.0));
}

TEST(LasCloud, EveryFormatWithExtraBytesAndUpperCaseExtension) {
  for (int format = 0; format <= 10; ++format) {
    for (const std::size_t extra : {0u, 7u}) {
      ScratchFile file("format" + std::to_string(format) + ".LAS");
      LasTestFile f;
      f.minor = format >= 6 ? 4 : format >= 4 ? 3 : 2;
      f.format = format;
      f.record_length = static_cast<std::uint16_t>(testing::las_min_record_length(format) + extra);
      f.scale = {0.5, 0.25, 0.125};
      f.offset = {10.0, 20.0, 30.0};
      f.points = {{1, 2, 3, 2}, {-4, 5, -6, 3}, {7, -8, 9, 2}};
      file.write(testing::las_bytes(f));
      PointCloudOptions o;
      o.las_classes = {2};
      EXPECT_EQ(read_point_cloud(file.path(), o), (std::vector<Vec3>{{10.5, 20.5, 30.375}, {13.5, 18.0, 31.125}}))
          << "format " << format << ", " << extra << " extra bytes";
    }
  }
}

TEST(LasCloud, ClassFilterKeepsTheGivenClasses) {
  ScratchFile file12("c12.las"), file14("c14.las");
  const LasTestFile a = las12(), b = las14();
  file12.write(testing::las_bytes(a));
  file14.write(testing::las_bytes(b));
  PointCloudOptions ground;
  ground.las_classes = {2};
  // Formats 0–5: the class is the low 5 bits of byte 15 (the synthetic flag does not hide it).
  EXPECT_EQ(read_point_cloud(file12.path(), ground),
            (std::vector<Vec3>{expected(a, a.points[0]), expected(a, a.points[1])}));
  PointCloudOptions unclassified;
  unclassified.las_classes = {1};  // withheld flag in bit 7
  EXPECT_EQ(read_point_cloud(file12.path(), unclassified), (std::vector<Vec3>{expected(a, a.points[3])}));
  // Formats 6–10: all of byte 16.
  EXPECT_EQ(read_point_cloud(file14.path(), ground),
            (std::vector<Vec3>{expected(b, b.points[0]), expected(b, b.points[2])}));
  PointCloudOptions two;
  two.las_classes = {200, 7};
  EXPECT_EQ(read_point_cloud(file14.path(), two),
            (std::vector<Vec3>{expected(b, b.points[1]), expected(b, b.points[3])}));
  // Empty: every point. Text clouds carry no classes and ignore it.
  EXPECT_EQ(read_point_cloud(file14.path()).size(), 4u);
  ScratchFile text("c.xyz");
  text.write("1 2 3\n");
  EXPECT_EQ(read_point_cloud(text.path(), ground).size(), 1u);
  // No point left: the message says which classes the file holds.
  PointCloudOptions water;
  water.las_classes = {9};
  EXPECT_EQ(cloud_error(file14.path(), water),
            file14.path() + ": no point of class 9 among its 4 points; its classes: 2 (2 points), 7 (1 point), "
                            "200 (1 point)");
}

TEST(LasCloud, LazIsRefusedWithTheCommandToDecompress) {
  // By extension, whatever the content.
  ScratchFile laz("scan.laz");
  laz.write(testing::las_bytes(las14()));
  EXPECT_TRUE(is_point_cloud_file(laz.path()));
  EXPECT_EQ(cloud_error(laz.path()),
            laz.path() + ": LAZ is compressed LAS, which Talus does not read: decompress it first, e.g. las2las -i "
                         "in.laz -o out.las (LAStools) or pdal translate in.laz out.las (PDAL)");
  EXPECT_EQ(error_of([&] { point_cloud_crs(laz.path()); }), cloud_error(laz.path()));
  // By the compression bit of the point data format, in a file named .las.
  ScratchFile las("compressed.las");
  LasTestFile f = las12();
  f.compressed = true;
  las.write(testing::las_bytes(f));
  EXPECT_EQ(cloud_error(las.path()),
            las.path() + ": the LAS header marks the points compressed (LAZ), which Talus does not read: decompress "
                         "it first, e.g. las2las -i in.laz -o out.las (LAStools) or pdal translate in.laz out.las (PDAL)");
}

TEST(LasCloud, TruncatedFileIsRefused) {
  ScratchFile file("cut.las");
  std::string bytes = testing::las_bytes(las12());
  bytes.resize(bytes.size() - 5);  // the last record loses 5 of its 28 bytes
  file.write(bytes);
  EXPECT_EQ(cloud_error(file.path()), file.path() + ": truncated LAS file: the header declares 4 points of 28 bytes "
                                                    "from byte 227, the file holds 3 (334 bytes)");
  // A count beyond the records (LAS 1.4, 64-bit count).
  LasTestFile f = las14();
  f.stated_points = 5000000000ull;
  file.write(testing::las_bytes(f));
  EXPECT_NE(cloud_error(file.path()).find("truncated LAS file: the header declares 5000000000 points of 30 bytes"),
            std::string::npos);
  // Inside the header.
  file.write(testing::las_bytes(las12()).substr(0, 100));
  EXPECT_EQ(cloud_error(file.path()), file.path() + ": truncated LAS file: 100 bytes, less than a LAS header (227 bytes)");
  file.write(testing::las_bytes(las14()).substr(0, 300));
  EXPECT_EQ(cloud_error(file.path()),
            file.path() + ": truncated LAS file: 300 bytes, less than its header (375 bytes)");
}

TEST(LasCloud, MalformedHeadersAreRefused) {
  ScratchFile file("bad.las");
  const auto error = [&](const LasTestFile& f) {
    file.write(testing::las_bytes(f));
    const std::string e = cloud_error(file.path());
    EXPECT_EQ(e.rfind(file.path() + ": ", 0), 0u) << e;
    return e.substr(std::min(e.size(), file.path().size() + 2));
  };
  LasTestFile f = las12();
  f.signature = "LASX";
  EXPECT_EQ(error(f), "not a LAS file: it does not start with the signature 'LASF'");
  file.write("");
  EXPECT_EQ(cloud_error(file.path()), file.path() + ": not a LAS file: it does not start with the signature 'LASF'");
  f = las12();
  f.major = 2;
  f.minor = 0;
  EXPECT_EQ(error(f), "LAS version 2.0 is not supported (1.0 to 1.4)");
  f = las12();
  f.minor = 5;
  EXPECT_EQ(error(f), "LAS version 1.5 is not supported (1.0 to 1.4)");
  f = las12();
  f.format = 11;
  EXPECT_EQ(error(f), "point data record format 11 is not supported (0 to 10)");
  f = las12();
  f.record_length = 27;
  EXPECT_EQ(error(f), "point data record length 27 bytes is less than the 28 of format 1");
  f = las14();
  f.scale[1] = 0.0;
  EXPECT_EQ(error(f), "Y scale factor 0 must be finite and non-zero");
  f = las14();
  f.scale[2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error(f), "Z scale factor inf must be finite and non-zero");
  f = las14();
  f.offset[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error(f), "X offset nan must be finite");
  f = las12();
  f.points.clear();
  EXPECT_EQ(error(f), "empty point cloud: the LAS header declares no points");
  // A LAS 1.4 file that says its header is a LAS 1.2 one.
  std::string bytes = testing::las_bytes(las14());
  bytes[94] = static_cast<char>(227);
  bytes[95] = 0;
  file.write(bytes);
  EXPECT_EQ(cloud_error(file.path()), file.path() + ": header size 227 bytes is less than the 375 of a LAS 1.4 header");
  // Point data that would start inside the header, or past the end.
  bytes = testing::las_bytes(las12());
  bytes[96] = 100;
  bytes[97] = 0;
  file.write(bytes);
  EXPECT_EQ(cloud_error(file.path()), file.path() + ": offset to point data 100 lies inside the header (227 bytes)");
  bytes[97] = 10;  // 2660
  file.write(bytes);
  EXPECT_EQ(cloud_error(file.path()),
            file.path() + ": truncated LAS file: the offset to point data 2660 lies beyond its end (339 bytes)");
}

TEST(LasCloud, CrsFromWktOrGeoTiffKeys) {
  ScratchFile file("crs.las");
  const std::string wkt = "PROJCS[\"CH1903+ / LV95\",AUTHORITY[\"EPSG\",\"2056\"]]";
  LasTestFile f = las12();
  f.records = {{"LASF_Projection", 2112, wkt + std::string(1, '\0'), false}};
  file.write(testing::las_bytes(f));
  EXPECT_EQ(point_cloud_crs(file.path()).text, wkt);
  EXPECT_EQ(read_point_cloud(file.path()).size(), 4u);  // the record shifts the points
  // LAS 1.4: the WKT in an extended VLR after the points; other records are passed over.
  LasTestFile g = las14();
  g.records = {{"LASF_Spec", 4, "ignored", false}, {"LASF_Projection", 2112, wkt + "\n", true}};
  file.write(testing::las_bytes(g));
  EXPECT_EQ(point_cloud_crs(file.path()).text, wkt);
  const auto pts = read_point_cloud(file.path());  // the extended VLR is not a point
  ASSERT_EQ(pts.size(), 4u);
  EXPECT_EQ(pts[3], expected(g, g.points[3]));
  // GeoTIFF keys: the projected CRS code; a geographic one (refused later, as degrees);
  // a user-defined one is not read.
  f.records = {{"LASF_Projection", 34735, testing::geokey_directory({{1024, 1}, {3072, 2056}, {4096, 5773}}), false}};
  file.write(testing::las_bytes(f));
  EXPECT_EQ(point_cloud_crs(file.path()).text, "EPSG:2056");
  f.records = {{"LASF_Projection", 34735, testing::geokey_directory({{1024, 2}, {2048, 4326}}), false}};
  file.write(testing::las_bytes(f));
  EXPECT_EQ(point_cloud_crs(file.path()).text, "EPSG:4326");
  f.records = {{"LASF_Projection", 34735, testing::geokey_directory({{1024, 1}, {3072, 32767}}), false}};
  file.write(testing::las_bytes(f));
  const DeclaredCrs user = point_cloud_crs(file.path());
  EXPECT_EQ(user.text, "");
  EXPECT_EQ(user.problem, "its GeoTIFF CRS is user-defined (no EPSG code), which Talus does not read");
  // The WKT wins over the keys.
  f.records = {{"LASF_Projection", 34735, testing::geokey_directory({{3072, 32632}}), false},
               {"LASF_Projection", 2112, wkt, false}};
  file.write(testing::las_bytes(f));
  EXPECT_EQ(point_cloud_crs(file.path()).text, wkt);
  // None declared; other formats declare none.
  file.write(testing::las_bytes(las12()));
  EXPECT_EQ(point_cloud_crs(file.path()).text, "");
  EXPECT_EQ(point_cloud_crs(file.path()).problem, "");
  ScratchFile text("crs.xyz");
  text.write("1 2 3\n");
  EXPECT_EQ(point_cloud_crs(text.path()).text, "");
  // A record running into the point data.
  std::string bytes = testing::las_bytes(f);
  bytes[227 + 20] = static_cast<char>(0xff);
  file.write(bytes);
  EXPECT_NE(error_of([&] { point_cloud_crs(file.path()); }).find("LAS VLR 0 (at byte 227) runs past the start of the point data"),
            std::string::npos);
}

}  // namespace
}  // namespace talus::io

namespace talus::io {
namespace {

// An ASCII PLY body word that is not a finite number is named with its line in the file
// (it was reported as the file ending early).
TEST(PlyCloud, BadValuesAreNamedWithTheirLine) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  ScratchFile f("bad.ply");
  f.write(header + "0 0 0\n1 abc 0\n0 1 0\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 9: 'abc' is not a number");
  f.write(header + "0 0 0\n1 0 0\n0 nan 0\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": line 10: non-finite value 'nan'");
  f.write(header + "0 0 0\n1 0 0\n");
  EXPECT_EQ(cloud_error(f.path()), f.path() + ": PLY file ends early");
  f.write(header + "0 0 0\n1 0 0\n0 1 0\n");
  EXPECT_EQ(read_point_cloud(f.path()).size(), 3u);
}

}  // namespace
}  // namespace talus::io

namespace talus::io {
namespace {

// A Leica .pts file starts with its point count on a line of its own; rows carry
// intensity and colour after x y z.
TEST(TextCloud, PtsPointCountLineIsSkipped) {
  ScratchFile f("scan.pts");
  f.write("3\n0 0 0 -1200 10 20 30\n1 0 0 -1100 10 20 30\n0 1 0.5 -1000 10 20 30\n");
  const std::vector<Vec3> points = read_point_cloud(f.path());
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points[2], Vec3(0.0, 1.0, 0.5));
  // In an .xyz file a lone number on the first line is still an error.
  ScratchFile g("count.xyz");
  g.write("3\n0 0 0\n1 0 0\n0 1 0\n");
  EXPECT_NE(cloud_error(g.path()), "");
}

}  // namespace
}  // namespace talus::io
