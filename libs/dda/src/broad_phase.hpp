// SPDX-License-Identifier: MIT
// The broad phase of the contact search: the terrain features near the block (the
// patch), and the feature pairs a search tests, gathered at one pose and reused at the
// poses close to it (docs/dda.md, "Reusing the pairs"). Nothing here decides a contact:
// the pairs only prune what the narrow phase then tests exactly.
#pragma once
#include <cstdint>
#include <vector>

#include "narrow_phase.hpp"

namespace talus::dda::detail {

// How much wider than a step's search (m, times the block's radius) a scanned block's
// candidate pairs are gathered: they serve the steps until the block has moved by that.
constexpr double kCandidateWidening = 0.05;
// The same for a detailed block, whose pairs are many more per unit of widening.
constexpr double kIndexedWidening = 0.02;
// How much farther than the search's margin (m, times the block's radius) a detailed
// block's triangles and ridges are taken by their boxes: they serve until it has moved by
// that (its pairs by their caps, usually sooner).
constexpr double kIndexedBoxWidening = 0.25;

/// Gathers the triangles `list` of `surface` into `patch`: corners, normals, the distinct
/// vertices, and the edges that are ridges (not between coplanar triangles).
void fill_patch(const terrain::Surface& surface, const std::vector<std::int32_t>& list, TerrainPatch& patch);

/// Whether the search of `model` crosses its edges with ridge te: every ridge but a
/// valley, whose crossings a block of short edges leaves to its vertex contacts
/// (Model::crosses_valleys; `every_valley`, SearchFilter's, crosses them all).
bool crosses(const Model& model, const TerrainPatch::Ridge& te, bool every_valley);

/// ‖a‖₂, generously (1e-6 over): 1 for a rotation (`rotation`, to round-off), else the
/// square root of aᵀa's largest eigenvalue.
double norm_bound(const Mat3& a, bool rotation);

/// A bound of ‖F − F₀‖₂ for the map F of `pose` and an earlier map F₀ of the same block
/// (`rigid0`: a rotation too): every block point r has moved by at most that times |r|
/// besides the centre's motion.
double map_change(const Pose& pose, const Mat3& map0, bool rigid0);

/// How far the points of a block at `pose` have moved at most (m) since the pose of
/// gathering g: ∞ when g is of another model or none.
double moved_since(const TerrainPatch::Candidates::Gathering& g, const Model& model, const Pose& pose);

/// The feature pairs of a scanned block (few vertices) that can form a contact within
/// search distance ds and depth limit `depth`, in the order detect_scanned tests them:
/// for each, the tests of detect_scanned that only a distance decides (a box, a gap),
/// widened to these distances. `prune` off keeps every pair (the brute-force reference);
/// `every_valley` crosses every valley (SearchFilter).
void gather_candidates(const PlacedBlock& at, const TerrainPatch& patch, double ds, double depth, bool prune,
                       bool every_valley, TerrainPatch::Candidates& c);

// The triangles and ridges of a detailed block's pairs (indices into Candidates::triangles
// and ::ridges, ascending) whose boxes meet a search's reach (the block's box inflated by
// the search's margin): the only ones its pairs are refreshed and tested for.
struct Live {
  std::vector<std::size_t> triangles, ridges;
};

/// A detailed block's pairs for a search at ds (m, the near distance if any) with depth
/// limit `depth`: the triangles and ridges by their boxes, then the pairs of each whose
/// box meets the search's reach, gathered again where they no longer serve (pairs_serve);
/// those met into `live`.
void refresh_pairs(const PlacedBlock& at, TerrainPatch& patch, double ds, double depth, bool every_valley,
                   Live& live);

}  // namespace talus::dda::detail
