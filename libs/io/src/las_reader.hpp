// SPDX-License-Identifier: MIT
#pragma once
// Private to talus_io: the LAS reader behind read_point_cloud and point_cloud_crs.
#include <string>
#include <vector>

#include "talus/geometry/types.hpp"
#include "talus/io/point_cloud.hpp"

namespace talus::io::detail {

/// True for the extensions of LAS (.las) and of compressed LAS (.laz), any letter case.
bool is_las_extension(const std::string& ext);

/// The points of an uncompressed LAS 1.0–1.4 file, point data record formats 0 to 10:
/// X, Y, Z × scale + offset, in file order; only those whose classification is one of
/// `classes` when it is not empty. Refuses `.laz` and a header marked compressed with the
/// commands that decompress the file. Throws core::InputError naming the file on a
/// malformed or truncated file, and when no point is left.
std::vector<geometry::Vec3> read_las(const std::string& path, const std::vector<int>& classes);

/// The CRS a LAS file declares (point_cloud_crs).
DeclaredCrs las_crs(const std::string& path);

}  // namespace talus::io::detail
