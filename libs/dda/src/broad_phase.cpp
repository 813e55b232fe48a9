// SPDX-License-Identifier: MIT
// The broad phase of the contact search (broad_phase.hpp).
#include "broad_phase.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace talus::dda::detail {

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
  // Every triangle edge with the triangle's third corner (for the crest test below).
  thread_local std::vector<std::pair<TerrainPatch::Ridge, Vec3>> sides;
  sides.clear();
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
      sides.emplace_back(e, d.p[(k + 2) % 3]);
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
  std::sort(sides.begin(), sides.end(), [](const auto& x, const auto& y) {
    return x.first.a != y.first.a ? x.first.a < y.first.a : x.first.b < y.first.b;
  });
  // An edge between coplanar triangles is no ridge: the vertex contacts of both sides
  // carry it.
  auto& edges = patch.ridges;
  for (std::size_t k = 0; k < sides.size();) {
    std::size_t end = k + 1;
    while (end < sides.size() && sides[end].first.a == sides[k].first.a && sides[end].first.b == sides[k].first.b)
      ++end;
    TerrainPatch::Ridge e = sides[k].first;
    bool flat = false;
    e.normals[0] = e.normal_sum;
    e.normal_count = static_cast<std::int32_t>(end - k);
    for (std::size_t m = k + 1; m < end; ++m) {
      flat = flat || e.normal_sum.dot(sides[m].first.normal_sum) > 1.0 - 1e-10;
      if (m == k + 1) e.normals[1] = sides[m].first.normal_sum;
      e.normal_sum += sides[m].first.normal_sum;
    }
    // A crest: the second triangle's third corner lies under the first one's plane.
    e.convex = e.normal_count == 2 && e.normals[0].dot(sides[k + 1].second - e.pa) < 0.0;
    if (!flat) {
      e.box = geometry::Aabb{};
      e.box.add(e.pa);
      e.box.add(e.pb);
      const Vec3 along = (e.pb - e.pa).normalized();
      const Vec3 out = e.normal_sum - e.normal_sum.dot(along) * along;
      if (out.norm() > 1e-6 * e.normal_sum.norm()) {
        e.out = out.normalized();
        e.out_allowance = 1e-9 * std::max(e.box.lo.cwiseAbs().maxCoeff(), e.box.hi.cwiseAbs().maxCoeff());
      }
      edges.push_back(e);
    }
    k = end;
  }
}

double norm_bound(const Mat3& a, bool rotation) {
  if (rotation) return 1.0 + 1e-6;
  Eigen::SelfAdjointEigenSolver<Mat3> eigen;
  eigen.computeDirect(a.transpose() * a, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff())) * (1.0 + 1e-6);
}

// A bound of ‖F − F₀‖₂ for the map F of `pose` and an earlier F₀ (`rigid0`: a rotation):
// between rotations √(3 − tr(F·F₀ᵀ)) = 2 sin(θ/2), with 1e-14 for round-off; else the
// Frobenius norm.
double map_change(const Pose& pose, const Mat3& map0, bool rigid0) {
  if (!pose.rigid || !rigid0) return (pose.map - map0).norm();
  const double trace = pose.map.row(0).dot(map0.row(0)) + pose.map.row(1).dot(map0.row(1)) +
                       pose.map.row(2).dot(map0.row(2));
  return std::sqrt(std::max(0.0, 3.0 - trace) + 1e-14);
}

namespace {

// How many vertices a walk (VertexClimb::below) may visit before a tree query is cheaper:
// 64, or a share of a fine mesh's vertices, whose caps hold more (docs/dda.md, Reusing the
// pairs).
std::size_t walk_limit(const Model& model) { return std::max<std::size_t>(64, model.vertices.size() / 20); }

// The slack of a walk for the plane m·r = level (VertexClimb::below): a few ulps of
// |m|·|r| and of the level's terms would do.
double walk_slack(const Model& model, const Vec3& m, double level) {
  return 1e-9 * (model.radius * m.norm() + std::abs(level));
}

// The cap of a walk under a plane: its lowest vertex and the reach of the vertices walked
// and their edges; every point above the level lies above it by (level − lowest)·|r −
// pivot|/reach.
TerrainPatch::Candidates::Cap walked_cap(const Model& model, const VertexClimb& climb,
                                         const std::vector<std::int32_t>& under, double lowest, double level) {
  TerrainPatch::Candidates::Cap cap;
  cap.pivot = model.vertices[static_cast<std::size_t>(under.front())];
  for (const std::int32_t v : under)
    cap.reach = std::max(cap.reach, (model.vertices[static_cast<std::size_t>(v)] - cap.pivot).norm() + climb.longest(v));
  cap.reach = cap.reach * (1.0 + 1e-9) + 1e-9 * model.radius;  // the sums' round-off, generously
  cap.rise = level - lowest;
  return cap;
}

// Sets p.coordinates from p.features (Pairs::coordinates): vertices, or edges' ends.
void set_coordinates(const Model& model, bool edges, TerrainPatch::Candidates::Pairs& p) {
  const std::size_t n = p.features.size();
  p.coordinates.resize((edges ? 6 : 3) * n);
  // Point r of feature k into the block of three coordinate rows starting at `rows`.
  const auto put = [&](double* rows, std::size_t k, const Vec3& r) {
    rows[k] = r.x();
    rows[n + k] = r.y();
    rows[2 * n + k] = r.z();
  };
  double* const a = p.coordinates.data();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t f = static_cast<std::size_t>(p.features[k]);
    if (!edges) {
      put(a, k, model.vertices[f]);
      continue;
    }
    put(a, k, model.vertices[static_cast<std::size_t>(model.edges[f].a)]);
    put(a + 3 * n, k, model.vertices[static_cast<std::size_t>(model.edges[f].b)]);
  }
}

