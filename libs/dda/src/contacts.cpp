// SPDX-License-Identifier: MIT
#include "contacts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#include <Eigen/Eigenvalues>

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
// infinite lines, when both lie in [0, 1]; callers keep only crossings strictly inside
// both segments. The numerators are compared with the (positive) denominator before
// dividing: most pairs cross outside a segment, and a quotient outside [0, 1] is exactly
// a numerator outside [0, denominator], so the divisions are spared without changing a
// result.
inline __attribute__((always_inline)) bool line_parameters(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double& s, double& t) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r), c = d1.dot(r), b = d1.dot(d2);
  const double denom = a * e - b * b;
  // Nearly parallel edges meet as vertex–face contacts instead.
  if (denom <= 1e-6 * a * e) return false;
  const double s_num = b * f - c * e;
  const double t_num = a * f - b * c;
  if (s_num < 0.0 || s_num > denom || t_num < 0.0 || t_num > denom) return false;
  s = s_num / denom;
  t = t_num / denom;
  return true;
}

// The squared distance between segments p0-p1 and q0-q1 (Ericson, Real-Time Collision
// Detection 5.1.9; degenerate segments included).
double segment_distance2(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 0.0 && e <= 0.0) return r.squaredNorm();
  if (a <= 0.0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 0.0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;
      s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return (p0 + s * d1 - (q0 + t * d2)).squaredNorm();
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

// Relative round-off allowances of the index queries: the queries only select candidates
// that the exact tests below then decide, so the allowances are generous.
constexpr double kRound = 1e-12;   // of world coordinates
constexpr double kSlack = 1e-6;    // of the search margin
// How much wider than a step's search (m, times the block's radius) a scanned block's
// candidate pairs are gathered: they serve the steps until the block has moved by that.
constexpr double kCandidateWidening = 0.05;
// The same for a detailed block, whose pairs are many more per unit of widening.
constexpr double kIndexedWidening = 0.02;
// How much farther than the search's margin (m, times the block's radius) a detailed
// block's triangles and ridges are taken by their boxes: they serve until it has moved by
// that (its pairs by their caps, usually sooner).
constexpr double kIndexedBoxWidening = 0.25;
// How far (m, times the block's radius) a detailed block may move before its box is
// computed afresh rather than widened from the last one (PlacedBlock).
constexpr double kBoxReuse = 0.02;

// How many vertices a walk over a convex block's vertex graph (VertexClimb::below) may
// visit before a tree query is cheaper: 64, or a share of the block's vertices (a walk's
// pairs serve longer than a query's, *Reusing the pairs*, and a finer mesh has more
// vertices in the same cap).
std::size_t walk_limit(const Model& model) { return std::max<std::size_t>(64, model.vertices.size() / 20); }

// The slack of a walk for the plane m·r = level (VertexClimb::below): a few ulps of
// |m|·|r| and of the level's terms would do.
double walk_slack(const Model& model, const Vec3& m, double level) {
  return 1e-9 * (model.radius * m.norm() + std::abs(level));
}

// The cap of a walk under a plane (VertexClimb::below into `under`, its lowest value and
// the level it walked to): the lowest vertex, and how far from it the vertices walked and
// their edges reach. The polytope's part under the plane has for its corners the
// vertices under it (all walked) and points on their edges, so every block point above
// the level lies above it by at least (level − lowest)·|r − pivot| / reach (docs/dda.md,
// "Reusing the pairs").
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

// m·r for the point k of coordinate rows `rows` of n points each (Pairs::coordinates),
// summed as Eigen sums a 3-vector's dot product (the first two products, then the third),
// so that it equals m.dot(r) to the last bit.
inline double coordinate_dot(const Vec3& m, const double* rows, std::size_t n, std::size_t k) {
  return (m.x() * rows[k] + m.y() * rows[n + k]) + m.z() * rows[2 * n + k];
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

// A bound of ‖F − F₀‖₂ for the map F of `pose` and an earlier map F₀ of the same block
// (`rigid0`: a rotation too): every block point r has moved by at most that times |r|
// besides the centre's motion. Between rotations ‖F − F₀‖₂ = ‖F·F₀ᵀ − I‖₂ = 2 sin(θ/2) =
// √(3 − tr(F·F₀ᵀ)) for the angle θ between them; 1e-14 under the root covers the trace's
// round-off and the maps' departure from orthonormality (a few ulps of a normalized
// quaternion's). For a rolling block this is 1/√2 of the Frobenius norm, which the
// 12-DOF path keeps.
double map_change(const Pose& pose, const Mat3& map0, bool rigid0) {
  if (!pose.rigid || !rigid0) return (pose.map - map0).norm();
  const double trace = pose.map.row(0).dot(map0.row(0)) + pose.map.row(1).dot(map0.row(1)) +
                       pose.map.row(2).dot(map0.row(2));
  return std::sqrt(std::max(0.0, 3.0 - trace) + 1e-14);
}

double magnitude(const geometry::Aabb& b) { return std::max(b.lo.cwiseAbs().maxCoeff(), b.hi.cwiseAbs().maxCoeff()); }

// A world plane's signed value w·(x − a) over the block's body frame, x = centre + F·r:
// w·(centre − a) + (Fᵀw)·r, with its extremes over a body box (centre c, half-sizes h)
// widened by `tol` (m times |w|) for the round-off of the world test it stands for.
struct BodyPlane {
  BodyPlane() = default;
  BodyPlane(const Pose& pose, const Vec3& w, const Vec3& a, double widening)
      : m(pose.map.transpose() * w), m_abs(m.cwiseAbs()), s0(w.dot(pose.centre - a)), tol(widening) {}
  double max_over(const Vec3& c, const Vec3& h) const { return s0 + m.dot(c) + m_abs.dot(h) + tol; }
  double min_over(const Vec3& c, const Vec3& h) const { return s0 + m.dot(c) - m_abs.dot(h) - tol; }
  /// min_over of the point r (a box of no size): the same value.
  double min_at(const Vec3& r) const { return s0 + m.dot(r) - tol; }
  /// max_over of the point r: the same value.
  double max_at(const Vec3& r) const { return s0 + m.dot(r) + tol; }
  Vec3 m = Vec3::Zero(), m_abs = Vec3::Zero();
  double s0 = 0.0, tol = 0.0;
};

// An edge whose two ends both have a value s₀ + m·r of at least this along a ridge's
// `out` (BodyPlane(pose, te.out, te.pa, 0)) cannot cross the ridge within ds (docs/dda.md,
// "The ridge's level"; detect_indexed). The allowances cover the round-off of those values
// (a world vertex's, per coordinate) and of the exact test's own gap, for each pose the
// values are compared across: 1 for a step's test, 2 for the gathering that serves it.
double ridge_level_limit(const TerrainPatch::Ridge& te, const PlacedBlock& at, double ds, double margin, int poses) {
  return ds + poses * (2.0 * te.out_allowance + 4.0 * at.round_off()) + 1e-9 * margin;
}

// The vertices of a detailed block that can pass the vertex–triangle tests of detect_in
// with `tri`: in tbox, under the ceiling, in the slab of the triangle's plane from −depth
// to ds, and inside the triangle's normal prism or (ground that faces up) its vertical
// prism, the prisms widened by `motion` (m). Tested on the body-frame boxes of the vertex
// tree, where a world plane's signed value is linear in r. Replaces `out`, in tree order.
// Returns whether they were found by a walk under the triangle's plane, raised to at
// least `rise` (m) over the block's lowest vertex, and then that walk's cap into `cap`.
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
    // A vertex that passes has s0 + m·r − tol < ds, so lies under a plane of the body
    // frame: those are found by a walk over the vertex graph (VertexClimb::below), and
    // each is given the tree's test on its own box, unless they are more than a tree
    // query costs.
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

// Whether the search of `model` crosses its edges with ridge te: every ridge but a valley,
// whose crossings a block of short edges leaves to its vertex contacts
// (Model::crosses_valleys; `every_valley`, SearchFilter's, crosses them all).
bool crosses(const Model& model, const TerrainPatch::Ridge& te, bool every_valley) {
  return !te.valley() || model.crosses_valleys() || every_valley;
}

// The convex edges of a convex block (VertexClimb::fills) that `keeps` (gather_ridge_pairs's
// tests of an edge: those of its tree query on the edge's own box, and those on its
// segment), into `edges` (in no particular order), found by walks over the vertex graph:
// false when the walks would visit more vertices than a tree query costs (`edges` then
// incomplete). In the body frame, with the ridge
// from a to a + along: every edge that passes has a point within `deep` of the ridge, and
// within `shallow` of it or an end under the ridge's planes `sides` (may_be_under of
// gather_ridge_pairs: on a crest both, else either of `planes`; any when there are none). A
// point within D of the ridge lies under the plane u·r = max over the ridge of u·r + D for
// every unit u, and so does an end of its edge: with u the direction from the ridge's
// point nearest the centre to the centre, the plane cuts off the block's side next to
// the ridge. So every such edge has an end under one of: that plane for `shallow`, and
// for `deep` either that plane again or the planes of the ridge's triangles. Before
// those, one walk under the plane `out` at `out_limit` (gather_ridge_pairs keeps no edge
// with both ends above it), which alone finds every edge that can pass when it is short.
//
// When that walk alone served, its cap is set in `cap` and `capped` (walked_cap); its
// level is raised to at least `rise` (m) over the block's lowest vertex along `out`.
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

// The convex edges of a detailed block that can pass the edge–ridge tests of
// detect_indexed with ridge te within search distance ds and depth limit `depth` at this
// pose or any pose whose points lie within `motion` (m) of theirs (ds and depth must
// include that motion): the edge near the ridge's box and segment, under the ceiling, the
// planes of the ridge's triangles widened by the motion. Into p, ascending, with what
// their reuse rests on (pairs_serve): the block's separation from a ridge it lies apart
// from, the cap of the walk under the ridge's `out` plane (its level raised by the
// motion), else a tree query's.
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
  // ‖F‖₂, generously: 1 for a rigid pose (a rotation, to round-off), else the square
  // root of FᵀF's largest eigenvalue.
  double stretch = 1.0 + 1e-6;
  if (!pose.rigid) {
    Eigen::SelfAdjointEigenSolver<Mat3> eigen;
    eigen.computeDirect(pose.map.transpose() * pose.map, Eigen::EigenvaluesOnly);
    stretch = std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff())) * (1.0 + 1e-6);
  }
  // In the body frame: the ridge's segment, and the distances lengthened by F⁻¹. A pair
  // with gap ≥ 0 has its crossing within ds of the ridge. One with gap < 0 has it at
  // most `depth` from the ridge, below the plane of a triangle of the ridge: the normal
  // n, oriented along the triangles' normal sum, has n·nᵢ ≥ 0 for one of them, and
  // (pc − qc)·nᵢ = gap·(n·nᵢ) ≤ 0 (unknown for an edge of more than two triangles);
  // on a crest below both planes (edge_meets_ridge).
  const geometry::Aabb ridge_box = te.box.inflated(margin);
  const double tol = at.round_off() + kRound * magnitude(ridge_box) + kSlack * margin + 1e-9 * model.radius;
  // Every pair passes the distance tests below: its edge lies within `deep` of the
  // ridge in the body frame, so within stretch·deep in the world. A ridge the block lies
  // farther from has none, and most in the block's box do (those beside a round block's
  // box corners): skipped by their separation, a lower bound of the distance between
  // the ridge and the hull of the world vertices, which lie within twice their
  // round-off of the exact images of the body points.
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
  // detect_indexed passes over an edge with both ends more than its ds above the ridge
  // along `out`; a point moves by at most `motion` before the pairs are gathered again,
  // so an edge with both ends more than ds (which holds that motion) above it here
  // never reaches the test.
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
  // The same tests on each edge's own segment: its distance to the ridge's instead of
  // a box's, its ends' plane values instead of a box's extremes (a segment's extremes
  // along a plane lie at its ends). An edge's box is as long as the edge: the box
  // tests let through 1.5–3 times the pairs that pass these.
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

