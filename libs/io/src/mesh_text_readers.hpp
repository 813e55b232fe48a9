// SPDX-License-Identifier: MIT
#pragma once
// Private to talus_io: the double-precision mesh readers of point_cloud.cpp, used by
// import_mesh before it falls back to assimp.
#include <optional>
#include <string>

#include "talus/geometry/triangle_mesh.hpp"
#include "talus/io/mesh_io.hpp"

namespace talus::io::detail {

/// Reads OBJ, plain OFF, PLY (ASCII or binary) and ASCII STL in double precision (assimp
/// keeps coordinates as 32-bit floats, which rounds projected coordinates of 10⁵ m to
/// centimetres). Coordinates are scaled and turned to z-up; nothing is welded. Returns
/// nullopt for any other format (binary STL, glTF …). Throws core::InputError naming the
/// file and line on malformed input.
std::optional<geometry::TriangleMesh> read_mesh_in_double(const std::string& path, double scale, UpAxis up);

}  // namespace talus::io::detail
