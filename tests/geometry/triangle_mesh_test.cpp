#include "talus/geometry/triangle_mesh.hpp"

#include <gtest/gtest.h>

namespace talus::geometry {
namespace {

// Two triangles stored STL-style (no shared vertices) share an edge after welding.
TEST(WeldVertices, MergesCoincidentAndDropsDegenerate) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 1e-12}, {2, 2, 2}, {2, 2, 2}, {3, 3, 3}};
  m.triangles = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}};
  const std::size_t removed = weld_vertices(m, 1e-9);
  EXPECT_EQ(removed, 3u);
  ASSERT_EQ(m.triangles.size(), 2u);  // the third collapsed to a segment
  EXPECT_EQ(m.vertices.size(), 6u);
  EXPECT_EQ(m.triangles[1][0], 1);
  EXPECT_EQ(m.triangles[1][2], 2);
}

TEST(TriangleMesh, AreaNormalAndBounds) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 3, 0}};
  m.triangles = {{0, 1, 2}};
  EXPECT_EQ(m.area_normal(0), Vec3(0, 0, 6));
  EXPECT_EQ(m.bounds().hi, Vec3(2, 3, 0));
}

}  // namespace
}  // namespace talus::geometry
