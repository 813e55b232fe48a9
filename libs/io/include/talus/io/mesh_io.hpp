// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "talus/geometry/triangle_mesh.hpp"

namespace talus::io {

/// Which input axis points up. Talus works with z up; meshing tools often write y up.
enum class UpAxis { z, y };

struct MeshImportOptions {
  double scale = 1.0;          ///< multiplies coordinates (-), e.g. 0.001 for mm files
  UpAxis up = UpAxis::z;       ///< input up axis; y-up input is rotated to z-up
  bool weld = true;            ///< merge coincident vertices (STL stores none shared)
  double weld_tolerance = 0.0; ///< absolute merge distance (m); 0 = 1e-9 × bounding-box diagonal
};

struct ImportedMesh {
  geometry::TriangleMesh mesh;
  std::size_t source_meshes = 0;      ///< meshes of the scene that were merged
  std::size_t welded_vertices = 0;    ///< vertices removed by welding
  std::size_t dropped_triangles = 0;  ///< triangles degenerate after welding
};

/// Reads every triangle of a mesh file. OBJ, plain OFF, PLY and ASCII STL are parsed in
/// double precision (a scan or survey in projected coordinates keeps every digit); other
/// formats (binary STL, glTF …) go through assimp, with node transforms applied and all
/// meshes merged, in its 32-bit float precision. Throws core::InputError naming the file
/// (and line, for the text formats) when it cannot be read or holds no triangles.
ImportedMesh import_mesh(const std::string& path, const MeshImportOptions& options = {});

/// Largest coordinate magnitude a mesh, point cloud or raster may have after scaling (m):
/// projected coordinates stay below 1e8 m; beyond 1e9 m products of coordinates in
/// volumes and inertias leave the double range.
inline constexpr double kMaxCoordinate = 1e9;

/// Throws core::InputError naming `path`, the point and the limit for the first point
/// with a non-finite coordinate or one beyond kMaxCoordinate.
void check_coordinates(const std::vector<geometry::Vec3>& points, const std::string& path, const char* what);

/// Writes a triangle mesh as OBJ or binary PLY, chosen by the extension, atomically.
/// For PLY, `face_values` (if not empty, one per triangle) is stored as the integer face
/// property "material".
void export_mesh(const std::string& path, const geometry::TriangleMesh& mesh,
                 const std::vector<std::int32_t>& face_values = {});

}  // namespace talus::io
