// SPDX-License-Identifier: MIT
#pragma once
// Vector files through GDAL/OGR: the stop points, barrier crossings and trajectories that
// stats writes (GeoPackage, GeoJSON), and the release zones and barrier lines a scene may
// take from a file (any format OGR reads: GeoPackage, GeoJSON, ESRI Shapefile …). GDAL's
// headers stay in the .cpp.
#include <array>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "talus/mc/scene.hpp"

namespace talus::io {

/// The type of an attribute field of a written layer.
enum class FieldType { integer, real, text };

struct VectorField {
  std::string name;
  FieldType type = FieldType::real;
};

/// An attribute value; std::monostate (and a NaN real) is written as null.
using FieldValue = std::variant<std::monostate, std::int64_t, double, std::string>;

/// Geometry of the features of a written layer: plan points, points with z, plan
/// polylines, polylines with z, and the plan multi-geometries of release zones.
enum class VectorGeometry { point, point_z, line_string, line_string_z, multi_point, multi_line_string, multi_polygon };

struct VectorFeature {
  /// The point (one vertex) or the polyline's vertices (x, y, z; z unused for plan
  /// geometries). Empty, or any non-finite coordinate: the feature has no geometry.
  std::vector<std::array<double, 3>> vertices;
  std::vector<FieldValue> values;  ///< one per field of the layer, in order
  /// A multi-geometry's parts, each a list of vertex lists: a point (one list of one
  /// vertex), a polyline, or a polygon (outer ring, then holes; without the closing
  /// vertex). Used instead of `vertices` by the multi_* geometries.
  std::vector<std::vector<std::vector<std::array<double, 3>>>> parts{};
};

struct VectorLayer {
  std::string name;
  VectorGeometry geometry = VectorGeometry::point_z;
  std::vector<VectorField> fields;
  std::vector<VectorFeature> features;
};

/// Writes `layers` into one vector file at `path`: `format` "gpkg" (GeoPackage, any
/// number of layers) or "geojson" (GeoJSON, one layer). Every layer carries the CRS
/// `crs_wkt` (none when empty). Coordinates and reals are stored as doubles (GeoJSON
/// with 17 significant digits), so they read back exactly. Atomic (io::AtomicOutput);
/// throws core::RuntimeError naming the file when GDAL fails.
void write_vector_file(const std::string& path, const std::string& format, const std::vector<VectorLayer>& layers,
                       const std::string& crs_wkt);

/// What a scene asks of one vector file.
struct VectorRequest {
  std::string path;         ///< the file (relative to the working directory)
  std::string layer;        ///< layer name; empty: the file's only layer
  std::string weight_field; ///< numeric field of the feature weights (-); empty: none
  std::string name_field;   ///< text field of the feature names; empty: none
  /// The geometries taken: "point" (Point, MultiPoint), "line" (LineString,
  /// MultiLineString) or "polygon" (Polygon, MultiPolygon, holes kept).
  std::string kind = "polygon";
  std::string key;          ///< the scene key that named the file, for messages ("release.file")
};

/// Reads the features of a layer as plan geometry in the file's coordinates (z and m are
/// dropped). `terrain_crs_wkt` is the terrain's CRS: a layer whose CRS is known and not
/// the same (OSRIsSame, after completing ESRI definitions with their EPSG code) is refused
/// with the ogr2ogr command that reprojects it. Throws core::InputError naming the file
/// on a missing or unreadable file, an unknown layer or field, a layer without features,
/// a feature without geometry, of another kind, empty or non-finite, a missing, negative
/// or non-finite weight, a missing name.
std::vector<mc::PlanFeature> read_plan_features(const VectorRequest& request, const std::string& terrain_crs_wkt);

/// True when `path` names a raster (.asc, .tif, .tiff), as release.file may.
bool is_raster_path(const std::string& path);

/// The release cells of a raster (.asc or GeoTIFF, input coordinates): one square
/// polygon feature per cell of value > 0, weighted by value × cell area (the value is a
/// relative release density, 1 for a plain release cell), cut to the plan box `extent`
/// (x0, x1, y0, y1: the terrain's, input coordinates). Throws core::InputError naming the
/// file for a raster in another CRS than `terrain_crs_wkt` (with the gdalwarp command), a
/// negative value, or no cell > 0 on the terrain.
std::vector<mc::PlanFeature> read_release_raster(const std::string& path, const std::string& terrain_crs_wkt,
                                                 const std::array<double, 4>& extent);

/// The files a scene names (release.file: a vector file, or a raster of release cells;
/// outputs.barriers[].file), read and checked against the terrain's CRS; empty when it
/// names none. Throws as read_plan_features and read_release_raster.
mc::SceneVectors read_scene_vectors(const mc::SceneSettings& settings, const terrain::Terrain& terrain);

}  // namespace talus::io