// Starts `g` for pairs gathered at the pose of `at` with these distances and motion (m).
void start_gathering(const PlacedBlock& at, double ds, double depth, double motion,
                     TerrainPatch::Candidates::Gathering& g) {
  g.model = &at.model();
  g.centre = at.pose().centre;
  g.map = at.pose().map;
  g.rigid = at.pose().rigid;
  g.ds = ds;
  g.depth = depth;
  g.motion = motion;
  g.box_margin = std::max(ds, depth);
}


// The vertices that can pass the vertex–triangle tests with `tri` (its slab, the ceiling,
// its prisms widened by `motion`), on the body-frame boxes of the vertex tree or by a walk;
// into `out`.
[[gnu::noinline]] bool vertices_near(const PlacedBlock& at, const TerrainPatch::Triangle& tri, const geometry::Aabb& tbox,
                                     double ceiling, double ds, double depth, double motion, double rise,
                                     std::vector<std::int32_t>& out, TerrainPatch::Candidates::Cap& cap) {
  const Pose& pose = at.pose();
  const double tol = at.round_off() + kRound * magnitude(tbox);
  const geometry::Aabb body = at.body_box(tbox);
  const BodyPlane floor_plane(pose, tri.normal, tri.p[0], tol);
  const BodyPlane ceiling_plane(pose, Vec3::UnitZ(), Vec3(0.0, 0.0, ceiling), tol);
  std::array<BodyPlane, 3> prism, plan;
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = tri.p[k];
    const Vec3 e = tri.p[(k + 1) % 3] - a;
    // The world tests compute (e × (p − a))·n and the 2-D cross product in plan; a point
    // that moves by `motion` changes either by at most |e|·motion.
    const double edge_tol = 4.0 * e.norm() * tol + e.norm() * motion;
    prism[static_cast<std::size_t>(k)] = BodyPlane(pose, tri.normal.cross(e), a, edge_tol);
    plan[static_cast<std::size_t>(k)] = BodyPlane(pose, Vec3(-e.y(), e.x(), 0.0), a, edge_tol);
  }
  const bool faces_up = tri.normal.z() > 0.0;
  const auto passes = [&](const geometry::Aabb& b) {
    if (!overlaps(b, body)) return false;
    const Vec3 c = b.center();
    const Vec3 h = 0.5 * b.extent();
    if (ceiling_plane.min_over(c, h) > 0.0 || floor_plane.min_over(c, h) >= ds ||
        floor_plane.max_over(c, h) <= -depth)
      return false;
    const auto reaches = [&](const std::array<BodyPlane, 3>& sides) {
      return sides[0].max_over(c, h) >= 0.0 && sides[1].max_over(c, h) >= 0.0 && sides[2].max_over(c, h) >= 0.0;
    };
    return reaches(prism) || (faces_up && reaches(plan));
  };
  // The same on a vertex's own box (a point: its centre is r, its half-sizes zero).
  const auto point_passes = [&](const Vec3& r) {
    if (!contains(body, r)) return false;
    if (ceiling_plane.min_at(r) > 0.0 || floor_plane.min_at(r) >= ds || floor_plane.max_at(r) <= -depth) return false;
    const auto reaches = [&](const std::array<BodyPlane, 3>& sides) {
      return sides[0].max_at(r) >= 0.0 && sides[1].max_at(r) >= 0.0 && sides[2].max_at(r) >= 0.0;
    };
    return reaches(prism) || (faces_up && reaches(plan));
  };
  out.clear();
  const Model& model = at.model();
  const VertexClimb& climb = at.index()->climb;
  if (climb.fills()) {
    // A vertex that passes lies under a plane of the body frame (s0 + m·r − tol < ds):
    // found by a walk over the vertex graph, each then given the tree's test on its own
    // box.
    thread_local std::vector<std::int32_t> under;
    double lowest = 0.0;
    double level = ds + floor_plane.tol - floor_plane.s0;
    if (climb.below(model.vertices, floor_plane.m, level, walk_slack(model, floor_plane.m, level), walk_limit(model), under,
                    lowest, rise)) {
      for (const std::int32_t v : under)
        if (point_passes(model.vertices[static_cast<std::size_t>(v)])) out.push_back(v);
      cap = walked_cap(model, climb, under, lowest, level);
      return true;
    }
    out.clear();
  }
  at.index()->vertices.query(passes, out);
  return false;
}

}  // namespace

