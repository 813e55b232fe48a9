// SPDX-License-Identifier: MIT
#include "contacts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

namespace talus::dda::detail {

namespace {

// Scalar box tests: the Eigen array form of Aabb::overlaps/contains does not vectorise
// for 3-vectors and was a sixth of the contact search.
inline bool overlaps(const geometry::Aabb& a, const geometry::Aabb& b) {
  return a.lo.x() <= b.hi.x() && b.lo.x() <= a.hi.x() && a.lo.y() <= b.hi.y() && b.lo.y() <= a.hi.y() &&
         a.lo.z() <= b.hi.z() && b.lo.z() <= a.hi.z();
}
inline bool contains(const geometry::Aabb& a, const Vec3& p) {
  return a.lo.x() <= p.x() && p.x() <= a.hi.x() && a.lo.y() <= p.y() && p.y() <= a.hi.y() && a.lo.z() <= p.z() &&
         p.z() <= a.hi.z();
}

// Point in polygon (crossing number) in the face's (u, v) coordinates.
bool inside_polygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& q) {
  bool inside = false;
  const std::size_t n = poly.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > q.y()) != (b.y() > q.y())) {
      const double x = a.x() + (q.y() - a.y()) / (b.y() - a.y()) * (b.x() - a.x());
      if (q.x() < x) inside = !inside;
    }
  }
  return inside;
}

// Whether p lies over or under the triangle in plan (the triangle counter-clockwise
// seen from above, as every upward-facing terrain triangle is).
bool inside_plan(const TerrainPatch::Triangle& tri, const Vec3& p) {
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = tri.p[k];
    const Vec3& b = tri.p[(k + 1) % 3];
    if ((b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x()) < 0.0) return false;
  }
  return true;
}

// Closest points of segments p0-p1 and q0-q1: parameters s (on p) and t (on q) of the
// infinite lines; callers keep only crossings strictly inside both segments.
bool line_parameters(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double& s, double& t) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r), c = d1.dot(r), b = d1.dot(d2);
  const double denom = a * e - b * b;
  // Nearly parallel edges meet as vertex–face contacts instead.
  if (denom <= 1e-6 * a * e) return false;
  s = (b * f - c * e) / denom;
  t = (a * f - b * c) / denom;
  return true;
}

