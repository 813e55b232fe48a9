// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "settings.hpp"
#include "talus/block/block.hpp"
#include "talus/core/settings.hpp"

namespace talus::block_gen {

/// Builds every block of the settings' list, then one block per positional input file
/// (a mesh, or a cloud by extension / a PLY without faces). `origins` say where each
/// setting was given (file and line, or --set key), for messages. Repairs and
/// simplifications are logged and kept in Block::notes.
std::vector<block::Block> build_blocks(const Settings& settings, const std::vector<std::string>& inputs,
                                       const core::SettingsOrigins& origins);

/// The master seed recorded in provenance: the seed of the first block that draws random
/// numbers, 0 if none does.
std::uint64_t provenance_seed(const Settings& settings);

}  // namespace talus::block_gen