// Whether the search of `model` crosses its edges with ridge te: every ridge but a valley,
// whose crossings a block of short edges leaves to its vertex contacts
// (Model::crosses_valleys; `every_valley`, SearchFilter's, crosses them all).
bool crosses(const Model& model, const TerrainPatch::Ridge& te, bool every_valley) {
  return !te.valley() || model.crosses_valleys() || every_valley;
}

namespace {

// The convex edges of a convex block that `keeps`, found by walks over the vertex graph
// under the planes every passing edge has an end under (docs/dda.md, The ridge's level);
// false: use a query.
template <class Keeps>
bool edges_by_walk(const PlacedBlock& at, const Vec3& a, const Vec3& along, double shallow, double deep, int planes,
                   bool crest, const std::array<BodyPlane, 2>& sides, const BodyPlane& out, double out_limit,
                   double rise, const Keeps& keeps, std::vector<std::int32_t>& edges,
                   TerrainPatch::Candidates::Cap& cap, bool& capped) {
  const Model& model = at.model();
  const VertexClimb& climb = at.index()->climb;
  edges.clear();
  // The ridge's point nearest the body frame's origin (the centre).
  const double length2 = along.squaredNorm();
  const double t = length2 > 0.0 ? std::clamp(-a.dot(along) / length2, 0.0, 1.0) : 0.0;
  const Vec3 nearest = a + t * along;
  const double distance = nearest.norm();
  if (!(distance > 0.0)) return false;
  const Vec3 u = -nearest / distance;
  const double ridge_top = std::max(u.dot(a), u.dot(a + along));
  // The edges at the vertices of each walk, each tested once.
  thread_local RoundMarks tested;
  tested.start(model.edges.size());
  thread_local std::vector<std::int32_t> under;
  double lowest = 0.0;
  // The edges at the vertices under m·r = level that may come within `reach` of the ridge:
  // a vertex further from it than that and its longest edge has none.
  const auto walk = [&](const Vec3& m, double level, double reach, double raise = 0.0) {
    if (!climb.below(model.vertices, m, level, walk_slack(model, m, level), walk_limit(model), under, lowest, raise))
      return false;
    for (const std::int32_t v : under) {
      const Vec3& r = model.vertices[static_cast<std::size_t>(v)];
      const double s = length2 > 0.0 ? std::clamp((r - a).dot(along) / length2, 0.0, 1.0) : 0.0;
      const double within = (reach + climb.longest(v)) * (1.0 + 1e-9) + 1e-9 * model.radius;
      if ((r - a - s * along).squaredNorm() > within * within) continue;
      for (std::int32_t k = climb.first(v); k < climb.first(v + 1); ++k) {
        const std::int32_t e = climb.edge(k);
        if (!tested.mark(e)) continue;
        if (!model.edges[static_cast<std::size_t>(e)].convex) continue;
        if (keeps(e)) edges.push_back(e);
      }
    }
    if (raise > 0.0) cap = walked_cap(model, climb, under, lowest, level);
    return true;
  };
  // Every edge that can pass has an end under the plane along the ridge's `out` (its
  // callers pass over the others): one walk there, when it is short, else the three.
  capped = false;
  if (out.m != Vec3::Zero() && walk(out.m, out_limit - out.s0, deep, rise)) {
    capped = true;
    return true;
  }
  tested.start(model.edges.size());
  edges.clear();
  if (!walk(u, ridge_top + shallow, shallow)) return false;
  // The deep ones: under the planes of the ridge's triangles (an end with s0 + m·r − tol
  // ≤ 0; on a crest under both, so under the first), else within `deep` along u.
  const auto under_plane = [&](int k) {
    const BodyPlane& side = sides[static_cast<std::size_t>(k)];
    return walk(side.m, side.tol - side.s0, deep);
  };
  if (planes > 0 && under_plane(0) && (crest || planes < 2 || under_plane(1))) return true;
  return walk(u, ridge_top + deep, deep);
}

// The convex edges that can pass the edge–ridge tests with ridge te at this pose or any
// within `motion` (m), into p, ascending, with what their reuse rests on (pairs_serve).
[[gnu::noinline]] void gather_ridge_pairs(const PlacedBlock& at, const TerrainPatch::Ridge& te, double ds,
                                          double depth, double motion, TerrainPatch::Candidates::Pairs& p) {
  using Basis = TerrainPatch::Candidates::Pairs::Basis;
  const Pose& pose = at.pose();
  const Model& model = at.model();
  const VertexClimb& climb = at.index()->climb;
  const double margin = std::max(ds, depth);
  start_gathering(at, ds, depth, motion, p);
  std::vector<std::int32_t>& edges = p.features;
  edges.clear();
  p.coordinates.clear();
  const double stretch = norm_bound(pose.map, pose.rigid);
  // In the body frame (distances lengthened by F⁻¹): a pair's crossing lies within ds of
  // the ridge, or within `depth` and below a plane of one of its triangles (both on a
  // crest).
  const geometry::Aabb ridge_box = te.box.inflated(margin);
  const double tol = at.round_off() + kRound * magnitude(ridge_box) + kSlack * margin + 1e-9 * model.radius;
  // A ridge the block lies farther from than any passing edge can (its separation, a lower
  // bound of the distance to the hull of the world vertices) has no pairs: most ridges in
  // the box.
  if (!climb.empty()) {
    const double apart = separation(at, {te.pa, te.pb, te.pb}) - 4.0 * at.round_off() - 1e-9 * model.radius;
    const double lengthened = stretch * at.inverse_stretch() * (1.0 + 1e-9);
    if (apart > lengthened * (margin + 2.0 * tol)) {
      // Still apart at a pose where the block has moved by d while the search's margin
      // is m, if m + d ≤ apart / lengthened − 2·tol (lengthened ≥ 1 on a rigid pose;
      // a stretched one's pairs serve only while every point moves by the motion).
      p.basis = pose.rigid ? Basis::apart : Basis::queried;
      p.room = apart / lengthened - 2.0 * tol;
      return;
    }
  }
  const geometry::Aabb body = at.body_box(ridge_box.inflated(tol));
  const Vec3 a = pose.inverse_map * (te.pa - pose.centre);
  const Vec3 along = pose.inverse_map * (te.pb - pose.centre) - a;
  const double inverse_length2 = along.squaredNorm() > 0.0 ? 1.0 / along.squaredNorm() : 0.0;
  const double shallow = at.inverse_stretch() * (ds + 2.0 * tol);
  const double deep = at.inverse_stretch() * (margin + 2.0 * tol);
  const int planes = te.normal_count <= 2 ? static_cast<int>(te.normal_count) : 0;
  std::array<BodyPlane, 2> sides;
  for (int k = 0; k < planes; ++k) {
    const Vec3& normal = te.normals[static_cast<std::size_t>(k)];
    sides[static_cast<std::size_t>(k)] = BodyPlane(pose, normal, te.pa, 4.0 * tol + normal.norm() * motion);
  }
  // Only edges at most `margin` above the ridge's highest point can pass (a crossing
  // lies in the ridge's box inflated by the margin).
  const BodyPlane ceiling_plane(pose, Vec3::UnitZ(), Vec3(0.0, 0.0, te.box.hi.z() + margin), tol);
  // The narrow phase passes over an edge with both ends more than ds above the ridge along
  // `out` (ridge_level_limit), and a point moves at most `motion` before the pairs are
  // gathered again.
  const BodyPlane out_plane(pose, te.out, te.pa, 0.0);
  const double out_limit = ridge_level_limit(te, at, ds, margin, 2);
  // Whether a deep pair may lie under the ridge's planes, `under(k)` telling whether
  // the edge (or a box of edges) reaches under plane k: on a crest both, else either.
  const auto may_be_under = [&](const auto& under) {
    if (planes == 0) return true;
    if (te.convex) return under(0) && under(1);
    return under(0) || (planes == 2 && under(1));
  };
  const auto passes = [&](const geometry::Aabb& b) {
    if (!overlaps(b, body)) return false;
    const Vec3 c = b.center();
    const Vec3 h = 0.5 * b.extent();
    if (ceiling_plane.min_over(c, h) > 0.0) return false;
    const double t = std::clamp((c - a).dot(along) * inverse_length2, 0.0, 1.0);
    const double distance2 = (c - a - t * along).squaredNorm();
    const double size = h.norm();
    if (distance2 <= (shallow + size) * (shallow + size)) return true;
    if (distance2 > (deep + size) * (deep + size)) return false;
    return may_be_under([&](int k) { return sides[static_cast<std::size_t>(k)].min_over(c, h) <= 0.0; });
  };
  // The same tests on each edge's own segment (its distance and its ends' plane values),
  // which let through far fewer pairs than its box.
  const auto segment_passes = [&](std::int32_t e) {
    const BlockEdge& edge = model.edges[static_cast<std::size_t>(e)];
    const Vec3& r0 = model.vertices[static_cast<std::size_t>(edge.a)];
    const Vec3& r1 = model.vertices[static_cast<std::size_t>(edge.b)];
    const auto lowest = [&](const BodyPlane& plane) { return std::min(plane.min_at(r0), plane.min_at(r1)); };
    if (lowest(ceiling_plane) > 0.0 || lowest(out_plane) >= out_limit) return false;
    const double distance2 = segment_distance2(r0, r1, a, a + along);
    return distance2 <= shallow * shallow ||
           (distance2 <= deep * deep &&
            may_be_under([&](int k) { return lowest(sides[static_cast<std::size_t>(k)]) <= 0.0; }));
  };
  // A walk's edges are given both, the segment's first (it decides most); a tree query's
  // pass the boxes' tests on the way.
  const auto keeps = [&](std::int32_t e) {
    if (!segment_passes(e)) return false;
    const BlockEdge& edge = model.edges[static_cast<std::size_t>(e)];
    geometry::Aabb b;
    b.add(model.vertices[static_cast<std::size_t>(edge.a)]);
    b.add(model.vertices[static_cast<std::size_t>(edge.b)]);
    return passes(b);
  };
  bool capped = false;
  if (!climb.fills() || !edges_by_walk(at, a, along, shallow, deep, planes, te.convex, sides, out_plane, out_limit,
                                       motion, keeps, edges, p.cap, capped)) {
    thread_local std::vector<std::int32_t> found;
    found.clear();
    at.index()->convex_edges.query(passes, found);
    edges.clear();
    for (const std::int32_t e : found)
      if (segment_passes(e)) edges.push_back(e);
  }
  p.basis = capped ? Basis::walked : Basis::queried;
  std::sort(edges.begin(), edges.end());
  set_coordinates(model, true, p);
}

// How far (m) the block lies wholly outside the prisms of `tri` that vertex_meets_triangle
// tests (≤ 0 when not): beyond a side's plane by the support along its inward normal,
// round-off included.
double outside_prisms(const PlacedBlock& at, const TerrainPatch::Triangle& tri, double tol) {
  const Vec3& centre = at.pose().centre;
  const auto beyond = [&](bool plan) {
    double most = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const Vec3& a = tri.p[static_cast<std::size_t>(k)];
      const Vec3 e = tri.p[static_cast<std::size_t>((k + 1) % 3)] - a;
      const Vec3 w = plan ? Vec3(-e.y(), e.x(), 0.0) : Vec3(tri.normal.cross(e));
      const double length = w.norm();
      if (!(length > 0.0)) continue;
      most = std::max(most, -(w.dot(centre - a) + at.support(w) + 4.0 * length * tol) / length);
    }
    return most;
  };
  double outside = beyond(false);
  if (outside > 0.0 && tri.normal.z() > 0.0) outside = std::min(outside, beyond(true));
  return outside;
}

