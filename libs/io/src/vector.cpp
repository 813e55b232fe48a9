#include "talus/io/vector.hpp"

#include <cpl_string.h>
#include <ogr_api.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <set>

#include "gdal_support.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/raster.hpp"

namespace talus::io {
namespace {

using core::format_number;
using core::InputError;

struct FeatureCloser {
  void operator()(OGRFeatureH f) const {
    if (f) OGR_F_Destroy(f);
  }
};
using FeaturePtr = std::unique_ptr<std::remove_pointer_t<OGRFeatureH>, FeatureCloser>;

struct GeometryCloser {
  void operator()(OGRGeometryH g) const {
    if (g) OGR_G_DestroyGeometry(g);
  }
};
using GeometryPtr = std::unique_ptr<std::remove_pointer_t<OGRGeometryH>, GeometryCloser>;

OGRwkbGeometryType geometry_type(VectorGeometry g) {
  switch (g) {
    case VectorGeometry::point: return wkbPoint;
    case VectorGeometry::point_z: return wkbPoint25D;
    case VectorGeometry::line_string: return wkbLineString;
    case VectorGeometry::line_string_z: return wkbLineString25D;
    case VectorGeometry::multi_point: return wkbMultiPoint;
    case VectorGeometry::multi_line_string: return wkbMultiLineString;
    case VectorGeometry::multi_polygon: return wkbMultiPolygon;
  }
  return wkbUnknown;
}

OGRFieldType field_type(FieldType t) {
  switch (t) {
    case FieldType::integer: return OFTInteger64;
    case FieldType::real: return OFTReal;
    case FieldType::text: return OFTString;
  }
  return OFTString;
}

bool planar(VectorGeometry kind) { return kind != VectorGeometry::point_z && kind != VectorGeometry::line_string_z; }

bool finite_vertices(VectorGeometry kind, const std::vector<std::array<double, 3>>& vertices) {
  return std::all_of(vertices.begin(), vertices.end(), [&](const auto& v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && (planar(kind) || std::isfinite(v[2]));
  });
}

// A multi-geometry of `feature.parts`: points, polylines or polygons (rings closed here).
OGRGeometryH make_multi_geometry(VectorGeometry kind, const VectorFeature& feature) {
  GeometryPtr multi(OGR_G_CreateGeometry(geometry_type(kind)));
  for (const auto& part : feature.parts) {
    if (part.empty()) return nullptr;
    for (const auto& list : part)
      if (list.empty() || !finite_vertices(kind, list)) return nullptr;
    OGRGeometryH g = nullptr;
    if (kind == VectorGeometry::multi_point) {
      g = OGR_G_CreateGeometry(wkbPoint);
      OGR_G_SetPoint_2D(g, 0, part[0][0][0], part[0][0][1]);
    } else if (kind == VectorGeometry::multi_line_string) {
      g = OGR_G_CreateGeometry(wkbLineString);
      for (const auto& v : part[0]) OGR_G_AddPoint_2D(g, v[0], v[1]);
    } else {
      g = OGR_G_CreateGeometry(wkbPolygon);
      for (const auto& ring : part) {
        OGRGeometryH r = OGR_G_CreateGeometry(wkbLinearRing);
        for (const auto& v : ring) OGR_G_AddPoint_2D(r, v[0], v[1]);
        OGR_G_CloseRings(r);
        OGR_G_AddGeometryDirectly(g, r);
      }
    }
    OGR_G_AddGeometryDirectly(multi.get(), g);
  }
  return feature.parts.empty() ? nullptr : multi.release();
}

// The geometry of a written feature; null when it has no vertex or a non-finite one (a
// realization that failed numerically ends at NaN).
OGRGeometryH make_geometry(VectorGeometry kind, const VectorFeature& feature) {
  if (kind == VectorGeometry::multi_point || kind == VectorGeometry::multi_line_string ||
      kind == VectorGeometry::multi_polygon)
    return make_multi_geometry(kind, feature);
  const auto& vertices = feature.vertices;
  if (vertices.empty() || !finite_vertices(kind, vertices)) return nullptr;
  OGRGeometryH g = OGR_G_CreateGeometry(geometry_type(kind));
  if (kind == VectorGeometry::point) {
    OGR_G_SetPoint_2D(g, 0, vertices[0][0], vertices[0][1]);
  } else if (kind == VectorGeometry::point_z) {
    OGR_G_SetPoint(g, 0, vertices[0][0], vertices[0][1], vertices[0][2]);
  } else if (kind == VectorGeometry::line_string) {
    for (const auto& v : vertices) OGR_G_AddPoint_2D(g, v[0], v[1]);
  } else {
    for (const auto& v : vertices) OGR_G_AddPoint(g, v[0], v[1], v[2]);
  }
  return g;
}

void set_value(OGRFeatureH f, int index, const FieldValue& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) {
    OGR_F_SetFieldInteger64(f, index, *i);
  } else if (const auto* d = std::get_if<double>(&value); d && !std::isnan(*d)) {
    OGR_F_SetFieldDouble(f, index, *d);
  } else if (const auto* s = std::get_if<std::string>(&value)) {
    OGR_F_SetFieldString(f, index, s->c_str());
  } else {
    OGR_F_SetFieldNull(f, index);
  }
}

}  // namespace