// The exact tests of the contact search, shared by the scan of a block of few vertices
// and the index of a detailed one.

// Block vertex p (world) against terrain triangle `tri`: whether its gap (set in `gap`)
// lies in (−depth, ds) and it lies inside the triangle's normal prism or, for ground that
// faces up, above or below the triangle in plan. In a concave valley (a slope meeting a
// steeper face) a vertex that has crossed the valley line lies under the steep face in
// plan but outside the normal prisms of both faces: without the plan test neither holds
// it and it sinks into the steep face unresisted.
inline bool vertex_meets_triangle(const TerrainPatch::Triangle& tri, const Vec3& p, double ds, double depth,
                                  double& gap) {
  gap = (p - tri.p[0]).dot(tri.normal);
  if (gap >= ds || gap <= -depth) return false;
  const Vec3 e0 = tri.p[1] - tri.p[0], e1 = tri.p[2] - tri.p[1], e2 = tri.p[0] - tri.p[2];
  const bool in_prism = e0.cross(p - tri.p[0]).dot(tri.normal) >= 0.0 &&
                        e1.cross(p - tri.p[1]).dot(tri.normal) >= 0.0 &&
                        e2.cross(p - tri.p[2]).dot(tri.normal) >= 0.0;
  return in_prism || (tri.normal.z() > 0.0 && inside_plan(tri, p));
}

void add_vertex_contact(const TerrainPatch::Triangle& tri, std::int32_t vertex, const Vec3& p, double gap,
                        std::vector<Contact>& out) {
  Contact& c = out.emplace_back();  // built in place: a contact is some 200 bytes
  c.kind = ContactKind::vertex_face;
  c.block_feature = vertex;
  c.terrain_feature = tri.index;
  c.triangle = tri.index;
  c.point = p;
  c.normal = tri.normal;
  c.gap = gap;
}

// Terrain vertex tv (qb: in the body frame) – block face: a spike of rough ground piercing
// a face between block vertices, tested in the body frame where the face polygons are
// stored. Only a vertex that is an extreme point of the terrain towards the face can
// touch it: every terrain edge from it must leave on the outer side of the face plane. A
// vertex of flat or concave ground (a grid node under a sliding cube) is no spike:
// without this test it would take a side face's horizontal normal and trip the block. A
// vertex of ground that is flat around it is no spike either: the block's own vertices
// on that plane carry the face, and a redundant spring inside the face only makes the
// contact states ambiguous. `faces` (ascending) are the faces whose polygon is within the
// margin of qb (a detailed block's index), or null for all of them; a face further away
// fails the gap or the polygon test. The allowance `face_tol` for the fallback's least
// depth covers the faces a scanned mesh splits one plane into (docs/dda.md, Detection).
void terrain_vertex_contact(const PlacedBlock& at, const TerrainPatch& patch, const TerrainPatch::Vertex& tv,
                            const Vec3& qb, const std::vector<std::int32_t>* faces, double ds, double depth,
                            double face_tol, std::vector<Contact>& out) {
  const Model& model = at.model();
  const Pose& pose = at.pose();
  const auto spike_towards = [&](const Vec3& face_normal_body) {
    const Vec3 n = pose.rotation * face_normal_body;
    bool falls_away = false;
    for (std::int32_t k = tv.first; k < tv.first + tv.count; ++k) {
      const double along = patch.neighbours[static_cast<std::size_t>(k)].dot(n);
      if (along < -1e-6) return false;
      falls_away = falls_away || along > 1e-6;
    }
    return falls_away;
  };
  const auto gap_to = [&](std::size_t f) {
    const BlockFace& face = model.faces[f];
    return face.normal.dot(qb) - face.offset;
  };
  const std::size_t face_count = faces != nullptr ? faces->size() : model.faces.size();
  int best = -1;
  double best_gap = -depth;
  for (std::size_t k = 0; k < face_count; ++k) {
    const std::size_t f = faces != nullptr ? static_cast<std::size_t>((*faces)[k]) : k;
    const BlockFace& face = model.faces[f];
    const double gap = gap_to(f);
    if (gap >= ds || gap <= best_gap) continue;
    if (!inside_polygon(face.polygon, Eigen::Vector2d(face.u.dot(qb), face.v.dot(qb)))) continue;
    if (!spike_towards(face.normal)) continue;
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
    if (!model.convex) return;
    if (faces != nullptr) {
      // The face it is least deep under has its polygon within that depth of it, so
      // is among the faces found: none of them in range, none at all.
      double near_least = -std::numeric_limits<double>::infinity();
      for (const std::int32_t fi : *faces) near_least = std::max(near_least, gap_to(static_cast<std::size_t>(fi)));
      if (!(near_least < -ds + face_tol && near_least > -depth - face_tol)) return;
    }
    double least = -std::numeric_limits<double>::infinity();
    for (std::size_t f = 0; f < model.faces.size(); ++f) {
      const double gap = gap_to(f);
      if (gap > least) {
        least = gap;
        best = static_cast<int>(f);
      }
    }
    if (!(least < -ds && least > -depth)) return;
  }
  const BlockFace& face = model.faces[static_cast<std::size_t>(best)];
  const Vec3 foot_body = qb - (face.normal.dot(qb) - face.offset) * face.normal;
  Contact c;
  c.kind = ContactKind::face_vertex;
  c.block_feature = best;
  c.terrain_feature = tv.id;
  c.triangle = tv.triangle;
  c.point = world_point(pose, foot_body);
  c.normal = -(pose.rotation * face.normal).normalized();
  c.gap = (c.point - tv.p).dot(c.normal);
  out.push_back(c);
}