// The features of `patch` whose boxes come within `margin` and `box_widening` (m) of the
// block's box, into `ids` in patch order; one already there keeps its pairs (pairs_serve
// decides them).
template <class Box>
void gather_by_boxes(const PlacedBlock& at, std::size_t count, const Box& box, double margin, double box_widening,
                     TerrainPatch::Candidates::Gathering& g, std::vector<std::int32_t>& ids,
                     std::vector<TerrainPatch::Candidates::Pairs>& pairs) {
  const bool same = g.model == &at.model();
  start_gathering(at, margin, margin, margin, g);
  g.box_margin = margin + box_widening;
  const geometry::Aabb reach = at.box().inflated(g.box_margin);
  thread_local std::vector<std::int32_t> before;
  thread_local std::vector<TerrainPatch::Candidates::Pairs> kept;
  before.swap(ids);
  kept.swap(pairs);
  ids.clear();
  for (std::size_t k = 0; k < count; ++k)
    if (overlaps(box(k), reach)) ids.push_back(static_cast<std::int32_t>(k));
  pairs.resize(ids.size());
  std::size_t k = 0;
  for (std::size_t j = 0; j < ids.size(); ++j) {
    while (same && k < before.size() && before[k] < ids[j]) ++k;
    if (same && k < before.size() && before[k] == ids[j]) std::swap(pairs[j], kept[k]);
    else pairs[j].basis = TerrainPatch::Candidates::Pairs::Basis::none;
  }
}