void write_vector_file(const std::string& path, const std::string& format, const std::vector<VectorLayer>& layers,
                       const std::string& crs_wkt) {
  const bool gpkg = format == "gpkg";
  if (!gpkg && format != "geojson") throw core::RuntimeError(path + ": unknown vector format '" + format + "'");
  if (!gpkg && layers.size() != 1) throw core::RuntimeError(path + ": a GeoJSON file holds exactly one layer");
  AtomicOutput out(path);
  gdal::Quiet quiet;
  const char* driver_name = gpkg ? "GPKG" : "GeoJSON";
  GDALDriverH driver = GDALGetDriverByName(driver_name);
  if (!driver) throw core::RuntimeError(path + ": GDAL has no " + std::string(driver_name) + " driver");
  const gdal::SrsPtr srs = crs_wkt.empty() ? nullptr : gdal::parse_srs(crs_wkt);
  if (!crs_wkt.empty() && !srs) throw core::RuntimeError(path + ": the terrain's CRS cannot be read" + gdal::Quiet::last_message());
  // The temporary's name does not end in .gpkg; the driver only warns about that.
  gdal::DatasetPtr ds(GDALCreate(driver, out.temp_path().c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (!ds) throw core::RuntimeError(path + ": cannot create the file" + gdal::Quiet::last_message());
  const auto h = static_cast<GDALDatasetH>(ds.get());
  auto fail = [&](const std::string& what) {
    return core::RuntimeError(path + ": " + what + gdal::Quiet::last_message());
  };
  for (const VectorLayer& layer : layers) {
    char** options = nullptr;
    // GeoJSON: every double with the digits that read back to the same value (GDAL's
    // default of 15 would round coordinates of projected CRSs at the 1e-9 m level).
    if (!gpkg) options = CSLSetNameValue(options, "SIGNIFICANT_FIGURES", "17");
    OGRLayerH l = GDALDatasetCreateLayer(h, layer.name.c_str(), srs.get(), geometry_type(layer.geometry), options);
    CSLDestroy(options);
    if (!l) throw fail("cannot create layer '" + layer.name + "'");
    for (const VectorField& field : layer.fields) {
      OGRFieldDefnH defn = OGR_Fld_Create(field.name.c_str(), field_type(field.type));
      const OGRErr err = OGR_L_CreateField(l, defn, TRUE);
      OGR_Fld_Destroy(defn);
      if (err != OGRERR_NONE) throw fail("cannot create field '" + field.name + "' of layer '" + layer.name + "'");
    }
    // One transaction per layer: a GeoPackage commits each feature on its own otherwise.
    const bool transaction = GDALDatasetStartTransaction(h, FALSE) == OGRERR_NONE;
    OGRFeatureDefnH defn = OGR_L_GetLayerDefn(l);
    for (const VectorFeature& feature : layer.features) {
      if (feature.values.size() != layer.fields.size())
        throw core::RuntimeError(path + ": a feature of layer '" + layer.name + "' has " +
                                 std::to_string(feature.values.size()) + " values for " +
                                 std::to_string(layer.fields.size()) + " fields");
      FeaturePtr f(OGR_F_Create(defn));
      for (std::size_t k = 0; k < feature.values.size(); ++k) set_value(f.get(), static_cast<int>(k), feature.values[k]);
      if (OGRGeometryH g = make_geometry(layer.geometry, feature)) OGR_F_SetGeometryDirectly(f.get(), g);
      if (OGR_L_CreateFeature(l, f.get()) != OGRERR_NONE) throw fail("cannot write a feature of layer '" + layer.name + "'");
    }
    if (transaction && GDALDatasetCommitTransaction(h) != OGRERR_NONE) throw fail("cannot write layer '" + layer.name + "'");
  }
  if (gpkg && !srs) {
    // Without a CRS GDAL registers the layers as "Undefined geographic SRS" (srs_id 0),
    // which a GIS takes for degrees; the GeoPackage's undefined Cartesian SRS (-1) says
    // what the coordinates are: metres in an unknown plane frame.
    for (const char* sql : {"UPDATE gpkg_geometry_columns SET srs_id = -1", "UPDATE gpkg_contents SET srs_id = -1"}) {
      OGRLayerH result = GDALDatasetExecuteSQL(h, sql, nullptr, nullptr);
      if (result) GDALDatasetReleaseResultSet(h, result);
    }
    if (CPLGetLastErrorType() >= CE_Failure) throw fail("cannot mark the layers as without CRS");
  }
  ds.reset();  // closing flushes the file
  if (CPLGetLastErrorType() >= CE_Failure) throw fail("cannot write the file");
  out.commit();
}

namespace {

// The names of a dataset's layers, "a, b, c".
std::string layer_names(GDALDatasetH h) {
  std::string names;
  for (int k = 0; k < GDALDatasetGetLayerCount(h); ++k)
    names += (k ? ", " : "") + std::string(OGR_L_GetName(GDALDatasetGetLayer(h, k)));
  return names.empty() ? "none" : names;
}

std::string field_names(OGRFeatureDefnH defn) {
  std::string names;
  for (int k = 0; k < OGR_FD_GetFieldCount(defn); ++k)
    names += (k ? ", " : "") + std::string(OGR_Fld_GetNameRef(OGR_FD_GetFieldDefn(defn, k)));
  return names.empty() ? "none" : names;
}

// The geometry types a kind takes, for messages.
const char* accepted(const std::string& kind) {
  if (kind == "point") return "Point or MultiPoint";
  if (kind == "line") return "LineString or MultiLineString";
  return "Polygon or MultiPolygon";
}

// The vertices of a point string (a LineString or a polygon ring); a ring loses its
// closing vertex. Throws (via `bad`) on a non-finite coordinate.
template <class Bad>
std::vector<Eigen::Vector2d> vertices_of(OGRGeometryH g, bool ring, const Bad& bad) {
  std::vector<Eigen::Vector2d> out;
  const int n = OGR_G_GetPointCount(g);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d p(OGR_G_GetX(g, k), OGR_G_GetY(g, k));
    if (!p.allFinite()) bad("has a non-finite coordinate");
    out.push_back(p);
  }
  if (ring && out.size() > 1 && out.front() == out.back()) out.pop_back();
  return out;
}

// One part (a point, a line, a polygon) of a feature's geometry as vertex lists.
template <class Bad>
std::vector<std::vector<Eigen::Vector2d>> part_of(OGRGeometryH g, const std::string& kind, const Bad& bad) {
  if (OGR_G_IsEmpty(g)) bad("has an empty part");
  std::vector<std::vector<Eigen::Vector2d>> part;
  if (kind == "point") {
    part.push_back(vertices_of(g, false, bad));
  } else if (kind == "line") {
    part.push_back(vertices_of(g, false, bad));
    if (part.back().size() < 2) bad("has a line of fewer than 2 vertices");
  } else {
    for (int r = 0; r < OGR_G_GetGeometryCount(g); ++r) {
      part.push_back(vertices_of(OGR_G_GetGeometryRef(g, r), true, bad));
      if (part.back().size() < 3) bad("has a polygon ring of fewer than 3 vertices");
    }
  }
  return part;
}

// The part geometries of a feature's geometry, or a one-line reason it does not fit `kind`.
std::vector<OGRGeometryH> parts_of(OGRGeometryH g, const std::string& kind, std::string& wrong) {
  const OGRwkbGeometryType type = wkbFlatten(OGR_G_GetGeometryType(g));
  const OGRwkbGeometryType single = kind == "point" ? wkbPoint : kind == "line" ? wkbLineString : wkbPolygon;
  const OGRwkbGeometryType multi =
      kind == "point" ? wkbMultiPoint : kind == "line" ? wkbMultiLineString : wkbMultiPolygon;
  std::vector<OGRGeometryH> parts;
  if (type == single) {
    parts.push_back(g);
  } else if (type == multi) {
    for (int k = 0; k < OGR_G_GetGeometryCount(g); ++k) parts.push_back(OGR_G_GetGeometryRef(g, k));
  } else {
    wrong = std::string("is a ") + OGRGeometryTypeToName(type) + ", not a " + accepted(kind);
  }
  return parts;
}

// The first two parts of a MultiPolygon whose interiors overlap, "parts 1 and 3" (numbered
// from 1, in the file's order), or empty when none do (parts that only touch do not).
std::string overlapping_parts(const std::vector<OGRGeometryH>& parts) {
  for (std::size_t i = 0; i < parts.size(); ++i)
    for (std::size_t j = i + 1; j < parts.size(); ++j)
      if (OGR_G_Intersects(parts[i], parts[j]) && !OGR_G_Touches(parts[i], parts[j]))
        return "parts " + std::to_string(i + 1) + " and " + std::to_string(j + 1);
  return {};
}

// A GeoPackage's placeholders for "no CRS" (srs_id -1, undefined Cartesian, and 0,
// undefined geographic), as GDAL reports them: no CRS to compare.
bool undefined_crs(OGRSpatialReferenceH srs) {
  const char* name = OSRGetName(srs);
  return OSRIsLocal(srs) || (name && std::string(name).rfind("Undefined ", 0) == 0);
}

// "EPSG:2056", or a description when the CRS has no code.
std::string crs_argument(OGRSpatialReferenceH srs) {
  const char* authority = OSRGetAuthorityName(srs, nullptr);
  const char* code = OSRGetAuthorityCode(srs, nullptr);
  return authority && code ? std::string(authority) + ":" + code : std::string("'<the terrain's CRS as WKT>'");
}

// 64-bit FNV-1a of the features read (coordinates, weights, names), for the run's record
// of its inputs: a file changed between a run and its resume or merge is noticed.
std::string fingerprint(const std::vector<mc::PlanFeature>& features) {
  std::uint64_t h = 1469598103934665603ull;
  auto add = [&h](const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < size; ++k) h = (h ^ bytes[k]) * 1099511628211ull;
  };
  for (const auto& f : features) {
    add(f.name.data(), f.name.size());
    const double w = f.weight.value_or(-1.0);
    add(&w, sizeof w);
    for (const auto& part : f.parts)
      for (const auto& list : part) {
        const std::size_t n = list.size();
        add(&n, sizeof n);
        for (const auto& p : list) add(p.data(), 2 * sizeof(double));
      }
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

}  // namespace

std::vector<mc::PlanFeature> read_plan_features(const VectorRequest& request, const std::string& terrain_crs_wkt) {
  const std::string& path = request.path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "cannot open file (missing or not a regular file; named by " + request.key + ")");
  gdal::Quiet quiet;
  gdal::DatasetPtr ds(GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!ds)
    throw InputError(path, "cannot be read as a vector file (GeoPackage, GeoJSON, ESRI Shapefile or another format "
                           "GDAL reads)" + gdal::Quiet::last_message());
  const auto h = static_cast<GDALDatasetH>(ds.get());
  OGRLayerH layer = nullptr;
  if (request.layer.empty()) {
    if (GDALDatasetGetLayerCount(h) != 1)
      throw InputError(path, "holds " + std::to_string(GDALDatasetGetLayerCount(h)) + " layers (" + layer_names(h) +
                                 "): name one with the layer key beside " + request.key);
    layer = GDALDatasetGetLayer(h, 0);
  } else {
    layer = GDALDatasetGetLayerByName(h, request.layer.c_str());
    if (!layer) throw InputError(path, "has no layer '" + request.layer + "' (it has: " + layer_names(h) + ")");
  }
  const std::string layer_name = OGR_L_GetName(layer);
  OGRFeatureDefnH defn = OGR_L_GetLayerDefn(layer);
  auto field_index = [&](const std::string& name, bool numeric) {
    if (name.empty()) return -1;
    const int index = OGR_FD_GetFieldIndex(defn, name.c_str());
    if (index < 0)
      throw InputError(path, "layer '" + layer_name + "' has no field '" + name + "' (its fields: " +
                                 field_names(defn) + ")");
    const OGRFieldType type = OGR_Fld_GetType(OGR_FD_GetFieldDefn(defn, index));
    if (numeric && type != OFTInteger && type != OFTInteger64 && type != OFTReal)
      throw InputError(path, "field '" + name + "' of layer '" + layer_name + "' is not numeric (it holds " +
                                 OGR_GetFieldTypeName(type) + ")");
    return index;
  };
  const int weight_index = field_index(request.weight_field, true);
  const int name_index = field_index(request.name_field, false);

  std::vector<mc::PlanFeature> features;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = Eigen::Vector2d::Constant(-INFINITY);
  OGR_L_ResetReading(layer);
  while (FeaturePtr f{OGR_L_GetNextFeature(layer)}) {
    mc::PlanFeature feature;
    feature.label = "feature " + std::to_string(OGR_F_GetFID(f.get()));
    const std::string where = "layer '" + layer_name + "', " + feature.label;
    auto bad = [&](const std::string& what) { throw InputError(path, where + " " + what); };
    OGRGeometryH g = OGR_F_GetGeometryRef(f.get());
    if (!g) bad("has no geometry");
    if (OGR_G_IsEmpty(g)) bad("has an empty geometry");
    // Arcs (CircularString, CurvePolygon, MultiSurface … as GIS drawing tools make them)
    // become line segments, GDAL's default of one per 4 degrees of arc.
    GeometryPtr linear;
    if (OGR_G_HasCurveGeometry(g, TRUE)) {
      linear.reset(OGR_G_GetLinearGeometry(g, 0.0, nullptr));
      if (!linear) bad("has a curved geometry GDAL cannot turn into line segments");
      g = linear.get();
    }
    std::string wrong;
    std::vector<OGRGeometryH> parts = parts_of(g, request.kind, wrong);
    if (!wrong.empty()) bad(wrong + " (" + request.key + " takes " + accepted(request.kind) + " features)");
    // A MultiPolygon is one zone: parts that overlap would be drawn twice where they do,
    // so the zone is their union (GEOS through OGR), as a GIS's Dissolve would make it.
    GeometryPtr dissolved;
    if (request.kind == "polygon" && parts.size() > 1) {
      if (const std::string overlap = overlapping_parts(parts); !overlap.empty()) {
        dissolved.reset(OGR_G_UnionCascaded(g));
        if (!dissolved || OGR_G_IsEmpty(dissolved.get()))
          bad("has overlapping " + overlap + " that GDAL cannot merge" + gdal::Quiet::last_message() +
              ": fix the geometry (e.g. QGIS's Fix geometries, then Dissolve)");
        parts = parts_of(dissolved.get(), request.kind, wrong);
        if (!wrong.empty()) bad("has overlapping " + overlap + " whose union " + wrong);
        core::log_info(path + ": " + where + ": " + overlap + " overlap: the zone is their union (" +
                       std::to_string(parts.size()) + " part(s))");
      }
    }
    for (OGRGeometryH part : parts) {
      feature.parts.push_back(part_of(part, request.kind, bad));
      for (const auto& list : feature.parts.back())
        for (const auto& p : list) {
          lo = lo.cwiseMin(p);
          hi = hi.cwiseMax(p);
        }
    }
    if (weight_index >= 0) {
      if (!OGR_F_IsFieldSetAndNotNull(f.get(), weight_index))
        bad("has no value in the weight field '" + request.weight_field + "'");
      const double w = OGR_F_GetFieldAsDouble(f.get(), weight_index);
      if (!std::isfinite(w) || w < 0.0)
        bad("has weight " + format_number(w) + " in field '" + request.weight_field + "': weights must be finite and >= 0");
      feature.weight = w;
    }
    if (name_index >= 0) {
      if (OGR_F_IsFieldSetAndNotNull(f.get(), name_index)) feature.name = OGR_F_GetFieldAsString(f.get(), name_index);
      if (feature.name.empty()) bad("has no name in the field '" + request.name_field + "'");
    }
    features.push_back(std::move(feature));
  }
  if (features.empty()) throw InputError(path, "layer '" + layer_name + "' holds no features");

  // A layer in another CRS would put the zones in the wrong place: refused, not reprojected
  // (the user chooses how; ogr2ogr does it in one line).
  OGRSpatialReferenceH layer_srs = OGR_L_GetSpatialRef(layer);
  if (layer_srs && !undefined_crs(layer_srs) && !terrain_crs_wkt.empty()) {
    const gdal::SrsPtr terrain = gdal::parse_srs(terrain_crs_wkt);
    const gdal::SrsPtr mine = gdal::identified(layer_srs);
    if (terrain && mine && !OSRIsSame(terrain.get(), mine.get())) {
      const std::string target = crs_argument(terrain.get());
      std::string message = "layer '" + layer_name + "' is in CRS " + gdal::name_of(mine.get()) +
                            ", not in the terrain's CRS " + gdal::name_of(terrain.get()) +
                            ": reproject it, e.g. ogr2ogr -t_srs " + target + " out.gpkg " + path;
      // GeoJSON without a "crs" member is WGS 84 by definition (RFC 7946): a file written
      // in projected coordinates without one reads as degrees far out of range.
      if (OSRIsGeographic(mine.get()) && (lo.cwiseAbs().maxCoeff() > 360.0 || hi.cwiseAbs().maxCoeff() > 360.0))
        message += " (its coordinates are not degrees: if they are in the terrain's CRS already, assign it with "
                   "ogr2ogr -a_srs " + target + " out.gpkg " + path + ")";
      throw InputError(path, message);
    }
  }
  return features;
}

bool is_raster_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".asc" || ext == ".tif" || ext == ".tiff";
}