// Gathers the triangles `list` of `surface` into `patch`: corners, normals, the
// distinct vertices, and the edges that are ridges (not between coplanar triangles).
void fill_patch(const terrain::Surface& surface, const std::vector<std::int32_t>& list, TerrainPatch& patch) {
  patch.triangles.clear();
  patch.vertices.clear();
  patch.neighbours.clear();
  patch.ridges.clear();
  // (vertex id, direction to a neighbour) from every triangle corner.
  thread_local std::vector<std::pair<std::int32_t, Vec3>> spokes;
  spokes.clear();
  for (std::int32_t t : list) {
    TerrainPatch::Triangle d;
    d.index = t;
    d.ids = surface.triangle(static_cast<std::size_t>(t));
    d.p = surface.triangle_vertices(static_cast<std::size_t>(t));
    // Counter-clockwise from above / outside, as Surface::normal.
    d.normal = (d.p[1] - d.p[0]).cross(d.p[2] - d.p[0]).normalized();
    for (const Vec3& q : d.p) d.box.add(q);
    patch.triangles.push_back(d);
    for (int k = 0; k < 3; ++k) {
      patch.vertices.push_back(TerrainPatch::Vertex{d.ids[k], t, d.p[k]});
      for (int o = 1; o < 3; ++o) spokes.emplace_back(d.ids[k], (d.p[(k + o) % 3] - d.p[k]).normalized());
      int i = k, j = (k + 1) % 3;
      if (d.ids[i] > d.ids[j]) std::swap(i, j);
      TerrainPatch::Ridge e;
      e.a = d.ids[i];
      e.b = d.ids[j];
      e.pa = d.p[i];
      e.pb = d.p[j];
      e.normal_sum = d.normal;
      e.triangle = t;
      patch.ridges.push_back(e);
    }
  }
  std::sort(patch.vertices.begin(), patch.vertices.end(),
            [](const TerrainPatch::Vertex& x, const TerrainPatch::Vertex& y) { return x.id < y.id; });
  patch.vertices.erase(std::unique(patch.vertices.begin(), patch.vertices.end(),
                                   [](const TerrainPatch::Vertex& x, const TerrainPatch::Vertex& y) { return x.id == y.id; }),
                       patch.vertices.end());
  std::stable_sort(spokes.begin(), spokes.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::size_t spoke = 0;
  for (TerrainPatch::Vertex& v : patch.vertices) {
    while (spoke < spokes.size() && spokes[spoke].first < v.id) ++spoke;
    v.first = static_cast<std::int32_t>(patch.neighbours.size());
    for (; spoke < spokes.size() && spokes[spoke].first == v.id; ++spoke)
      patch.neighbours.push_back(spokes[spoke].second);
    v.count = static_cast<std::int32_t>(patch.neighbours.size()) - v.first;
  }
  auto& edges = patch.ridges;
  std::sort(edges.begin(), edges.end(), [](const TerrainPatch::Ridge& x, const TerrainPatch::Ridge& y) {
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  // An edge between coplanar triangles is no ridge: the vertex contacts of both sides
  // carry it.
  std::size_t kept = 0;
  for (std::size_t k = 0; k < edges.size();) {
    std::size_t end = k + 1;
    while (end < edges.size() && edges[end].a == edges[k].a && edges[end].b == edges[k].b) ++end;
    TerrainPatch::Ridge e = edges[k];
    bool flat = false;
    for (std::size_t m = k + 1; m < end; ++m) {
      flat = flat || e.normal_sum.dot(edges[m].normal_sum) > 1.0 - 1e-10;
      e.normal_sum += edges[m].normal_sum;
    }
    if (!flat) {
      e.box = geometry::Aabb{};
      e.box.add(e.pa);
      e.box.add(e.pb);
      edges[kept++] = e;
    }
    k = end;
  }
  edges.resize(kept);
}

void detect_in(const Model& model, const Pose& pose, const std::vector<Vec3>& world, const TerrainPatch& patch,
               double ds, double depth, bool prune, std::vector<Contact>& out) {
  // Boxes are inflated by the larger of the search distance and the depth limit: a
  // feature may be found up to `depth` below a surface.
  const double margin = std::max(ds, depth);
  geometry::Aabb block_box;
  for (const Vec3& p : world) block_box.add(p);
  const geometry::Aabb reach = block_box.inflated(margin);

  // Only block features at most `margin` above the highest terrain point under the
  // block can touch it (a bounding-box argument, valid for any surface).
  double top = -std::numeric_limits<double>::infinity();
  for (const TerrainPatch::Triangle& tri : patch.triangles)
    if (!prune || overlaps(tri.box, reach)) top = std::max(top, tri.box.hi.z());
  const double ceiling = prune ? top + margin : std::numeric_limits<double>::infinity();
  thread_local std::vector<std::int32_t> low;
  low.clear();
  for (std::size_t i = 0; i < world.size(); ++i)
    if (world[i].z() <= ceiling) low.push_back(static_cast<std::int32_t>(i));

  // Block vertex – terrain triangle.
  const std::size_t first = out.size();
  for (const TerrainPatch::Triangle& tri : patch.triangles) {
    if (low.empty()) break;
    if (prune && !overlaps(tri.box, reach)) continue;
    const geometry::Aabb tbox = tri.box.inflated(margin);
    const Vec3 e0 = tri.p[1] - tri.p[0], e1 = tri.p[2] - tri.p[1], e2 = tri.p[0] - tri.p[2];
    for (const std::int32_t vi : low) {
      const std::size_t i = static_cast<std::size_t>(vi);
      const Vec3& p = world[i];
      if (prune && !contains(tbox, p)) continue;
      const double gap = (p - tri.p[0]).dot(tri.normal);
      if (gap >= ds || gap <= -depth) continue;
      // Inside the triangle's normal prism; or, for ground that faces up, above or below
      // it in plan. In a concave valley (a slope meeting a steeper face) a vertex that has
      // crossed the valley line lies under the steep face in plan but outside the normal
      // prisms of both faces: without the plan test neither holds it and it sinks into
      // the steep face unresisted.
      const bool in_prism = e0.cross(p - tri.p[0]).dot(tri.normal) >= 0.0 &&
                            e1.cross(p - tri.p[1]).dot(tri.normal) >= 0.0 &&
                            e2.cross(p - tri.p[2]).dot(tri.normal) >= 0.0;
      if (!in_prism && !(tri.normal.z() > 0.0 && inside_plan(tri, p))) continue;
      // A vertex over a shared edge of two coplanar triangles is one contact, not two.
      bool duplicate = false;
      for (std::size_t k = first; k < out.size(); ++k)
        if (out[k].block_feature == static_cast<std::int32_t>(i) && out[k].normal.dot(tri.normal) > 1.0 - 1e-9)
          duplicate = true;
      if (duplicate) continue;
      Contact c;
      c.kind = ContactKind::vertex_face;
      c.block_feature = static_cast<std::int32_t>(i);
      c.terrain_feature = tri.index;
      c.triangle = tri.index;
      c.point = p;
      c.normal = tri.normal;
      c.gap = gap;
      out.push_back(c);
    }
  }

  // Terrain vertex – block face (a spike of rough ground piercing a face between
  // block vertices), tested in the body frame where the face polygons are stored. Only a
  // vertex that is an extreme point of the terrain towards the face can touch it: every
  // terrain edge from it must leave on the outer side of the face plane. A vertex of flat
  // or concave ground (a grid node under a sliding cube) is no spike: without this test
  // it would take a side face's horizontal normal and trip the block.
  // A vertex of ground that is flat around it is no spike either: the block's own
  // vertices on that plane carry the face, and a redundant spring inside the face only
  // makes the contact states ambiguous.
  auto spike_towards = [&](const TerrainPatch::Vertex& tv, const Vec3& face_normal_body) {
    const Vec3 n = pose.rotation * face_normal_body;
    bool falls_away = false;
    for (std::int32_t k = tv.first; k < tv.first + tv.count; ++k) {
      const double along = patch.neighbours[static_cast<std::size_t>(k)].dot(n);
      if (along < -1e-6) return false;
      falls_away = falls_away || along > 1e-6;
    }
    return falls_away;
  };
  const bool convex =
      std::all_of(model.edges.begin(), model.edges.end(), [](const BlockEdge& e) { return e.convex; });
  for (const TerrainPatch::Vertex& tv : patch.vertices) {
    if (prune && !contains(reach, tv.p)) continue;
    const Vec3 qb = pose.inverse_map * (tv.p - pose.centre);
    int best = -1;
    double best_gap = -depth;
    for (std::size_t f = 0; f < model.faces.size(); ++f) {
      const BlockFace& face = model.faces[f];
      const double gap = face.normal.dot(qb) - face.offset;
      if (gap >= ds || gap <= best_gap) continue;
      if (!inside_polygon(face.polygon, Eigen::Vector2d(face.u.dot(qb), face.v.dot(qb)))) continue;
      if (!spike_towards(tv, face.normal)) continue;
      best = static_cast<int>(f);
      best_gap = gap;
    }
    if (best < 0) {
      // A terrain vertex that is no spike towards any face but lies inside a convex block
      // deeper than the search distance (how far features approach in one step) has
      // slipped past the other contacts (e.g. a ridge node under a block edge that runs
      // along a grid line, where the edge–edge tests see parallel edges): it is held by
      // the face it is least deep under, the shortest way out. Found deep, the contact
      // takes that depth as its offset (carry_contacts), so it stops the vertex going
      // further in without pushing it out with energy no force stored.
      if (!convex) continue;
      double least = -std::numeric_limits<double>::infinity();
      for (std::size_t f = 0; f < model.faces.size(); ++f) {
        const BlockFace& face = model.faces[f];
        const double gap = face.normal.dot(qb) - face.offset;
        if (gap > least) {
          least = gap;
          best = static_cast<int>(f);
        }
      }
      if (!(least < -ds && least > -depth)) continue;
    }
    const BlockFace& face = model.faces[best];
    const Vec3 foot_body = qb - (face.normal.dot(qb) - face.offset) * face.normal;
    Contact c;
    c.kind = ContactKind::face_vertex;
    c.block_feature = best;
    c.terrain_feature = tv.id;
    c.triangle = tv.triangle;
    c.point = pose.centre + pose.map * foot_body;
    c.normal = -(pose.rotation * face.normal).normalized();
    c.gap = (c.point - tv.p).dot(c.normal);
    out.push_back(c);
  }

  // Block edge – terrain ridge crossings.
  thread_local std::vector<const TerrainPatch::Ridge*> near;
  near.clear();
  for (const TerrainPatch::Ridge& r : patch.ridges)
    if (!prune || overlaps(r.box, reach)) near.push_back(&r);
  if (near.empty()) return;
  for (std::size_t be = 0; be < model.edges.size(); ++be) {
    const BlockEdge& bedge = model.edges[be];
    if (!bedge.convex) continue;
    const Vec3& p0 = world[bedge.a];
    const Vec3& p1 = world[bedge.b];
    if (std::min(p0.z(), p1.z()) > ceiling) continue;
    geometry::Aabb ebox;
    ebox.add(p0);
    ebox.add(p1);
    ebox = ebox.inflated(margin);
    for (const TerrainPatch::Ridge* te : near) {
      if (prune && !overlaps(te->box, ebox)) continue;
      double s = 0.0, t = 0.0;
      if (!line_parameters(p0, p1, te->pa, te->pb, s, t)) continue;
      constexpr double kEnd = 1e-6;  // ends are vertex contacts
      if (s <= kEnd || s >= 1.0 - kEnd || t <= kEnd || t >= 1.0 - kEnd) continue;
      Vec3 n = (p1 - p0).cross(te->pb - te->pa).normalized();
      if (n.dot(te->normal_sum) < 0.0) n = -n;
      const Vec3 pc = p0 + s * (p1 - p0);
      // The normal points out of the terrain and, at a convex edge of the block, into
      // the block: a pair for which the two disagree (a ridge seen edge-on, e₁ × e₂ nearly
      // across the ground) has no way out along it and is left to the other contacts.
      if (n.dot(pose.centre - pc) <= 0.0) continue;
      const Vec3 qc = te->pa + t * (te->pb - te->pa);
      const double gap = (pc - qc).dot(n);
      if (gap >= ds || gap <= -depth) continue;
      Contact c;
      c.kind = ContactKind::edge_edge;
      c.block_feature = static_cast<std::int32_t>(be);
      c.terrain_feature = (static_cast<std::int64_t>(te->a) << 32) | static_cast<std::int64_t>(te->b);
      c.triangle = te->triangle;
      c.point = pc;
      c.normal = n;
      c.gap = gap;
      out.push_back(c);
    }
  }
}

}  // namespace

void detect_contacts(const Model& model, const terrain::Surface& surface, const Pose& pose,
                     const std::vector<Vec3>& world, double search_distance, double depth_limit,
                     TerrainPatch& patch, std::vector<Contact>& out) {
  geometry::Aabb box;
  for (const Vec3& p : world) box.add(p);
  box = box.inflated(std::max(search_distance, depth_limit));
  if (patch.surface != &surface || patch.box.empty() || !patch.box.contains(box.lo) || !patch.box.contains(box.hi)) {
    // Gather with a margin of half the block's radius, so the next steps reuse it.
    patch.surface = &surface;
    patch.box = box.inflated(0.5 * model.radius);
    patch.query.clear();
    surface.triangles_in_box(patch.box, patch.query);
    fill_patch(surface, patch.query, patch);
  }
  detect_in(model, pose, world, patch, search_distance, depth_limit, true, out);
}

void detect_contacts_brute_force(const Model& model, const terrain::Surface& surface, const Pose& pose,
                                 const std::vector<Vec3>& world, double search_distance,
                                 double depth_limit, std::vector<Contact>& out) {
  std::vector<std::int32_t> all(surface.triangle_count());
  std::iota(all.begin(), all.end(), 0);
  TerrainPatch patch;
  fill_patch(surface, all, patch);
  detect_in(model, pose, world, patch, search_distance, depth_limit, false, out);
}

}  // namespace talus::dda::detail
