#include "talus/mc/scene.hpp"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <utility>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/terrain/material_classes.hpp"

namespace talus::mc {

using core::format_number;
using core::InputError;

// Realization indices are 32-bit (the random streams' counters): at most 2^32 − 1 of them.
constexpr double kMaxRealizations = 4294967295.0;

void MaterialOverride::visit(core::SettingsVisitor& v) {
  v.field("name", name, "name of the terrain file's material to override");
  terrain::visit_material_class(v, class_name, nullptr);
  terrain::Material::visit_properties(v, *this);
}

void ReleaseSettings::visit(core::SettingsVisitor& v) {
  v.choice("kind", kind, {"point", "line", "polygon"},
           "release zone: one or more points (each realization draws one, all equally likely), a polyline "
           "(uniform along it) or a polygon (uniform inside)");
  v.field("points", points, "m", "plan [x, y] of the points, the line's vertices or the polygon's");
  v.field("file", file,
          "vector file of release features instead of points (GeoPackage, GeoJSON, Shapefile …; points, lines or "
          "polygons as kind says, in the terrain's input coordinates and CRS), or a raster of release cells (.asc, "
          ".tif; kind polygon; a cell's value > 0 is its relative release density per m2, 0 or NODATA none); "
          "empty = points");
  v.field("layer", layer, "layer of the vector file; empty = its only layer");
  v.field("weight_field", weight_field,
          "numeric field of the features' relative weights (-, >= 0): each realization draws a feature with "
          "probability proportional to it; empty = proportional to the feature's area, length or point count");
  // A fall from 10 km already reaches the step limit; far higher ones run for hours.
  v.bounded("height", height, "m",
            "height above the realized ground: of the centroid at the release point (height_reference "
            "centroid) or of the block's lowest point above the ground under it (lowest_point; 0 = touching); "
            "with height_reference elevation, the centroid's elevation in the scene's frame (a drop test from a "
            "fixed height)",
            core::Range::symmetric(1e4));
  v.choice("height_reference", height_reference, {"centroid", "lowest_point", "elevation"},
           "what height measures: the centroid above the ground, the gap under the block lowered vertically "
           "onto the ground, or the centroid's absolute elevation");
  v.choice("clearance", clearance, {"refuse", "lift"},
           "a centroid-placed block in the ground (or nearer than clearance_gap): refuse the scene, "
           "or lift the block vertically just enough");
  v.bounded("clearance_gap", clearance_gap, "m",
          "vertical gap required between a centroid-placed block and the ground (refused or lifted below it)",
            core::Range::closed(0.0, 1e3));
  v.choice("orientation", orientation, {"random", "fixed", "list"},
           "block orientation: uniform random rotation per realization, orientation_deg, or the rows of "
           "orientation_file (realization i: row floor(i/B) mod N with block_selection cycle over B blocks, "
           "else i mod N)");
  v.bounded("orientation_deg", orientation_deg, "deg",
            "fixed orientation: z-y-x Euler angles (yaw about z, pitch about y, roll about x)",
            core::Range::symmetric(360.0));
  v.field("orientation_file", orientation_file,
          "text file of orientations for orientation list, one per row (body to world, in the block file's body "
          "axes); a header row and # comments are skipped");
  v.choice("orientation_format", orientation_format, {"quaternion", "euler_zyx_deg"},
           "orientation_file rows: quaternion w x y z (scalar first, unit norm) or z-y-x Euler angles in deg");
  v.choice("orientation_up_axis", orientation_up_axis, {"z", "y"},
           "y: the orientations are in y-up axes (a mesh read with block-gen input.up_axis y)");
  v.bounded("velocity", velocity, "m/s", "initial centroid velocity", core::Range::symmetric(1e3));
  v.bounded("angular_velocity", angular_velocity, "rad/s", "initial spin (world frame)", core::Range::symmetric(1e3));
  v.bounded("main_direction_deg", main_direction_deg, "deg",
            "azimuth of the main slope direction from +x, counter-clockwise (runout along it)",
            core::Range::symmetric(360.0));
}

void StochasticSettings::visit(core::SettingsVisitor& v) {
  v.field("roughness", roughness, "redraw the ground roughness for each realization (off: smooth base)");
  v.field("restitution", restitution, "draw R_v per impact (off: the material mean)");
  v.field("friction", friction, "draw the friction coefficient per impact (off: the mean angle)");
  v.field("lateral_tilt", lateral_tilt, "draw a lateral ground tilt per impact (off: none)");
}

void BarrierSettings::visit(core::SettingsVisitor& v) {
  v.field("name", name, "barrier name");
  v.field("line", line, "m", "plan polyline [x, y] of the barrier (at least 2 vertices)");
  v.field("file", file,
          "vector file of barrier lines instead of line (LineString features in the terrain's input coordinates "
          "and CRS): one barrier per line; empty = line");
  v.field("layer", layer, "layer of the vector file; empty = its only layer");
  v.field("name_field", name_field,
          "text field naming each line of the file; empty = name (else layer, else the file's stem), numbered by feature");
}

void StopZoneSettings::visit(core::SettingsVisitor& v) {
  v.field("name", name, "zone name (e.g. 'bench 1')");
  v.field("x_range", x_range, "m", "[x_min, x_max): the zone is this x-interval (or give polygon)");
  v.field("polygon", polygon, "m", "plan polygon [x, y] of the zone (or give x_range)");
}

void OutputSettings::visit(core::SettingsVisitor& v) {
  v.bounded("hazard_cell_size", hazard_cell_size, "m",
            "cell of the hazard-map accumulators (reach, energy and height quantiles); 0 = none",
            core::Range{0.0, std::numeric_limits<double>::infinity()});
  v.bounded("hazard_relative_accuracy", hazard_relative_accuracy, "-",
            "relative error of the per-cell energy and height quantiles", core::Range{0.0, 0.5, true, true});
  v.list_of("barriers", "barrier lines: every crossing is recorded", barriers);
  v.bounded("chunk", chunk, "-", "realizations written to disk together (a crash loses at most one chunk)",
            core::Range::closed(1.0, kMaxRealizations));
}

void SceneSettings::visit(core::SettingsVisitor& v) {
  v.field("schema_version", schema_version, "scene schema version (this build reads 1.x)");
  v.field("terrain", terrain, "terrain file (terrain-gen output)");
  v.choice("frame", frame, {"input", "local"},
           "frame of the scene's plan coordinates (release points, barriers, stop zones): input = the terrain's "
           "input coordinates (those of its DEM, mesh or point cloud); local = the terrain file's shifted frame "
           "(input minus its origin_shift)");
  v.field("block_file", block_file, "block file (block-gen output; one block or a library)");
  v.field("blocks", blocks, "names of the library's blocks to use; empty = all");
  v.choice("block_selection", block_selection, {"cycle", "weighted"},
           "weighted: each realization draws a block with the library's weights (weight 0: never); "
           "cycle: realization i uses block i mod B");
  v.list_of("materials", "overrides of the terrain file's materials, by name", materials);
  v.section("release", "release conditions", [this](core::SettingsVisitor& s) { release.visit(s); });
  v.section("engine", "DDA numerical and physical settings", [this](core::SettingsVisitor& s) { engine.visit(s); });
  v.section("stochastic", "random ingredients (each can be switched off)",
            [this](core::SettingsVisitor& s) { stochastic.visit(s); });
  v.bounded("realizations", realizations, "-", "number of realizations (0 … n-1)",
            core::Range::closed(1.0, kMaxRealizations));
  v.field("seed", seed, "-", "master seed of the release, block and impact draws");
  v.section("outputs", "what is recorded besides the per-realization summary",
            [this](core::SettingsVisitor& s) { outputs.visit(s); });
  v.list_of("stop_zones", "named zones classifying where blocks stop (first match wins)", stop_zones);
}

std::int64_t HazardGridSpec::cell(double x, double y) const {
  if (size <= 0.0) return -1;
  const double fx = std::floor((x - x0) / size);
  const double fy = std::floor((y - y0) / size);
  if (!(fx >= 0.0 && fy >= 0.0 && fx < nx && fy < ny)) return -1;
  return static_cast<std::int64_t>(fy) * nx + static_cast<std::int64_t>(fx);
}

std::string extent_text(const geometry::Aabb& b, const Eigen::Vector2d& shift) {
  return "x in [" + format_number(b.lo.x() + shift.x()) + ", " + format_number(b.hi.x() + shift.x()) + "], y in [" +
         format_number(b.lo.y() + shift.y()) + ", " + format_number(b.hi.y() + shift.y()) + "]";
}

std::string local_frame_hint(const Eigen::Vector2d& shift, const std::string& where) {
  return "; it lies " + where + " the terrain in its local frame (input coordinates minus the origin shift [" +
         format_number(shift.x()) + ", " + format_number(shift.y()) + "])";
}

std::string observed_stop_off_terrain(const terrain::Surface& base, const Eigen::Vector2d& p,
                                     const Eigen::Vector2d& shift) {
  const Eigen::Vector2d local = p - shift;
  if (base.height_at(local.x(), local.y())) return "";
  const geometry::Aabb& b = base.bounds();
  const bool within = local.x() >= b.lo.x() && local.x() <= b.hi.x() && local.y() >= b.lo.y() && local.y() <= b.hi.y();
  std::string hint;
  if (shift.squaredNorm() > 0.0 && base.height_at(p.x(), p.y()))
    hint = local_frame_hint(shift, "inside") + ": give the observed stops in the terrain's input coordinates";
  return (within ? " has no terrain under it (a hole or gap in the terrain's surface; " : " is outside the terrain (") +
         std::string("input coordinates: ") + extent_text(b, shift) + "): no simulated block can stop there" + hint;
}

namespace {

bool finite_points(const std::vector<std::array<double, 2>>& points) {
  for (const auto& p : points)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) return false;
  return true;
}

std::string point_text(const std::array<double, 2>& p) {
  return "(" + format_number(p[0]) + ", " + format_number(p[1]) + ")";
}

std::vector<Eigen::Vector2d> to_vectors(const std::vector<std::array<double, 2>>& points) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : points) out.emplace_back(p[0], p[1]);
  return out;
}

