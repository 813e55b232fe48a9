#include "talus/io/mesh_io.hpp"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cerrno>
#include <filesystem>
#include <fstream>

#include "mesh_text_readers.hpp"
#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/paths.hpp"

namespace talus::io {

namespace {

// Why a file named .stl that assimp cannot read is no STL, when its size tells: a
// binary STL is an 80-byte header, a 4-byte triangle count n and 50 bytes a triangle
// (84 + 50·n bytes). Empty when the size does not tell (an ASCII STL, a right size).
std::string stl_size_problem(const std::string& path) {
  if (lower_extension(path) != ".stl") return {};
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return {};
  std::ifstream in(path, std::ios::binary);
  char head[84] = {};
  in.read(head, sizeof head);
  if (std::string(head, std::min<std::size_t>(5, static_cast<std::size_t>(size))) == "solid" && size < 84) return {};
  if (size < 84)
    return "a binary STL of " + std::to_string(size) + " bytes is shorter than its 84-byte header (truncated?)";
  std::uint32_t count = 0;
  std::memcpy(&count, head + 80, 4);  // little-endian, as STL stores it and x86 reads it
  const std::uint64_t expected = 84 + 50ULL * count;
  if (expected == size) return {};
  if (std::string(head, 5) == "solid") return {};  // an ASCII STL: assimp's message stands
  return "binary STL header counts " + std::to_string(count) + " triangles (" + std::to_string(expected) +
         " bytes) but the file has " + std::to_string(size) + " bytes" + (size < expected ? " (truncated?)" : "");
}

// Every triangle of a scene through assimp (32-bit float coordinates), meshes merged.
ImportedMesh import_with_assimp(const std::string& path, const MeshImportOptions& options) {
  Assimp::Importer importer;
  // Points and lines are removed; polygons are split into triangles.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_PreTransformVertices | aiProcess_SortByPType);
  if (!scene || !scene->mRootNode) {
    if (const std::string stl = stl_size_problem(path); !stl.empty())
      throw core::InputError(path, "cannot read mesh: " + stl);
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "unreadable mesh";
    throw core::InputError(path, "cannot read mesh: " + why);
  }
  ImportedMesh out;
  auto& mesh = out.mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* src = scene->mMeshes[m];
    if (!(src->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    ++out.source_meshes;
    const auto base = static_cast<std::int32_t>(mesh.vertices.size());
    for (unsigned v = 0; v < src->mNumVertices; ++v) {
      const aiVector3D& p = src->mVertices[v];
      geometry::Vec3 q(p.x, p.y, p.z);
      if (options.up == UpAxis::y) q = geometry::Vec3(p.x, -p.z, p.y);
      q *= options.scale;
      if (!q.allFinite()) throw core::InputError(path, "non-finite vertex coordinate");
      mesh.vertices.push_back(q);
    }
    for (unsigned f = 0; f < src->mNumFaces; ++f) {
      const aiFace& face = src->mFaces[f];
      if (face.mNumIndices != 3) continue;
      mesh.triangles.push_back({base + static_cast<std::int32_t>(face.mIndices[0]),
                                base + static_cast<std::int32_t>(face.mIndices[1]),
                                base + static_cast<std::int32_t>(face.mIndices[2])});
    }
  }
  return out;
}

}  // namespace

void check_coordinates(const std::vector<geometry::Vec3>& points, const std::string& path, const char* what) {
  for (std::size_t k = 0; k < points.size(); ++k) {
    const geometry::Vec3& p = points[k];
    if (p.allFinite() && p.cwiseAbs().maxCoeff() <= kMaxCoordinate) continue;
    throw core::InputError(path, std::string(what) + " " + std::to_string(k) + " (" + core::format_number(p.x()) + ", " +
                                     core::format_number(p.y()) + ", " + core::format_number(p.z()) +
                                     ") m after scaling: coordinates must be finite and in [-1e9, 1e9] m (check the "
                                     "scale setting)");
  }
}

ImportedMesh import_mesh(const std::string& path, const MeshImportOptions& options) {
  if (!std::filesystem::is_regular_file(path)) throw core::InputError(path, "cannot open mesh file");
  if (std::filesystem::file_size(path) == 0) throw core::InputError(path, "empty mesh file");
  ImportedMesh out;
  if (auto mesh = detail::read_mesh_in_double(path, options.scale, options.up)) {
    out.mesh = std::move(*mesh);
    out.source_meshes = 1;
  } else {
    out = import_with_assimp(path, options);
  }
  auto& mesh = out.mesh;
  if (mesh.triangles.empty()) throw core::InputError(path, "mesh has no triangles");
  check_coordinates(mesh.vertices, path, "vertex");
  if (options.weld) {
    double tol = options.weld_tolerance;
    if (tol <= 0.0) tol = 1e-9 * std::max(mesh.bounds().extent().norm(), 1e-300);
    const std::size_t before = mesh.triangles.size();
    out.welded_vertices = geometry::weld_vertices(mesh, tol);
    out.dropped_triangles = before - mesh.triangles.size();
    if (mesh.triangles.empty()) throw core::InputError(path, "every triangle is degenerate");
  }
  return out;
}

void export_mesh(const std::string& path, const geometry::TriangleMesh& mesh,
                 const std::vector<std::int32_t>& face_values) {
  const std::string ext = std::filesystem::path(path).extension().string();
  AtomicOutput out(path);
  {
    errno = 0;
    std::ofstream file(out.temp_path(), std::ios::binary);
    if (ext == ".obj") {
      char line[128];
      for (const auto& p : mesh.vertices) {
        std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
        file << line;
      }
      for (const auto& t : mesh.triangles) file << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    } else if (ext == ".ply") {
      const bool with_values = !face_values.empty();
      if (with_values && face_values.size() != mesh.triangles.size())
        throw core::RuntimeError(path + ": face value count does not match triangles");
      file << "ply\nformat binary_little_endian 1.0\ncomment written by Talus\n"
           << "element vertex " << mesh.vertices.size() << "\n"
           << "property double x\nproperty double y\nproperty double z\n"
           << "element face " << mesh.triangles.size() << "\n"
           << "property list uchar int vertex_indices\n";
      if (with_values) file << "property int material\n";
      file << "end_header\n";
      // Talus supports little-endian hosts only (checked at configure time).
      for (const auto& p : mesh.vertices) file.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(double));
      for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const unsigned char n = 3;
        file.write(reinterpret_cast<const char*>(&n), 1);
        file.write(reinterpret_cast<const char*>(mesh.triangles[t].data()), 3 * sizeof(std::int32_t));
        if (with_values) file.write(reinterpret_cast<const char*>(&face_values[t]), sizeof(std::int32_t));
      }
    } else {
      throw core::UsageError(path + ": mesh export supports .obj and .ply");
    }
    file.close();
    if (!file) throw core::RuntimeError(path + ": cannot write mesh" + write_cause());
  }
  out.commit();
}

}  // namespace talus::io
