// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/core/settings.hpp"
#include "talus/dda/model.hpp"
#include "talus/dda/settings.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::mc {

/// The scene schema this build reads ("MAJOR.MINOR"; a scene of another major is refused).
inline constexpr int kSceneSchemaMajor = 1;
inline constexpr const char* kSceneSchemaVersion = "1.0";

/// Overrides of one ground material of the terrain file, matched by name. A class sets
/// all six parameters first; the fields given then override it; absent fields keep the
/// terrain file's value.
struct MaterialOverride {
  std::string name;
  std::string class_name = "none";                ///< starting class (material_classes.hpp), none = keep
  std::optional<double> restitution_mean;         ///< R_v mean (-)
  std::optional<double> restitution_sd;           ///< R_v sd (-)
  std::optional<double> restitution_scale;        ///< K (m/s)
  std::optional<double> friction_angle_mean_deg;  ///< deg
  std::optional<double> friction_coefficient_sd;  ///< sd of tan φ (-)
  std::optional<double> lateral_tilt_sd_deg;      ///< deg
  std::optional<double> ploughing;                ///< -
  void visit(core::SettingsVisitor& v);
};

/// Where and how blocks are released.
struct ReleaseSettings {
  /// "point" (≥ 1 points: a realization draws one of them with equal probability), "line"
  /// (polyline, ≥ 2 vertices), "polygon" (≥ 3 vertices).
  std::string kind = "point";
  std::vector<std::array<double, 2>> points = {{1.0, 20.0}};  ///< plan coordinates (m)
  /// A vector file of release features instead of `points` (path relative to the working
  /// directory): points, lines or polygons as `kind` says, in the terrain's input
  /// coordinates (m) and CRS; or a raster of release cells (.asc, .tif: kind "polygon";
  /// a cell's value > 0 is its relative release density, -/m², 0 or NODATA: none).
  /// Empty: `points`.
  std::string file;
  std::string layer;         ///< the file's layer; empty: its only layer
  /// Numeric field of the features' relative weights (-, ≥ 0): a realization draws a
  /// feature with probability proportional to it. Empty: proportional to the feature's
  /// size (area, length, point count), so the features act as one zone.
  std::string weight_field;
  /// Height above the realized ground (m): of the centroid at the release point
  /// (height_reference "centroid"), or of the block's lowest contact point above the
  /// ground under it ("lowest_point"); or the centroid's elevation ("elevation", m in the
  /// scene's frame).
  double height = 2.5;
  /// "centroid": `height` places the centroid; "lowest_point": the block is lowered
  /// vertically until it touches the ground, then raised by `height` (0 = resting on it);
  /// "elevation": the centroid at that absolute elevation (a drop test), the clearance
  /// rule applying as for "centroid".
  std::string height_reference = "centroid";
  /// A centroid-placed block closer to the ground than clearance_gap (or in it):
  /// "refuse" (an error naming the realization) or "lift" (raised vertically just enough).
  std::string clearance = "refuse";
  /// Vertical gap required between a centroid-placed block and the ground (m), ≥ 0.
  double clearance_gap = 0.0;
  /// "random" (uniform over rotations), "fixed" (orientation_deg) or "list" (the rows of
  /// orientation_file: realization i takes row ⌊i/B⌋ mod N with block_selection "cycle"
  /// over B blocks, so B·N realizations run every block in every orientation once; row
  /// i mod N otherwise).
  std::string orientation = "random";
  /// Fixed orientation as z-y-x Euler angles (yaw about z, then pitch about y, roll about x) (deg).
  std::array<double, 3> orientation_deg = {0.0, 0.0, 0.0};
  /// Text file of orientations for "list", one per row (path relative to the working
  /// directory): body → world, in the block file's body axes (the input mesh's, translated).
  std::string orientation_file;
  /// The rows of orientation_file: "quaternion" (w x y z, scalar first, unit norm) or
  /// "euler_zyx_deg" (z-y-x Euler angles as orientation_deg, deg).
  std::string orientation_format = "quaternion";
  /// "z", or "y" for orientations given in y-up axes (those of a mesh read with block-gen
  /// input.up_axis y): turned into the z-up axes as the mesh was.
  std::string orientation_up_axis = "z";
  std::array<double, 3> velocity = {0.0, 0.0, 0.0};          ///< centroid (m/s)
  std::array<double, 3> angular_velocity = {0.0, 0.0, 0.0};  ///< world frame (rad/s)
  /// Azimuth of the main slope direction, counter-clockwise from +x (deg): runout is
  /// measured along it, lateral displacement across it.
  double main_direction_deg = 0.0;
  void visit(core::SettingsVisitor& v);
};

