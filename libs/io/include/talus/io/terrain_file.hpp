// SPDX-License-Identifier: MIT
#pragma once
#include <optional>
#include <string>

#include "talus/io/file_header.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::io {

/// What a terrain file holds besides the terrain model itself.
struct TerrainFileInfo {
  SchemaVersion version;                 ///< schema version of the file
  Provenance provenance;                 ///< tool, settings, command line, inputs, seed
  std::optional<double> roughness_index; ///< Römkens–Wang R the σ came from (-), if given that way
};

/// The first inconsistency of a terrain model, or an empty string when there is none:
/// materials missing or with out-of-range parameters (non-finite, negative sd, K <= 0),
/// non-finite vertices, vertex indices or material ids out of range, a grid whose sizes do
/// not match its vertices, diagonals and triangles, a negative σ. What write and read check.
std::string terrain_problem(const terrain::Terrain& terrain);

/// Writes `terrain` as a Talus terrain file (layout in docs/formats.md, "Terrain file"):
/// the header and provenance, /trn (vertices, triangles, material per triangle — readable
/// without Talus, e.g. by ParaView through the XDMF sidecar), /grid for a grid TRN (spec,
/// base elevations, diagonal per cell), /materials, /roughness and /origin_shift. Large
/// arrays are compressed. Written atomically; the same input gives byte-identical files.
/// `roughness_index` is recorded when σ was given as R. Checks the terrain first
/// (core::RuntimeError if it is inconsistent: that is a bug of the caller, not bad input).
/// With `xdmf_path`, the sidecar (write_terrain_xdmf) is written after the HDF5 file is
/// complete and before it is renamed, so a failure of either keeps both earlier files.
void write_terrain_file(const std::string& path, const terrain::Terrain& terrain,
                        const Provenance& provenance,
                        std::optional<double> roughness_index = std::nullopt,
                        const std::string& xdmf_path = {});

/// Reads a terrain file written by write_terrain_file. Validates everything — kind and
/// major schema version, dataset shapes, vertex indices and material ids in range, finite
/// coordinates and parameters, the grid consistent with the TRN — and throws a one-line
/// core::InputError naming the file and the offending object when anything is wrong.
terrain::Terrain read_terrain_file(const std::string& path);

/// Same, also returning the schema version, provenance and roughness index.
terrain::Terrain read_terrain_file(const std::string& path, TerrainFileInfo& info);

/// Checks that `path` is a Talus terrain file of a schema this build reads, from its
/// header alone; throws core::InputError naming the file otherwise (a block or run file,
/// not HDF5, another schema).
void check_terrain_file(const std::string& path);

/// A 64-bit FNV-1a digest (16 hex digits) of everything a run depends on in a terrain:
/// vertices, triangles, materials per triangle, material parameters, roughness and origin
/// shift. A run file records it, so that stats can tell the run's terrain from another.
std::string terrain_fingerprint(const terrain::Terrain& terrain);

}  // namespace talus::io
