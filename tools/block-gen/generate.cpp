#include "generate.hpp"

#include <array>
#include <cmath>
#include <filesystem>
#include <set>

#include "talus/block/hull.hpp"
#include "talus/block/mesh_check.hpp"
#include "talus/block/simplify.hpp"
#include "talus/block/solids.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/io/mesh_io.hpp"
#include "talus/io/point_cloud.hpp"

namespace talus::block_gen {

using geometry::Polyhedron;
using geometry::Vec3;

namespace {

bool draws_random(const BlockSettings& b) {
  return b.solid == "rock" || (b.solid == "ellipsoid" && b.roughness > 0.0);
}

block::RepairOptions repair_options(const RepairSettings& r, const std::string& where, const std::string& key) {
  core::require(r.max_hole_edges >= 3, where, key + ".max_hole_edges must be at least 3");
  core::require(r.stitch_tolerance >= 0.0 && std::isfinite(r.stitch_tolerance), where,
                key + ".stitch_tolerance must be >= 0 m");
  block::RepairOptions o;
  o.orient = r.orient;
  o.stitch = r.stitch;
  o.stitch_tolerance = r.stitch_tolerance;
  o.fill_holes = r.fill_holes;
  o.max_hole_edges = static_cast<std::size_t>(r.max_hole_edges);
  o.settings_key = key;
  return o;
}

// A mesh or cloud file to a valid polyhedron in the file's frame (scaled, z up).
// `key` is where `in` is set ("inputs", "blocks[2].input"), for the hints of messages.
Polyhedron read_solid_file(const std::string& path, bool cloud, const InputSettings& in, const std::string& where,
                           const std::string& key, std::vector<std::string>& notes) {
  core::require(in.scale > 0.0 && std::isfinite(in.scale), where, "input.scale must be positive");
  const io::UpAxis up = in.up_axis == "y" ? io::UpAxis::y : io::UpAxis::z;
  const block::RepairOptions repair = repair_options(in.repair, where, key + ".repair");
  block::CheckedMesh checked;
  if (cloud) {
    io::PointCloudOptions options;
    options.scale = in.scale;
    options.up = up;
    const std::vector<Vec3> points = io::read_point_cloud(path, options);
    if (in.reconstruction == "hull") {
      checked.polyhedron = block::convex_hull(points, path);
      notes.push_back("convex hull of " + std::to_string(points.size()) + " points");
    } else {
      block::ReconstructionOptions r;
      r.radius_ratio_bound = in.radius_ratio_bound;
      r.beta_deg = in.beta_deg;
      checked = block::check_mesh(block::reconstruct_surface(points, r, path), repair, path);
      // The reconstruction's face order depends on CGAL's internal shuffles.
      geometry::canonicalize(checked.polyhedron);
      notes.push_back("advancing-front reconstruction of " + std::to_string(points.size()) +
                      " points (radius_ratio_bound " + core::format_number(r.radius_ratio_bound) + ", beta " +
                      core::format_number(r.beta_deg) + " deg)");
    }
  } else {
    io::MeshImportOptions options;
    options.scale = in.scale;
    options.up = up;
    io::ImportedMesh imported = io::import_mesh(path, options);
    checked = block::check_mesh(std::move(imported.mesh), repair, path);
  }
  for (const auto& r : checked.repairs) {
    core::log_warn(path + ": repaired: " + r);
    notes.push_back("repaired: " + r);
  }
  return std::move(checked.polyhedron);
}

// `item` is the block's key path ("blocks[2]"), `where` its place in messages.
Polyhedron make_named_solid(const BlockSettings& b, const std::string& item, const std::string& where,
                            const core::SettingsOrigins& origins) {
  block::SolidSpec spec;
  spec.kind = *block::parse_solid_kind(b.solid);
  const bool needs_volume = spec.kind != block::SolidKind::box && spec.kind != block::SolidKind::ellipsoid;
  // A box's or ellipsoid's shape is its dimensions: none has a default.
  if (!needs_volume) {
    const bool box = spec.kind == block::SolidKind::box;
    const std::string what = std::string(box ? "a box needs its edges" : "an ellipsoid needs its diameters") +
                             " along x, y, z in dimensions: [a, b, c] (m)";
    if (b.dimensions == std::array<double, 3>{0.0, 0.0, 0.0})
      throw core::InputError(origins.of({item + ".dimensions", item + ".solid"}), item + ": " + what);
    if (!(b.dimensions[0] > 0.0 && b.dimensions[1] > 0.0 && b.dimensions[2] > 0.0))
      throw core::InputError(origins.of(item + ".dimensions"), item + ": " + what + ", each > 0, got [" +
                                                                   core::format_number(b.dimensions[0]) + ", " +
                                                                   core::format_number(b.dimensions[1]) + ", " +
                                                                   core::format_number(b.dimensions[2]) + "]");
  }
  spec.volume = b.volume ? *b.volume : (needs_volume ? 1.0 : 0.0);
  core::require(!b.volume || *b.volume > 0.0, origins.of(item + ".volume"), "volume must be positive, got " +
                                                         core::format_number(b.volume.value_or(0.0)) + " m^3");
  spec.dimensions = Vec3(b.dimensions[0], b.dimensions[1], b.dimensions[2]);
  spec.resolution = static_cast<int>(std::clamp<std::int64_t>(b.resolution, -1, 1 << 20));
  spec.roughness = b.roughness;
  spec.elongation = b.elongation;
  spec.flatness = b.flatness;
  spec.points = static_cast<int>(std::clamp<std::int64_t>(b.points, -1, 1 << 24));
  spec.seed = b.seed;
  return block::make_solid(spec, where);
}

// Scales a polyhedron about its centroid to the target volume.
void rescale(Polyhedron& poly, double target) {
  const geometry::MassProperties m = geometry::mass_properties(poly);
  const double s = block::scale_to_volume(m.volume, target);
  for (Vec3& p : poly.vertices) p = m.centroid + s * (p - m.centroid);
}

block::Block finish(const std::string& name, Polyhedron poly, const BlockSettings& b, const Settings& settings,
                    const std::string& source, const std::string& where, std::vector<std::string> notes) {
  core::require(std::isfinite(b.weight) && b.weight >= 0.0, where,
                "weight must be a finite number >= 0, got " + core::format_number(b.weight));
  const double density = b.density.value_or(settings.density);
  block::Block blk = block::make_block(name, poly, density, where);
  const SimplifySettings& simplify = b.input.simplify;
  if (simplify.mode != "none") {
    Polyhedron reduced = simplify.mode == "hull"
                             ? block::simplify_to_hull(blk.polyhedron, where)
                             : block::simplify_to_faces(blk.polyhedron, static_cast<std::size_t>(std::max<std::int64_t>(
                                                                            simplify.target_faces, 0)),
                                                        where);
    for (Vec3& p : reduced.vertices) p += blk.translation;
    block::Block simpler = block::make_block(name, reduced, density, where);
    const block::SimplifyReport report = block::compare(blk, simpler);
    core::log_info(name + ": " + report.describe());
    notes.push_back(report.describe());
    blk = std::move(simpler);
  }
  blk.source = source;
  blk.weight = b.weight;
  blk.notes = std::move(notes);
  return blk;
}

}  // namespace

std::vector<block::Block> build_blocks(const Settings& settings, const std::vector<std::string>& inputs,
                                       const core::SettingsOrigins& origins) {
  core::require(settings.density > 0.0 && std::isfinite(settings.density), origins.of("density"),
                "density must be positive, got " + core::format_number(settings.density) + " kg/m^3");
  std::vector<block::Block> blocks;
  for (std::size_t i = 0; i < settings.blocks.size(); ++i) {
    const BlockSettings& b = settings.blocks[i];
    const std::string item = "blocks[" + std::to_string(i) + "]";
    const std::string where = origins.of(item) + ": " + item;
    const int sources = (b.solid != "none") + !b.mesh.empty() + !b.cloud.empty();
    if (sources != 1)
      throw core::InputError(
          origins.of({item + ".solid", item + ".mesh", item + ".cloud"}),
          item + ": give exactly one of solid, mesh or cloud (" + std::to_string(sources) + " given)");
    std::vector<std::string> notes;
    Polyhedron poly;
    std::string name = b.name, source;
    if (b.solid != "none") {
      poly = make_named_solid(b, item, where, origins);
      source = b.solid;
      if (name.empty()) name = b.solid;
    } else {
      const std::string& path = b.mesh.empty() ? b.cloud : b.mesh;
      poly = read_solid_file(path, !b.cloud.empty(), b.input, where, "blocks[" + std::to_string(i) + "].input", notes);
      if (b.volume) {
        core::require(*b.volume > 0.0, origins.of(item + ".volume"), "volume must be positive");
        rescale(poly, *b.volume);
        notes.push_back("scaled to " + core::format_number(*b.volume) + " m^3");
      }
      source = path;
      if (name.empty()) name = std::filesystem::path(path).stem().string();
    }
    blocks.push_back(finish(name, std::move(poly), b, settings, source, where, std::move(notes)));
  }
  for (const std::string& path : inputs) {
    BlockSettings b;
    b.input = settings.inputs;
    std::vector<std::string> notes;
    Polyhedron poly = read_solid_file(path, io::is_point_cloud_file(path), b.input, path, "inputs", notes);
    blocks.push_back(
        finish(std::filesystem::path(path).stem().string(), std::move(poly), b, settings, path, path, std::move(notes)));
  }
  if (blocks.empty())
    throw core::UsageError("nothing to build: give INPUT files or a settings file with a 'blocks' list (see --help)");
  std::set<std::string> names;
  for (std::size_t k = 0; k < blocks.size(); ++k)
    if (!names.insert(blocks[k].name).second)
      throw core::InputError(k < settings.blocks.size() ? origins.of("blocks[" + std::to_string(k) + "].name")
                                                        : blocks[k].source,
                             "duplicate block name '" + blocks[k].name + "' (set 'name' to tell them apart)");
  double total_weight = 0.0;
  for (const auto& blk : blocks) total_weight += blk.weight;
  core::require(total_weight > 0.0, origins.of("blocks"), "the block weights sum to zero");
  return blocks;
}

std::uint64_t provenance_seed(const Settings& settings) {
  for (const auto& b : settings.blocks)
    if (draws_random(b)) return b.seed;
  return 0;
}

}  // namespace talus::block_gen
