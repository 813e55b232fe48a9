// SPDX-License-Identifier: MIT
// The contact search: the broad phase (the terrain patch near the block and the pairs
// gathered from it) and then the narrow phase over those pairs (contacts.hpp,
// detect_contacts).
#include <numeric>

#include "broad_phase.hpp"

namespace talus::dda::detail {

void detect_contacts(const PlacedBlock& at, const terrain::Surface& surface, double search_distance,
                     double depth_limit, TerrainPatch& patch, std::vector<Contact>& out, const SearchFilter& filter) {
  const double near_distance = filter.near_distance;
  MotionFilter* const pass = filter.motion;
  const geometry::Aabb box = at.box().inflated(std::max(search_distance, depth_limit));
  if (patch.surface != &surface || patch.box.empty() || !patch.box.contains(box.lo) || !patch.box.contains(box.hi)) {
    // Gather with a margin of half the block's radius, so the next steps reuse it.
    patch.surface = &surface;
    patch.box = box.inflated(0.5 * at.model().radius);
    patch.query.clear();
    surface.triangles_in_box(patch.box, patch.query);
    fill_patch(surface, patch.query, patch);
    patch.candidates.gathering.model = nullptr;
    patch.candidates.ridge_gathering.model = nullptr;
  }
  // Pairs are gathered afresh when the block has moved by more than their wider distances
  // allow: a point moves by at most |Δcentre| + ‖ΔF‖·radius, a gap or a box distance no
  // more.
  const Model& model = at.model();
  const Pose& pose = at.pose();
  TerrainPatch::Candidates& c = patch.candidates;
  if (at.index() != nullptr) {
    // The pairs serve the vertex–triangle and edge–ridge tests, at the near distance.
    const double ds = near_distance > 0.0 && near_distance < search_distance ? near_distance : search_distance;
    thread_local Live live;
    refresh_pairs(at, patch, ds, depth_limit, filter.every_valley, live);
    detect_indexed(at, patch, ds, search_distance, depth_limit, c, live, out,
                   pass != nullptr && at.pose().rigid && ds < search_distance ? pass : nullptr);
    return;
  }
  const double moved = moved_since(c.gathering, model, pose);
  const TerrainPatch::Candidates::Gathering& g = c.gathering;
  const bool reusable = search_distance + moved <= g.ds && depth_limit + moved <= g.depth && moved <= g.motion;
  if (!reusable) {
    const double widening = kCandidateWidening * model.radius;
    gather_candidates(at, patch, search_distance + widening, depth_limit + widening, true, filter.every_valley, c);
  }
  detect_scanned(at, patch, search_distance, depth_limit, true, c, out);
}

void detect_contacts_brute_force(const Model& model, const terrain::Surface& surface, const Pose& pose,
                                 double search_distance, double depth_limit, std::vector<Contact>& out,
                                 bool every_valley) {
  std::vector<std::int32_t> all(surface.triangle_count());
  std::iota(all.begin(), all.end(), 0);
  TerrainPatch patch;
  fill_patch(surface, all, patch);
  std::vector<Vec3> world;
  const PlacedBlock at(model, pose, world, true);
  TerrainPatch::Candidates every;
  gather_candidates(at, patch, search_distance, depth_limit, false, every_valley, every);
  detect_scanned(at, patch, search_distance, depth_limit, false, every, out);
}

}  // namespace talus::dda::detail
