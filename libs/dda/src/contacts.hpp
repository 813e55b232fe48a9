// SPDX-License-Identifier: MIT
#pragma once
#include <vector>

#include "talus/dda/model.hpp"
#include "talus/dda/state.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::dda::detail {

/// The block's placement at the start of a step: world x = centre + F·r_body.
struct Pose {
  Vec3 centre = Vec3::Zero();
  Mat3 rotation = Mat3::Identity();     ///< R
  Mat3 map = Mat3::Identity();          ///< F = R·U
  Mat3 inverse_map = Mat3::Identity();  ///< F⁻¹
};

/// Finds every block–terrain contact candidate within `search_distance` (m) of the
/// block at `pose` (world vertices `world`): block vertex – terrain triangle, terrain
/// vertex – block face, block edge – terrain ridge edge. Candidates deeper than
/// `depth_limit` (m) are ignored (they belong to another side of the terrain). Terrain
/// features come from `patch`, re-gathered (with a margin) only when the block's search
/// box leaves it. Appends to `out` (geometric fields only).
void detect_contacts(const Model& model, const terrain::Surface& surface, const Pose& pose,
                     const std::vector<Vec3>& world, double search_distance, double depth_limit,
                     TerrainPatch& patch, std::vector<Contact>& out);

/// Brute-force reference of detect_contacts: every triangle of the surface, no pruning.
void detect_contacts_brute_force(const Model& model, const terrain::Surface& surface, const Pose& pose,
                                 const std::vector<Vec3>& world, double search_distance,
                                 double depth_limit, std::vector<Contact>& out);

}  // namespace talus::dda::detail