// Whether point p lies in the ground of `patch` no deeper than `depth` (m): under a
// triangle's plane, inside its normal prism or, for ground that faces up, under it in
// plan (the test of a block vertex that has penetrated, vertex_meets_triangle).
bool in_ground(const TerrainPatch& patch, const Vec3& p, double depth) {
  double gap = 0.0;
  return std::any_of(patch.triangles.begin(), patch.triangles.end(),
                     [&](const TerrainPatch::Triangle& tri) { return vertex_meets_triangle(tri, p, 0.0, depth, gap); });
}

// Block edge `be` (world ends p0, p1) – terrain ridge te of `patch`: a crossing strictly
// inside both.
inline __attribute__((always_inline)) void edge_meets_ridge(const Pose& pose, std::int32_t be, const Vec3& p0,
                                                            const Vec3& p1, const TerrainPatch& patch,
                                                            const TerrainPatch::Ridge& te, double ds, double depth,
                                                            std::vector<Contact>& out) {
  double s = 0.0, t = 0.0;
  if (!line_parameters(p0, p1, te.pa, te.pb, s, t)) return;
  constexpr double kEnd = 1e-6;  // ends are vertex contacts
  if (s <= kEnd || s >= 1.0 - kEnd || t <= kEnd || t >= 1.0 - kEnd) return;
  Vec3 n = (p1 - p0).cross(te.pb - te.pa).normalized();
  if (n.dot(te.normal_sum) < 0.0) n = -n;
  const Vec3 pc = p0 + s * (p1 - p0);
  // The normal points out of the terrain and, at a convex edge of the block, into the
  // block: a pair for which the two disagree (a ridge seen edge-on, e₁ × e₂ nearly across
  // the ground) has no way out along it and is left to the other contacts.
  if (n.dot(pose.centre - pc) <= 0.0) return;
  const Vec3 qc = te.pa + t * (te.pb - te.pa);
  const double gap = (pc - qc).dot(n);
  if (gap >= ds || gap <= -depth) return;
  // A crossing below the ridge (gap < 0) is inside the ground only if it lies under the
  // planes of both triangles on a crest (pc − qc = gap·n: n·nᵢ > 0 for both), under
  // either in a valley (n·nᵢ ≥ 0 for one of them holds always). A block edge beside a
  // crest, over one side and under the other side's plane continued, is out of the ground:
  // it was taken as a penetrated contact with a normal that points out of one side only.
  if (gap < 0.0 && te.convex && !(n.dot(te.normals[0]) > 0.0 && n.dot(te.normals[1]) > 0.0)) return;
  // Near an end of the ridge (or beside a narrow triangle) the crossing's foot may lie
  // over a third triangle, whose plane that test does not see: a crossing below the
  // ridge is kept only where some triangle holds it as it would hold a block vertex
  // there, within twice the depth limit: it lies within |gap| + |qc − end| ≤ 2·depth of
  // any plane through that end. (14 of 61 532 crossings below ridges, in random poses on
  // the roughest bench slope, lay up to 2.5 cm above the ground, all within |gap| of a
  // ridge's end.) The crest test above stays: the index gathers a crest's deep pairs by
  // it (gather_ridge_pairs), and it is cheaper.
  if (gap < 0.0 && !in_ground(patch, pc, 2.0 * depth)) return;
  Contact c;
  c.kind = ContactKind::edge_edge;
  c.block_feature = be;
  c.terrain_feature = te.key();
  c.triangle = te.triangle;
  c.point = pc;
  c.normal = n;
  c.gap = gap;
  out.push_back(c);
}

inline geometry::Aabb edge_box(const Vec3& p0, const Vec3& p1, double margin) {
  return geometry::Aabb{p0.cwiseMin(p1), p0.cwiseMax(p1)}.inflated(margin);
}

// How far (m) the block lies wholly outside the prisms of `tri` that vertex_meets_triangle
// tests a vertex against: its normal prism and, for ground that faces up, its prism over
// the triangle in plan; ≤ 0 when not. Outside a prism means beyond the plane of one of
// its sides, with w the side's inward normal (n × e over an edge e, or e turned left in
// plan): w·(x − a) is at most w·(centre − a) plus the block's support along w (round-off
// included), and the test's own round-off is within 4·|w|·tol of it (vertices_near).
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

// The features of `patch` (of `count`; `box(k)` the box of feature k) whose boxes come
// within `margin` and `box_widening` (m) of a detailed block's box, into `ids` (in patch
// order), with their pairs in `pairs`, gathered in g. A feature that was among them
// before, from the same patch and block, keeps its pairs (they have their own reuse
// test, pairs_serve); the others are to be gathered.
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

