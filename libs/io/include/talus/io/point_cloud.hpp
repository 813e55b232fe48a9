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
  /// LAS files: keep only the points of these classification codes (ASPRS: 2 ground, 3–5
  /// vegetation, 6 building, 7 low noise, 9 water …; 0 to 255); empty: every point.
  /// Other cloud formats carry no classes and ignore it.
  std::vector<int> las_classes;
};

/// Reads the points of a cloud file, by extension:
/// - `.xyz`, `.txt`, `.pts`, `.csv`: one point per line. When the first line that is not
///   blank or a comment starts with a number, x y z are the first three numbers of each
///   line (separated by spaces, tabs or commas; further columns such as colour are
///   ignored). Otherwise that line is a header naming the columns (`"X","Y","Z",…` as
///   PDAL writes it, or unquoted `x y z` / `X,Y,Z,…`): the columns named X, Y and Z (any
///   letter case, any order) are read from every following line and the others ignored.
///   Blank lines and lines starting with '#' or '//' are skipped;
/// - `.las`: an uncompressed LAS 1.0–1.4 file, point data record formats 0 to 10
///   (X, Y, Z × scale + offset), optionally only the points of `las_classes`;
///   `.laz` (and LAS files whose header marks them compressed) are refused with the
///   command that decompresses them;
/// - `.ply`: the x, y, z properties of the vertex element (ASCII or binary, any numeric
///   type); faces, if any, are ignored.
/// Throws core::InputError naming the file (and line, for text) on malformed input, and
/// on a file without points.
std::vector<geometry::Vec3> read_point_cloud(const std::string& path, const PointCloudOptions& options = {});

/// True if `path` has a point-cloud extension (.xyz, .txt, .pts, .csv, .las, .laz), or is
/// a PLY file without faces: block-gen then treats it as a cloud rather than a mesh.
bool is_point_cloud_file(const std::string& path);

/// The coordinate reference system a point cloud file declares.
struct DeclaredCrs {
  std::string text;     ///< WKT or "EPSG:n", for resolve_crs; empty when none is declared or usable
  std::string problem;  ///< why a declared CRS could not be taken (a user-defined GeoTIFF CRS); else empty
};

/// The CRS of a LAS file: the WKT of its OGC coordinate system record (user ID
/// "LASF_Projection", record ID 2112, in a VLR or an extended VLR), else "EPSG:n" from the
/// ProjectedCSTypeGeoKey (or GeographicTypeGeoKey) of its GeoTIFF key directory (record
/// 34735). Nothing for other cloud formats, which declare none. Throws core::InputError
/// naming the file when the LAS header or its records are malformed, and for LAZ.
DeclaredCrs point_cloud_crs(const std::string& path);

}  // namespace talus::io
