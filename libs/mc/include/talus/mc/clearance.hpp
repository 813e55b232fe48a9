// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Geometry>
#include <limits>

#include "talus/dda/model.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::mc {

/// How far a placed block is above the ground, measured vertically.
struct Clearance {
  /// Smallest z_block − z_ground over the plan points where the block lies over the
  /// terrain (m): > 0 the block floats that high, 0 it touches, < 0 it reaches −gap into
  /// the ground. Infinity when no part of the block lies over the terrain.
  double gap = std::numeric_limits<double>::infinity();
  /// The block point where the smallest gap is found (world, m).
  geometry::Vec3 point = geometry::Vec3::Zero();
};

/// The vertical clearance of `model` placed with its centroid at `position` (m) and
/// rotated by `orientation` (body → world) over `ground`. The ground is everything below
/// the terrain surface along the vertical within the terrain's plan bounds (on a TIN with
/// overhangs, below its highest surface). Exact for any block, convex or not: the gap is
/// piecewise linear over the block's surface, so its minimum lies at a block vertex over a
/// terrain triangle, a terrain vertex under a block face, or where a block edge crosses a
/// terrain edge in plan; all three are tested. Lowering the block by `gap` makes it touch
/// the ground without entering it (to round-off). Candidates that cannot be the smallest
/// are passed over by a bound (their height over the ground's mean slope); `prune` off
/// tests every one (the reference), with the same result to the bit.
Clearance vertical_clearance(const dda::Model& model, const geometry::Vec3& position,
                             const Eigen::Quaterniond& orientation, const terrain::Surface& ground,
                             bool prune = true);

/// A lower bound of vertical_clearance(model, position, …, ground).gap (m) that reads no
/// block geometry: the centroid's height less the circumscribed radius, less the highest
/// terrain vertex of the triangles under the block's plan square (the centroid ± the
/// radius), less an allowance for round-off. Every block point lies above the first and
/// every ground height the exact clearance reads lies on one of those triangles. Infinity
/// when no triangle lies under the square. A release that floats well clear of the
/// ground is settled by it without the block's vertices, faces and edges.
double clearance_lower_bound(const dda::Model& model, const geometry::Vec3& position,
                             const terrain::Surface& ground);

}  // namespace talus::mc