// The vertices of a detailed block that can pass the vertex–triangle tests with `tri`
// within search distance ds and depth limit `depth` at this pose or any pose whose points
// lie within `motion` (m) of theirs (ds and depth must include that motion), ascending,
// into p with what their reuse rests on (pairs_serve).
void gather_triangle_pairs(const PlacedBlock& at, const TerrainPatch::Triangle& tri, double ds, double depth,
                           double motion, TerrainPatch::Candidates::Pairs& p) {
  using Basis = TerrainPatch::Candidates::Pairs::Basis;
  const Pose& pose = at.pose();
  start_gathering(at, ds, depth, motion, p);
  p.features.clear();
  p.coordinates.clear();
  const double margin = std::max(ds, depth);
  const geometry::Aabb tbox = tri.box.inflated(margin);
  // A plane the whole block lies above by more than ds has none of its vertices in the
  // slab of vertices_near's floor test: the block's least value along the normal is
  // bounded below by its support (round-off included), and the test's own round-off is
  // within tol of it. Most triangles of the box lie so (the ground beside and below a
  // round block's box corners), and this costs one support query.
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

// The triangles and ridges of a detailed block's pairs (indices into Candidates::triangles
// and ::ridges, ascending) whose boxes meet a search's reach (the block's box inflated by
// the search's margin): the only ones its pairs are refreshed and tested for.
struct Live {
  std::vector<std::size_t> triangles, ridges;
};

// The search of detect_contacts in `patch` for a detailed block, over the pairs of `c`
// (gathered per triangle and ridge by gather_triangle_pairs and gather_ridge_pairs, at
// this pose or one close enough for them to serve, pairs_serve): every test of a search
// that gathered at this very pose, in its order, so the same contacts in the same order,
// those of the scan. Terrain vertices are searched afresh (the faces near each).
void detect_indexed(const PlacedBlock& at, const TerrainPatch& patch, double ds, double vertex_ds, double depth,
                    const TerrainPatch::Candidates& c, const Live& live, std::vector<Contact>& out, MotionFilter* pass) {
  const Model& model = at.model();
  const Pose& pose = at.pose();
  const BlockIndex* index = at.index();
  const double margin = std::max(ds, depth);
  double top = -std::numeric_limits<double>::infinity();
  for (const std::size_t j : live.triangles)
    top = std::max(top, patch.triangles[static_cast<std::size_t>(c.triangles[j])].box.hi.z());
  const double ceiling = top + margin;
  // Whether any vertex is that low (the lowest vertex is the box's floor).
  const bool any_low = at.box().lo.z() <= ceiling;

  // World vertices, each computed once per search (those `placed`; PlacedBlock::vertex
  // gives the same bits each time): a vertex is tested against the triangles around it
  // and is an end of the edges around it.
  thread_local std::vector<Vec3> world;
  thread_local RoundMarks placed;
  if (world.size() < model.vertices.size()) world.resize(model.vertices.size());
  placed.start(model.vertices.size());
  const auto world_vertex = [&](std::int32_t v) -> const Vec3& {
    const std::size_t i = static_cast<std::size_t>(v);
    if (placed.mark(v)) world[i] = at.vertex(i);
    return world[i];
  };

  // Block vertex – terrain triangle. The vertex contacts found so far of each vertex, as
  // chains: latest[vertex] and then earlier[contact] (numbered from `first`), −1 ending
  // them; a vertex over a shared edge of two coplanar triangles is one contact, not two.
  // Between searches every entry of `latest` is −1 (those set are reset below), so it
  // costs what the contacts found cost, not what the block has.
  const std::size_t first = out.size();
  thread_local std::vector<double> body_gaps;
  thread_local std::vector<std::int32_t> latest, earlier;
  if (latest.size() < model.vertices.size()) latest.resize(model.vertices.size(), -1);
  earlier.clear();
  // The triangle's plane over the body frame: a vertex whose gap there lies outside
  // (−depth, ds) by more than the round-off of either computation fails the exact test
  // below, so it is passed over before its world position is computed (the pairs were
  // gathered for a wider distance).
  for (std::size_t l = 0; l < live.triangles.size() && any_low; ++l) {
    const std::size_t j = live.triangles[l];
    const TerrainPatch::Triangle& tri = patch.triangles[static_cast<std::size_t>(c.triangles[j])];
    const std::vector<std::int32_t>& vertices = c.triangle_pairs[j].features;
    if (vertices.empty()) continue;
    const geometry::Aabb tbox = tri.box.inflated(margin);
    const BodyPlane slab(pose, tri.normal, tri.p[0], at.round_off() + kRound * magnitude(tbox));
    // Each vertex's gap over the body frame, s0 + m·r, in one pass over the coordinates.
    const std::size_t n = vertices.size();
    const double* x = c.triangle_pairs[j].coordinates.data();
    body_gaps.resize(n);
    for (std::size_t k = 0; k < n; ++k) body_gaps[k] = slab.s0 + coordinate_dot(slab.m, x, n, k);
    for (std::size_t k = 0; k < n; ++k) {
      const double body_gap = body_gaps[k];
      if (body_gap - slab.tol >= ds || body_gap + slab.tol <= -depth) continue;
      const std::int32_t vi = vertices[k];
      if (pass != nullptr) {
        // A candidate the motion filter passes over: its gap's lower bound beyond
        // what it can move, by more than that figure's round-off.
        const double low = body_gap - slab.tol;
        if (low > pass->scale * pass->fall) {
          const Vec3 r(x[k], x[n + k], x[2 * n + k]);
          if (low > pass->reach((pass->velocity + pass->spin.cross(r)).norm()) &&
              !std::binary_search(pass->keep->begin(), pass->keep->end(), vi)) {
            pass->take(low);
            continue;
          }
        }
      }
      const std::size_t i = static_cast<std::size_t>(vi);
      const Vec3& p = world_vertex(vi);
      if (p.z() > ceiling || !contains(tbox, p)) continue;
      double gap = 0.0;
      if (!vertex_meets_triangle(tri, p, ds, depth, gap)) continue;
      bool duplicate = false;
      for (std::int32_t e = latest[i]; e >= 0 && !duplicate; e = earlier[static_cast<std::size_t>(e)])
        duplicate = out[first + static_cast<std::size_t>(e)].normal.dot(tri.normal) > 1.0 - 1e-9;
      if (duplicate) continue;
      earlier.push_back(latest[i]);
      latest[i] = static_cast<std::int32_t>(out.size() - first);
      add_vertex_contact(tri, vi, p, gap, out);
    }
  }
  for (std::size_t k = first; k < out.size(); ++k) latest[static_cast<std::size_t>(out[k].block_feature)] = -1;

  // Terrain vertex – block face, against the faces whose polygon is near it, within the
  // terrain vertices' own search distance.
  const double vertex_margin = std::max(vertex_ds, depth);
  const geometry::Aabb vertex_reach = at.box().inflated(vertex_margin);
  const double face_tol = kSlack * vertex_margin + 1e-6 * model.radius;
  thread_local std::vector<std::int32_t> faces;
  // How much more than a terrain vertex's own point its contact's point may move, per
  // metre of gap, times the motion filter's scale: scale·|ω|·h.
  const double turn = pass != nullptr ? pass->scale * pass->spin.norm() * pass->h : 0.0;
  for (const TerrainPatch::Vertex& tv : patch.vertices) {
    if (!contains(vertex_reach, tv.p)) continue;
    const Vec3 qb = pose.inverse_map * (tv.p - pose.centre);
    if (pass != nullptr && turn < 0.5 &&
        !std::binary_search(pass->keep_terrain->begin(), pass->keep_terrain->end(), tv.id)) {
      // A terrain vertex whose contact the motion filter passes over. Its contact's
      // gap is its distance to a face it lies over, at least its distance to the block's
      // hull, which is at least |d| − S(d/|d|) for d from the centre (S the support, an
      // upper bound; a few round-offs less). The contact's point, its foot on that face,
      // moves at most |v + ω × d|·h + |ω|·h·gap + ½g·h²: a gap beyond scale times that
      // is passed over, as it is when the bound times (1 − scale·|ω|·h) exceeds scale
      // times the rest.
      const Vec3 d = tv.p - pose.centre;
      const double length = d.norm();
      if (length > 0.0) {
        const double low = length - at.support(d / length) - 4.0 * at.round_off() - 1e-12 * length;
        if (low > pass->scale * pass->fall) {
          if (low * (1.0 - turn) * (1.0 - 1e-9) > pass->reach((pass->velocity + pass->spin.cross(qb)).norm())) {
            pass->take(low);
            continue;
          }
        }
      }
    }
    faces.clear();
    const geometry::Aabb near_qb{qb - Vec3::Constant(vertex_margin + face_tol),
                                 qb + Vec3::Constant(vertex_margin + face_tol)};
    index->faces.query([&](const geometry::Aabb& b) { return overlaps(b, near_qb); }, faces);
    std::sort(faces.begin(), faces.end());
    terrain_vertex_contact(at, patch, tv, qb, &faces, vertex_ds, depth, face_tol, out);
  }

  // Block edge – terrain ridge crossings, ridge by ridge and then put in the order of the
  // scan (by edge, then ridge). A crossing's gap g is along n, ⟂ both lines and oriented
  // so that n·out = n·normal_sum ≥ 0 (`out` is the ridge's normal sum with its part along
  // the ridge taken out). So g·(n·out) = (pc − qc)·out ≥ min(out·(p0 − pa), out·(p1 −
  // pa)): an edge with both ends more than ds above the ridge along `out` has its gap
  // beyond ds, and is passed over (ridge_level_limit). Tested in the body frame before
  // the ends' world positions are computed. Most gathered pairs are passed over so
  // (edge_meets_ridge solves for each crossing).
  const std::size_t first_crossing = out.size();
  thread_local std::vector<std::pair<std::int32_t, std::int32_t>> order;  // (edge, ridge) of each crossing
  order.clear();
  for (const std::size_t j : live.ridges) {
    const std::int32_t r = c.ridges[j];
    const TerrainPatch::Ridge& te = patch.ridges[static_cast<std::size_t>(r)];
    const std::vector<std::int32_t>& edges = c.ridge_pairs[j].features;
    if (edges.empty()) continue;
    const BodyPlane level(pose, te.out, te.pa, 0.0);
    const double limit = ridge_level_limit(te, at, ds, margin, 1);
    // Each edge's lower end's value along `out`, in one pass over the coordinates (ends
    // a, then ends b).
    const std::size_t n = edges.size();
    const double* x = c.ridge_pairs[j].coordinates.data();
    body_gaps.resize(n);
    for (std::size_t k = 0; k < n; ++k)
      body_gaps[k] = std::min(coordinate_dot(level.m, x, n, k), coordinate_dot(level.m, x + 3 * n, n, k)) + level.s0;
    for (std::size_t k = 0; k < n; ++k) {
      if (body_gaps[k] >= limit) continue;
      const std::int32_t be = edges[k];
      if (pass != nullptr) {
        // A crossing the motion filter passes over: the level less its round-off
        // (that of the limit over ds) bounds the crossing's gap below when positive.
        const double low = body_gaps[k] - (limit - ds);
        if (low > pass->scale * pass->fall) {
          const Vec3 ra(x[k], x[n + k], x[2 * n + k]), rb(x[3 * n + k], x[4 * n + k], x[5 * n + k]);
          const double speed = std::max((pass->velocity + pass->spin.cross(ra)).norm(),
                                        (pass->velocity + pass->spin.cross(rb)).norm());
          if (low > pass->reach(speed) && !std::binary_search(pass->keep_edges->begin(), pass->keep_edges->end(), be)) {
            pass->take(low);
            continue;
          }
        }
      }
      const BlockEdge& bedge = model.edges[static_cast<std::size_t>(be)];
      const Vec3& p0 = world_vertex(bedge.a);
      const Vec3& p1 = world_vertex(bedge.b);
      if (std::min(p0.z(), p1.z()) > ceiling || !overlaps(te.box, edge_box(p0, p1, margin))) continue;
      const std::size_t before = out.size();
      edge_meets_ridge(pose, be, p0, p1, patch, te, ds, depth, out);
      if (out.size() > before) order.emplace_back(be, r);
    }
  }
  // Few crossings: an insertion sort.
  for (std::size_t i = 1; i < order.size(); ++i)
    for (std::size_t k = i; k > 0 && order[k] < order[k - 1]; --k) {
      std::swap(order[k], order[k - 1]);
      std::swap(out[first_crossing + k], out[first_crossing + k - 1]);
    }
}

// The feature pairs of a scanned block (few vertices) that can form a contact within
// search distance ds and depth limit `depth`, in the order detect_scanned tests them:
// for each, the tests of detect_scanned that only a distance decides (a box, a gap),
// widened to these distances. `prune` off keeps every pair (the brute-force reference);
// `every_valley` crosses every valley (SearchFilter).
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

// The search of detect_contacts in `patch` for a scanned block, over the pairs of `c`
// (gathered at this pose or one close enough, with distances at least this search's
// plus the block's motion since): every test in the order of a scan of all the pairs,
// so the same contacts in the same order. `prune` off tests every pair (the reference).
void detect_scanned(const PlacedBlock& at, const TerrainPatch& patch, double ds, double depth, bool prune,
                    const TerrainPatch::Candidates& c, std::vector<Contact>& out) {
  const Model& model = at.model();
  const Pose& pose = at.pose();
  const std::vector<Vec3>& world = at.vertices();
  const double margin = std::max(ds, depth);
  const geometry::Aabb reach = at.box().inflated(margin);
  // Only block features at most `margin` above the highest terrain point under the
  // block can touch it (a bounding-box argument, valid for any surface).
  double top = -std::numeric_limits<double>::infinity();
  for (const std::int32_t t : c.triangles) {
    const TerrainPatch::Triangle& tri = patch.triangles[static_cast<std::size_t>(t)];
    if (!prune || overlaps(tri.box, reach)) top = std::max(top, tri.box.hi.z());
  }
  const double ceiling = prune ? top + margin : std::numeric_limits<double>::infinity();

  // Block vertex – terrain triangle; a vertex over a shared edge of two coplanar
  // triangles is one contact, not two.
  const std::size_t first = out.size();
  if (at.box().lo.z() <= ceiling) {
    for (const auto& [t, vi] : c.vertex_triangle) {
      const TerrainPatch::Triangle& tri = patch.triangles[static_cast<std::size_t>(t)];
      if (prune && !overlaps(tri.box, reach)) continue;
      const Vec3& p = world[static_cast<std::size_t>(vi)];
      if (p.z() > ceiling) continue;
      if (prune && !contains(tri.box.inflated(margin), p)) continue;
      double gap = 0.0;
      if (!vertex_meets_triangle(tri, p, ds, depth, gap)) continue;
      bool duplicate = false;
      for (std::size_t k = first; k < out.size(); ++k)
        if (out[k].block_feature == vi && out[k].normal.dot(tri.normal) > 1.0 - 1e-9) duplicate = true;
      if (duplicate) continue;
      add_vertex_contact(tri, vi, p, gap, out);
    }
  }

  // Terrain vertex – block face, against every face.
  const double face_tol = kSlack * margin + 1e-6 * model.radius;
  for (const std::int32_t k : c.vertices) {
    const TerrainPatch::Vertex& tv = patch.vertices[static_cast<std::size_t>(k)];
    if (prune && !contains(reach, tv.p)) continue;
    terrain_vertex_contact(at, patch, tv, pose.inverse_map * (tv.p - pose.centre), nullptr, ds, depth, face_tol,
                           out);
  }

  // Block edge – terrain ridge crossings.
  for (const auto& [be, r] : c.edge_ridge) {
    const TerrainPatch::Ridge& te = patch.ridges[static_cast<std::size_t>(r)];
    if (prune && !overlaps(te.box, reach)) continue;
    const BlockEdge& bedge = model.edges[static_cast<std::size_t>(be)];
    const Vec3& p0 = world[bedge.a];
    const Vec3& p1 = world[bedge.b];
    if (std::min(p0.z(), p1.z()) > ceiling) continue;
    if (prune && !overlaps(te.box, edge_box(p0, p1, margin))) continue;
    edge_meets_ridge(pose, be, p0, p1, patch, te, ds, depth, out);
  }
}

}  // namespace

