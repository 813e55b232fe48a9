// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "talus/geometry/types.hpp"
#include "talus/io/mesh_io.hpp"

namespace talus::io {

struct PointCloudOptions {
  double scale = 1.0;     ///< multiplies coordinates (−), e.g. 0.001 for mm files
  UpAxis up = UpAxis::z;  ///< input up axis; y-up input is rotated to z-up
};

/// Reads the points of a cloud file, by extension:
/// - `.xyz`, `.txt`, `.pts`, `.csv`: one point per line. When the first line that is not
///   blank or a comment starts with a number, x y z are the first three numbers of each
///   line (separated by spaces, tabs or commas; further columns such as colour are
///   ignored). Otherwise that line is a header naming the columns (`"X","Y","Z",…` as
///   PDAL writes it, or unquoted `x y z` / `X,Y,Z,…`): the columns named X, Y and Z (any
///   letter case, any order) are read from every following line and the others ignored.
///   Blank lines and lines starting with '#' or '//' are skipped;
/// - `.ply`: the x, y, z properties of the vertex element (ASCII or binary, any numeric
///   type); faces, if any, are ignored.
/// Throws core::InputError naming the file and line on malformed input, and on a file
/// without points.
std::vector<geometry::Vec3> read_point_cloud(const std::string& path, const PointCloudOptions& options = {});

/// True if `path` has a point-cloud extension (.xyz, .txt, .pts, .csv), or is a PLY file
/// without faces: block-gen then treats it as a cloud rather than a mesh.
bool is_point_cloud_file(const std::string& path);

}  // namespace talus::io
