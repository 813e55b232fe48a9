// The half-edge structure: topology checks and coplanar face merging.
#include "talus/geometry/half_edge.hpp"

#include <gtest/gtest.h>

namespace talus::geometry {
namespace {

Polyhedron unit_cube_triangles() {
  Polyhedron p;
  for (int k = 0; k < 8; ++k) p.vertices.emplace_back(k & 1, (k >> 1) & 1, (k >> 2) & 1);
  const std::vector<std::vector<std::int32_t>> quads = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                                        {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    p.faces.push_back({q[0], q[1], q[2]});
    p.faces.push_back({q[0], q[2], q[3]});
  }
  return p;
}

TEST(HalfEdge, ClosedCubeHasTwinsAndEulerCharacteristicTwo) {
  const Polyhedron p = unit_cube_triangles();
  HalfEdgeMesh m;
  ASSERT_TRUE(HalfEdgeMesh::build(p.vertices, p.faces, m).ok());
  EXPECT_EQ(m.face_count(), 12u);
  EXPECT_EQ(m.edge_count(), 18u);
  EXPECT_EQ(m.euler_characteristic(), 2);
  EXPECT_EQ(m.connected_components(), 1u);
  for (std::size_t h = 0; h < m.half_edges().size(); ++h) {
    const auto& e = m.half_edges()[h];
    EXPECT_EQ(m.half_edges()[e.twin].twin, static_cast<std::int32_t>(h));
    EXPECT_EQ(m.half_edges()[e.twin].origin, m.half_edges()[e.next].origin);
  }
  EXPECT_EQ(m.face_vertices(0), (std::vector<std::int32_t>{0, 2, 3}));
}

TEST(HalfEdge, EachDefectIsNamed) {
  Polyhedron p = unit_cube_triangles();
  HalfEdgeMesh m;
  EXPECT_EQ(HalfEdgeMesh::build(p.vertices, {}, m).defect, TopologyDefect::empty);

  Polyhedron open = p;
  open.faces.pop_back();
  TopologyReport r = HalfEdgeMesh::build(open.vertices, open.faces, m);
  EXPECT_EQ(r.defect, TopologyDefect::open_boundary);
  EXPECT_EQ(r.count, 3u);
  EXPECT_EQ(r.describe(), "open surface: 3 boundary edge(s) (e.g. at vertex 1)");

  Polyhedron flipped = p;
  std::swap(flipped.faces[0][1], flipped.faces[0][2]);
  EXPECT_EQ(HalfEdgeMesh::build(flipped.vertices, flipped.faces, m).defect, TopologyDefect::inconsistent_orientation);

  Polyhedron bad = p;
  bad.faces[2][1] = 99;
  r = HalfEdgeMesh::build(bad.vertices, bad.faces, m);
  EXPECT_EQ(r.defect, TopologyDefect::bad_index);
  EXPECT_EQ(r.face, 2);

  Polyhedron repeated = p;
  repeated.faces[1] = {0, 0, 3};
  EXPECT_EQ(HalfEdgeMesh::build(repeated.vertices, repeated.faces, m).defect, TopologyDefect::repeated_vertex);
  EXPECT_EQ(m.face_count(), 0u);  // nothing built on a defect
}

TEST(HalfEdge, CoplanarTrianglesMergeIntoQuads) {
  const Polyhedron merged = merge_coplanar_faces(unit_cube_triangles(), 1e-12);
  ASSERT_EQ(merged.faces.size(), 6u);
  EXPECT_EQ(merged.vertices.size(), 8u);
  for (const auto& f : merged.faces) EXPECT_EQ(f.size(), 4u);
  const MassProperties m = mass_properties(merged);
  EXPECT_NEAR(m.volume, 1.0, 1e-15);
  EXPECT_NEAR(m.surface_area, 6.0, 1e-14);
  HalfEdgeMesh he;
  EXPECT_TRUE(HalfEdgeMesh::build(merged.vertices, merged.faces, he).ok());
}

TEST(HalfEdge, SubdividedFaceMergesAndDropsItsInnerVertex) {
  // Split the top quad of the cube into four triangles around its centre.
  Polyhedron p = unit_cube_triangles();
  p.faces.erase(p.faces.begin() + 2, p.faces.begin() + 4);  // top quad {4,5,7,6}
  p.vertices.emplace_back(0.5, 0.5, 1.0);
  p.faces.push_back({4, 5, 8});
  p.faces.push_back({5, 7, 8});
  p.faces.push_back({7, 6, 8});
  p.faces.push_back({6, 4, 8});
  const Polyhedron merged = merge_coplanar_faces(p, 1e-12);
  EXPECT_EQ(merged.faces.size(), 6u);
  EXPECT_EQ(merged.vertices.size(), 8u);
}

TEST(HalfEdge, NonConvexCoplanarRegionKeepsItsTriangles) {
  // An L-shaped prism: its L-shaped top and bottom are coplanar regions that are not
  // convex, so they stay triangulated (fan areas of a non-convex polygon would be wrong).
  Polyhedron p;
  const double xy[6][2] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  for (double z : {0.0, 1.0})
    for (const auto& q : xy) p.vertices.emplace_back(q[0], q[1], z);
  const std::vector<std::array<int, 3>> cap = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}};
  for (const auto& t : cap) {
    p.faces.push_back({t[0], t[2], t[1]});          // bottom, seen from below
    p.faces.push_back({t[0] + 6, t[1] + 6, t[2] + 6});  // top
  }
  for (int k = 0; k < 6; ++k) {
    const int a = k, b = (k + 1) % 6;
    p.faces.push_back({a, b, b + 6});
    p.faces.push_back({a, b + 6, a + 6});
  }
  const Polyhedron merged = merge_coplanar_faces(p, 1e-12);
  // 6 side quads + 4 + 4 cap triangles.
  EXPECT_EQ(merged.faces.size(), 14u);
  EXPECT_NEAR(mass_properties(merged).surface_area, 2 * 3.0 + 8.0, 1e-14);
}

}  // namespace
}  // namespace talus::geometry
