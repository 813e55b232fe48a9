// Block files round-trip; point clouds are read from XYZ and PLY.
#include "talus/io/block_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "talus/block/solids.hpp"
#include "talus/core/error.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/point_cloud.hpp"
#include "test_support.hpp"

namespace talus::io {
namespace {

using geometry::Vec3;

class BlockFile : public block::test::ScratchTest {};

std::vector<block::Block> library() {
  std::vector<block::Block> blocks;
  block::SolidSpec spec;
  spec.kind = block::SolidKind::dodecahedron;
  blocks.push_back(block::make_block("R4", block::make_solid(spec, "t"), 2800.0, "dodecahedron"));
  spec.kind = block::SolidKind::rock;
  spec.volume = 0.3;
  blocks.push_back(block::make_block("rock", block::make_solid(spec, "t"), 2650.0, "rock"));
  blocks.back().weight = 3.0;
  blocks.back().notes = {"first note", "second note"};
  return blocks;
}

TEST_F(BlockFile, RoundTripKeepsEveryField) {
  const std::vector<block::Block> blocks = library();
  Provenance prov;
  prov.tool = "block-gen";
  const std::string file = path("lib.h5");
  write_block_file(file, blocks, prov);
  const std::vector<block::Block> back = read_block_file(file);
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const block::Block &a = blocks[i], &b = back[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.source, b.source);
    EXPECT_EQ(a.notes, b.notes);
    EXPECT_EQ(a.polyhedron.vertices, b.polyhedron.vertices);
    EXPECT_EQ(a.polyhedron.faces, b.polyhedron.faces);
    EXPECT_EQ(a.volume_exact, b.volume_exact);
    EXPECT_EQ(a.volume_rational, b.volume_rational);
    EXPECT_EQ(a.volume, b.volume);
    EXPECT_EQ(a.centroid, b.centroid);
    EXPECT_EQ(a.second_moments, b.second_moments);
    EXPECT_EQ(a.inertia_per_density, b.inertia_per_density);
    EXPECT_EQ(a.inertia, b.inertia);
    EXPECT_EQ(a.principal_moments, b.principal_moments);
    EXPECT_EQ(a.principal_axes, b.principal_axes);
    EXPECT_EQ(a.dimensions, b.dimensions);
    EXPECT_EQ(a.rotation, b.rotation);
    EXPECT_EQ(a.translation, b.translation);
    EXPECT_EQ(a.surface_area, b.surface_area);
    EXPECT_EQ(a.sphericity, b.sphericity);
    EXPECT_EQ(a.density, b.density);
    EXPECT_EQ(a.mass, b.mass);
    EXPECT_EQ(a.weight, b.weight);
  }
  EXPECT_EQ(back[1].weight, 3.0);
  EXPECT_TRUE(describe_block(back[0]).find("sphericity         0.910453") != std::string::npos)
      << describe_block(back[0]);
}

TEST_F(BlockFile, CorruptAndForeignFilesAreClearErrors) {
  try {
    read_block_file(path("missing.h5"));
    FAIL() << "missing file read";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.h5"), std::string::npos) << e.what();
  }
  const std::string terrain = path("terrain.h5");
  {
    const h5::File f = h5::File::create(terrain);
    write_header(f.root(), "terrain", kTerrainSchema, Provenance{});
  }
  try {
    read_block_file(terrain);
    FAIL() << "terrain file read as block file";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()), terrain + ": is a Talus terrain file, expected a block file");
  }
}

TEST_F(BlockFile, ReaderRefusesBrokenPolyhedra) {
  std::vector<block::Block> one{library()[0]};
  one[0].polyhedron.faces.pop_back();  // open surface
  const std::string file = path("open.h5");
  write_block_file(file, one, Provenance{});
  try {
    read_block_file(file);
    FAIL() << "open polyhedron accepted";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              file + " (block_0000): corrupt polyhedron: open surface: 5 boundary edge(s) (e.g. at vertex 6)");
  }
}

TEST_F(BlockFile, ReaderRefusesAPolyhedronThatDoesNotEncloseTheStatedVolume) {
  // Every face reversed: a closed surface enclosing -V, which dda-run reported as
  // "block: volume -1 m^3" without the file.
  std::vector<block::Block> one{library()[0]};
  for (auto& face : one[0].polyhedron.faces) std::reverse(face.begin(), face.end());
  const std::string inverted = path("inverted.h5");
  write_block_file(inverted, one, Provenance{});
  try {
    read_block_file(inverted);
    FAIL() << "inverted polyhedron accepted";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(inverted + " (block_0000): corrupt block: the polyhedron encloses -", 0), 0u)
        << e.what();
  }
  // A non-finite property.
  one = {library()[0]};
  one[0].inertia(0, 0) = std::numeric_limits<double>::infinity();
  const std::string infinite = path("infinite.h5");
  write_block_file(infinite, one, Provenance{});
  EXPECT_THROW(read_block_file(infinite), core::InputError);
}