// The vertices that can pass the vertex–triangle tests with `tri` at this pose or any
// within `motion` (m), ascending, into p, with what their reuse rests on (pairs_serve).
void gather_triangle_pairs(const PlacedBlock& at, const TerrainPatch::Triangle& tri, double ds, double depth,
                           double motion, TerrainPatch::Candidates::Pairs& p) {
  using Basis = TerrainPatch::Candidates::Pairs::Basis;
  const Pose& pose = at.pose();
  start_gathering(at, ds, depth, motion, p);
  p.features.clear();
  p.coordinates.clear();
  const double margin = std::max(ds, depth);
  const geometry::Aabb tbox = tri.box.inflated(margin);
  // A plane the whole block lies above by more than ds (its support bounds that, round-off
  // included) has none of its vertices in the slab: one support query settles most
  // triangles of the box.
  const double tol = at.round_off() + kRound * magnitude(tbox);
  if (!at.index()->climb.empty()) {
    const double above =
        tri.normal.dot(pose.centre - tri.p[0]) - at.support(-tri.normal) - 4.0 * tol - 1e-9 * at.model().radius;
    if (above > ds) {
      p.basis = Basis::above;
      p.room = above;
      return;
    }
    // Nor has a triangle whose prisms the whole block lies beside, farther than the
    // motion the prism tests are widened by. Many of those near the block cut through it
    // (the ground rising beside it), and walks under their planes are long.
    const double beside = outside_prisms(at, tri, tol);
    if (beside > motion) {
      p.basis = Basis::beside;
      p.room = beside;
      return;
    }
  }
  // Only vertices at most `margin` above the triangle's highest point can pass (its box
  // inflated by the margin holds every vertex that does).
  p.basis = vertices_near(at, tri, tbox, tri.box.hi.z() + margin, ds, depth, motion, motion, p.features, p.cap)
                ? Basis::walked
                : Basis::queried;
  std::sort(p.features.begin(), p.features.end());
  set_coordinates(at.model(), false, p);
}

