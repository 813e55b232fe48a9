// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/io/file_header.hpp"

namespace talus::io {

/// Writes a block library (one or more blocks) as a Talus block file, atomically
/// (layout: docs/formats.md, "Block file"). Throws core::RuntimeError if it cannot be written.
/// With `xdmf_path`, the sidecar (write_block_xdmf) is written after the HDF5 file is
/// complete and before it is renamed, so a failure of either keeps both earlier files.
void write_block_file(const std::string& path, const std::vector<block::Block>& blocks,
                      const Provenance& provenance, const std::string& xdmf_path = {});

/// Reads every block of a block file, with the polyhedron checked to be closed and
/// consistently oriented. Throws core::InputError naming the file and the block on a
/// wrong kind or version, a missing dataset, or corrupt geometry.
std::vector<block::Block> read_block_file(const std::string& path);

/// Writes an XDMF sidecar describing the triangles of every block of `h5_path` (a
/// spatial collection, one grid per block, each in its centroid frame), so ParaView opens
/// the library without Talus. Atomic.
void write_block_xdmf(const std::string& xdmf_path, const std::string& h5_path,
                      const std::vector<block::Block>& blocks);

/// Human-readable properties of one block (several lines), as `block-gen info` prints them.
std::string describe_block(const block::Block& block);

}  // namespace talus::io
