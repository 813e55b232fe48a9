// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>

#include "talus/io/hdf5.hpp"

namespace talus::io {

/// What produced a file: enough to regenerate it (docs/formats.md, "Provenance").
struct Provenance {
  std::string tool;           ///< e.g. "terrain-gen"
  std::string tool_version;   ///< Talus version
  std::string settings_yaml;  ///< effective settings, defaults included
  std::string command_line;   ///< the invocation, for the record
  std::uint64_t seed = 0;     ///< master seed (0 when the tool draws nothing)
  std::string inputs;         ///< input files, one per line
};

/// The kinds of Talus file and their current schema versions.
struct SchemaVersion {
  int major = 1;
  int minor = 0;
};
inline constexpr SchemaVersion kTerrainSchema{1, 1};  // 1.1: optional crs_wkt attribute
inline constexpr SchemaVersion kBlockSchema{1, 0};
inline constexpr SchemaVersion kRunSchema{1, 2};  // 1.1: optional /hazard exact values, speed sketch, energy maxima; 1.2: trajectory orientation, angular velocity, motion

/// Writes the root attributes "talus_format" (kind) and "schema_version" ("MAJOR.MINOR"),
/// and the /provenance group.
void write_header(const h5::Group& root, const std::string& kind, SchemaVersion version,
                  const Provenance& provenance);

/// Checks that the file is a Talus file of `kind` whose major schema version this build
/// reads; throws core::InputError naming the file otherwise. Returns the file's version.
SchemaVersion check_header(const h5::Group& root, const std::string& kind, SchemaVersion supported);

/// Reads the /provenance group.
Provenance read_provenance(const h5::Group& root);

}  // namespace talus::io
