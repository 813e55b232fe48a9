// SPDX-License-Identifier: MIT
// The narrow phase of the contact search: the exact tests of a block feature against a
// terrain feature (vertex–triangle, terrain vertex–face, edge–ridge), the primitives they
// share, and the searches over gathered pairs that apply them (narrow_phase.cpp). Every
// test is a pure function of the geometry and the pose.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "contacts.hpp"

namespace talus::dda::detail {

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
inline bool inside_polygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& q) {
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
inline bool inside_plan(const TerrainPatch::Triangle& tri, const Vec3& p) {
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = tri.p[k];
    const Vec3& b = tri.p[(k + 1) % 3];
    if ((b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x()) < 0.0) return false;
  }
  return true;
}

// Closest points of segments p0-p1 and q0-q1: the lines' parameters s and t when both lie
// in [0, 1]; numerators are compared with the denominator first, sparing most divisions
// exactly.
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
inline double segment_distance2(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
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

// Relative round-off allowances of the index queries: the queries only select candidates
// that the exact tests below then decide, so the allowances are generous.
constexpr double kRound = 1e-12;   // of world coordinates
constexpr double kSlack = 1e-6;    // of the search margin

inline double magnitude(const geometry::Aabb& b) { return std::max(b.lo.cwiseAbs().maxCoeff(), b.hi.cwiseAbs().maxCoeff()); }

// m·r for the point k of coordinate rows `rows` of n points each (Pairs::coordinates),
// summed as Eigen sums a 3-vector's dot product (the first two products, then the third),
// so that it equals m.dot(r) to the last bit.
inline double coordinate_dot(const Vec3& m, const double* rows, std::size_t n, std::size_t k) {
  return (m.x() * rows[k] + m.y() * rows[n + k]) + m.z() * rows[2 * n + k];
}

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

// An edge with both ends at least this high along a ridge's `out` cannot cross it within ds
// (docs/dda.md, The ridge's level); round-off allowed for `poses` poses (1 a step's, 2 a
// gathering's).
inline double ridge_level_limit(const TerrainPatch::Ridge& te, const PlacedBlock& at, double ds, double margin, int poses) {
  return ds + poses * (2.0 * te.out_allowance + 4.0 * at.round_off()) + 1e-9 * margin;
}

// and the index of a detailed one.

// Block vertex p against triangle `tri`: its gap in (−depth, ds) and inside the normal
// prism, or (ground facing up) over or under it in plan, so a vertex past a concave valley
// line is held.
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

inline void add_vertex_contact(const TerrainPatch::Triangle& tri, std::int32_t vertex, const Vec3& p, double gap,
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

// How deep the body-frame point qb lies behind every face plane of a convex block, the
// least over the faces (m, < 0 outside), and in `face` the first face that deep.
double depth_inside(const Model& model, const Vec3& qb, std::size_t& face);

// Terrain vertex tv (qb, body frame) against a block face: only a spike (every terrain edge
// from it leaves outside the face plane) can touch a face; `faces` those near qb, or null
// for all.
void terrain_vertex_contact(const PlacedBlock& at, const TerrainPatch& patch, const TerrainPatch::Vertex& tv,
                            const Vec3& qb, const std::vector<std::int32_t>* faces, double ds, double depth,
                            double face_tol, std::vector<Contact>& out);

// Whether point p lies in the ground of `patch` no deeper than `depth` (m): under a
// triangle's plane, inside its normal prism or, for ground that faces up, under it in
// plan (the test of a block vertex that has penetrated, vertex_meets_triangle).
inline bool in_ground(const TerrainPatch& patch, const Vec3& p, double depth) {
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
  // A crossing below the ridge is inside the ground only under both triangles' planes on a
  // crest (either in a valley): an edge beside a crest, under one side's plane continued,
  // is not.
  if (gap < 0.0 && te.convex && !(n.dot(te.normals[0]) > 0.0 && n.dot(te.normals[1]) > 0.0)) return;
  // Near a ridge's end the crossing's foot may lie over a third triangle: a crossing below
  // the ridge is kept only where some triangle would hold a vertex there, within twice the
  // depth limit.
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

// Terrain crests of `patch` (`ridges`, those that may meet the block's box) inside a
// convex block deeper, by a twentieth of ds, than the crossings found on them
// (out[first..]) hold them (a crest that entered a face between the block's edges, where
// no crossing reaches it): each held at its deepest point by the face it is least deep
// under, as a terrain vertex deep inside is (terrain_vertex_contact).
void deep_ridge_contacts(const PlacedBlock& at, const TerrainPatch& patch, const std::vector<std::int32_t>& ridges,
                         double ds, double depth, std::size_t first, std::vector<Contact>& out);

struct Live;

/// The search of detect_contacts in `patch` for a detailed block, over the pairs of `c`
/// whose triangles and ridges `live` lists (broad_phase.hpp): every test of a search that
/// gathered at this very pose, in its order, so the same contacts in the same order, those
/// of the scan. Vertex–triangle and edge–ridge pairs within ds, terrain vertices (the
/// faces near each) within vertex_ds; `pass`, when given, passes over what it shows cannot
/// close (MotionFilter).
void detect_indexed(const PlacedBlock& at, const TerrainPatch& patch, double ds, double vertex_ds, double depth,
                    const TerrainPatch::Candidates& c, const Live& live, std::vector<Contact>& out,
                    MotionFilter* pass);

/// The search of detect_contacts in `patch` for a scanned block, over the pairs of `c`
/// (gathered at this pose or one close enough, with distances at least this search's
/// plus the block's motion since): every test in the order of a scan of all the pairs,
/// so the same contacts in the same order. `prune` off tests every pair (the reference).
void detect_scanned(const PlacedBlock& at, const TerrainPatch& patch, double ds, double depth, bool prune,
                    const TerrainPatch::Candidates& c, std::vector<Contact>& out);

}  // namespace talus::dda::detail