PlacedBlock::PlacedBlock(const Model& model, const Pose& pose, std::vector<Vec3>& storage, bool scan,
                         BlockBox* reuse)
    : model_(&model), pose_(&pose), world_(&storage) {
  if (model.index == nullptr || scan) {
    storage.resize(model.vertices.size());
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (std::size_t i = 0; i < model.vertices.size(); ++i) {
      const Vec3 p = world_point(pose, model.vertices[i]);
      storage[i] = p;
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], p[k]);
        hi[k] = std::max(hi[k], p[k]);
      }
    }
    box_ = geometry::Aabb{lo, hi};
    return;
  }
  index_ = model.index.get();
  abs_inverse_ = pose.inverse_map.cwiseAbs();
  const Mat3 abs_map = pose.map.cwiseAbs();
  // centre + F·r rounds by a few ulps of |centre| + |F|·|r|, |r| ≤ radius.
  round_off_ = kRound * (pose.centre.cwiseAbs().maxCoeff() + model.radius * abs_map.rowwise().sum().maxCoeff());
  // ‖F⁻¹‖₂ = 1/σ_min(F), generously: 1 for a rigid pose (a rotation, to round-off), else
  // the square root of the largest eigenvalue of F⁻ᵀF⁻¹.
  inverse_stretch_ = 1.0 + 1e-6;
  if (!pose.rigid) {
    Eigen::SelfAdjointEigenSolver<Mat3> eigen;
    eigen.computeDirect(pose.inverse_map.transpose() * pose.inverse_map, Eigen::EigenvaluesOnly);
    inverse_stretch_ = std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff())) * (1.0 + 1e-6);
  }
  if (reuse != nullptr && reuse->model == &model) {
    // A vertex has moved by at most |Δcentre| + ‖ΔF‖·|r| since (map_change bounds the
    // spectral norm), plus the round-off of its two world positions.
    const double moved =
        (pose.centre - reuse->centre).norm() + map_change(pose, reuse->map, reuse->rigid) * model.radius;
    const double slack = 2.0 * round_off_ + 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius);
    if (moved <= kBoxReuse * model.radius) {
      box_ = reuse->box.inflated(moved + slack);
      return;
    }
  }
  // The box's faces are the extreme vertices along each axis: on a convex block by
  // climbing its vertex graph along the rows of F (the farthest vertex by its body-frame
  // value, within round-off of the farthest by world coordinate, so the box is widened by
  // twice the round-off of a world vertex); else by branch and bound over the vertex tree,
  // the values then the vertices' own world coordinates.
  if (!index_->climb.empty()) {
    const double slack = 2.0 * round_off_;
    for (int k = 0; k < 3; ++k) {
      const Vec3 row = pose.map.row(k).transpose();
      const std::int32_t hi = index_->climb.farthest(model.vertices, row);
      const std::int32_t lo = index_->climb.farthest(model.vertices, -row);
      box_.hi[k] = world_point(pose, model.vertices[static_cast<std::size_t>(hi)])[k] + slack;
      box_.lo[k] = world_point(pose, model.vertices[static_cast<std::size_t>(lo)])[k] - slack;
    }
    if (reuse != nullptr) *reuse = BlockBox{&model, pose.centre, pose.map, box_, pose.rigid};
    return;
  }
  for (int k = 0; k < 3; ++k) {
    const Vec3 row = pose.map.row(k).transpose();
    const Vec3 abs_row = abs_map.row(k).transpose();
    const double centre = pose.centre[k];
    const auto coordinate = [&](std::int32_t i) {
      return world_point(pose, model.vertices[static_cast<std::size_t>(i)])[k];
    };
    box_.hi[k] = index_->vertices.maximum(
        [&](const geometry::Aabb& b) {
          return centre + row.dot(b.center()) + abs_row.dot(0.5 * b.extent()) + round_off_;
        },
        coordinate);
    box_.lo[k] = -index_->vertices.maximum(
        [&](const geometry::Aabb& b) {
          return -centre - row.dot(b.center()) + abs_row.dot(0.5 * b.extent()) + round_off_;
        },
        [&](std::int32_t i) { return -coordinate(i); });
  }
  if (reuse != nullptr) *reuse = BlockBox{&model, pose.centre, pose.map, box_, pose.rigid};
}

