// SPDX-License-Identifier: MIT
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "settings.hpp"
#include "talus/core/settings.hpp"
#include "talus/geometry/types.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain_gen {

/// `file` is an existing terrain file, read back for --summary and --export-mesh only.
enum class SourceKind { synthetic, dem, tin, points, file };

/// The input kind: `settings.source`, or inferred from the input extensions when "auto".
/// Throws core::UsageError for inputs that contradict it or cannot be told apart.
SourceKind resolve_source(const Settings& settings, const std::vector<std::string>& inputs);

/// A built terrain and what the summary reports about how it was built.
struct Built {
  terrain::Terrain terrain;
  SourceKind kind = SourceKind::synthetic;
  std::optional<double> roughness_index;  ///< R when σ was given through it
  std::string triangulation;              ///< grid terrains: the diagonal mode
};

/// Builds the terrain the settings describe from the inputs. `origins` say where each
/// setting was given (the -c file and line, or the --set key), for messages about a
/// value. Throws core::InputError for bad input.
Built build_terrain(const Settings& settings, const std::vector<std::string>& inputs,
                    const core::SettingsOrigins& origins);

/// A human-readable description of the terrain (several lines).
std::string summary(const Built& built);

}  // namespace talus::terrain_gen
