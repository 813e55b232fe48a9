// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

/// A synthetic slope, so that tests and benchmarks need no external data. x points
/// downslope (z decreases with x), y across; the DEM starts at (0, 0) unless a profile
/// starts elsewhere, with y in [0, width].
///
/// kind "bench" (the default) is the SPEC §6 reference slope, as the profile
///   (0, 30) (6, 24) (8, 24) (14, 18) (16, 18) (22, 12) (24, 12) (36, 0) (60, 0):
/// 60 m long, crest at x = 0 (z = 30 m), a 1:1 slope broken by three 2 m benches at
/// x = 6–8 (z = 24), 14–16 (z = 18) and 22–24 m (z = 12), toe at x = 36 m (z = 0), flat
/// run-out to x = 60 m; with the default 2 m cells and 40 m width: 31 × 21 points.
/// kind "plane": z = (length − x)·tan(slope_angle) for x in [0, length] (toe at z = 0).
/// kind "profile": z piecewise linear in x through `profile`, constant in y.
/// The grid has nx = ⌊extent/cell_size⌋ + 1 points along x (extent = length, or the
/// profile's x range) and ⌊width/cell_size⌋ + 1 along y (within 1e-9 of a cell).
struct SyntheticSlope {
  std::string kind = "bench";
  double cell_size = 2.0;         ///< m, grid spacing in x and y
  double width = 40.0;            ///< m, extent across the slope (y)
  double length = 60.0;           ///< m, plane only: extent downslope (x)
  double slope_angle_deg = 45.0;  ///< deg, plane only: inclination, in [0, 90)
  std::vector<std::array<double, 2>> profile;  ///< profile only: [x, z] (m), x strictly increasing
  void visit(core::SettingsVisitor& v);
};

/// The SPEC §6 bench profile as [x, z] breakpoints (m).
std::vector<std::array<double, 2>> bench_profile();

/// The DEM of a synthetic slope. Throws core::InputError naming the bad setting, where
/// `origins` (those of the slope's section) say it was given: non-positive or non-finite
/// sizes, an angle outside [0, 90), fewer than 2 profile points, x not strictly
/// increasing, a grid of fewer than 2 × 2 points, or a cell_size that does not divide the
/// slope's length and width.
DemGrid make_synthetic(const SyntheticSlope& slope, const core::SettingsOrigins& origins);

}  // namespace talus::terrain