double polygon_area(const std::vector<Eigen::Vector2d>& poly) {
  double a = 0.0;
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const auto& p = poly[k];
    const auto& q = poly[(k + 1) % poly.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

// The first pair of edges of a closed ring that meet though they are not neighbours
// (the ring crosses or touches itself: its area and inside are then not what was drawn),
// as "edges i and j" (1-based, edge k from vertex k to k + 1); empty when there is none.
// Exact orientation signs on the given doubles; O(n²), rings are drawn by hand.
std::string ring_crossing(const std::vector<Eigen::Vector2d>& drawn) {
  // A vertex given twice in a row (the closing one repeated, as GeoJSON writes rings)
  // makes an edge of no length, not a crossing.
  std::vector<Eigen::Vector2d> ring;
  for (const auto& p : drawn)
    if (ring.empty() || p != ring.back()) ring.push_back(p);
  while (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
  const std::size_t n = ring.size();
  if (n < 4) return {};
  const auto side = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    const double d = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    return (d > 0.0) - (d < 0.0);
  };
  const auto on = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return std::min(a.x(), b.x()) <= c.x() && c.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= c.y() &&
           c.y() <= std::max(a.y(), b.y());
  };
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d &a = ring[i], &b = ring[(i + 1) % n];
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // neighbours through the closing vertex
      const Eigen::Vector2d &c = ring[j], &d = ring[(j + 1) % n];
      const int s1 = side(a, b, c), s2 = side(a, b, d), s3 = side(c, d, a), s4 = side(c, d, b);
      const bool meet = (s1 != s2 && s3 != s4 && s1 * s2 <= 0 && s3 * s4 <= 0 && (s1 != 0 || s2 != 0)) ||
                        (s1 == 0 && on(a, b, c)) || (s2 == 0 && on(a, b, d)) || (s3 == 0 && on(c, d, a)) ||
                        (s4 == 0 && on(c, d, b));
      if (meet) return "edges " + std::to_string(i + 1) + " and " + std::to_string(j + 1);
    }
  }
  return {};
}

