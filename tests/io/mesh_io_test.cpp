#include "talus/io/mesh_io.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

std::string temp_file(const std::string& name) {
  return talus::testing::temp_path("mesh_test", name);
}

// An ASCII STL stores each triangle's vertices separately: welding must share them.
TEST(MeshImport, StlIsWeldedAndYUpRotated) {
  const std::string path = temp_file("quad.stl");
  write_text_file(path, R"(solid quad
facet normal 0 1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 1 0 -1
 endloop
endfacet
facet normal 0 1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 -1
  vertex 0 0 -1
 endloop
endfacet
endsolid quad
)");
  MeshImportOptions options;
  options.up = UpAxis::y;
  const ImportedMesh m = import_mesh(path, options);
  EXPECT_EQ(m.mesh.vertices.size(), 4u);
  EXPECT_EQ(m.welded_vertices, 2u);
  ASSERT_EQ(m.mesh.triangles.size(), 2u);
  // y-up input: the quad lies in the input's x-z plane, facing +y, so in z-up it faces +z.
  EXPECT_GT(m.mesh.area_normal(0).z(), 0.0);
  std::filesystem::remove(path);
}

TEST(MeshImport, ErrorsNameTheFile) {
  const std::string empty = temp_file("empty.obj");
  write_text_file(empty, "");
  try {
    import_mesh(empty);
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_EQ(e.source(), empty);
  }
  const std::string points = temp_file("points.obj");
  write_text_file(points, "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_THROW(import_mesh(points), core::InputError);
  EXPECT_THROW(import_mesh(temp_file("missing.obj")), core::InputError);
  std::filesystem::remove(empty);
  std::filesystem::remove(points);
}

// A binary STL cut short is said to be so, from its header's triangle count.
TEST(MeshImport, TruncatedBinaryStlIsNamedSo) {
  // 80-byte header, a count of 2, then 50 bytes a triangle: 12 floats and 2 spare bytes.
  std::string data(80, ' ');
  data.replace(0, 6, "binary");
  const std::uint32_t count = 2;
  data.append(reinterpret_cast<const char*>(&count), 4);
  const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (int k = 0; k < 2; ++k) {
    data.append(reinterpret_cast<const char*>(tri), sizeof tri);
    data.append(2, '\0');
  }
  ASSERT_EQ(data.size(), 184u);
  const std::string whole = temp_file("whole.stl"), cut = temp_file("cut.stl"), stub = temp_file("stub.stl");
  write_text_file(whole, data);
  write_text_file(cut, data.substr(0, 150));
  write_text_file(stub, data.substr(0, 40));
  EXPECT_EQ(import_mesh(whole).mesh.triangles.size(), 2u);
  const auto message = [](const std::string& path) {
    try {
      import_mesh(path);
    } catch (const core::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(cut), cut + ": cannot read mesh: binary STL header counts 2 triangles (184 bytes) but the file "
                                "has 150 bytes (truncated?)");
  EXPECT_EQ(message(stub),
            stub + ": cannot read mesh: a binary STL of 40 bytes is shorter than its 84-byte header (truncated?)");
  for (const auto& path : {whole, cut, stub}) std::filesystem::remove(path);
}

TEST(MeshExport, ObjRoundTrips) {
  geometry::TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0.25}};
  mesh.triangles = {{0, 1, 2}};
  const std::string path = temp_file("tri.obj");
  export_mesh(path, mesh);
  const ImportedMesh back = import_mesh(path);
  ASSERT_EQ(back.mesh.vertices.size(), 3u);
  EXPECT_EQ(back.mesh.vertices[2].z(), 0.25);
  const std::string ply = temp_file("tri.ply");
  export_mesh(ply, mesh, {4});
  EXPECT_EQ(import_mesh(ply).mesh.triangles.size(), 1u);
  std::filesystem::remove(path);
  std::filesystem::remove(ply);
}

}  // namespace
}  // namespace talus::io