// How far a block at `pose` has moved since an earlier pose (centre, map, rigid): the
// map's change and its bound, the centre's shift, and every point's motion at most
// (|Δcentre| + ‖ΔF‖₂·radius, plus round-off), with the round-off allowance of each.
struct Motion {
  std::uint64_t search = 0;
  Mat3 change;
  Vec3 shift;
  double turn = 0.0, moved = 0.0, slack = 0.0;
};

Motion motion_since(const Model& model, const Pose& pose, const TerrainPatch::Candidates::Gathering& g) {
  Motion m;
  m.change = pose.map - g.map;
  m.shift = pose.centre - g.centre;
  m.turn = map_change(pose, g.map, g.rigid);
  m.slack = 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius);
  m.moved = m.shift.norm() + m.turn * model.radius + m.slack;
  return m;
}

}  // namespace

// How far the points of a block at `pose` have moved at most (m) since the pose of
// gathering g (∞ when g holds no pairs of `model`; Motion::moved).
double moved_since(const TerrainPatch::Candidates::Gathering& g, const Model& model, const Pose& pose) {
  if (g.model != &model) return std::numeric_limits<double>::infinity();
  return motion_since(model, pose, g).moved;
}

namespace {

// Whether pairs p serve a search at `pose` with ds and depth (m): the motion since they
// were gathered within what their tests were widened by, or a walk's cap still holds
// (docs/dda.md, Reusing the pairs).
inline __attribute__((always_inline)) bool pairs_serve(const TerrainPatch::Candidates::Pairs& p, const Motion& since,
                                                       double ds, double depth) {
  using Basis = TerrainPatch::Candidates::Pairs::Basis;
  const double moved = since.moved;
  const auto within = [&](double motion) { return ds + motion <= p.ds && depth + motion <= p.depth && motion <= p.motion; };
  switch (p.basis) {
    case Basis::above:
      return ds + moved <= p.room;
    case Basis::beside:
      return moved <= p.room;
    case Basis::apart:
      return std::max(ds, depth) + moved <= p.room;
    case Basis::queried:
      return within(moved);
    case Basis::walked: {
      if (within(moved)) return true;
      if (since.search == 0) return false;  // a bound of the motion only, not the poses
      const double swing = since.turn * p.cap.reach * (1.0 + 1e-9);
      return swing + since.slack <= p.cap.rise &&
             within((since.shift + since.change * p.cap.pivot).norm() + swing + since.slack);
    }
    case Basis::none:
      break;
  }
  return false;
}

}  // namespace