double PlacedBlock::support(const Vec3& u) const {
  const Vec3& centre = pose_->centre;
  if (index_ == nullptr) {
    double far = -std::numeric_limits<double>::infinity();
    for (const Vec3& x : *world_) far = std::max(far, u.dot(x - centre));
    return far;
  }
  // u·(c + F·r − c) = (Fᵀu)·r. A convex block's farthest vertex by that body-frame value
  // (VertexClimb) is within round-off of the farthest by world value: twice a world
  // vertex's round-off (per coordinate) on top makes it an upper bound.
  if (!index_->climb.empty()) {
    std::int32_t from = -1;
    Vec3 lever;
    return climbed_support(u, from, lever);
  }
  const Vec3 m = pose_->map.transpose() * u;
  // Else bounded over a body box by its centre and half-sizes; the world vertex's
  // round-off (per coordinate) on top.
  const Vec3 abs_m = m.cwiseAbs();
  const double slack = round_off_ * u.cwiseAbs().sum();
  return index_->vertices.maximum(
      [&](const geometry::Aabb& b) { return m.dot(b.center()) + abs_m.dot(0.5 * b.extent()) + slack; },
      [&](std::int32_t i) { return u.dot(world_point(*pose_, model_->vertices[static_cast<std::size_t>(i)]) - centre); });
}

double PlacedBlock::climbed_support(const Vec3& u, std::int32_t& from, Vec3& lever) const {
  from = index_->climb.farthest(model_->vertices, pose_->map.transpose() * u, from);
  lever = world_point(*pose_, model_->vertices[static_cast<std::size_t>(from)]) - pose_->centre;
  return u.dot(lever) + 2.0 * round_off_ * u.cwiseAbs().sum();
}

double PlacedBlock::support_bound(const Vec3& u) const {
  if (index_ == nullptr) return support(u);
  const Vec3 m = pose_->map.transpose() * u;
  const geometry::Aabb& b = index_->body_box;
  return m.dot(b.center()) + m.cwiseAbs().dot(0.5 * b.extent()) + 2.0 * round_off_ * u.cwiseAbs().sum() +
         1e-12 * model_->radius;
}

geometry::Aabb PlacedBlock::body_box(const geometry::Aabb& world) const {
  const Vec3 c = pose_->inverse_map * (world.center() - pose_->centre);
  const Vec3 h = abs_inverse_ * (0.5 * world.extent());
  // The round-off of the world points and of F⁻¹ (a few ulps of |F⁻¹|·|x − centre|).
  const double slack = abs_inverse_.rowwise().sum().maxCoeff() * (round_off_ + kRound * (magnitude(world) + h.maxCoeff()));
  return geometry::Aabb{c - h - Vec3::Constant(slack), c + h + Vec3::Constant(slack)};
}

geometry::Aabb PlacedBlock::world_box(const geometry::Aabb& body) const {
  const Vec3 c = world_point(*pose_, body.center());
  const Vec3 h = pose_->map.cwiseAbs() * (0.5 * body.extent());
  // The round-off of centre + F·r (a few ulps of |centre| + |F|·|r|) on top.
  const double slack = round_off_ + kRound * (c.cwiseAbs().maxCoeff() + h.maxCoeff());
  return geometry::Aabb{c - h - Vec3::Constant(slack), c + h + Vec3::Constant(slack)};
}

