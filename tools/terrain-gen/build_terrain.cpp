#include "build_terrain.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/io/mesh_io.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/point_cloud.hpp"
#include "talus/io/raster.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/vector.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/roughness.hpp"

namespace talus::terrain_gen {
namespace {

namespace fs = std::filesystem;
using core::format_number;
using core::InputError;
using geometry::Vec3;
using terrain::DemGrid;
using terrain::Terrain;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::optional<SourceKind> kind_of_extension(const std::string& path) {
  const std::string ext = io::lower_extension(path);
  if (io::is_dem_path(path)) return SourceKind::dem;
  if (ext == ".h5") return SourceKind::file;
  // Before the mesh extensions: a PLY file without faces is a cloud.
  if (io::is_point_cloud_file(path)) return SourceKind::points;
  if (ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".gltf" || ext == ".glb")
    return SourceKind::tin;
  return std::nullopt;
}

const char* kind_name(SourceKind kind) {
  switch (kind) {
    case SourceKind::synthetic: return "synthetic";
    case SourceKind::dem: return "dem";
    case SourceKind::tin: return "tin";
    case SourceKind::points: return "points";
    case SourceKind::file: return "terrain file";
  }
  return "?";
}

// The plan window to keep, in input coordinates (unbounded sides are infinite).
struct Window {
  double xmin = -kInf, ymin = -kInf, xmax = kInf, ymax = kInf;
  bool contains(double x, double y) const { return x >= xmin && x <= xmax && y >= ymin && y <= ymax; }
};

// What the summary and the up-axis check count as wall: steeper than this (degrees from
// horizontal).
constexpr double kWallSlope = 80.0;

// Whether a triangle of area normal n (of any length; none for a degenerate one) is
// steeper than kWallSlope.
bool is_wall(const Vec3& n) {
  const double length = n.norm();
  return length > 0.0 && n.z() <= std::cos(kWallSlope * std::numbers::pi / 180.0) * length;
}

io::UpAxis up_axis(const Settings& s) { return s.tin.up_axis == "y" ? io::UpAxis::y : io::UpAxis::z; }

// The crop window; unbounded when no side is given.
Window window_of(const Settings::Crop& crop, const core::SettingsOrigins& origins) {
  Window w;
  if (crop.xmin) w.xmin = *crop.xmin;
  if (crop.ymin) w.ymin = *crop.ymin;
  if (crop.xmax) w.xmax = *crop.xmax;
  if (crop.ymax) w.ymax = *crop.ymax;
  if (!(w.xmin < w.xmax && w.ymin < w.ymax))
    throw InputError(origins.of({"crop.xmin", "crop.xmax", "crop.ymin", "crop.ymax"}),
                     "crop: the window [" + format_number(w.xmin) + ", " + format_number(w.xmax) + "] x [" +
                         format_number(w.ymin) + ", " + format_number(w.ymax) +
                         "] is empty (need xmin < xmax and ymin < ymax)");
  return w;
}

// Keeps the triangles whose plan centroid lies in the window, and the vertices they use.
geometry::TriangleMesh crop_mesh(const geometry::TriangleMesh& mesh, const Window& w) {
  geometry::TriangleMesh out;
  std::vector<std::int32_t> remap(mesh.vertices.size(), -1);
  for (const auto& t : mesh.triangles) {
    const Vec3 c = (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
    if (!w.contains(c.x(), c.y())) continue;
    std::array<std::int32_t, 3> kept{};
    for (int k = 0; k < 3; ++k) {
      auto& id = remap[t[k]];
      if (id < 0) {
        id = static_cast<std::int32_t>(out.vertices.size());
        out.vertices.push_back(mesh.vertices[t[k]]);
      }
      kept[k] = id;
    }
    out.triangles.push_back(kept);
  }
  return out;
}

// Plan bounds of points, for the automatic origin shift.
struct PlanBounds {
  double xmin = kInf, ymin = kInf, xmax = -kInf, ymax = -kInf;
  void add(double x, double y) {
    xmin = std::min(xmin, x);
    ymin = std::min(ymin, y);
    xmax = std::max(xmax, x);
    ymax = std::max(ymax, y);
  }
};

// The shift subtracted from input coordinates. Auto: projected coordinates (beyond 1e5 m)
// keep about 1e-11 m of resolution in doubles but far less in the float32 some readers
// use; subtracting the lower-left corner rounded down to a kilometre keeps local
// coordinates small while leaving round numbers round.
Vec3 origin_shift(const Settings::Origin& origin, const PlanBounds& b) {
  if (origin.mode == "none") return Vec3::Zero();
  if (origin.mode == "given") return Vec3(origin.shift[0], origin.shift[1], origin.shift[2]);
  const double largest = std::max({std::abs(b.xmin), std::abs(b.xmax), std::abs(b.ymin), std::abs(b.ymax)});
  if (!(largest > 1e5)) return Vec3::Zero();
  return Vec3(std::floor(b.xmin / 1000.0) * 1000.0, std::floor(b.ymin / 1000.0) * 1000.0, 0.0);
}

terrain::Diagonal diagonal_of(const std::string& mode) {
  if (mode == "fixed") return terrain::Diagonal::fixed;
  if (mode == "random") return terrain::Diagonal::random;
  return terrain::Diagonal::alternating;
}

// The DEM of a DEM input or synthetic slope, cropped and trimmed, in input coordinates.
DemGrid input_dem(const Settings& s, SourceKind kind, const std::vector<std::string>& inputs,
                  const core::SettingsOrigins& origins) {
  DemGrid dem = kind == SourceKind::synthetic ? terrain::make_synthetic(s.synthetic, origins.within("synthetic"))
                                              : io::read_dem(inputs.front());
  const std::string& source = kind == SourceKind::synthetic ? origins.source() : inputs.front();
  if (s.crop.any()) {
    // Unbounded sides become the DEM's own extent: crop_dem wants a finite window.
    const Window w = window_of(s.crop, origins);
    const auto& g = dem.spec;
    const double x1 = g.x0 + (g.nx - 1) * g.dx, y1 = g.y0 + (g.ny - 1) * g.dy;
    dem = terrain::crop_dem(dem, std::max(w.xmin, g.x0), std::max(w.ymin, g.y0), std::min(w.xmax, x1),
                            std::min(w.ymax, y1), source);
  }
  return terrain::trim_nodata(dem);
}

void shift_dem(DemGrid& dem, const Vec3& shift) {
  dem.spec.x0 -= shift.x();
  dem.spec.y0 -= shift.y();
  if (shift.z() != 0.0)
    for (double& z : dem.z) z -= shift.z();
}

// Grid material of a resampled TIN: the material of the TIN triangle above each grid
// triangle's centroid (or above one of its corners at the border).
void carry_tin_materials(Terrain& grid, const terrain::Surface& tin) {
  std::size_t unmatched = 0;
  for (std::size_t t = 0; t < grid.mesh.triangles.size(); ++t) {
    const auto& tri = grid.mesh.triangles[t];
    const Vec3& a = grid.mesh.vertices[tri[0]];
    const Vec3& b = grid.mesh.vertices[tri[1]];
    const Vec3& c = grid.mesh.vertices[tri[2]];
    const Vec3 probes[] = {(a + b + c) / 3.0, a, b, c};
    std::int32_t material = -1;
    for (const Vec3& p : probes) {
      if (const auto hit = tin.height_at(p.x(), p.y())) {
        material = tin.material(static_cast<std::size_t>(hit->triangle));
        break;
      }
    }
    if (material < 0) {
      ++unmatched;
      material = 0;
    }
    grid.material_of_triangle[t] = material;
  }
  if (unmatched > 0)
    core::log_warn(std::to_string(unmatched) + " resampled triangles lie off the TIN; they take material 0");
}

// Materials of a TIN built from one file per material: each file's material takes the
// parameters of the settings entry of the same name; entries matching no file follow.
void merge_tin_materials(Terrain& t, const std::vector<terrain::Material>& configured) {
  std::set<std::string> used;
  for (auto& m : t.materials) {
    const auto it = std::find_if(configured.begin(), configured.end(),
                                 [&](const terrain::Material& c) { return c.name == m.name; });
    if (it != configured.end()) m = *it;
    used.insert(m.name);
  }
  for (const auto& c : configured)
    if (!used.count(c.name)) t.materials.push_back(c);
}

std::vector<terrain::MaterialZone> shifted_zones(const std::vector<terrain::MaterialZone>& zones, const Vec3& shift) {
  std::vector<terrain::MaterialZone> out = zones;
  for (auto& z : out)
    for (auto& p : z.polygon) {
      p[0] -= shift.x();
      p[1] -= shift.y();
    }
  return out;
}

}  // namespace

SourceKind resolve_source(const Settings& s, const std::vector<std::string>& inputs) {
  if (s.source == "synthetic" || (s.source == "auto" && inputs.empty())) {
    if (!inputs.empty())
      throw core::UsageError("source is synthetic but input files were given (" + inputs.front() + ")");
    return SourceKind::synthetic;
  }
  if (inputs.empty()) throw core::UsageError("source '" + s.source + "' needs input files (see --help)");
  std::optional<SourceKind> kind;
  if (s.source == "dem") kind = SourceKind::dem;
  if (s.source == "tin") kind = SourceKind::tin;
  if (s.source == "points") kind = SourceKind::points;
  if (!kind) {
    for (const auto& input : inputs) {
      const auto k = kind_of_extension(input);
      if (!k)
        throw core::UsageError("cannot tell the kind of input '" + input +
                               "' from its extension (.asc/.tif/.tiff: DEM; .stl/.obj/.ply/.off/.gltf/.glb: "
                               "mesh; .xyz/.txt/.pts/.csv: points; .h5: terrain file); set source");
      if (kind && *kind != *k)
        throw core::UsageError("inputs mix kinds: '" + inputs.front() + "' is " + kind_name(*kind) + ", '" + input +
                               "' is " + kind_name(*k));
      kind = k;
    }
  }
  if (*kind == SourceKind::dem && inputs.size() != 1)
    throw core::UsageError("a DEM terrain takes one DEM file, got " + std::to_string(inputs.size()));
  if (*kind == SourceKind::file && inputs.size() != 1)
    throw core::UsageError("give one terrain file to inspect, got " + std::to_string(inputs.size()));
  return *kind;
}

namespace {

// The diagonal mode a stored grid was built with, told from its diagonals.
std::string triangulation_of(const Terrain& t) {
  const auto& g = *t.grid;
  bool fixed = true, alternating = true;
  for (std::size_t c = 0; c < t.cell_diagonal.size(); ++c) {
    const std::size_t i = c % static_cast<std::size_t>(g.nx - 1), j = c / static_cast<std::size_t>(g.nx - 1);
    fixed = fixed && t.cell_diagonal[c] == 0;
    alternating = alternating && t.cell_diagonal[c] == (i + j) % 2;
  }
  return fixed ? "fixed" : alternating ? "alternating" : "random";
}

// σ from the settings (given directly or as R), after the checks that need no input.
double checked_sigma(const Settings& s, const core::SettingsOrigins& origins) {
  if (s.roughness.sigma && s.roughness.roughness_index)
    throw InputError(origins.of({"roughness.roughness_index", "roughness.sigma"}),
                     "roughness: give sigma or roughness_index, not both");
  if (s.roughness.sigma) {
    if (!(*s.roughness.sigma >= 0.0))
      throw InputError(origins.of("roughness.sigma"),
                       "roughness.sigma must be >= 0, got " + format_number(*s.roughness.sigma));
    return *s.roughness.sigma;
  }
  if (!s.roughness.roughness_index) return 0.0;
  try {
    return terrain::sigma_from_roughness_index(*s.roughness.roughness_index);
  } catch (const InputError& e) {
    throw InputError(origins.of("roughness.roughness_index"), "roughness.roughness_index " + e.detail());
  }
}

// Settings the library does not check itself, checked before any input is read.
void check_settings(const Settings& s, const core::SettingsOrigins& origins) {
  if (s.materials.empty()) throw InputError(origins.of("materials"), "materials: at least one material is needed");
  std::set<std::string> names;
  for (std::size_t m = 0; m < s.materials.size(); ++m)
    if (!names.insert(s.materials[m].name).second)
      throw InputError(origins.of("materials[" + std::to_string(m) + "].name"),
                       "materials[" + std::to_string(m) + "]: duplicate material name '" + s.materials[m].name + "'");
  if (s.tin.mode == "resample" && !(s.tin.cell_size > 0.0))
    throw InputError(origins.of("tin.cell_size"), "tin.cell_size must be > 0, got " + format_number(s.tin.cell_size));
  if (!(s.tin.scale > 0.0))
    throw InputError(origins.of("tin.scale"), "tin.scale must be > 0, got " + format_number(s.tin.scale));
  for (double c : s.tin.las_classes)
    if (!(c >= 0.0 && c <= 255.0 && c == std::floor(c)))
      throw InputError(origins.of("tin.las_classes"), "tin.las_classes: " + format_number(c) +
                                            " is not a LAS classification code (an integer from 0 to 255)");
}

// A grid TRN from a DEM file or the synthetic slope.
Terrain terrain_from_dem(const Settings& s, SourceKind kind, const std::vector<std::string>& inputs,
                         const core::SettingsOrigins& origins) {
  DemGrid dem = input_dem(s, kind, inputs, origins);
  const std::string& source = kind == SourceKind::synthetic ? origins.source() : inputs.front();
  if (dem.spec.nx < 2 || dem.spec.ny < 2)
    throw InputError(source, "no grid of at least 2 x 2 points with data remains (after crop and NODATA trim)");
  // Checked before the origin shift, so that a point without data is named in the DEM's
  // own coordinates.
  terrain::validate_dem(dem, source);
  PlanBounds b;
  b.add(dem.spec.x0, dem.spec.y0);
  b.add(dem.spec.x0 + (dem.spec.nx - 1) * dem.spec.dx, dem.spec.y0 + (dem.spec.ny - 1) * dem.spec.dy);
  const Vec3 shift = origin_shift(s.origin, b);
  shift_dem(dem, shift);
  Terrain t = terrain::build_grid_terrain(dem, diagonal_of(s.triangulation), s.seed, source);
  t.materials = s.materials;
  t.origin_shift = shift;
  return t;
}

// A grid of tin.cell_size sampling the highest point of a TIN, with the TIN's materials.
// A TIN whose footprint is not a rectangle leaves grid points without data inside the
// trimmed border: the result is then a TIN of the grid triangles with data at every corner
// (the same cut; nothing invented outside the survey).
Terrain resample_tin(const Terrain& tin, const Settings& s, const std::string& source,
                     const core::SettingsOrigins& origins) {
  const terrain::Surface surface = terrain::Surface::realize(tin, std::nullopt);
  const geometry::Aabb box = surface.bounds();
  terrain::GridSpec spec;
  spec.x0 = box.lo.x();
  spec.y0 = box.lo.y();
  spec.dx = spec.dy = s.tin.cell_size;
  const double nx = std::floor((box.hi.x() - box.lo.x()) / spec.dx + 1e-9) + 1.0;
  const double ny = std::floor((box.hi.y() - box.lo.y()) / spec.dy + 1e-9) + 1.0;
  if (nx * ny > 1e8)
    throw InputError(origins.of("tin.cell_size"), "tin.cell_size " + format_number(spec.dx) + " m gives " +
                                          format_number(nx * ny) + " grid points (more than 1e8)");
  spec.nx = static_cast<std::int32_t>(nx);
  spec.ny = static_cast<std::int32_t>(ny);
  const DemGrid dem = terrain::trim_nodata(terrain::resample_to_grid(surface, spec));
  if (dem.z.empty())
    throw InputError(origins.of("tin.cell_size"),
                     "tin.cell_size " + format_number(spec.dx) + " m: no grid point lies on the TIN");
  const auto missing = static_cast<std::size_t>(std::count_if(dem.z.begin(), dem.z.end(), [](double z) { return std::isnan(z); }));
  Terrain t;
  if (missing == 0) {
    t = terrain::build_grid_terrain(dem, diagonal_of(s.triangulation), s.seed, source);
  } else {
    t = terrain::build_grid_tin(dem, diagonal_of(s.triangulation), s.seed, source);
    core::log_warn(source + ": the TIN's footprint is not a rectangle: " + std::to_string(missing) + " of " +
                   std::to_string(dem.z.size()) + " grid points lie off it; resampled as a TIN of the " +
                   std::to_string(t.mesh.triangles.size()) + " grid triangles inside it");
  }
  t.materials = tin.materials;
  t.origin_shift = tin.origin_shift;
  carry_tin_materials(t, surface);
  return t;
}

// A TIN (kept or resampled) from mesh files, one material per file.
// A surveyed TIN read with the wrong up axis lies on its side: its elevations are then a
// horizontal coordinate (a northing of 10⁶ m), or nearly all of its surface is wall. Neither
// stops the build (a scan of a quarry face alone is three quarters wall), so both are
// warned about, naming tin.up_axis.
void warn_if_on_its_side(const Terrain& tin, const Settings& s, const std::string& source) {
  const geometry::Aabb box = tin.mesh.bounds();
  const double z_lo = box.lo.z() + tin.origin_shift.z(), z_hi = box.hi.z() + tin.origin_shift.z();
  // Below the deepest ocean floor or above the highest summit: not an elevation (m).
  constexpr double kLowest = -11000.0, kHighest = 9000.0;
  const std::string hint = " (tin.up_axis is " + s.tin.up_axis + "; meshing tools often write y up: set tin.up_axis: " +
                           (s.tin.up_axis == "y" ? "z" : "y") + " if the surface lies on its side)";
  if (z_lo < kLowest || z_hi > kHighest) {
    core::log_warn(source + ": elevations from " + format_number(z_lo) + " to " + format_number(z_hi) +
                   " m are no terrain's" + hint);
    return;
  }
  double wall = 0.0, total = 0.0;
  for (std::size_t k = 0; k < tin.mesh.triangles.size(); ++k) {
    const Vec3 n = tin.mesh.area_normal(k);
    total += n.norm();
    if (is_wall(n)) wall += n.norm();
  }
  if (total > 0.0 && wall > 0.9 * total)
    core::log_warn(source + ": " + format_number(std::round(100.0 * wall / total)) + " % of the surface is steeper than " +
                   format_number(kWallSlope) + " degrees" + hint);
}

Terrain terrain_from_meshes(const Settings& s, const std::vector<std::string>& inputs,
                            const core::SettingsOrigins& origins) {
  const io::MeshImportOptions options{.scale = s.tin.scale, .up = up_axis(s)};
  const Window w = window_of(s.crop, origins);
  std::vector<geometry::TriangleMesh> parts;
  std::vector<std::string> part_names;
  PlanBounds b;
  for (const auto& input : inputs) {
    geometry::TriangleMesh mesh = io::import_mesh(input, options).mesh;
    if (s.crop.any()) {
      mesh = crop_mesh(mesh, w);
      if (mesh.triangles.empty()) throw InputError(input, "no triangle of the mesh lies in the crop window");
    }
    for (const Vec3& p : mesh.vertices) b.add(p.x(), p.y());
    parts.push_back(std::move(mesh));
    const std::string stem = fs::path(input).stem().string();
    if (std::find(part_names.begin(), part_names.end(), stem) != part_names.end())
      throw InputError(input, "two mesh files are named '" + stem + "': each file is one material, named after it");
    part_names.push_back(stem);
  }
  const Vec3 shift = origin_shift(s.origin, b);
  for (auto& part : parts)
    for (Vec3& p : part.vertices) p -= shift;
  const std::string source = inputs.size() == 1 ? inputs.front() : "meshes";
  Terrain tin = terrain::build_tin_terrain(parts, part_names, source);
  merge_tin_materials(tin, s.materials);
  tin.origin_shift = shift;
  warn_if_on_its_side(tin, s, source);
  return s.tin.mode == "resample" ? resample_tin(tin, s, source, origins) : tin;
}

bool is_las(const std::string& path) {
  const std::string ext = io::lower_extension(path);
  return ext == ".las" || ext == ".laz";
}

// The CRS the point clouds declare (LAS files do), checked; clouds declaring different
// CRSs are refused. Empty when none declares one.
std::string declared_cloud_crs(const std::vector<std::string>& inputs) {
  std::string crs, from;
  for (const auto& input : inputs) {
    const io::DeclaredCrs declared = io::point_cloud_crs(input);
    if (!declared.problem.empty())
      core::log_warn(input + ": " + declared.problem + "; give the crs setting to record the CRS in the terrain file");
    if (declared.text.empty()) continue;
    const std::string wkt = io::resolve_crs(declared.text, input, io::CrsData::point_cloud);
    if (crs.empty()) {
      crs = wkt;
      from = input;
    } else if (wkt != crs && io::crs_name(wkt) != io::crs_name(crs)) {
      throw InputError(input, "CRS " + io::crs_name(wkt) + " differs from " + io::crs_name(crs) + " of " + from +
                                  ": reproject the point clouds to one CRS");
    }
  }
  return crs;
}

// A TIN by Delaunay triangulation of point clouds.
Terrain terrain_from_points(const Settings& s, const std::vector<std::string>& inputs,
                            const core::SettingsOrigins& origins) {
  io::PointCloudOptions options;
  options.scale = s.tin.scale;
  options.up = up_axis(s);
  for (double c : s.tin.las_classes) options.las_classes.push_back(static_cast<int>(c));
  const Window w = window_of(s.crop, origins);
  std::vector<Vec3> points;
  PlanBounds b;
  for (const auto& input : inputs) {
    if (!s.tin.las_classes.empty() && !is_las(input))
      core::log_warn(input + ": tin.las_classes selects LAS points by class; this file has no classes and is read whole");
    for (const Vec3& p : io::read_point_cloud(input, options)) {
      if (!w.contains(p.x(), p.y())) continue;
      b.add(p.x(), p.y());
      points.push_back(p);
    }
  }
  const std::string source = inputs.size() == 1 ? inputs.front() : "points";
  if (points.empty()) throw InputError(source, "no point lies in the crop window");
  // Delaunay runs on shifted coordinates: that is where the precision matters.
  const Vec3 shift = origin_shift(s.origin, b);
  for (Vec3& p : points) p -= shift;
  Terrain t = terrain::build_delaunay_terrain(points, source);
  t.materials = s.materials;
  t.origin_shift = shift;
  return t;
}

// The polygons of zone_file: each triangle whose plan centroid lies in a feature's polygon
// (outside its holes) takes the material the feature names; later features win. `crs` is
// the terrain's: a layer in another is refused (read_plan_features).
void assign_zone_file(Terrain& t, const Settings::ZoneFile& z, const std::string& crs) {
  io::VectorRequest request;
  request.path = z.file;
  request.layer = z.layer;
  request.name_field = z.material_field;
  request.kind = "polygon";
  request.key = "zone_file.file";
  const std::vector<mc::PlanFeature> features = io::read_plan_features(request, crs);
  std::vector<Vec3> centroids;
  for (const auto& tri : t.mesh.triangles)
    centroids.push_back((t.mesh.vertices[tri[0]] + t.mesh.vertices[tri[1]] + t.mesh.vertices[tri[2]]) / 3.0);
  const Eigen::Vector2d shift(t.origin_shift.x(), t.origin_shift.y());
  for (const mc::PlanFeature& f : features) {
    const auto named = std::find_if(t.materials.begin(), t.materials.end(),
                                    [&](const terrain::Material& m) { return m.name == f.name; });
    if (named == t.materials.end()) {
      std::string known;
      for (const auto& m : t.materials) known += (known.empty() ? "" : ", ") + m.name;
      throw InputError(z.file, f.label + ": material '" + f.name + "' (field '" + z.material_field +
                                   "') is not one of the materials (" + known + ")");
    }
    const auto id = static_cast<std::int32_t>(named - t.materials.begin());
    for (auto rings : f.parts) {
      Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (auto& ring : rings)
        for (auto& p : ring) {
          p -= shift;
          lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
        }
      // The box first: most triangles lie far from most polygons.
      for (std::size_t k = 0; k < centroids.size(); ++k) {
        const Eigen::Vector2d c = centroids[k].head<2>();
        if ((c.array() < lo.array()).any() || (c.array() > hi.array()).any()) continue;
        if (mc::point_in_rings(rings, c)) t.material_of_triangle[k] = id;
      }
    }
  }
}

// Material raster, zone file, then zones (all in input coordinates), over what the source gave.
void assign_materials(Terrain& t, const Settings& s, const core::SettingsOrigins& origins, const std::string& crs) {
  if (!s.material_raster.empty()) {
    DemGrid ids = io::read_dem(s.material_raster);
    shift_dem(ids, Vec3(t.origin_shift.x(), t.origin_shift.y(), 0.0));
    terrain::assign_material_raster(t, ids, s.material_raster);
  }
  if (!s.zone_file.file.empty()) assign_zone_file(t, s.zone_file, crs);
  if (!s.zones.empty()) terrain::assign_zones(t, shifted_zones(s.zones, t.origin_shift), origins.within("zones"));
}

std::string default_name(const Settings& s, SourceKind kind, const std::vector<std::string>& inputs) {
  if (kind == SourceKind::synthetic) return "synthetic-" + s.synthetic.kind;
  std::string name;
  for (const auto& input : inputs) name += (name.empty() ? "" : "+") + fs::path(input).stem().string();
  return name;
}

}  // namespace

Built build_terrain(const Settings& s, const std::vector<std::string>& inputs, const core::SettingsOrigins& origins) {
  Built built;
  built.kind = resolve_source(s, inputs);
  if (built.kind == SourceKind::file) {
    io::TerrainFileInfo info;
    built.terrain = io::read_terrain_file(inputs.front(), info);
    built.roughness_index = info.roughness_index;
    if (built.terrain.grid) built.triangulation = triangulation_of(built.terrain);
    return built;
  }
  // Settings first: a contradiction should not wait for a large input to be read.
  const double sigma = checked_sigma(s, origins);
  if (s.roughness.roughness_index) built.roughness_index = s.roughness.roughness_index;
  check_settings(s, origins);
  // The CRS before the inputs: a DEM in degrees is refused before it is read.
  std::string crs;
  const io::CrsData data = built.kind == SourceKind::points ? io::CrsData::point_cloud : io::CrsData::raster;
  if (!s.crs.empty()) crs = io::resolve_crs(s.crs, origins.of("crs"), data);
  else if (built.kind == SourceKind::dem) {
    if (const io::DemCrs declared = io::dem_crs(inputs.front()); !declared.text.empty())
      crs = io::resolve_crs(declared.text, declared.file);
  } else if (built.kind == SourceKind::points) {
    crs = declared_cloud_crs(inputs);
  }

  Terrain& t = built.terrain;
  switch (built.kind) {
    case SourceKind::synthetic:
    case SourceKind::dem: t = terrain_from_dem(s, built.kind, inputs, origins); break;
    case SourceKind::tin: t = terrain_from_meshes(s, inputs, origins); break;
    case SourceKind::points: t = terrain_from_points(s, inputs, origins); break;
    case SourceKind::file: break;
  }
  if (t.grid) built.triangulation = s.triangulation;
  // The R → σ table is that of a 2 m cell (SPEC §2): say so when it is used elsewhere.
  if (built.roughness_index && !(t.grid && t.grid->dx == 2.0 && t.grid->dy == 2.0))
    core::log_warn("roughness_index maps to sigma by the reference table for 2 m cells; this terrain has " +
                   (t.grid ? format_number(t.grid->dx) + " x " + format_number(t.grid->dy) + " m cells"
                           : std::string("no cells (TIN)")) +
                   ": give roughness.sigma to choose sigma for it");
  assign_materials(t, s, origins, crs);
  t.roughness.sigma = sigma;
  t.roughness.seed = s.seed;
  t.name = s.name.empty() ? default_name(s, built.kind, inputs) : s.name;
  t.crs_wkt = crs;
  if (const std::string problem = io::terrain_problem(t); !problem.empty())
    throw InputError(origins.source(), problem);
  return built;
}

std::string summary(const Built& built) {
  const Terrain& t = built.terrain;
  std::ostringstream out;
  auto num = [](double v) { return format_number(v); };
  out << "terrain: " << t.name << " (" << (t.grid ? "grid TRN" : "TIN") << ", from " << kind_name(built.kind)
      << ")\n";
  out << "points: " << t.mesh.vertices.size();
  if (t.grid) out << " (" << t.grid->nx << " x " << t.grid->ny << ")";
  out << ", triangles: " << t.mesh.triangles.size() << "\n";
  if (t.grid) {
    std::size_t cut0 = 0;
    for (auto d : t.cell_diagonal) cut0 += d == 0;
    out << "cell size: " << num(t.grid->dx) << " x " << num(t.grid->dy) << " m, triangulation: " << built.triangulation
        << " (" << cut0 << " cells cut (i,j)-(i+1,j+1), " << t.cell_diagonal.size() - cut0 << " cut (i+1,j)-(i,j+1))\n";
  } else {
    // Walls and overhangs: triangles steeper than kWallSlope (a quarry face surveyed at
    // 89.7° is a wall though its normal still points up), and of them those facing down.
    std::size_t steep = 0, down = 0;
    for (std::size_t k = 0; k < t.mesh.triangles.size(); ++k) {
      const Vec3 n = t.mesh.area_normal(k);
      if (!is_wall(n)) continue;
      ++steep;
      down += n.z() < 0.0;
    }
    out << "walls and overhangs: " << steep << " triangles steeper than " << num(kWallSlope) << " degrees, " << down
        << " of them facing down\n";
  }
  const geometry::Aabb box = t.mesh.bounds();
  out << "extent (local): x [" << num(box.lo.x()) << ", " << num(box.hi.x()) << "] m, y [" << num(box.lo.y()) << ", "
      << num(box.hi.y()) << "] m, z [" << num(box.lo.z()) << ", " << num(box.hi.z()) << "] m\n";
  const Vec3 lo = box.lo + t.origin_shift, hi = box.hi + t.origin_shift;
  out << "extent (input coordinates, the scene's): x [" << num(lo.x()) << ", " << num(hi.x()) << "] m, y ["
      << num(lo.y()) << ", " << num(hi.y()) << "] m, z [" << num(lo.z()) << ", " << num(hi.z()) << "] m\n";
  out << "CRS: " << io::crs_name(t.crs_wkt) << "\n";
  out << "origin shift: [" << num(t.origin_shift.x()) << ", " << num(t.origin_shift.y()) << ", "
      << num(t.origin_shift.z()) << "] m (added to local coordinates gives input coordinates)\n";
  out << "roughness: sigma " << num(t.roughness.sigma) << " m";
  if (built.roughness_index) out << " (R = " << num(*built.roughness_index) << ")";
  out << ", seed " << t.roughness.seed << "\n";
  std::vector<std::size_t> count(t.materials.size(), 0);
  for (std::int32_t m : t.material_of_triangle) ++count[static_cast<std::size_t>(m)];
  out << "materials: " << t.materials.size() << "\n";
  for (std::size_t m = 0; m < t.materials.size(); ++m) {
    const auto& p = t.materials[m];
    out << "  " << m << " " << p.name << ": " << count[m] << " triangles; ";
    if (p.class_name != "none") out << "class " << p.class_name << ", ";
    out << "R_v " << num(p.restitution_mean) << " (sd "
        << num(p.restitution_sd) << "), K " << num(p.restitution_scale) << " m/s, friction angle "
        << num(p.friction_angle_mean_deg) << " deg (sd of tan " << num(p.friction_coefficient_sd)
        << "), lateral tilt sd " << num(p.lateral_tilt_sd_deg) << " deg\n";
  }
  return out.str();
}

}  // namespace talus::terrain_gen