namespace {

// Whether pairs p still serve: first on bounds of the motion since the gathering (the sums
// between searches in `c`), on the two poses only when those do not show it; `since` caches
// per search.
bool still_serve(TerrainPatch::Candidates::Pairs& p, const TerrainPatch::Candidates& c, const Model& model,
                 const Pose& pose, double ds, double depth, double slack, std::vector<Motion>& since) {
  using Basis = TerrainPatch::Candidates::Pairs::Basis;
  if (p.basis == Basis::none || p.model != &model) return false;
  // The motion since the gathering is at most the sum's growth since then, and at most
  // what the last test on the poses found plus the sum's growth since that test (a bound
  // of the motion between the two searches; the same for the turn).
  Motion bound;
  bound.moved = c.travelled - p.travelled;
  const TerrainPatch::Candidates::Pairs::Checked& k = p.checked;
  const double grown = c.travelled - k.travelled, turned = c.turned - k.turned;
  const bool checked = std::isfinite(k.moved) && grown >= 0.0 && turned >= 0.0;
  if (checked && !(bound.moved >= 0.0 && bound.moved <= k.moved + grown)) bound.moved = k.moved + grown;
  if (bound.moved >= 0.0 && pairs_serve(p, bound, ds, depth)) return true;
  if (checked && p.basis == Basis::walked) {
    // The cap's test of pairs_serve on those bounds: the pivot moves and the block turns
    // by at most what the last test found plus the sums' growth.
    const double swing = (k.turn + turned) * (1.0 + 1e-9) * p.cap.reach * (1.0 + 1e-9);
    const double motion = k.pivot + grown + swing + slack;
    if (swing + slack <= p.cap.rise && ds + motion <= p.ds && depth + motion <= p.depth && motion <= p.motion)
      return true;
  }
  auto known = std::find_if(since.begin(), since.end(), [&](const Motion& m) { return m.search == p.search; });
  if (known == since.end()) {
    since.push_back(motion_since(model, pose, p));
    since.back().search = p.search;
    known = since.end() - 1;
  }
  p.checked.moved = known->moved;
  p.checked.pivot = p.basis == Basis::walked ? (known->shift + known->change * p.cap.pivot).norm() : 0.0;
  p.checked.turn = known->turn;
  p.checked.travelled = c.travelled;
  p.checked.turned = c.turned;
  return pairs_serve(p, *known, ds, depth);
}

// The pairs of the features (`ids`, of `features`) that are searched and whose boxes meet
// `reach`, gathered again by `gather(feature, pairs)` where they no longer serve; their
// places in `ids` into `met`.
template <class Features, class Searched, class Serves, class Gather>
void refresh(const std::vector<std::int32_t>& ids, const Features& features,
             std::vector<TerrainPatch::Candidates::Pairs>& pairs, std::vector<std::size_t>& met,
             const geometry::Aabb& reach, std::uint64_t search, double travelled, const Searched& searched,
             const Serves& serves, const Gather& gather) {
  met.clear();
  for (std::size_t j = 0; j < ids.size(); ++j) {
    const auto& feature = features[static_cast<std::size_t>(ids[j])];
    if (!searched(feature) || !overlaps(feature.box, reach)) continue;
    met.push_back(j);
    if (serves(pairs[j])) continue;
    gather(feature, pairs[j]);
    pairs[j].search = search;
    pairs[j].travelled = travelled;
    pairs[j].checked = {};
  }
}

}  // namespace