namespace {

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

// How far the points of a block at `pose` have moved at most (m) since the pose of
// gathering g (∞ when g holds no pairs of `model`; Motion::moved).
double moved_since(const TerrainPatch::Candidates::Gathering& g, const Model& model, const Pose& pose) {
  if (g.model != &model) return std::numeric_limits<double>::infinity();
  return motion_since(model, pose, g).moved;
}

// Whether a detailed block's pairs p with one triangle or ridge serve a search at `pose`
// with distances ds and depth (m) (docs/dda.md, "Reusing the pairs"). Every point has
// moved by at most `moved` = |Δcentre| + ‖ΔF‖·radius since they were gathered. Those of
// a tree query serve while that is within the motion their tests were widened by, with
// ds + moved and depth + moved within their distances. Those of a walk serve too while
// the points within its cap's reach of its pivot move by at most that, μ = |Δ(pivot)| +
// ‖ΔF‖·reach, and ‖ΔF‖·reach ≤ rise: every point the walk left out then stays out of
// reach. None serve while the block stays above the triangle's plane, beside its prisms
// or apart from the ridge.
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
  // The candidate pairs are gathered afresh when the block has moved, since they were
  // gathered, by more than their wider distances allow: a block point moves by at most
  // |Δcentre| + ‖ΔF‖·radius, and a gap, a box or a point's distance to a box by no more
  // than that. A detailed block's were gathered with its prism and plane tests widened by
  // a motion, which bounds it too, or that of the points near its walks' pivots.
  const Model& model = at.model();
  const Pose& pose = at.pose();
  TerrainPatch::Candidates& c = patch.candidates;
  if (at.index() != nullptr) {
    // The pairs serve the vertex–triangle and edge–ridge tests, at the near distance.
    const double ds = near_distance > 0.0 && near_distance < search_distance ? near_distance : search_distance;
    const double widening = kIndexedWidening * model.radius;
    const double box_widening = kIndexedBoxWidening * model.radius;
    // The triangles and ridges by their boxes, then the pairs of each (those the search
    // tests: of the features whose boxes meet its reach).
    const double margin = std::max(ds, depth_limit);
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
      using Basis = TerrainPatch::Candidates::Pairs::Basis;
      if (p.basis == Basis::none || p.model != &model) return false;
      // The motion since the gathering is at most the sum's growth since then, and at
      // most what the last test on the poses found plus the sum's growth since that test
      // (a bound of the motion between the two searches; the same for the turn).
      Motion bound;
      bound.moved = c.travelled - p.travelled;
      const TerrainPatch::Candidates::Pairs::Checked& k = p.checked;
      const double grown = c.travelled - k.travelled, turned = c.turned - k.turned;
      const bool checked = std::isfinite(k.moved) && grown >= 0.0 && turned >= 0.0;
      if (checked && !(bound.moved >= 0.0 && bound.moved <= k.moved + grown)) bound.moved = k.moved + grown;
      if (bound.moved >= 0.0 && pairs_serve(p, bound, ds, depth_limit)) return true;
      if (checked && p.basis == Basis::walked) {
        // The cap's test of pairs_serve on those bounds: the pivot moves and the block
        // turns by at most what the last test found plus the sums' growth.
        const double swing = (k.turn + turned) * (1.0 + 1e-9) * p.cap.reach * (1.0 + 1e-9);
        const double motion = k.pivot + grown + swing + slack;
        if (swing + slack <= p.cap.rise && ds + motion <= p.ds && depth_limit + motion <= p.depth &&
            motion <= p.motion)
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
      return pairs_serve(p, *known, ds, depth_limit);
    };
    // The pairs of the features (`ids`, of `features`) that are searched and whose boxes
    // meet the reach, gathered again by `gather(feature, pairs)` where they no longer serve.
    thread_local Live live;
    const auto refresh = [&](const std::vector<std::int32_t>& ids, const auto& features,
                             std::vector<TerrainPatch::Candidates::Pairs>& pairs, std::vector<std::size_t>& met,
                             const auto& searched, const auto& gather) {
      met.clear();
      for (std::size_t j = 0; j < ids.size(); ++j) {
        const auto& feature = features[static_cast<std::size_t>(ids[j])];
        if (!searched(feature) || !overlaps(feature.box, reach)) continue;
        met.push_back(j);
        if (serves(pairs[j])) continue;
        gather(feature, pairs[j]);
        pairs[j].search = search;
        pairs[j].travelled = c.travelled;
        pairs[j].checked = {};
      }
    };
    refresh(c.triangles, patch.triangles, c.triangle_pairs, live.triangles,
            [](const TerrainPatch::Triangle&) { return true; },
            [&](const TerrainPatch::Triangle& tri, TerrainPatch::Candidates::Pairs& pairs) {
              gather_triangle_pairs(at, tri, ds + widening, depth_limit + widening, widening, pairs);
            });
    refresh(c.ridges, patch.ridges, c.ridge_pairs, live.ridges,
            [&](const TerrainPatch::Ridge& te) { return crosses(model, te, filter.every_valley); },
            [&](const TerrainPatch::Ridge& te, TerrainPatch::Candidates::Pairs& pairs) {
              gather_ridge_pairs(at, te, ds + widening, depth_limit + widening, widening, pairs);
            });
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

// How far apart the block (the hull of its world vertices `block`) and the triangle
// `corners` lie (m) along the direction from `centre` (the block's centroid) to the
// triangle's point nearest to it: the separating direction of a block near
// a triangle whose plane, continued, passes by the block (a steeper triangle beside the
// one under it). The triangle's extent along it is that of its corners, and the
// block's that of its vertices, so the value is a lower bound of their distance whatever
// the direction's round-off.
namespace {

// The unit direction from centre to the triangle's point nearest to it into u; false
// when centre lies on the triangle.
bool towards_triangle(const Vec3& centre, const std::array<Vec3, 3>& corners, Vec3& u) {
  // The triangle's point nearest to centre (Ericson, Real-Time Collision Detection 5.1.5).
  const Vec3& a = corners[0];
  const Vec3& b = corners[1];
  const Vec3& c = corners[2];
  const Vec3 ab = b - a, ac = c - a, ap = centre - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  Vec3 nearest;
  if (d1 <= 0.0 && d2 <= 0.0) {
    nearest = a;
  } else {
    const Vec3 bp = centre - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    const Vec3 cp = centre - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d3 >= 0.0 && d4 <= d3) {
      nearest = b;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      nearest = a + (d1 / (d1 - d3)) * ab;
    } else if (d6 >= 0.0 && d5 <= d6) {
      nearest = c;
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      nearest = a + (d2 / (d2 - d6)) * ac;
    } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
      nearest = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    } else {
      const double inverse = 1.0 / (va + vb + vc);
      nearest = a + ab * (vb * inverse) + ac * (vc * inverse);
    }
  }
  const Vec3 towards = nearest - centre;
  const double length = towards.norm();
  if (!(length > 0.0)) return false;
  u = towards / length;
  return true;
}

// The triangle's least extent along u from centre.
double triangle_from(const Vec3& centre, const std::array<Vec3, 3>& corners, const Vec3& u) {
  return std::min({u.dot(corners[0] - centre), u.dot(corners[1] - centre), u.dot(corners[2] - centre)});
}

}  // namespace

double separation(const std::vector<Vec3>& block, const Vec3& centre, const std::array<Vec3, 3>& corners,
                  Vec3* direction) {
  Vec3 u;
  if (!towards_triangle(centre, corners, u)) return -std::numeric_limits<double>::infinity();
  if (direction != nullptr) *direction = u;
  double block_to = -std::numeric_limits<double>::infinity();
  for (const Vec3& v : block) block_to = std::max(block_to, u.dot(v - centre));
  return triangle_from(centre, corners, u) - block_to;
}

double separation(const PlacedBlock& at, const std::array<Vec3, 3>& corners, Vec3* direction) {
  const Vec3& centre = at.pose().centre;
  Vec3 u;
  if (!towards_triangle(centre, corners, u)) return -std::numeric_limits<double>::infinity();
  if (direction != nullptr) *direction = u;
  return triangle_from(centre, corners, u) - at.support(u);
}

void FlightBound::reset(const std::vector<Vec3>& vertices, const Vec3& centre, const Vec3& velocity, const Vec3& spin,
                        double gravity, bool damped, double round_off) {
  vertices_ = &vertices;
  placed_ = nullptr;
  centre_ = centre;
  velocity_ = velocity;
  gravity_ = gravity;
  damped_ = damped;
  round_off_ = round_off;
  enough_ = 0.0;
  rates_.resize(vertices.size());
  curvature_.resize(vertices.size());
  const double spin2 = spin.squaredNorm();
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Vec3 r = vertices[i] - centre;
    rates_[i] = damped ? spin.cross(r) : Vec3(velocity + spin.cross(r));
    curvature_[i] = spin2 * r.norm();
  }
}

void FlightBound::reset(const PlacedBlock& at, const Vec3& velocity, const Vec3& spin, double gravity, bool damped,
                        double round_off) {
  vertices_ = nullptr;
  placed_ = &at;
  centre_ = at.pose().centre;
  velocity_ = velocity;
  gravity_ = gravity;
  damped_ = damped;
  // The support's own round-off comes on top of the caller's.
  round_off_ = round_off + 4.0 * at.round_off();
  enough_ = 0.0;
  spin_ = spin.norm();
  spin_vector_ = spin;
  radius_ = at.model().radius * (1.0 + 1e-12);
}

namespace {

// The earliest time (s, at most `limit`) at which a point `height` (m) above a plane may
// reach it when it approaches at `rate` (m/s) with the approach accelerating at `a`
// (m/s²) at most: the smaller positive root of ½a·t² + rate·t = height, in its stable
// form, or `limit` when there is none before it.
double reach_time(double height, double rate, double a, double limit) {
  // It cannot come that close before `limit`: no root to find.
  if (height > (std::max(0.0, rate) + 0.5 * std::max(0.0, a) * limit) * limit) return limit;
  // None when the approach turns back before reaching it.
  const double disc = rate * rate + 2.0 * a * height;
  if (disc < 0.0) return limit;
  const double den = rate + std::sqrt(disc);
  return den > 0.0 ? std::min(limit, 2.0 * height / den) : limit;
}

}  // namespace

