// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/core/settings.hpp"

namespace talus::block_gen {

/// Repairs of an imported mesh or reconstructed cloud, made only when asked.
struct RepairSettings {
  bool orient = false;
  bool stitch = false;
  double stitch_tolerance = 0.0;  ///< m; 0 = 1e-6 × bounding-box diagonal
  bool fill_holes = false;
  std::int64_t max_hole_edges = 16;
  void visit(core::SettingsVisitor& v);
};

/// Level of detail.
struct SimplifySettings {
  std::string mode = "none";  ///< none, faces (edge collapse to target_faces) or hull
  std::int64_t target_faces = 500;
  void visit(core::SettingsVisitor& v);
};

/// How to read a mesh or cloud file.
struct InputSettings {
  double scale = 1.0;
  std::string up_axis = "z";
  std::string reconstruction = "hull";  ///< clouds: hull or advancing_front
  double radius_ratio_bound = 5.0;
  double beta_deg = 30.0;
  RepairSettings repair;
  SimplifySettings simplify;
  void visit(core::SettingsVisitor& v);
};

/// Volumes a block may have (m³): from a pebble of 1 cm³ to a rock mass of 1e6 m³.
/// Outside it the exact arithmetic and the engine's scales leave the double range.
core::Range block_volume_range();
/// Rock densities (kg/m³).
core::Range density_range();

/// One block of the library: a named solid, a mesh file or a point cloud.
struct BlockSettings {
  std::string name;                   ///< default: the solid name or the file stem
  std::string solid = "none";
  std::string mesh;
  std::string cloud;
  std::optional<double> volume;       ///< m³
  std::array<double, 3> dimensions{0.0, 0.0, 0.0};  ///< m; all 0 = not given (a box or ellipsoid needs them)
  std::int64_t resolution = 8;
  double roughness = 0.0;
  double elongation = 0.7;
  double flatness = 0.7;
  std::int64_t points = 40;
  std::uint64_t seed = 1;
  std::optional<double> density;      ///< kg/m³; default: the top-level density
  double weight = 1.0;
  InputSettings input;
  void visit(core::SettingsVisitor& v);
};

struct Settings {
  double density = block::kDefaultDensity;  ///< kg/m³
  bool xdmf = true;
  InputSettings inputs;  ///< how positional INPUT files are read
  std::vector<BlockSettings> blocks;
  void visit(core::SettingsVisitor& v);
};

}  // namespace talus::block_gen