double polyline_length(const std::vector<Eigen::Vector2d>& line) {
  double length = 0.0;
  for (std::size_t k = 1; k < line.size(); ++k) length += (line[k] - line[k - 1]).norm();
  return length;
}

std::string point_text(const Eigen::Vector2d& p) {
  return "(" + format_number(p.x()) + ", " + format_number(p.y()) + ")";
}

// Whether plan point p (local frame) lies within the plan bounds b.
bool within_bounds(const geometry::Aabb& b, const Eigen::Vector2d& p) {
  return p.x() >= b.lo.x() && p.x() <= b.hi.x() && p.y() >= b.lo.y() && p.y() <= b.hi.y();
}

// Whether the plan box [lo, hi] (local frame) meets the plan bounds b.
bool meets_bounds(const geometry::Aabb& b, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  return lo.x() <= b.hi.x() && hi.x() >= b.lo.x() && lo.y() <= b.hi.y() && hi.y() >= b.lo.y();
}

// The end of a message about a position of the scene given in the terrain's local frame
// when the scene's frame is its input coordinates.
std::string scene_frame_hint(const Eigen::Vector2d& shift, const std::string& where) {
  return local_frame_hint(shift, where) + ": give the scene's coordinates in the terrain's input coordinates, or set "
                                          "frame: local";
}

// A barrier line or stop zone (`what`, its plan box [lo, hi] in the local frame) must
// meet the terrain: one that lies beside it never sees a block, and its statistics would
// be zeros that look like results. The error gives the extent in the scene's frame and,
// when the box meets the terrain in the local frame, says the scene is in the wrong one.
void require_on_terrain(const geometry::Aabb& b, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                        const Eigen::Vector2d& shift, bool input, const std::string& what, const std::string& source) {
  if (meets_bounds(b, lo, hi)) return;
  std::string hint;
  if (input && shift.squaredNorm() > 0.0 && meets_bounds(b, lo + shift, hi + shift))
    hint = scene_frame_hint(shift, "on");
  throw InputError(source, what + " lies outside the terrain (" + (input ? "input" : "local") +
                               " coordinates: " + extent_text(b, shift) + "), so no block can reach it" + hint);
}

// The plan box of points (local frame).
std::pair<Eigen::Vector2d, Eigen::Vector2d> plan_box(const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {lo, hi};
}

// The release features of a vector file in the local frame, with their part sizes and
// weights; every vertex must lie over the terrain. Errors name the file.
std::vector<ReleaseFeature> local_release_features(const ReleaseSettings& r, const std::vector<PlanFeature>& read,
                                                   const terrain::Surface& base, const Eigen::Vector2d& shift) {
  const std::string& file = r.file;
  if (read.empty()) throw InputError(file, "holds no release features");
  std::vector<ReleaseFeature> out;
  double total = 0.0;
  for (const PlanFeature& f : read) {
    ReleaseFeature feature;
    double size = 0.0;
    for (const auto& part : f.parts) {
      std::vector<std::vector<Eigen::Vector2d>> local = part;
      for (auto& list : local)
        for (auto& p : list) {
          if (!base.height_at(p.x() - shift.x(), p.y() - shift.y()))
            throw InputError(file, "release " + f.label + ": point " + point_text(p) +
                                       (within_bounds(base.bounds(), p - shift)
                                            ? " has no terrain under it (a hole or gap in the terrain's surface; "
                                            : " is outside the terrain (") +
                                       "input coordinates: " + extent_text(base.bounds(), shift) + ")");
          p -= shift;
        }
      double part_size = 1.0;
      if (r.kind == "line") part_size = polyline_length(local[0]);
      if (r.kind == "polygon") {
        for (const auto& ring : local)
          if (const std::string crossing = ring_crossing(ring); !crossing.empty())
            throw InputError(file, "release " + f.label + ": a ring crosses itself (" + crossing +
                                       " meet): fix the polygon (e.g. QGIS's Fix geometries)");
        part_size = std::abs(polygon_area(local[0]));
        for (std::size_t k = 1; k < local.size(); ++k) part_size -= std::abs(polygon_area(local[k]));
      }
      feature.parts.push_back(std::move(local));
      feature.part_sizes.push_back(std::max(part_size, 0.0));
      size += feature.part_sizes.back();
    }
    if (!(size > 0.0))
      throw InputError(file, "release " + f.label + " has zero " + (r.kind == "line" ? "length" : "area"));
    feature.weight = f.weight ? *f.weight : size;
    total += feature.weight;
    out.push_back(std::move(feature));
  }
  if (!(total > 0.0)) throw InputError(file, "every release feature has weight 0 in field '" + r.weight_field + "'");
  return out;
}

// Barriers of one outputs.barriers entry that names a vector file: one per line (each
// part of a MultiLineString), in the local frame. Errors name the file.
std::vector<Barrier> file_barriers(const BarrierSettings& b, const std::vector<PlanFeature>& read,
                                   const Eigen::Vector2d& shift) {
  if (read.empty()) throw InputError(b.file, "holds no barrier lines");
  const std::string base = b.name.empty() ? (b.layer.empty() ? std::filesystem::path(b.file).stem().string() : b.layer) : b.name;
  std::vector<Barrier> out;
  for (std::size_t k = 0; k < read.size(); ++k) {
    const PlanFeature& f = read[k];
    std::string name = f.name;
    if (name.empty()) name = read.size() == 1 ? base : base + " " + std::to_string(k + 1);
    for (std::size_t part = 0; part < f.parts.size(); ++part) {
      Barrier barrier{f.parts.size() == 1 ? name : name + "-" + std::to_string(part + 1), f.parts[part][0], {0.0}};
      for (auto& p : barrier.line) p -= shift;
      for (std::size_t j = 1; j < barrier.line.size(); ++j) {
        const double len = (barrier.line[j] - barrier.line[j - 1]).norm();
        if (!(len > 0.0))
          throw InputError(b.file, "barrier " + f.label + " ('" + barrier.name + "') has a zero-length segment");
        barrier.offsets.push_back(barrier.offsets.back() + len);
      }
      out.push_back(std::move(barrier));
    }
  }
  return out;
}