/// Each random ingredient of a realization can be switched off for sensitivity studies.
struct StochasticSettings {
  bool roughness = true;     ///< ground roughness realization i per run (off: the smooth base)
  bool restitution = true;   ///< R_v drawn per impact (off: the material mean)
  bool friction = true;      ///< friction drawn per impact (off: the mean angle)
  bool lateral_tilt = true;  ///< lateral ground tilt drawn per impact (off: none)
  void visit(core::SettingsVisitor& v);
};

/// A barrier line in plan: every crossing of the centroid path is recorded. Or the lines
/// of a vector file: one barrier per line.
struct BarrierSettings {
  std::string name;
  std::vector<std::array<double, 2>> line;  ///< polyline vertices (m), ≥ 2
  /// A vector file of barrier lines instead of `line` (path relative to the working
  /// directory; LineString or MultiLineString features in the terrain's input coordinates
  /// and CRS). Empty: `line`.
  std::string file{};
  std::string layer{};     ///< the file's layer; empty: its only layer
  /// Text field naming each line; empty: `name` (else `layer`, else the file's stem), numbered by feature.
  std::string name_field{};
  void visit(core::SettingsVisitor& v);
};

/// A named zone where blocks stop: an x-interval or a plan polygon (first match wins).
struct StopZoneSettings {
  std::string name;
  std::vector<double> x_range;                 ///< [x_min, x_max) (m), or empty
  std::vector<std::array<double, 2>> polygon;  ///< plan polygon (m), ≥ 3 vertices, or empty
  void visit(core::SettingsVisitor& v);
};

struct OutputSettings {
  double hazard_cell_size = 0.0;            ///< hazard-map cell (m); 0 = no hazard map
  double hazard_relative_accuracy = 0.01;   ///< relative error of the per-cell quantiles (-)
  std::vector<BarrierSettings> barriers;
  std::int64_t chunk = 64;                  ///< realizations flushed to disk together
  void visit(core::SettingsVisitor& v);
};

/// A scene: everything dda-run reads besides the command line (docs/dda-run.md).
struct SceneSettings {
  std::string schema_version = kSceneSchemaVersion;
  std::string terrain;                  ///< terrain file (path, relative to the working directory)
  /// Frame of every plan coordinate of the scene (release points, barrier lines, stop
  /// zones): "input", the terrain's input coordinates (those of the DEM, mesh or point
  /// cloud, e.g. projected metres); "local", the terrain file's shifted frame (input minus
  /// the terrain's origin_shift), the frame of scenes before the setting existed.
  std::string frame = "input";
  std::string block_file;               ///< block file (one block or a library)
  std::vector<std::string> blocks;      ///< names of the blocks to use; empty = every block
  /// "weighted": drawn from the block_shape stream with the library's sampling weights (a
  /// block of weight 0 is never drawn); "cycle": realization i uses block i mod B (equal
  /// shares, whatever the weights).
  std::string block_selection = "weighted";
  std::vector<MaterialOverride> materials;
  ReleaseSettings release;
  dda::Settings engine;
  StochasticSettings stochastic;
  std::int64_t realizations = 100;      ///< total count, realizations 0 … n−1
  std::uint64_t seed = 1;               ///< master seed of the release, impact and block draws
  OutputSettings outputs;
  std::vector<StopZoneSettings> stop_zones;
  void visit(core::SettingsVisitor& v);
};

/// One feature of a vector file a scene names (release.file, outputs.barriers[].file),
/// as read by io::read_scene_vectors (mc reads no file formats): plan coordinates in the
/// terrain's input coordinates (m).
struct PlanFeature {
  std::string label;              ///< "feature 7" (its OGR feature id), for messages
  std::string name;               ///< value of the name field; empty without one
  std::optional<double> weight;   ///< value of the weight field (-); none without one
  /// Its parts, each a list of vertex lists: a point (one list of one vertex), a line (one
  /// polyline), or a polygon (its outer ring, then its holes; rings without the closing
  /// vertex). A Multi* geometry has several parts.
  std::vector<std::vector<std::vector<Eigen::Vector2d>>> parts;
};