TEST_F(BlockFile, ReaderRefusesStatedPropertiesThePolyhedronContradicts) {
  const auto refused = [&](const std::string& name, const std::vector<block::Block>& blocks, const std::string& words) {
    const std::string file = path(name);
    write_block_file(file, blocks, Provenance{});
    try {
      read_block_file(file);
      ADD_FAILURE() << name << " accepted";
    } catch (const core::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  std::vector<block::Block> one{library()[0]};
  one[0].volume_exact = std::numeric_limits<double>::quiet_NaN();
  refused("nan-exact.h5", one, "volume_exact is nan");
  one = {library()[0]};
  one[0].volume_exact = 7.5;  // the dodecahedron encloses 1 m^3
  refused("wrong-exact.h5", one, "volume_exact is 7.5");
  one = {library()[0]};
  one[0].mass = 0.0;
  refused("no-mass.h5", one, "mass is 0 kg");
  std::vector<block::Block> two = library();
  two[1].name = two[0].name;
  refused("same-name.h5", two, "two blocks are named 'R4'");
}

TEST_F(BlockFile, XdmfSidecarNamesEveryBlockSafely) {
  std::vector<block::Block> blocks = library();
  blocks[1].name = "a<b & \"c\"";
  write_block_xdmf(path("lib.xmf"), path("lib.h5"), blocks);
  const std::string x = block::test::read_text(path("lib.xmf"));
  EXPECT_NE(x.find("<Grid Name=\"a&lt;b &amp; &quot;c&quot;\""), std::string::npos) << x;
  EXPECT_NE(x.find("lib.h5:/blocks/block_0001/triangles"), std::string::npos) << x;
  EXPECT_NE(x.find("TopologyType=\"Triangle\" NumberOfElements=\"36\""), std::string::npos) << x;  // 12 pentagons
}

class PreciseMeshes : public block::test::ScratchTest {};

// Text meshes keep every digit (assimp would round to float), and OBJ polygons, v/vt/vn
// references and negative indices are understood.
TEST_F(PreciseMeshes, ObjKeepsDoublesAndSplitsPolygons) {
  const std::string file = path("quad.obj");
  block::test::write_text(file, "o sheet\nv 0.1 0 123456.789\nv 1 0 123456.789\nv 1 1 123456.789\nv 0 1 123456.789\n"
                                "vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -4 -2 -1\n");
  const ImportedMesh m = import_mesh(file);
  ASSERT_EQ(m.mesh.vertices.size(), 4u);
  EXPECT_EQ(m.mesh.vertices[0], Vec3(0.1, 0, 123456.789));
  EXPECT_EQ(m.mesh.triangles.size(), 3u);
  EXPECT_EQ(m.mesh.triangles[2], (std::array<std::int32_t, 3>{0, 2, 3}));
  block::test::write_text(file, "v 0 0 0\nv 1 0 0\nf 1 2 9\n");
  try {
    import_mesh(file);
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()), file + ": line 3: face refers to vertex 9 of 2");
  }
}

TEST_F(PreciseMeshes, OffAndBinaryPlyFaces) {
  const std::string off = path("t.off");
  block::test::write_text(off, "OFF\n# tetra\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  EXPECT_EQ(import_mesh(off).mesh.triangles.size(), 4u);

  const std::string ply = path("t.ply");
  geometry::TriangleMesh tet;
  tet.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1e-3}};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  export_mesh(ply, tet);  // binary little-endian doubles
  const ImportedMesh m = import_mesh(ply);
  EXPECT_EQ(m.mesh.vertices, tet.vertices);
  EXPECT_EQ(m.mesh.triangles, tet.triangles);
}

class PointClouds : public block::test::ScratchTest {};

TEST_F(PointClouds, XyzWithCommentsColumnsAndCommas) {
  const std::string file = path("scan.xyz");
  block::test::write_text(file, "# x y z r g b\n1 2 3 255 0 0\n\n4,5,6\n  7\t8\t9\n");
  PointCloudOptions o;
  o.scale = 2.0;
  const auto pts = read_point_cloud(file, o);
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_EQ(pts[0], Vec3(2, 4, 6));
  EXPECT_EQ(pts[2], Vec3(14, 16, 18));
  EXPECT_TRUE(is_point_cloud_file(file));
  block::test::write_text(file, "1 2 3\n4 five 6\n");
  try {
    read_point_cloud(file);
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()), file + ": line 2: expected x y z numbers");
  }
  block::test::write_text(file, "# nothing\n");
  EXPECT_THROW(read_point_cloud(file), core::InputError);
}

TEST_F(PointClouds, PlyAsciiAndBinaryYUp) {
  const std::string ascii = path("a.ply");
  block::test::write_text(ascii,
                          "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                          "property float z\nproperty uchar red\nend_header\n1 2 3 9\n-1 0.5 4 9\n");
  auto pts = read_point_cloud(ascii);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[1], Vec3(-1, 0.5, 4));
  EXPECT_TRUE(is_point_cloud_file(ascii));

  const std::string binary = path("b.ply");
  std::string text =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
      "property double z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
  const double xyz[6] = {1, 2, 3, 4, 5, 6};
  text.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
  block::test::write_text(binary, text);
  PointCloudOptions o;
  o.up = UpAxis::y;
  pts = read_point_cloud(binary, o);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0], Vec3(1, -3, 2));
  EXPECT_TRUE(is_point_cloud_file(binary));  // no faces

  const std::string mesh = path("m.ply");
  block::test::write_text(mesh, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_FALSE(is_point_cloud_file(mesh));
}

}  // namespace
}  // namespace talus::io