// Inline release points are checked in the scene's frame (`shift` takes them to the
// terrain's local one) and reported in it.
void check_release_points(const SceneSettings& s, const terrain::Surface& base, const Eigen::Vector2d& shift,
                          const core::SettingsOrigins& origins) {
  const ReleaseSettings& r = s.release;
  const std::size_t n = r.points.size();
  const std::string source = origins.of("release.points");
  const std::string count_source = origins.of({"release.points", "release.kind"});
  if (r.kind == "point" && n < 1)
    throw InputError(count_source,
                     "release.kind 'point' needs at least 1 point in release.points, got " + std::to_string(n));
  if (r.kind == "line" && n < 2)
    throw InputError(count_source,
                     "release.kind 'line' needs at least 2 points in release.points, got " + std::to_string(n));
  if (r.kind == "polygon" && n < 3)
    throw InputError(count_source,
                     "release.kind 'polygon' needs at least 3 points in release.points, got " + std::to_string(n));
  if (!finite_points(r.points)) throw InputError(source, "release.points must be finite");
  if (r.kind == "polygon") {
    if (const std::string crossing = ring_crossing(to_vectors(r.points)); !crossing.empty())
      throw InputError(source, "release polygon crosses itself (" + crossing +
                                   " of release.points meet): give its vertices in order around it");
    if (std::abs(polygon_area(to_vectors(r.points))) <= 0.0) throw InputError(source, "release polygon has zero area");
  }
  if (r.kind == "line") {
    double length = 0.0;
    for (std::size_t k = 1; k < n; ++k)
      length += std::hypot(r.points[k][0] - r.points[k - 1][0], r.points[k][1] - r.points[k - 1][1]);
    if (!(length > 0.0)) throw InputError(source, "release line has zero length");
  }
  const geometry::Aabb& b = base.bounds();
  const bool input = s.frame == "input";
  for (const auto& p : r.points) {
    if (base.height_at(p[0] - shift.x(), p[1] - shift.y())) continue;
    std::string hint;
    // A scene written for the shifted frame (the only one before `frame` existed).
    if (input && shift.squaredNorm() > 0.0 && base.height_at(p[0], p[1])) hint = scene_frame_hint(shift, "inside");
    const bool within = within_bounds(b, Eigen::Vector2d(p[0], p[1]) - shift);
    throw InputError(origins.of({"release.points", "frame"}), "release point " + point_text(p) +
                                 (within ? " has no terrain under it (a hole or gap in the terrain's surface; "
                                         : " is outside the terrain (") +
                                 (input ? "input" : "local") + " coordinates: " + extent_text(b, shift) + ")" +
                                 hint);
  }
}

// The release settings (the features of a release file are checked as they are placed).
void check_release(const SceneSettings& s, const terrain::Surface& base, const Eigen::Vector2d& shift,
                   const core::SettingsOrigins& origins) {
  const ReleaseSettings& r = s.release;
  if (!r.file.empty()) {
    // Points left at their default, or emptied (--set 'release.points=[]' over a scene
    // that gives some), leave the file alone.
    if (!r.points.empty() && r.points != ReleaseSettings{}.points)
      throw InputError(origins.of({"release.points", "release.file"}),
                       "release: give release.points or release.file, not both");
  } else if (!r.layer.empty() || !r.weight_field.empty()) {
    throw InputError(origins.of({r.layer.empty() ? "release.weight_field" : "release.layer"}),
                     "release.layer and release.weight_field need release.file");
  } else {
    check_release_points(s, base, shift, origins);
  }
  if (!std::isfinite(r.height)) throw InputError(origins.of("release.height"), "release.height must be finite");
  if (r.height_reference == "lowest_point" && r.height < 0.0)
    throw InputError(origins.of({"release.height", "release.height_reference"}),
                     "release.height " + format_number(r.height) +
                         " m is negative: with height_reference lowest_point it is the gap under the block");
  for (double c : r.velocity)
    if (!std::isfinite(c)) throw InputError(origins.of("release.velocity"), "release.velocity must be finite");
  for (double c : r.angular_velocity)
    if (!std::isfinite(c))
      throw InputError(origins.of("release.angular_velocity"), "release.angular_velocity must be finite");
  for (double c : r.orientation_deg)
    if (!std::isfinite(c))
      throw InputError(origins.of("release.orientation_deg"), "release.orientation_deg must be finite");
  if (r.orientation == "list" && r.orientation_file.empty())
    throw InputError(origins.of({"release.orientation", "release.orientation_file"}),
                     "release.orientation list needs release.orientation_file");
  if (r.orientation != "list" && !r.orientation_file.empty())
    throw InputError(origins.of({"release.orientation_file", "release.orientation"}),
                     "release.orientation_file needs release.orientation: list (it is " + r.orientation + ")");
  if (!std::isfinite(r.main_direction_deg))
    throw InputError(origins.of("release.main_direction_deg"), "release.main_direction_deg must be finite");
}

void apply_override(terrain::Material& m, const MaterialOverride& o, const std::string& source) {
  if (o.class_name != "none") {
    terrain::apply_material_class(m, o.class_name, source);
    m.class_name = o.class_name;
  }
  if (o.restitution_mean) m.restitution_mean = *o.restitution_mean;
  if (o.restitution_sd) m.restitution_sd = *o.restitution_sd;
  if (o.restitution_scale) m.restitution_scale = *o.restitution_scale;
  if (o.friction_angle_mean_deg) m.friction_angle_mean_deg = *o.friction_angle_mean_deg;
  if (o.friction_coefficient_sd) m.friction_coefficient_sd = *o.friction_coefficient_sd;
  if (o.lateral_tilt_sd_deg) m.lateral_tilt_sd_deg = *o.lateral_tilt_sd_deg;
  if (o.ploughing) m.ploughing = *o.ploughing;
}

