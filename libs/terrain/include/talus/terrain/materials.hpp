// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

/// A plan-view zone of one ground material.
struct MaterialZone {
  std::string material;                         ///< name of a Terrain::materials entry
  std::vector<std::array<double, 2>> polygon;   ///< [x, y] vertices (m, local coordinates), >= 3, either orientation
  void visit(core::SettingsVisitor& v);
};

/// Gives each triangle the material of the last zone whose polygon contains the plan
/// position (x, y) of its centroid (even–odd rule; base geometry), else leaves it as it
/// is. Throws core::InputError for an unknown material name, a polygon with fewer than
/// 3 points or a non-finite coordinate, naming the zone and where it was given
/// (`origins` of the zones list: of("[2].polygon") for zone 2's polygon).
void assign_zones(Terrain& terrain, const std::vector<MaterialZone>& zones, const core::SettingsOrigins& origins);

/// Gives each triangle the material id of the raster point nearest the plan position of
/// its centroid: raster point (i, j) stands for the cell of size dx × dy centred on it
/// (local coordinates, as the terrain). Throws core::InputError(source, …) when a
/// centroid lies outside the raster's cells, or when an id used is not an integer in
/// [0, materials.size()) (NODATA included), naming the id and the raster point, with
/// positions in the terrain's input coordinates (local + terrain.origin_shift).
void assign_material_raster(Terrain& terrain, const DemGrid& ids, const std::string& source);

}  // namespace talus::terrain