/// The vector files of a scene, read before it is built.
struct SceneVectors {
  std::vector<PlanFeature> release;                ///< features of release.file
  std::vector<std::vector<PlanFeature>> barriers;  ///< per outputs.barriers entry; empty for inline lines
  /// One line per file read (path, key, layer, feature count, fingerprint of the
  /// geometry), recorded with the run's inputs so a resume or merge notices a changed file.
  std::string inputs;
};

/// A release feature in the local frame, ready to draw from: its parts (as PlanFeature)
/// and their sizes (m² of a polygon less its holes, m of a line, 1 for a point).
struct ReleaseFeature {
  std::vector<std::vector<std::vector<Eigen::Vector2d>>> parts;
  std::vector<double> part_sizes;
  double weight = 1.0;  ///< relative probability of the feature (-)
};

/// A plan grid of hazard cells covering the terrain: cell (i, j) spans
/// [x0 + i·size, x0 + (i+1)·size) × [y0 + j·size, …); id = j·nx + i.
struct HazardGridSpec {
  double x0 = 0.0, y0 = 0.0;  ///< m
  double size = 0.0;          ///< m, 0 = no grid
  std::int32_t nx = 0, ny = 0;
  /// Cell id of (x, y), or −1 outside.
  std::int64_t cell(double x, double y) const;
};

struct SceneBlock {
  std::string name;
  dda::Model model;
  double weight = 1.0;  ///< relative sampling weight (-)
};

struct Barrier {
  std::string name;
  std::vector<Eigen::Vector2d> line;  ///< m
  std::vector<double> offsets;        ///< distance along the line at each vertex (m)
};

struct StopZone {
  std::string name;
  double x_min = 0.0, x_max = 0.0;     ///< used when polygon is empty (m)
  std::vector<Eigen::Vector2d> polygon;  ///< m
};

/// The rotation of z-y-x Euler angles (deg): yaw about z, then pitch about y, roll about x
/// (release.orientation_deg and orientation_format euler_zyx_deg).
Eigen::Quaterniond zyx_rotation(const std::array<double, 3>& deg);

/// A validated scene, ready to run: terrain, materials after overrides and switches,
/// block models, barriers, zones. Immutable; realizations read it from any thread.
class Scene {
 public:
  /// Validates `settings` against the loaded terrain and blocks and builds the scene.
  /// `origins` says where each setting was given (the scene file and line, or the --set
  /// key): an error names where the value it refuses came from, its source the scene.
  /// Throws core::InputError with a one-line reason:
  /// wrong schema major, non-positive counts, unknown block or material names, release
  /// points outside the terrain, a non-finite or (lowest_point) negative release height,
  /// degenerate lines, zones or polygons, bad engine settings. Whether a block starts in
  /// the ground depends on the realization: draw_release checks it.
  /// `vectors` holds the features of the vector files the settings name (release.file,
  /// outputs.barriers[].file), read by io::read_scene_vectors; their errors name the
  /// file the scene names.
  static Scene build(const SceneSettings& settings, terrain::Terrain terrain,
                     const std::vector<block::Block>& library, const core::SettingsOrigins& origins,
                     const SceneVectors& vectors = {});