void check_material(const terrain::Material& m, const std::string& source) {
  const std::string where = "material '" + m.name + "': ";
  auto ok = [](double x) { return std::isfinite(x) && x >= 0.0; };
  if (!ok(m.restitution_mean) || !ok(m.restitution_sd) || !ok(m.friction_coefficient_sd) ||
      !ok(m.lateral_tilt_sd_deg) || !ok(m.ploughing) || !std::isfinite(m.friction_angle_mean_deg))
    throw InputError(source, where + "values must be finite and the means and sds non-negative");
  if (!(m.restitution_scale > 0.0) || !std::isfinite(m.restitution_scale))
    throw InputError(source, where + "restitution_scale must be positive");
  if (m.friction_angle_mean_deg < 0.0 || m.friction_angle_mean_deg >= 90.0)
    throw InputError(source, where + "friction_angle_mean_deg must be in [0, 90)");
}

// The engine keys a message of dda::Model::build names ("time_step = 0.001 s is below
// min_time_step = 0.01 s", "preset 'x': …"): each word before " = ", else its first word.
std::vector<std::string> engine_keys(const std::string& detail) {
  std::vector<std::string> keys;
  for (std::size_t at = detail.find(" = "); at != std::string::npos; at = detail.find(" = ", at + 3)) {
    const std::size_t start = detail.find_last_of(" (", at - 1);
    keys.push_back("engine." + detail.substr(start == std::string::npos ? 0 : start + 1,
                                             at - (start == std::string::npos ? 0 : start + 1)));
  }
  if (keys.empty()) keys.push_back("engine." + detail.substr(0, detail.find_first_of(" '")));
  return keys;
}

// A row of numbers separated by blanks, commas or semicolons; false if a token is not one.
bool parse_row(const std::string& line, std::vector<double>& out) {
  out.clear();
  std::size_t at = 0;
  while (at < line.size()) {
    at = line.find_first_not_of(" \t\r,;", at);
    if (at == std::string::npos) break;
    const std::size_t end = std::min(line.find_first_of(" \t\r,;", at), line.size());
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(line.data() + at, line.data() + end, value);
    if (ec != std::errc{} || ptr != line.data() + end) return false;
    out.push_back(value);
    at = end;
  }
  return true;
}

// The rows of release.orientation_file, body → world in the engine's z-up axes.
std::vector<Eigen::Quaterniond> read_orientations(const ReleaseSettings& r) {
  const std::string& path = r.orientation_file;
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open the release orientation file");
  const bool quaternion = r.orientation_format == "quaternion";
  const std::size_t columns = quaternion ? 4 : 3;
  const char* what = quaternion ? "4 numbers (a quaternion w x y z)" : "3 numbers (z-y-x Euler angles, deg)";
  // y-up axes to z-up ones: (x, y, z) → (x, −z, y), a quarter turn about x.
  const Eigen::Quaterniond up(Eigen::AngleAxisd(r.orientation_up_axis == "y" ? M_PI / 2.0 : 0.0, Eigen::Vector3d::UnitX()));
  std::vector<Eigen::Quaterniond> out;
  std::vector<double> row;
  std::string line;
  bool header_allowed = true;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    if (line.find_first_not_of(" \t\r,;") == std::string::npos) continue;
    const std::string at = path + ": line " + std::to_string(number);
    if (!parse_row(line, row)) {
      if (header_allowed) {  // a header row of column names
        header_allowed = false;
        continue;
      }
      throw InputError(at, "expected " + std::string(what) + ", got '" + line + "'");
    }
    header_allowed = false;
    if (row.size() != columns)
      throw InputError(at, "expected " + std::string(what) + ", got " + std::to_string(row.size()) +
                               " (release.orientation_format is " + r.orientation_format + ")");
    for (const double v : row)
      if (!std::isfinite(v)) throw InputError(at, "orientation values must be finite");
    Eigen::Quaterniond q;
    if (quaternion) {
      q = Eigen::Quaterniond(row[0], row[1], row[2], row[3]);
      // Rows rounded to a few digits are unit to about 1e-4; anything further is not a
      // rotation (a scaled quaternion or another column order).
      if (std::abs(q.norm() - 1.0) > 1e-3)
        throw InputError(at, "quaternion norm " + format_number(q.norm()) + " is not 1 (w x y z, scalar first)");
      q.normalize();
    } else {
      for (const double v : row)
        if (std::abs(v) > 360.0) throw InputError(at, "Euler angle " + format_number(v) + " deg is outside [-360, 360]");
      q = zyx_rotation({row[0], row[1], row[2]});
    }
    out.push_back(up * q * up.conjugate());
  }
  if (out.empty()) throw InputError(path, "the release orientation file has no orientations");
  return out;
}

}  // namespace

