// Point clouds read by terrain-gen and block-gen: text clouds with and without a header
// line.
#include "talus/io/point_cloud.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

using geometry::Vec3;

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

}  // namespace
}  // namespace talus::io