  const SceneSettings& settings() const { return settings_; }
  /// The scene's name in messages (its file).
  const std::string& source() const { return origins_.source(); }
  /// Where the setting at `path` was given, for a message about its value (see
  /// core::SettingsOrigins).
  const core::SettingsOrigins& origins() const { return origins_; }
  const terrain::Terrain& terrain() const { return *terrain_; }
  /// Add to a position in the terrain's local frame to get it in the scene's frame (m):
  /// the terrain's origin shift with frame "input", zero with "local". Messages report
  /// positions in the scene's frame, as the user wrote them.
  Eigen::Vector3d frame_shift() const;
  const std::vector<terrain::Material>& materials() const { return materials_; }
  const std::vector<SceneBlock>& blocks() const { return blocks_; }
  const std::vector<Barrier>& barriers() const { return barriers_; }
  const std::vector<StopZone>& zones() const { return zones_; }
  /// Zone names, then "other" (in no zone), then "out of domain" (left the terrain).
  std::vector<std::string> stop_classes() const;
  const HazardGridSpec& hazard_grid() const { return hazard_; }
  /// The release points, line or polygon vertices in plan (m); empty with release.file.
  const std::vector<Eigen::Vector2d>& release_zone() const { return release_zone_; }
  /// The release zone as features: an inline line or polygon is one feature of one part,
  /// inline points one feature each (as a file of Point features without weight_field).
  const std::vector<ReleaseFeature>& release_features() const { return release_features_; }
  /// The rows of release.orientation_file (orientation "list"), body → world.
  const std::vector<Eigen::Quaterniond>& release_orientations() const { return release_orientations_; }
  Eigen::Vector2d main_direction() const { return main_direction_; }
  std::uint32_t realizations() const { return static_cast<std::uint32_t>(settings_.realizations); }
  /// The smooth surface (or the TIN template whose search structure realizations share).
  const terrain::Surface& base_surface() const { return *base_; }

  /// Stop class of a final plan position and end reason (index into stop_classes()).
  std::int32_t classify(const Eigen::Vector2d& final_xy, bool left_terrain) const;

 private:
  SceneSettings settings_;
  core::SettingsOrigins origins_;
  std::unique_ptr<terrain::Terrain> terrain_;
  std::unique_ptr<terrain::Surface> base_;
  std::vector<terrain::Material> materials_;
  std::vector<SceneBlock> blocks_;
  std::vector<Barrier> barriers_;
  std::vector<StopZone> zones_;
  HazardGridSpec hazard_;
  std::vector<Eigen::Vector2d> release_zone_;
  std::vector<ReleaseFeature> release_features_;
  std::vector<Eigen::Quaterniond> release_orientations_;
  Eigen::Vector2d main_direction_ = Eigen::Vector2d::UnitX();
};

/// True if `p` lies inside the simple polygon `polygon` (even–odd rule).
bool point_in_polygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);
/// True if `p` lies inside a polygon with holes given as its rings (outer, then holes):
/// even–odd over all rings, so a point in a hole is outside.
bool point_in_rings(const std::vector<std::vector<Eigen::Vector2d>>& rings, const Eigen::Vector2d& p);

/// "x in [a, b], y in [c, d]": the plan extent of bounds `b` (local frame, m) shifted by
/// `shift` into another frame (by the origin shift: the terrain's input coordinates), for
/// messages about positions off the terrain.
std::string extent_text(const geometry::Aabb& b, const Eigen::Vector2d& shift);
/// "; it lies WHERE the terrain in its local frame (input coordinates minus the origin shift
/// [x, y])": the middle of a message about a position given in input coordinates that lies
/// on the terrain when read in its local frame (`where`: "inside", "on"); the caller adds
/// what to do.
std::string local_frame_hint(const Eigen::Vector2d& shift, const std::string& where);

/// Why an observed stop at plan point `p` (the terrain's input coordinates) is where no
/// simulated block can stop, for a message that names it first: "" when it lies on the
/// terrain `base` (its surface, local frame; `shift` its origin shift), else " is outside
/// the terrain (…)" or " has no terrain under it (…)" with the terrain's extent, and the
/// local-frame hint when p lies on the terrain read in that frame.
std::string observed_stop_off_terrain(const terrain::Surface& base, const Eigen::Vector2d& p,
                                     const Eigen::Vector2d& shift);

/// Parses "K/N" (0 ≤ K < N) as a shard; throws core::UsageError otherwise.
struct Shard {
  std::uint32_t index = 0;  ///< K
  std::uint32_t count = 1;  ///< N
  static Shard parse(const std::string& text);
  std::string text() const;
  /// Realizations of this shard: i ≡ K (mod N), ascending (round-robin, so every shard gets
  /// a fair mix of blocks and of easy and hard realizations).
  std::vector<std::uint32_t> indices(std::uint32_t total) const;
};

}  // namespace talus::mc