Eigen::Quaterniond zyx_rotation(const std::array<double, 3>& deg) {
  const double k = M_PI / 180.0;
  return Eigen::AngleAxisd(deg[0] * k, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(deg[1] * k, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(deg[2] * k, Eigen::Vector3d::UnitX());
}

Scene Scene::build(const SceneSettings& settings, terrain::Terrain terrain,
                   const std::vector<block::Block>& library, const core::SettingsOrigins& origins,
                   const SceneVectors& vectors) {
  Scene scene;
  scene.settings_ = settings;
  scene.origins_ = origins;
  const std::string& source = origins.source();
  const SceneSettings& s = scene.settings_;

  {
    const std::string& v = s.schema_version;
    int major = -1;
    const auto dot = v.find('.');
    const auto [end, err] = std::from_chars(v.data(), v.data() + (dot == std::string::npos ? v.size() : dot), major);
    if (err != std::errc() || v.empty())
      throw InputError(origins.of("schema_version"), "schema_version '" + v + "' is not MAJOR.MINOR");
    if (major != kSceneSchemaMajor)
      throw InputError(origins.of("schema_version"), "scene schema version " + v +
                                                         " is not supported (this build reads " +
                                                         std::to_string(kSceneSchemaMajor) + ".x)");
  }
  // The ranges the fields declare (the reader checks them on what it reads, naming the
  // line or --set key; these are settings made in code too).
  {
    SceneSettings declared = s;
    core::check_ranges([&](core::SettingsVisitor& v) { declared.visit(v); }, origins);
  }

  // Blocks.
  if (library.empty()) throw InputError(origins.of("block_file"), "the block file holds no block");
  std::vector<const block::Block*> chosen;
  if (s.blocks.empty()) {
    for (const auto& b : library) chosen.push_back(&b);
  } else {
    for (const auto& name : s.blocks) {
      const block::Block* found = nullptr;
      for (const auto& b : library)
        if (b.name == name) found = &b;
      if (!found) {
        std::string names;
        for (const auto& b : library) names += (names.empty() ? "" : ", ") + b.name;
        throw InputError(origins.of("blocks"), "block '" + name + "' is not in the block file (it has: " + names + ")");
      }
      chosen.push_back(found);
    }
  }
  // The fastest a block can move in this scene (m/s), but for its own spin and size:
  // free fall over the terrain's relief (with the roughness's few σ and a release above
  // it) plus the release velocity; nothing in the model is a source of energy.
  const geometry::Aabb relief = terrain.mesh.bounds();
  const double rough = 8.0 * terrain.roughness.sigma;
  double drop = relief.hi.z() - relief.lo.z() + rough + s.release.clearance_gap;
  if (s.release.height_reference == "elevation") {
    const double floor = relief.lo.z() + (s.frame == "input" ? terrain.origin_shift.z() : 0.0);
    drop = std::max(drop, s.release.height - floor + rough);
  } else {
    drop += std::max(0.0, s.release.height);
  }
  const auto norm3 = [](const std::array<double, 3>& a) { return std::hypot(a[0], a[1], a[2]); };
  for (const block::Block* b : chosen) {
    dda::Settings engine = s.engine;
    engine.density = b->density;
    // A nominal step in which the block could travel more than max_step_travel of its
    // diameter is shortened to that (with the contact springs stiffened to keep Ω, as a
    // shorter time_step does): coarser, a small fast block's impacts lose rebound (docs/
    // dda-run.md, "Time step"). Not with a stiffness given in N/m, whose Ω the step sets.
    double radius = 0.0;
    for (const geometry::Vec3& v : b->polyhedron.vertices) radius = std::max(radius, v.norm());
    const double fastest = norm3(s.release.velocity) + norm3(s.release.angular_velocity) * radius +
                           std::sqrt(2.0 * engine.gravity * (drop + 2.0 * radius));
    const double travel = fastest * engine.time_step / (2.0 * radius);
    if (engine.max_step_travel > 0.0 && engine.penalty_stiffness == 0.0 && travel > engine.max_step_travel) {
      engine.time_step = std::max(engine.min_time_step, engine.time_step * engine.max_step_travel / travel);
      core::log_info(source + ": block '" + b->name + "': time_step " + format_number(engine.time_step) +
                     " s (it may reach " + format_number(fastest) + " m/s; engine.max_step_travel " +
                     format_number(engine.max_step_travel) + " of its " + format_number(2.0 * radius) +
                     " m diameter per step)");
    }
    // The engine's refusal of a block (a penalty stiffness ill-posed for its mass, a
    // polyhedron it cannot use) names the scene, the block and the engine's key.
    auto model = [&] {
      try {
        return dda::Model::build(engine, b->polyhedron);
      } catch (const InputError& e) {
        const bool setting = e.source() == "dda settings";
        throw InputError(setting ? origins.of(engine_keys(e.detail())) : source,
                         "block '" + b->name + "': " + (setting ? "engine." : "") + e.detail());
      }
    }();
    SceneBlock sb{b->name, std::move(model), b->weight};
    if (s.block_selection == "weighted" && !(sb.weight >= 0.0 && std::isfinite(sb.weight)))
      throw InputError(origins.of("block_selection"), "block '" + b->name + "' has sampling weight " +
                                                          format_number(sb.weight) +
                                                          ": weights must be finite and >= 0");
    scene.blocks_.push_back(std::move(sb));
  }
  // A block of weight 0 is never drawn (block-gen allows it), but one of them must be.
  if (s.block_selection == "weighted" && scene.blocks_.size() > 1) {
    double total = 0.0;
    for (const SceneBlock& b : scene.blocks_) total += b.weight;
    if (!(total > 0.0))
      throw InputError(origins.of("block_selection"),
                       "every block has sampling weight 0, so block_selection weighted has none to draw: "
                       "give some a weight (block-gen 'weight') or set block_selection: cycle");
  }

  // Materials: overrides by name, then the stochastic switches.
  scene.materials_ = terrain.materials;
  // Where each material's values were last overridden: the place its errors name.
  std::vector<std::string> material_origin(scene.materials_.size(), source);
  for (std::size_t k = 0; k < s.materials.size(); ++k) {
    const MaterialOverride& o = s.materials[k];
    const std::string item = "materials[" + std::to_string(k) + "]";
    bool found = false;
    for (std::size_t j = 0; j < scene.materials_.size(); ++j)
      if (scene.materials_[j].name == o.name) {
        apply_override(scene.materials_[j], o, origins.of(item + ".class"));
        material_origin[j] = origins.of(item);
        found = true;
      }
    if (!found) throw InputError(origins.of(item + ".name"), "material '" + o.name + "' is not in the terrain file");
  }
  for (std::size_t j = 0; j < scene.materials_.size(); ++j) {
    terrain::Material& m = scene.materials_[j];
    if (!s.stochastic.restitution) m.restitution_sd = 0.0;
    if (!s.stochastic.friction) m.friction_coefficient_sd = 0.0;
    if (!s.stochastic.lateral_tilt) m.lateral_tilt_sd_deg = 0.0;
    check_material(m, material_origin[j]);
  }

  scene.terrain_ = std::make_unique<terrain::Terrain>(std::move(terrain));
  scene.base_ = std::make_unique<terrain::Surface>(terrain::Surface::realize(*scene.terrain_, std::nullopt));
  // Scene coordinates in the terrain's input frame become local ones here, once.
  const Eigen::Vector2d shift = s.frame == "input" ? Eigen::Vector2d(scene.terrain_->origin_shift.x(),
                                                                     scene.terrain_->origin_shift.y())
                                                   : Eigen::Vector2d::Zero();
  auto local = [&](const std::vector<std::array<double, 2>>& points) {
    std::vector<Eigen::Vector2d> out = to_vectors(points);
    for (auto& p : out) p -= shift;
    return out;
  };
  // Vector files are in the terrain's input coordinates whatever the scene's frame: a GIS
  // file holds the coordinates of its CRS.
  const Eigen::Vector2d input_shift(scene.terrain_->origin_shift.x(), scene.terrain_->origin_shift.y());
  check_release(s, *scene.base_, shift, origins);
  if (s.release.file.empty() && s.release.kind == "point") {
    // Each point is a feature of weight 1, as a file of Point features without a
    // weight_field: equally likely, and one point draws nothing to choose it.
    scene.release_zone_ = local(s.release.points);
    for (const Eigen::Vector2d& p : scene.release_zone_) {
      ReleaseFeature point;
      point.parts = {{{p}}};
      point.part_sizes = {1.0};
      scene.release_features_.push_back(std::move(point));
    }
  } else if (s.release.file.empty()) {
    // An inline line or polygon is one feature of one part.
    scene.release_zone_ = local(s.release.points);
    ReleaseFeature zone;
    zone.parts = {{scene.release_zone_}};
    zone.part_sizes = {s.release.kind == "line" ? polyline_length(scene.release_zone_) : 1.0};
    scene.release_features_.push_back(std::move(zone));
  } else {
    scene.release_features_ = local_release_features(s.release, vectors.release, *scene.base_, input_shift);
  }
  if (s.release.orientation == "list") scene.release_orientations_ = read_orientations(s.release);
  const double azimuth = s.release.main_direction_deg * M_PI / 180.0;
  scene.main_direction_ = Eigen::Vector2d(std::cos(azimuth), std::sin(azimuth));

  const geometry::Aabb& plan = scene.base_->bounds();
  const bool input_frame = s.frame == "input";
  const auto on_terrain = [&](const std::vector<Eigen::Vector2d>& line, const std::string& what,
                              const std::string& from, bool in_input_frame) {
    const auto [lo, hi] = plan_box(line);
    require_on_terrain(plan, lo, hi, in_input_frame ? input_shift : shift, in_input_frame, what, from);
  };
  std::set<std::string> barrier_names;
  for (std::size_t k = 0; k < s.outputs.barriers.size(); ++k) {
    const BarrierSettings& b = s.outputs.barriers[k];
    const std::string item = "outputs.barriers[" + std::to_string(k) + "]";
    if (!b.file.empty()) {
      if (!b.line.empty())
        throw InputError(origins.of({item + ".line", item + ".file"}),
                         "outputs.barriers entry " + std::to_string(k + 1) + ": give line or file, not both");
      const std::vector<PlanFeature> none;
      for (Barrier& barrier : file_barriers(b, k < vectors.barriers.size() ? vectors.barriers[k] : none, input_shift)) {
        // Barrier names name the statistics of their crossings: they must differ.
        if (!barrier_names.insert(barrier.name).second)
          throw InputError(b.file, "barrier name '" + barrier.name + "' is taken by another barrier: give distinct " +
                                       (b.name_field.empty() ? "names (outputs.barriers[].name or name_field)"
                                                             : "names in field '" + b.name_field + "'"));
        on_terrain(barrier.line, "barrier '" + barrier.name + "'", b.file, true);
        scene.barriers_.push_back(std::move(barrier));
      }
      continue;
    }
    if (!b.layer.empty() || !b.name_field.empty())
      throw InputError(origins.of(item + (b.layer.empty() ? ".name_field" : ".layer")),
                       "outputs.barriers entry " + std::to_string(k + 1) + ": layer and name_field need file");
    const std::string name = b.name.empty() ? "barrier " + std::to_string(k + 1) : b.name;
    if (!barrier_names.insert(name).second)
      throw InputError(origins.of(item + ".name"), "barrier name '" + name +
                                   "' is taken by another barrier: give distinct names (outputs.barriers[].name)");
    if (b.line.size() < 2 || !finite_points(b.line))
      throw InputError(origins.of(item + ".line"),
                       "barrier '" + name + "' needs at least 2 finite vertices in its line");
    Barrier barrier{name, local(b.line), {0.0}};
    on_terrain(barrier.line, "barrier '" + name + "'", origins.of({item + ".line", "frame"}), input_frame);
    for (std::size_t j = 1; j < barrier.line.size(); ++j) {
      const double len = (barrier.line[j] - barrier.line[j - 1]).norm();
      if (!(len > 0.0))
        throw InputError(origins.of(item + ".line"), "barrier '" + name + "' has a zero-length segment");
      barrier.offsets.push_back(barrier.offsets.back() + len);
    }
    scene.barriers_.push_back(std::move(barrier));
  }

  for (std::size_t k = 0; k < s.stop_zones.size(); ++k) {
    const StopZoneSettings& z = s.stop_zones[k];
    const std::string item = "stop_zones[" + std::to_string(k) + "]";
    const std::string range_source = origins.of(item + ".x_range"), polygon_source = origins.of(item + ".polygon");
    StopZone zone{z.name, 0.0, 0.0, {}};
    if (z.name.empty()) throw InputError(origins.of(item + ".name"), "a stop zone has no name");
    if (!z.polygon.empty() == !z.x_range.empty())
      throw InputError(origins.of({item + ".x_range", item + ".polygon"}),
                       "stop zone '" + z.name + "' needs either x_range or polygon");
    if (!z.x_range.empty()) {
      if (z.x_range.size() != 2 || !(z.x_range[0] < z.x_range[1]))
        throw InputError(range_source, "stop zone '" + z.name + "': x_range must be [x_min, x_max] with x_min < x_max");
      zone.x_min = z.x_range[0] - shift.x();
      zone.x_max = z.x_range[1] - shift.x();
      // The zone spans every y.
      const double all = std::numeric_limits<double>::infinity();
      require_on_terrain(plan, Eigen::Vector2d(zone.x_min, -all), Eigen::Vector2d(zone.x_max, all), shift, input_frame,
                         "stop zone '" + z.name + "'", origins.of({item + ".x_range", "frame"}));
    } else {
      zone.polygon = local(z.polygon);
      if (zone.polygon.size() < 3 || !finite_points(z.polygon))
        throw InputError(polygon_source, "stop zone '" + z.name + "': polygon needs 3 or more vertices and an area");
      if (const std::string crossing = ring_crossing(zone.polygon); !crossing.empty())
        throw InputError(polygon_source, "stop zone '" + z.name + "': polygon crosses itself (" + crossing +
                                     " meet): give its vertices in order around it");
      if (polygon_area(zone.polygon) == 0.0)
        throw InputError(polygon_source, "stop zone '" + z.name + "': polygon needs 3 or more vertices and an area");
      on_terrain(zone.polygon, "stop zone '" + z.name + "'", origins.of({item + ".polygon", "frame"}), input_frame);
    }
    scene.zones_.push_back(std::move(zone));
  }

  const double cell = s.outputs.hazard_cell_size;
  if (cell > 0.0) {
    const geometry::Aabb& b = scene.base_->bounds();
    double nx = 0.0, ny = 0.0;
    const auto& dem = scene.terrain_->grid;
    if (dem && dem->dx == dem->dy) {
      // On the DEM grid: a cell of the DEM's own size is centred on a DEM point (the
      // rasters have the DEM's origin, cell and size); multiples and divisors of it share
      // the DEM cells' edges. Other sizes would put the rasters off the grid.
      const double d = dem->dx;
      const double up = std::round(cell / d), down = std::round(d / cell);
      const bool multiple = up >= 1.0 && std::abs(cell - up * d) <= 1e-9 * cell;
      const bool divisor = down >= 1.0 && std::abs(cell * down - d) <= 1e-9 * d;
      if (!multiple && !divisor)
        throw InputError(origins.of("outputs.hazard_cell_size"), "outputs.hazard_cell_size " + format_number(cell) +
                                     " m is neither a multiple nor a divisor of the DEM cell (" + format_number(d) +
                                     " m): hazard rasters lie on the DEM grid; give e.g. " + format_number(d / 2) +
                                     ", " + format_number(d) + " or " + format_number(2 * d) + " m");
      scene.hazard_.x0 = dem->x0 - 0.5 * d;
      scene.hazard_.y0 = dem->y0 - 0.5 * d;
      nx = std::ceil(dem->nx * d / cell - 1e-9);
      ny = std::ceil(dem->ny * d / cell - 1e-9);
    } else {
      // A TIN (or a grid of unequal spacings): cells from the lower-left corner of its plan
      // bounds.
      scene.hazard_.x0 = b.lo.x();
      scene.hazard_.y0 = b.lo.y();
      nx = std::ceil((b.hi.x() - b.lo.x()) / cell);
      ny = std::ceil((b.hi.y() - b.lo.y()) / cell);
    }
    scene.hazard_.size = cell;
    if (nx * ny > 1e8)
      throw InputError(origins.of("outputs.hazard_cell_size"),
                       "outputs.hazard_cell_size " + format_number(cell) + " m gives more than 1e8 cells");
    scene.hazard_.nx = std::max(1, static_cast<std::int32_t>(nx));
    scene.hazard_.ny = std::max(1, static_cast<std::int32_t>(ny));
  }
  return scene;
}

bool point_in_rings(const std::vector<std::vector<Eigen::Vector2d>>& rings, const Eigen::Vector2d& p) {
  bool in = false;
  for (const auto& ring : rings) in = in != point_in_polygon(ring, p);
  return in;
}

bool point_in_polygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool in = false;
  for (std::size_t k = 0, j = poly.size() - 1; k < poly.size(); j = k++) {
    const auto& a = poly[k];
    const auto& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

Eigen::Vector3d Scene::frame_shift() const {
  return settings_.frame == "input" ? terrain_->origin_shift : Eigen::Vector3d::Zero();
}

std::vector<std::string> Scene::stop_classes() const {
  std::vector<std::string> names;
  for (const auto& z : zones_) names.push_back(z.name);
  names.emplace_back("other");
  names.emplace_back("out of domain");
  return names;
}

std::int32_t Scene::classify(const Eigen::Vector2d& p, bool left_terrain) const {
  const auto n = static_cast<std::int32_t>(zones_.size());
  if (left_terrain) return n + 1;
  for (std::int32_t k = 0; k < n; ++k) {
    const StopZone& z = zones_[static_cast<std::size_t>(k)];
    if (z.polygon.empty() ? (p.x() >= z.x_min && p.x() < z.x_max) : point_in_polygon(z.polygon, p)) return k;
  }
  return n;
}

Shard Shard::parse(const std::string& text) {
  const auto slash = text.find('/');
  Shard shard;
  auto number = [&](std::size_t from, std::size_t to, std::uint32_t& out) {
    const auto [end, err] = std::from_chars(text.data() + from, text.data() + to, out);
    return err == std::errc() && end == text.data() + to && to > from;
  };
  if (slash == std::string::npos || !number(0, slash, shard.index) ||
      !number(slash + 1, text.size(), shard.count) || shard.count == 0 || shard.index >= shard.count)
    throw core::UsageError("--shard expects K/N with 0 <= K < N, got '" + text + "'");
  return shard;
}

std::string Shard::text() const { return std::to_string(index) + "/" + std::to_string(count); }

std::vector<std::uint32_t> Shard::indices(std::uint32_t total) const {
  std::vector<std::uint32_t> out;
  for (std::uint64_t i = index; i < total; i += count) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

}  // namespace talus::mc