void refresh_pairs(const PlacedBlock& at, TerrainPatch& patch, double ds, double depth, bool every_valley,
                   Live& live) {
  const Model& model = at.model();
  const Pose& pose = at.pose();
  TerrainPatch::Candidates& c = patch.candidates;
  const double widening = kIndexedWidening * model.radius;
  const double box_widening = kIndexedBoxWidening * model.radius;
  // The triangles and ridges by their boxes, then the pairs of each (those the search
  // tests: of the features whose boxes meet its reach).
  const double margin = std::max(ds, depth);
  if (!(margin + moved_since(c.gathering, model, pose) <= c.gathering.box_margin))
    gather_by_boxes(
        at, patch.triangles.size(), [&](std::size_t k) -> const geometry::Aabb& { return patch.triangles[k].box; },
        margin + widening, box_widening, c.gathering, c.triangles, c.triangle_pairs);
  if (!(margin + moved_since(c.ridge_gathering, model, pose) <= c.ridge_gathering.box_margin))
    gather_by_boxes(
        at, patch.ridges.size(), [&](std::size_t k) -> const geometry::Aabb& { return patch.ridges[k].box; },
        margin + widening, box_widening, c.ridge_gathering, c.ridges, c.ridge_pairs);
  const geometry::Aabb reach = at.box().inflated(margin);
  // The pairs gathered in one search share its pose, and how far the block has moved
  // since (a few searches' at most).
  const std::uint64_t search = ++c.searches;
  thread_local std::vector<Motion> since;
  since.clear();
  // Every point's motion since pairs were gathered is bounded first by the sum of the
  // motions between the searches since (one bound per search), and computed from the
  // two poses only when that sum does not show them to serve.
  if (c.last_search.model == &model) {
    const Motion step = motion_since(model, pose, c.last_search);
    c.travelled += step.moved;
    c.turned += step.turn;
  } else {
    c.travelled = 0.0;
    c.turned = 0.0;
  }
  start_gathering(at, 0.0, 0.0, 0.0, c.last_search);
  const double slack = 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius);
  const auto serves = [&](TerrainPatch::Candidates::Pairs& p) {
    return still_serve(p, c, model, pose, ds, depth, slack, since);
  };
  refresh(
      c.triangles, patch.triangles, c.triangle_pairs, live.triangles, reach, search, c.travelled,
      [](const TerrainPatch::Triangle&) { return true; }, serves,
      [&](const TerrainPatch::Triangle& tri, TerrainPatch::Candidates::Pairs& pairs) {
        gather_triangle_pairs(at, tri, ds + widening, depth + widening, widening, pairs);
      });
  refresh(
      c.ridges, patch.ridges, c.ridge_pairs, live.ridges, reach, search, c.travelled,
      [&](const TerrainPatch::Ridge& te) { return crosses(model, te, every_valley); }, serves,
      [&](const TerrainPatch::Ridge& te, TerrainPatch::Candidates::Pairs& pairs) {
        gather_ridge_pairs(at, te, ds + widening, depth + widening, widening, pairs);
      });
}

// The pairs of a scanned block that can form a contact within ds and `depth`, in the order
// detect_scanned tests them; `prune` off keeps every pair; `every_valley` crosses every
// valley.
void gather_candidates(const PlacedBlock& at, const TerrainPatch& patch, double ds, double depth, bool prune,
                       bool every_valley, TerrainPatch::Candidates& c) {
  const Model& model = at.model();
  const std::vector<Vec3>& world = at.vertices();
  const double margin = std::max(ds, depth);
  const geometry::Aabb reach = at.box().inflated(margin);
  start_gathering(at, ds, depth, std::numeric_limits<double>::infinity(), c.gathering);
  c.triangles.clear();
  c.vertex_triangle.clear();
  c.vertices.clear();
  c.ridges.clear();
  c.edge_ridge.clear();
  for (std::size_t t = 0; t < patch.triangles.size(); ++t) {
    const TerrainPatch::Triangle& tri = patch.triangles[t];
    if (prune && !overlaps(tri.box, reach)) continue;
    c.triangles.push_back(static_cast<std::int32_t>(t));
    const geometry::Aabb tbox = tri.box.inflated(margin);
    for (std::size_t i = 0; i < world.size(); ++i) {
      if (prune) {
        if (!contains(tbox, world[i])) continue;
        const double gap = (world[i] - tri.p[0]).dot(tri.normal);
        if (gap >= ds || gap <= -depth) continue;
      }
      c.vertex_triangle.emplace_back(static_cast<std::int32_t>(t), static_cast<std::int32_t>(i));
    }
  }
  for (std::size_t k = 0; k < patch.vertices.size(); ++k)
    if (!prune || contains(reach, patch.vertices[k].p)) c.vertices.push_back(static_cast<std::int32_t>(k));
  for (std::size_t k = 0; k < patch.ridges.size(); ++k)
    if (crosses(model, patch.ridges[k], every_valley) && (!prune || overlaps(patch.ridges[k].box, reach)))
      c.ridges.push_back(static_cast<std::int32_t>(k));
  for (std::size_t be = 0; be < model.edges.size(); ++be) {
    const BlockEdge& bedge = model.edges[be];
    if (!bedge.convex) continue;
    const Vec3& p0 = world[bedge.a];
    const Vec3& p1 = world[bedge.b];
    const geometry::Aabb ebox = edge_box(p0, p1, margin);
    // A crossing's gap is the distance between the two segments' crossing points, so a
    // pair whose segments lie farther apart than the margin has none. The allowance
    // covers the distance's round-off.
    const double within = margin + 1e-9 * (magnitude(ebox) + margin);
    for (const std::int32_t r : c.ridges) {
      const TerrainPatch::Ridge& te = patch.ridges[static_cast<std::size_t>(r)];
      if (prune && (!overlaps(te.box, ebox) || segment_distance2(p0, p1, te.pa, te.pb) > within * within)) continue;
      c.edge_ridge.emplace_back(static_cast<std::int32_t>(be), r);
    }
  }
}

}  // namespace talus::dda::detail