std::vector<mc::PlanFeature> read_release_raster(const std::string& path, const std::string& terrain_crs_wkt,
                                                 const std::array<double, 4>& extent) {
  const terrain::DemGrid cells = read_dem(path);
  // Cells in another CRS would release blocks in the wrong place: refused, as a vector layer.
  if (const DemCrs declared = dem_crs(path); !declared.text.empty() && !terrain_crs_wkt.empty()) {
    gdal::Quiet quiet;
    const gdal::SrsPtr terrain = gdal::parse_srs(terrain_crs_wkt), mine = gdal::parse_srs(declared.text);
    if (terrain && mine && !OSRIsSame(terrain.get(), mine.get()))
      throw InputError(path, "is in CRS " + gdal::name_of(mine.get()) + ", not in the terrain's CRS " +
                                 gdal::name_of(terrain.get()) + ": reproject it, e.g. gdalwarp -t_srs " +
                                 crs_argument(terrain.get()) + " -r near " + path + " out.tif");
  }
  const auto& g = cells.spec;
  std::vector<mc::PlanFeature> out;
  for (std::int32_t j = 0; j < g.ny; ++j)
    for (std::int32_t i = 0; i < g.nx; ++i) {
      const double v = cells.z[g.index(i, j)];
      if (std::isnan(v) || v == 0.0) continue;  // NODATA and 0: no release
      const double x = g.x0 + i * g.dx, y = g.y0 + j * g.dy;
      const std::string at = "cell (i=" + std::to_string(i) + ", j=" + std::to_string(j) + ") at (x=" +
                             format_number(x) + ", y=" + format_number(y) + ")";
      if (!(v > 0.0) || !std::isfinite(v))
        throw InputError(path, at + " has value " + format_number(v) +
                                   ": release densities must be finite and >= 0 (0 or NODATA: no release)");
      // The cell's square, cut to the terrain's plan box (a DEM's border points are cell
      // centres: half their cell lies off the terrain).
      const double x0 = std::max(x - 0.5 * g.dx, extent[0]), x1 = std::min(x + 0.5 * g.dx, extent[1]);
      const double y0 = std::max(y - 0.5 * g.dy, extent[2]), y1 = std::min(y + 0.5 * g.dy, extent[3]);
      if (!(x1 > x0 && y1 > y0)) continue;
      mc::PlanFeature f;
      f.label = at;
      f.weight = v * (x1 - x0) * (y1 - y0);
      f.parts = {{{Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0), Eigen::Vector2d(x1, y1), Eigen::Vector2d(x0, y1)}}};
      out.push_back(std::move(f));
    }
  if (out.empty()) throw InputError(path, "holds no release cell (value > 0) on the terrain");
  return out;
}

