// SPDX-License-Identifier: MIT
#pragma once
#include <vector>

#include "contacts.hpp"

namespace talus::dda::detail {

/// Depth (m) of the deepest terrain vertex of `patch` inside the block at `pose`, 0 if
/// none is inside. Any closed polyhedron: inside by ray parity, depth = distance to the
/// nearest face.
double terrain_depth_in_block(const Model& model, const Pose& pose, const TerrainPatch& patch);

/// Depth (m) of the deepest block vertex below the terrain triangles of `patch` it lies
/// over (vertical projection, depth measured along the triangle normal), 0 if none.
double block_depth_below_terrain(const std::vector<Vec3>& world, const TerrainPatch& patch, double radius);

/// How deep (m) the block at `pose` lies below the ground surface of a height-field
/// terrain: the largest ground height less block height over every vertical line through
/// the block, 0 if none is below it. Exact: the difference of the two piecewise-linear
/// surfaces is largest at a block vertex, at a terrain vertex (against the block's lowest
/// point on its vertical line) or where a block edge crosses a terrain edge in plan, and
/// all three are looked at. It sees what the contact depths cannot: a terrain edge or face
/// through a thin block with no vertex of either inside the other. 0 on a TIN that is no
/// height field (walls, overhangs).
double depth_below_ground(const Model& model, const Pose& pose, const terrain::Surface& surf);

/// Whether part of the block (state `s`) has dropped past the terrain's rim (engine.cpp,
/// where the rule is written out). A detailed block over ground whose rim bounds its
/// footprint (Surface::rim_bounds_footprint: a grid, a TIN without walls, overhangs or
/// folds) looks only at the vertices its tree finds near the rim or off the ground;
/// `scan` looks at every vertex (the reference the tests compare with). `s.height` NaN
/// (finish_step) says the centroid is off the ground: over a hole or bay of a TIN's
/// footprint, where the rim may lie beyond the bounding sphere.
bool hangs_past_rim(const Model& model, const terrain::Surface& surf, const State& s, bool scan = false);

}  // namespace talus::dda::detail
