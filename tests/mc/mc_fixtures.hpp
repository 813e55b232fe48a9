// SPDX-License-Identifier: MIT
// Small terrains, blocks and scenes shared by the Monte-Carlo tests.
#pragma once
#include <cmath>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/block/solids.hpp"
#include "talus/mc/scene.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/synthetic.hpp"

namespace talus::mc::testing {

/// The SPEC §6 bench profile, 20 m wide (31 × 11 points) unless told, with roughness σ (m).
inline terrain::Terrain bench_terrain(double sigma = 0.1, double width = 20.0) {
  terrain::SyntheticSlope slope;
  slope.width = width;
  terrain::Terrain t =
      terrain::build_grid_terrain(terrain::make_synthetic(slope, "test"), terrain::Diagonal::alternating, 7, "test");
  t.roughness.sigma = sigma;
  t.materials[0].name = "slope";
  t.name = "bench-test";
  return t;
}

/// A flat 40 m × 20 m plane at z = 0, 2 m cells.
inline terrain::Terrain flat_terrain() {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 2.0, 2.0, 21, 11};
  dem.z.assign(dem.spec.point_count(), 0.0);
  terrain::Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "test");
  t.name = "flat";
  return t;
}

/// A plane descending along +x at `slope_deg`: z = (20 − x)·tan(slope), x in [0, 20],
/// y in [0, 10], 1 m cells.
inline terrain::Terrain plane_terrain(double slope_deg) {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 21, 11};
  const double rise = std::tan(slope_deg * M_PI / 180.0);
  for (std::int32_t j = 0; j < dem.spec.ny; ++j)
    for (std::int32_t i = 0; i < dem.spec.nx; ++i) dem.z.push_back((20.0 - i) * rise);
  terrain::Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "test");
  t.name = "plane";
  return t;
}

/// A library of 1 m³ named solids.
inline std::vector<block::Block> library(std::initializer_list<block::SolidKind> kinds) {
  std::vector<block::Block> out;
  for (const auto kind : kinds) {
    block::SolidSpec spec;
    spec.kind = kind;
    spec.volume = 1.0;
    out.push_back(block::make_block(std::string(block::solid_name(kind)), block::make_solid(spec, "test"), 2800.0,
                                    "test"));
  }
  return out;
}

/// A scene on bench_terrain(), centred (y = 10). To keep the tests quick (they also run
/// under the sanitizers) blocks start on the lowest slope, 10 m before the toe, and a
/// realization lasts at most 4 s.
inline SceneSettings bench_scene(std::int64_t realizations = 4) {
  SceneSettings s;
  s.release.points = {{26.0, 10.0}};
  s.engine.max_steps = 4000;
  s.realizations = realizations;
  s.seed = 11;
  s.outputs.hazard_cell_size = 4.0;
  s.outputs.barriers = {{"lower slope", {{30.0, 0.0}, {30.0, 20.0}}}, {"toe", {{36.0, 0.0}, {36.0, 20.0}}}};
  s.stop_zones = {{"bench 1", {5.5, 9.0}, {}}, {"slope", {-1.0, 35.5}, {}}, {"run-out", {35.5, 61.0}, {}}};
  return s;
}

}  // namespace talus::mc::testing
