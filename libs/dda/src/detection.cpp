// SPDX-License-Identifier: MIT
// The contact search: the broad phase (the terrain patch near the block and the pairs
// gathered from it) and then the narrow phase over those pairs (contacts.hpp,
// detect_contacts).
#include <algorithm>
#include <array>
#include <numeric>

#include "broad_phase.hpp"

namespace talus::dda::detail {

namespace {

// Puts the vertex contacts out[first..] on the smooth surface the facets stand for
// (Model::vertex_rounding, docs/dda.md "Smooth surface"), blended over the faces from the
// spheres tangent at their vertices so that its extent along any direction is
// continuous; its anchors roll, and the other smooth vertices of the patch on that plane
// have no contact.
void round_vertex_contacts(const PlacedBlock& at, const TerrainPatch& patch, std::vector<Contact>& out,
                           std::size_t first) {
  const Model& model = at.model();
  if (model.vertex_rounding.empty()) return;
  const Pose& pose = at.pose();
  const auto normal = [&](std::size_t v) {
    return pose.rigid ? Vec3(pose.rotation * model.vertex_normals[v])
                      : Vec3((pose.inverse_map.transpose() * model.vertex_normals[v]).normalized());
  };
  // The vertex contacts found, by vertex: (vertex, index into out).
  thread_local std::vector<std::pair<std::int32_t, std::size_t>> by_vertex;
  by_vertex.clear();
  for (std::size_t i = first; i < out.size(); ++i)
    if (out[i].kind == ContactKind::vertex_face) by_vertex.emplace_back(out[i].block_feature, i);
  std::sort(by_vertex.begin(), by_vertex.end());
  // Whether vertex w has a contact with a triangle of normal n among those found.
  const auto touches = [&](std::int32_t w, const Vec3& n) {
    for (auto it = std::lower_bound(by_vertex.begin(), by_vertex.end(), std::make_pair(w, std::size_t{0}));
         it != by_vertex.end() && it->first == w; ++it)
      if (out[it->second].normal.dot(n) > 1.0 - 1e-12) return true;
    return false;
  };
  // The smooth surface's point facing the unit direction u near vertex v, as an offset
  // from v (m), from the patch of a face around v whose vertex normals span u
  // (u = α·ν_a + β·ν_b + γ·ν_c, all ≥ 0): the blend Σλᵢ·(cᵢ + ρᵢ·u) of the vertices'
  // spheres (centres cᵢ = xᵢ − ρᵢ·νᵢ) with weights λ ∝ (α, β, γ). It is continuous in u
  // across the faces, and at u = νᵢ it is the vertex xᵢ. False when no face around v
  // spans u.
  const auto patch_point = [&](std::size_t v, const Vec3& u, Vec3& offset) {
    const Vec3 p = at.vertex(v);
    for (auto k = model.face_offsets[v]; k < model.face_offsets[v + 1]; ++k) {
      const auto& ids = model.faces[static_cast<std::size_t>(model.vertex_faces[static_cast<std::size_t>(k)])].vertices;
      // A polygon as the fan of triangles from v.
      const std::size_t at_v = static_cast<std::size_t>(std::find(ids.begin(), ids.end(), static_cast<std::int32_t>(v)) - ids.begin());
      for (std::size_t j = 1; j + 1 < ids.size(); ++j) {
        const std::array<std::size_t, 3> tri{v, static_cast<std::size_t>(ids[(at_v + j) % ids.size()]),
                                             static_cast<std::size_t>(ids[(at_v + j + 1) % ids.size()])};
        Mat3 spans;
        for (int q = 0; q < 3; ++q) spans.col(q) = normal(tri[static_cast<std::size_t>(q)]);
        const Vec3 w = spans.partialPivLu().solve(u);
        if (!(w.minCoeff() >= 0.0) || !(w.sum() > 0.0)) continue;
        const Vec3 lambda = w / w.sum();
        Vec3 x = Vec3::Zero();
        for (int q = 0; q < 3; ++q) {
          const std::size_t i = tri[static_cast<std::size_t>(q)];
          const double rho = model.vertex_rounding[i];
          x += lambda[q] * (at.vertex(i) - p + rho * (u - spans.col(q)));
        }
        offset = x;
        return true;
      }
    }
    return false;
  };
  thread_local std::vector<std::uint8_t> drop;
  drop.assign(out.size() - first, 0);
  for (std::size_t i = first; i < out.size(); ++i) {
    Contact& c = out[i];
    if (c.kind != ContactKind::vertex_face) continue;
    const auto v = static_cast<std::size_t>(c.block_feature);
    if (!(model.vertex_rounding[v] > 0.0)) continue;
    const Vec3 u = -c.normal;
    // The patch's point touches from the smooth vertex whose normal is nearest u among
    // those touching the plane; a smooth vertex beside a nearer one lies on the flank of
    // the contact patch and has no contact: on a curved surface pressed into the ground
    // only the patch's point touches, however fine the mesh.
    const double facing = normal(v).dot(u);
    bool nearest = true;
    for (auto k = model.neighbour_offsets[v]; k < model.neighbour_offsets[v + 1] && nearest; ++k) {
      const std::int32_t w = model.vertex_neighbours[static_cast<std::size_t>(k)];
      if (!(model.vertex_rounding[static_cast<std::size_t>(w)] > 0.0)) continue;
      const double other = normal(static_cast<std::size_t>(w)).dot(u);
      if ((other > facing || (other == facing && w < static_cast<std::int32_t>(v))) && touches(w, c.normal))
        nearest = false;
    }
    if (!nearest) {
      drop[i - first] = 1;
      continue;
    }
    Vec3 offset;
    if (!patch_point(v, u, offset)) continue;
    c.point += offset;
    c.gap -= std::min(u.dot(offset), model.rounding_reach);
    c.rolling = true;
  }
  // A crest crossed by smooth edges meets the smooth surface where the nearest sphere
  // touches it: one contact, from the vertex whose sphere comes nearest the crest (a climb
  // over the smooth neighbours), instead of the crossings of however many edges.
  const auto to_ridge = [&](std::size_t v, const TerrainPatch::Ridge& r, double& t, Vec3& q) {
    const Vec3 centre = at.vertex(v) - model.vertex_rounding[v] * normal(v);
    const Vec3 e = r.pb - r.pa;
    t = e.dot(centre - r.pa) / e.squaredNorm();
    q = r.pa + std::clamp(t, 0.0, 1.0) * e;
    return (centre - q).norm() - model.vertex_rounding[v];
  };
  thread_local std::vector<std::pair<std::int32_t, std::int64_t>> crests;
  crests.clear();
  // The crests the smooth edges cross, found in one pass over the patch's ridges.
  const auto smooth_edge = [&](const Contact& c) {
    if (c.kind != ContactKind::edge_edge) return false;
    const BlockEdge& edge = model.edges[static_cast<std::size_t>(c.block_feature)];
    return model.vertex_rounding[static_cast<std::size_t>(edge.a)] > 0.0 &&
           model.vertex_rounding[static_cast<std::size_t>(edge.b)] > 0.0;
  };
  thread_local std::vector<std::pair<std::int64_t, const TerrainPatch::Ridge*>> crossed;
  crossed.clear();
  for (std::size_t i = first; i < out.size(); ++i)
    if (smooth_edge(out[i])) crossed.emplace_back(out[i].terrain_feature, nullptr);
  if (!crossed.empty()) {
    std::sort(crossed.begin(), crossed.end());
    crossed.erase(std::unique(crossed.begin(), crossed.end()), crossed.end());
    for (const TerrainPatch::Ridge& r : patch.ridges) {
      const auto it = std::lower_bound(crossed.begin(), crossed.end(), std::make_pair(r.key(), static_cast<const TerrainPatch::Ridge*>(nullptr)));
      if (it != crossed.end() && it->first == r.key()) it->second = &r;
    }
  }
  for (std::size_t i = first; i < out.size(); ++i) {
    Contact& c = out[i];
    if (!smooth_edge(c)) continue;
    const BlockEdge& edge = model.edges[static_cast<std::size_t>(c.block_feature)];
    const auto found = std::lower_bound(crossed.begin(), crossed.end(),
                                        std::make_pair(c.terrain_feature, static_cast<const TerrainPatch::Ridge*>(nullptr)));
    const TerrainPatch::Ridge* ridge = found != crossed.end() && found->first == c.terrain_feature ? found->second : nullptr;
    if (ridge == nullptr || !ridge->convex || ridge->normal_count != 2) continue;
    double t = 0.0;
    Vec3 q;
    // The vertex whose normal faces the crest most nearly (a climb over the smooth
    // neighbours, as a vertex contact's patch is chosen), and its sphere's gap to it.
    auto v = static_cast<std::size_t>(edge.a);
    double gap = to_ridge(v, *ridge, t, q);
    for (int climb = 0; climb < 64; ++climb) {
      const Vec3 u = (q - (at.vertex(v) - model.vertex_rounding[v] * normal(v))).normalized();
      std::size_t best = v;
      double facing = normal(v).dot(u);
      for (auto k = model.neighbour_offsets[v]; k < model.neighbour_offsets[v + 1]; ++k) {
        const auto w = static_cast<std::size_t>(model.vertex_neighbours[static_cast<std::size_t>(k)]);
        if (!(model.vertex_rounding[w] > 0.0)) continue;
        const double f = normal(w).dot(u);
        if (f > facing) best = w, facing = f;
      }
      if (best == v) break;
      v = best;
      gap = to_ridge(v, *ridge, t, q);
    }
    // The crest itself, not one of its triangles, is nearest: the foot inside the edge and
    // the direction to the sphere's centre between the two triangles' normals.
    const Vec3 centre = at.vertex(v) - model.vertex_rounding[v] * normal(v);
    const Vec3 m = (centre - q).normalized();
    const Vec3 dir = (ridge->pb - ridge->pa).normalized();
    const double side = ridge->normals[0].cross(ridge->normals[1]).dot(dir);
    const bool between = ridge->normals[0].cross(m).dot(dir) * side >= 0.0 && m.cross(ridge->normals[1]).dot(dir) * side >= 0.0;
    constexpr double kEnd = 1e-6;
    const Vec3 nu = normal(v);
    const bool on_cap = std::atan2(nu.cross(-m).norm(), -nu.dot(m)) <= model.vertex_cone[v];
    if (!(t > kEnd && t < 1.0 - kEnd) || !between || !on_cap || !(gap > -model.rounding_reach - 1.0)) continue;
    const std::pair<std::int32_t, std::int64_t> key{static_cast<std::int32_t>(v), c.terrain_feature};
    if (std::find(crests.begin(), crests.end(), key) != crests.end()) {
      drop[i - first] = 1;
      continue;
    }
    crests.push_back(key);
    c.kind = ContactKind::vertex_ridge;
    c.block_feature = static_cast<std::int32_t>(v);
    c.normal = m;
    c.point = centre - model.vertex_rounding[v] * m;
    c.gap = gap;
    c.rolling = true;
  }
  std::size_t kept = first;
  for (std::size_t i = first; i < out.size(); ++i)
    if (drop[i - first] == 0) {
      if (kept != i) out[kept] = out[i];
      ++kept;
    }
  out.resize(kept);
}

void detect_polyhedron(const PlacedBlock& at, const terrain::Surface& surface, double search_distance,
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

}  // namespace

void detect_contacts(const PlacedBlock& at, const terrain::Surface& surface, double search_distance,
                     double depth_limit, TerrainPatch& patch, std::vector<Contact>& out, const SearchFilter& filter) {
  const std::size_t first = out.size();
  detect_polyhedron(at, surface, search_distance, depth_limit, patch, out, filter);
  round_vertex_contacts(at, patch, out, first);
  deep_ridge_contacts(at, patch, patch.candidates.ridges, search_distance, depth_limit, first, out);
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
  const std::size_t first = out.size();
  detect_scanned(at, patch, search_distance, depth_limit, false, every, out);
  round_vertex_contacts(at, patch, out, first);
  deep_ridge_contacts(at, patch, every.ridges, search_distance, depth_limit, first, out);
}

}  // namespace talus::dda::detail