mc::SceneVectors read_scene_vectors(const mc::SceneSettings& settings, const terrain::Terrain& terrain) {
  const std::string& terrain_crs_wkt = terrain.crs_wkt;
  mc::SceneVectors out;
  auto record = [&out](const VectorRequest& r, const std::vector<mc::PlanFeature>& features) {
    out.inputs += r.path + " (" + r.key + ", " + (r.layer.empty() ? std::string("its only layer") : "layer '" + r.layer + "'") +
                  ", " + std::to_string(features.size()) +
                  " features, fingerprint " + fingerprint(features) + ")\n";
  };
  const mc::ReleaseSettings& rel = settings.release;
  if (!rel.file.empty() && is_raster_path(rel.file)) {
    if (rel.kind != "polygon")
      throw InputError(rel.file, "a raster of release cells gives release areas: set release.kind: polygon");
    if (!rel.layer.empty() || !rel.weight_field.empty())
      throw InputError(rel.file, "release.layer and release.weight_field are for vector files: a raster's "
                                 "values are the release densities");
    std::array<double, 4> extent = {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                                    std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (const auto& v : terrain.mesh.vertices) {
      extent = {std::min(extent[0], v.x() + terrain.origin_shift.x()), std::max(extent[1], v.x() + terrain.origin_shift.x()),
                std::min(extent[2], v.y() + terrain.origin_shift.y()), std::max(extent[3], v.y() + terrain.origin_shift.y())};
    }
    out.release = read_release_raster(rel.file, terrain_crs_wkt, extent);
    out.inputs += rel.file + " (release.file, raster, " + std::to_string(out.release.size()) +
                  " release cells, fingerprint " + fingerprint(out.release) + ")\n";
  } else if (!rel.file.empty()) {
    const VectorRequest r{rel.file, rel.layer, rel.weight_field, "", rel.kind, "release.file"};
    out.release = read_plan_features(r, terrain_crs_wkt);
    record(r, out.release);
  }
  for (std::size_t k = 0; k < settings.outputs.barriers.size(); ++k) {
    const mc::BarrierSettings& b = settings.outputs.barriers[k];
    out.barriers.emplace_back();
    if (b.file.empty()) continue;
    const VectorRequest r{b.file, b.layer, "", b.name_field, "line",
                          "outputs.barriers[" + std::to_string(k) + "].file"};
    out.barriers.back() = read_plan_features(r, terrain_crs_wkt);
    record(r, out.barriers.back());
  }
  return out;
}

}  // namespace talus::io