double FlightBound::plane_time(const Vec3& n, double offset, double limit) const {
  const double translation = damped_ ? std::max(0.0, -n.dot(velocity_)) : 0.0;
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  if (placed_ != nullptr) {
    // The block's box first (a lower height, in constant time): a plane it keeps clear
    // of for the whole limit needs no search of the vertex tree.
    if (box_plane_time(n, offset, limit) >= limit) return limit;
    if (!placed_->index()->climb.empty()) return climb_plane_time(n, offset, limit);
    // Then each vertex's own time, as the scan below computes it, by branch and bound over
    // the vertex tree (the largest −time): over a body box (centre c, half-sizes h) the
    // height n·(centre + F·r) is at least its value at c less |Fᵀn|·h, the approach
    // −n·(v + ω × F·r) = −n·v − (Fᵀ(n × ω))·r at most its value at c plus |Fᵀ(n × ω)|·h,
    // and the curvature |ω|²·|F·r| at most |ω|²·(|c| + |h|) (F a rotation: the rigid path).
    const Pose& pose = placed_->pose();
    const Model& model = placed_->model();
    const Vec3 m = pose.map.transpose() * n;
    const Vec3 k = pose.map.transpose() * n.cross(spin_vector_);
    const Vec3 m_abs = m.cwiseAbs(), k_abs = k.cwiseAbs();
    const double spin2 = spin_vector_.squaredNorm();
    const double base = n.dot(centre_) - offset - round_off_;
    // The round-off of a vertex's computed height and approach against these bounds.
    const double slack_height = 4.0 * placed_->round_off() + 1e-12 * (std::abs(base) + model.radius);
    const double slack_rate = 1e-12 * (velocity_.norm() + spin_ * model.radius);
    const double earliest = placed_->index()->vertices.maximum(
        [&](const geometry::Aabb& b) {
          const Vec3 c = b.center();
          const Vec3 h = 0.5 * b.extent();
          const double height = base + m.dot(c) - m_abs.dot(h) - slack_height;
          if (!(height > 0.0)) return 0.0;
          const double spin_part = -k.dot(c) + k_abs.dot(h) + slack_rate;
          const double approach = damped_ ? translation + std::max(0.0, spin_part) : -n.dot(velocity_) + spin_part;
          const double curvature = fall + spin2 * (c.norm() + h.norm()) * (1.0 + 1e-12);
          return -reach_time(height, approach, curvature, limit);
        },
        [&](std::int32_t i) {
          const Vec3 x = world_point(pose, model.vertices[static_cast<std::size_t>(i)]);
          const double height = n.dot(x) - offset - round_off_;
          if (!(height > 0.0)) return 0.0;
          const Vec3 r = x - centre_;
          const Vec3 w = damped_ ? Vec3(spin_vector_.cross(r)) : Vec3(velocity_ + spin_vector_.cross(r));
          const double rate_i = damped_ ? translation + std::max(0.0, -n.dot(w)) : -n.dot(w);
          return -reach_time(height, rate_i, fall + spin2 * r.norm(), limit);
        },
        -limit);
    return -earliest;
  }
  const std::vector<Vec3>& vertices = *vertices_;
  double earliest = limit;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const double height = n.dot(vertices[i]) - offset - round_off_;
    if (!(height > 0.0)) return 0.0;
    const double rate = damped_ ? translation + std::max(0.0, -n.dot(rates_[i])) : -n.dot(rates_[i]);
    earliest = reach_time(height, rate, fall + curvature_[i], earliest);
  }
  return earliest;
}

double FlightBound::box_plane_time(const Vec3& n, double offset, double limit) const {
  const double translation = damped_ ? std::max(0.0, -n.dot(velocity_)) : 0.0;
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  const double rate = (damped_ ? translation : -n.dot(velocity_)) + spin_ * radius_;
  const double height = n.dot(centre_) - placed_->support_bound(-n) - offset - round_off_;
  if (!(height > 0.0)) return 0.0;
  return reach_time(height, rate, fall + spin_ * spin_ * radius_, limit);
}

// On a convex block the vertices' least gap to the plane after a time t of free flight is
// bounded by one concave function of t, with every vertex's curvature taken at the radius
// R (A = max(0, g·n_z + |ω|²·R)) and k = n × ω:
//   G(t) = n·c − offset + (n·v)·t − ½A·t² − S(−(n + t·k)),
// S(u) = max over the vertices of u·(xᵢ − c), the support (convex in u, so −S of an affine
// direction is concave in t). When damped, the approaches count only where positive:
// (n·v)·t becomes −max(0, −n·v)·t and S(−(n + t·k)) becomes max(S(−n), S(−(n + t·k))),
// still concave. G(0) > 0 and G(t) > 0 give G > 0 on [0, t] (concavity), so a time at
// which the evaluated G is positive is a proven lower bound of the first reach. It is
// found by Newton steps from above (the tangent of a concave function lies above it, so
// they never pass the root) and chords from below (a chord lies below it), to within a
// thousandth of the limit. Each evaluation is one support query, warm from the last.
double FlightBound::climb_plane_time(const Vec3& n, double offset, double limit) const {
  const Vec3 k = n.cross(spin_vector_);
  const double base = n.dot(centre_) - offset - round_off_;
  const double lift = damped_ ? -std::max(0.0, -n.dot(velocity_)) : n.dot(velocity_);
  const double fall = gravity_ * (damped_ ? std::max(0.0, n.z()) : n.z());
  const double a = std::max(0.0, fall + spin_ * spin_ * radius_);
  std::int32_t from = -1;
  Vec3 lever = Vec3::Zero();  // xᵢ − c of the last support vertex
  const auto extent = [&](const Vec3& u) { return placed_->climbed_support(u, from, lever); };
  const double floor_extent = damped_ ? extent(-n) : -std::numeric_limits<double>::infinity();
  // G(t), and its slope there (the support vertex's, a supergradient).
  const auto gap = [&](double t, double& slope) {
    const double s = extent(-(n + t * k));
    const double free = base + lift * t - 0.5 * a * t * t;
    if (s >= floor_extent) {
      slope = lift - a * t + k.dot(lever);
      return free - s;
    }
    slope = lift - a * t;
    return free - floor_extent;
  };
  double slope_lo = 0.0, slope_hi = 0.0;
  double g_lo = gap(0.0, slope_lo);
  if (!(g_lo > 0.0)) return 0.0;
  double g_hi = gap(limit, slope_hi);
  if (g_hi > 0.0) return limit;
  double t_lo = 0.0, t_hi = limit;
  const double tolerance = 1e-3 * limit;
  const auto take = [&](double t) {
    double slope = 0.0;
    const double g = gap(t, slope);
    // G(t) = 0 (a Newton step onto a straight piece): the first reach is t itself.
    if (g >= 0.0) {
      t_lo = t;
      g_lo = g;
    } else {
      t_hi = t;
      g_hi = g;
      slope_hi = slope;
    }
  };
  // Below `enough_` the time need not be exact (settle_below): once a time there is shown
  // not to be clear, so is the answer.
  for (int iteration = 0; iteration < 16 && t_hi - t_lo > tolerance && t_hi > enough_; ++iteration) {
    if (slope_hi < 0.0) {
      const double t = t_hi - g_hi / slope_hi;
      if (t > t_lo && t < t_hi) take(t);
      if (t_hi - t_lo <= tolerance || t_hi <= enough_) break;
    }
    if (!(g_lo > 0.0)) break;
    const double chord = t_lo + g_lo * (t_hi - t_lo) / (g_lo - g_hi);
    take(chord > t_lo && chord < t_hi ? chord : 0.5 * (t_lo + t_hi));
  }
  return t_lo;
}

double FlightBound::quick_triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const {
  if (placed_ == nullptr) return triangle_time(normal, corners, limit);
  return box_plane_time(normal, normal.dot(corners[0]), limit);
}

double FlightBound::triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const {
  const double below = plane_time(normal, normal.dot(corners[0]), limit);
  if (below >= limit) return limit;
  Vec3 u = Vec3::Zero();
  const double apart =
      placed_ != nullptr ? separation(*placed_, corners, &u) : separation(*vertices_, centre_, corners, &u);
  if (!(apart > 0.0)) return below;
  const double from = std::min({u.dot(corners[0]), u.dot(corners[1]), u.dot(corners[2])});
  return std::max(below, plane_time(-u, -from, limit));
}

}  // namespace talus::dda::detail
