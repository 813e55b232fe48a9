// SPDX-License-Identifier: MIT
// The narrow phase of the contact search (narrow_phase.hpp).
#include "narrow_phase.hpp"

#include <limits>

#include "broad_phase.hpp"

namespace talus::dda::detail {

double depth_inside(const Model& model, const Vec3& qb, std::size_t& face) {
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t f = 0; f < model.faces.size(); ++f) {
    const double d = model.faces[f].offset - model.faces[f].normal.dot(qb);
    if (d < least) {
      least = d;
      face = f;
    }
  }
  return least;
}

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
    // A terrain vertex that is no spike but lies deeper inside a convex block than the
    // search distance has slipped past the other contacts: held by the face it is least
    // deep under, offset by that depth.
    if (!model.convex) return;
    if (faces != nullptr) {
      // The face it is least deep under has its polygon within that depth of it, so
      // is among the faces found: none of them in range, none at all.
      double near_least = -std::numeric_limits<double>::infinity();
      for (const std::int32_t fi : *faces) near_least = std::max(near_least, gap_to(static_cast<std::size_t>(fi)));
      if (!(near_least < -ds + face_tol && near_least > -depth - face_tol)) return;
    }
    std::size_t least = 0;
    const double deep = depth_inside(model, qb, least);
    if (!(deep > ds && deep < depth)) return;
    best = static_cast<int>(least);
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

namespace {
constexpr double kDeepCrest = 0.05;
}  // namespace

void deep_ridge_contacts(const PlacedBlock& at, const TerrainPatch& patch, const std::vector<std::int32_t>& ridges,
                         double ds, double depth, std::size_t first, std::vector<Contact>& out) {
  const Model& model = at.model();
  if (!model.convex) return;
  const Pose& pose = at.pose();
  const geometry::Aabb box = at.box();
  const std::size_t found = out.size();
  // A crest its crossings hold lies barely deeper elsewhere inside the block than where
  // they hold it; a twentieth of ds deeper, it has slipped past them (docs/dda.md,
  // Detection: at a fiftieth, crests held as they should be got a second contact).
  const double beyond = kDeepCrest * ds;
  const double reach2 = (1.25 * model.radius) * (1.25 * model.radius);
  for (const std::int32_t r : ridges) {
    const TerrainPatch::Ridge& te = patch.ridges[static_cast<std::size_t>(r)];
    if (!te.convex || !overlaps(te.box, box)) continue;
    // The circumscribed sphere first (S(u) ≤ radius), with room for a 12-DOF block's strains.
    const Vec3 along = te.pb - te.pa;
    const double t_near = std::clamp((pose.centre - te.pa).dot(along) / along.squaredNorm(), 0.0, 1.0);
    const Vec3 towards = te.pa + t_near * along - pose.centre;
    const double distance2 = towards.squaredNorm();
    if (distance2 >= reach2) continue;
    // A point x inside the block at depth d has u·(x − c) + d ≤ S(u) for every unit u, and
    // u·(x − c) is least over the crest at an end: no point deeper than S(u) less that.
    // Tight for u into the ground across the crest (a block resting on it) or under one of
    // its triangles (a block beside it), or towards its point nearest the centre.
    const auto deepest_along = [&](const Vec3& u) {
      return at.support(u) - std::min(u.dot(te.pa - pose.centre), u.dot(te.pb - pose.centre));
    };
    double bound = te.out != Vec3::Zero() ? deepest_along(-te.out) : std::numeric_limits<double>::infinity();
    if (bound <= beyond) continue;
    bound = std::min({bound, deepest_along(-te.normals[0]), deepest_along(-te.normals[1])});
    if (bound <= beyond) continue;
    const double distance = std::sqrt(distance2);
    if (distance > 0.0) bound = std::min(bound, at.support(towards / distance) - distance);
    if (bound <= beyond) continue;
    // How deep the crossings found on this crest hold it.
    double held = 0.0;
    for (std::size_t k = first; k < found; ++k)
      if ((out[k].kind == ContactKind::edge_edge || out[k].kind == ContactKind::vertex_ridge) &&
          out[k].terrain_feature == te.key())
        held = std::max(held, -out[k].gap);
    const double floor = held + beyond;
    if (bound <= floor) continue;
    // The depth D(t) = min over faces of (offset − m·x(t)) along the crest is concave: its
    // part deeper than the floor under every face plane, [t0, t1], by clipping, then its
    // maximum there by golden-section search.
    const Vec3 a = pose.inverse_map * (te.pa - pose.centre);
    const Vec3 ab = pose.inverse_map * (te.pb - pose.centre) - a;
    double t0 = 0.0, t1 = 1.0;
    bool inside = true;
    for (const BlockFace& f : model.faces) {
      const double d0 = f.normal.dot(a) - f.offset + floor, d1 = f.normal.dot(a + ab) - f.offset + floor;
      if (d0 >= 0.0 && d1 >= 0.0) {
        inside = false;
        break;
      }
      if (d0 > 0.0) t0 = std::max(t0, d0 / (d0 - d1));
      if (d1 > 0.0) t1 = std::min(t1, d0 / (d0 - d1));
      if (t0 >= t1) {
        inside = false;
        break;
      }
    }
    if (!inside) continue;
    std::size_t face = 0;
    const auto depth_at = [&](double t) { return depth_inside(model, a + t * ab, face); };
    constexpr double kGolden = 0.6180339887498949;
    double lo = t0, hi = t1;
    double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
    double d1 = depth_at(x1), d2 = depth_at(x2);
    for (int iteration = 0; iteration < 60; ++iteration) {
      if (d1 < d2) {
        lo = x1;
        x1 = x2;
        d1 = d2;
        x2 = lo + kGolden * (hi - lo);
        d2 = depth_at(x2);
      } else {
        hi = x2;
        x2 = x1;
        d2 = d1;
        x1 = hi - kGolden * (hi - lo);
        d1 = depth_at(x1);
      }
    }
    const double t = 0.5 * (lo + hi);
    const double deepest = depth_at(t);
    if (!(deepest > floor && deepest < depth)) continue;
    const Vec3 xb = a + t * ab;
    // The deepest point is where two faces are equally deep (the crest passes under the
    // edge between them) unless it is an end of the crest: there the depth is the blend of
    // theirs whose gradient is across the crest, the two faces weighted by how steeply the
    // crest rises under the other. Either face alone flips from step to step, one of them
    // pushing the block down onto the crest, and the block sinks.
    const double tie = deepest + 1e-9 * std::sqrt(ab.squaredNorm() + model.radius * model.radius);
    int rising = -1, falling = -1;  // the tied faces whose depth grows fastest along +t, along −t
    double rise = 0.0, fall = 0.0;
    for (std::size_t k = 0; k < model.faces.size(); ++k) {
      const BlockFace& fk = model.faces[k];
      if (fk.offset - fk.normal.dot(xb) > tie) continue;
      const double slope = -fk.normal.dot(ab);
      if (slope > rise) rise = slope, rising = static_cast<int>(k);
      if (slope < fall) fall = slope, falling = static_cast<int>(k);
    }
    Vec3 push = model.faces[face].normal;  // outward, body frame
    double held_depth = deepest;
    if (rising >= 0 && falling >= 0) {
      const Vec3 blend = (-fall * model.faces[static_cast<std::size_t>(rising)].normal +
                          rise * model.faces[static_cast<std::size_t>(falling)].normal) /
                         (rise - fall);
      const double length = blend.norm();
      if (length > 1e-6) {
        push = blend / length;
        held_depth = deepest / length;
      }
    }
    Contact& c = out.emplace_back();
    c.kind = ContactKind::ridge_face;
    // No block feature: the contact follows its crest from face to face as the deepest
    // point moves (carry_contacts matches it by the crest).
    c.block_feature = -1;
    c.terrain_feature = te.key();
    c.triangle = te.triangle;
    c.point = world_point(pose, xb + held_depth * push);
    c.normal = -(pose.rotation * push).normalized();
    c.gap = (c.point - world_point(pose, xb)).dot(c.normal);
  }
}

namespace {

// The search of a detailed block over its pairs (detect_indexed), in three parts; each
// world vertex is computed once per search (the same bits as PlacedBlock::vertex).
class IndexedSearch {
 public:
  IndexedSearch(const PlacedBlock& at, const TerrainPatch& patch, double ds, double depth,
                const TerrainPatch::Candidates& c, const Live& live, std::vector<Contact>& out, MotionFilter* pass)
      : at_(at), model_(at.model()), pose_(at.pose()), patch_(patch), c_(c), live_(live), out_(out), pass_(pass),
        ds_(ds), depth_(depth), margin_(std::max(ds, depth)) {
    double top = -std::numeric_limits<double>::infinity();
    for (const std::size_t j : live.triangles)
      top = std::max(top, patch.triangles[static_cast<std::size_t>(c.triangles[j])].box.hi.z());
    ceiling_ = top + margin_;
    if (world_.size() < model_.vertices.size()) world_.resize(model_.vertices.size());
    placed_.start(model_.vertices.size());
  }
  void vertex_triangle();
  void terrain_vertex_face(double vertex_ds);
  void edge_ridge();

 private:
  const Vec3& world_vertex(std::int32_t v) {
    const std::size_t i = static_cast<std::size_t>(v);
    if (placed_.mark(v)) world_[i] = at_.vertex(i);
    return world_[i];
  }
  const PlacedBlock& at_;
  const Model& model_;
  const Pose& pose_;
  const TerrainPatch& patch_;
  const TerrainPatch::Candidates& c_;
  const Live& live_;
  std::vector<Contact>& out_;
  MotionFilter* pass_;
  const double ds_, depth_, margin_;
  double ceiling_ = 0.0;
  inline static thread_local std::vector<Vec3> world_;
  inline static thread_local RoundMarks placed_;
  inline static thread_local std::vector<double> body_gaps_;
};

// Block vertex – terrain triangle: a vertex over two coplanar triangles is one contact
// (chains in latest/earlier); a body-frame gap outside (−depth, ds) beyond round-off is
// passed over first.
void IndexedSearch::vertex_triangle() {
  // Whether any vertex is that low (the lowest vertex is the box's floor).
  const bool any_low = at_.box().lo.z() <= ceiling_;
  const std::size_t first = out_.size();
  thread_local std::vector<std::int32_t> latest, earlier;
  if (latest.size() < model_.vertices.size()) latest.resize(model_.vertices.size(), -1);
  earlier.clear();
  for (std::size_t l = 0; l < live_.triangles.size() && any_low; ++l) {
    const std::size_t j = live_.triangles[l];
    const TerrainPatch::Triangle& tri = patch_.triangles[static_cast<std::size_t>(c_.triangles[j])];
    const std::vector<std::int32_t>& vertices = c_.triangle_pairs[j].features;
    if (vertices.empty()) continue;
    const geometry::Aabb tbox = tri.box.inflated(margin_);
    const BodyPlane slab(pose_, tri.normal, tri.p[0], at_.round_off() + kRound * magnitude(tbox));
    // Each vertex's gap over the body frame, s0 + m·r, in one pass over the coordinates.
    const std::size_t n = vertices.size();
    const double* x = c_.triangle_pairs[j].coordinates.data();
    body_gaps_.resize(n);
    for (std::size_t k = 0; k < n; ++k) body_gaps_[k] = slab.s0 + coordinate_dot(slab.m, x, n, k);
    for (std::size_t k = 0; k < n; ++k) {
      const double body_gap = body_gaps_[k];
      if (body_gap - slab.tol >= ds_ || body_gap + slab.tol <= -depth_) continue;
      const std::int32_t vi = vertices[k];
      if (pass_ != nullptr) {
        // A candidate the motion filter passes over: its gap's lower bound beyond what
        // it can move, by more than that figure's round-off.
        const double low = body_gap - slab.tol;
        if (low > pass_->scale * pass_->fall) {
          const Vec3 r(x[k], x[n + k], x[2 * n + k]);
          if (low > pass_->reach((pass_->velocity + pass_->spin.cross(r)).norm()) &&
              !std::binary_search(pass_->keep->begin(), pass_->keep->end(), vi)) {
            pass_->take(low);
            continue;
          }
        }
      }
      const std::size_t i = static_cast<std::size_t>(vi);
      const Vec3& p = world_vertex(vi);
      if (p.z() > ceiling_ || !contains(tbox, p)) continue;
      double gap = 0.0;
      if (!vertex_meets_triangle(tri, p, ds_, depth_, gap)) continue;
      bool duplicate = false;
      for (std::int32_t e = latest[i]; e >= 0 && !duplicate; e = earlier[static_cast<std::size_t>(e)])
        duplicate = out_[first + static_cast<std::size_t>(e)].normal.dot(tri.normal) > 1.0 - 1e-9;
      if (duplicate) continue;
      earlier.push_back(latest[i]);
      latest[i] = static_cast<std::int32_t>(out_.size() - first);
      add_vertex_contact(tri, vi, p, gap, out_);
    }
  }
  for (std::size_t k = first; k < out_.size(); ++k) latest[static_cast<std::size_t>(out_[k].block_feature)] = -1;
}

// Terrain vertex – block face, against the faces whose polygon is near it, within the
// terrain vertices' own search distance.
void IndexedSearch::terrain_vertex_face(double vertex_ds) {
  const double vertex_margin = std::max(vertex_ds, depth_);
  const geometry::Aabb vertex_reach = at_.box().inflated(vertex_margin);
  const double face_tol = kSlack * vertex_margin + 1e-6 * model_.radius;
  thread_local std::vector<std::int32_t> faces;
  // How much more than a terrain vertex's own point its contact's point may move, per
  // metre of gap, times the motion filter's scale: scale·|ω|·h.
  const double turn = pass_ != nullptr ? pass_->scale * pass_->spin.norm() * pass_->h : 0.0;
  for (const TerrainPatch::Vertex& tv : patch_.vertices) {
    if (!contains(vertex_reach, tv.p)) continue;
    const Vec3 qb = pose_.inverse_map * (tv.p - pose_.centre);
    if (pass_ != nullptr && turn < 0.5 &&
        !std::binary_search(pass_->keep_terrain->begin(), pass_->keep_terrain->end(), tv.id)) {
      // Its contact's gap is at least its distance to the hull, |d| − S(d/|d|), and its
      // foot moves at most |v + ω × d|·h + |ω|·h·gap + ½g·h²: the motion filter's test on
      // that bound.
      const Vec3 d = tv.p - pose_.centre;
      const double length = d.norm();
      if (length > 0.0) {
        const double low = length - at_.support(d / length) - 4.0 * at_.round_off() - 1e-12 * length;
        if (low > pass_->scale * pass_->fall) {
          if (low * (1.0 - turn) * (1.0 - 1e-9) > pass_->reach((pass_->velocity + pass_->spin.cross(qb)).norm())) {
            pass_->take(low);
            continue;
          }
        }
      }
    }
    faces.clear();
    const geometry::Aabb near_qb{qb - Vec3::Constant(vertex_margin + face_tol),
                                 qb + Vec3::Constant(vertex_margin + face_tol)};
    at_.index()->faces.query([&](const geometry::Aabb& b) { return overlaps(b, near_qb); }, faces);
    std::sort(faces.begin(), faces.end());
    terrain_vertex_contact(at_, patch_, tv, qb, &faces, vertex_ds, depth_, face_tol, out_);
  }
}

// Block edge – terrain ridge crossings, put in the scan's order (edge, then ridge); an edge
// with both ends more than ds above the ridge along `out` is passed over
// (ridge_level_limit).
void IndexedSearch::edge_ridge() {
  const std::size_t first_crossing = out_.size();
  thread_local std::vector<std::pair<std::int32_t, std::int32_t>> order;  // (edge, ridge) of each crossing
  order.clear();
  for (const std::size_t j : live_.ridges) {
    const std::int32_t r = c_.ridges[j];
    const TerrainPatch::Ridge& te = patch_.ridges[static_cast<std::size_t>(r)];
    const std::vector<std::int32_t>& edges = c_.ridge_pairs[j].features;
    if (edges.empty()) continue;
    const BodyPlane level(pose_, te.out, te.pa, 0.0);
    const double limit = ridge_level_limit(te, at_, ds_, margin_, 1);
    // Each edge's lower end's value along `out`, in one pass over the coordinates (ends
    // a, then ends b).
    const std::size_t n = edges.size();
    const double* x = c_.ridge_pairs[j].coordinates.data();
    body_gaps_.resize(n);
    for (std::size_t k = 0; k < n; ++k)
      body_gaps_[k] = std::min(coordinate_dot(level.m, x, n, k), coordinate_dot(level.m, x + 3 * n, n, k)) + level.s0;
    for (std::size_t k = 0; k < n; ++k) {
      if (body_gaps_[k] >= limit) continue;
      const std::int32_t be = edges[k];
      if (pass_ != nullptr) {
        // A crossing the motion filter passes over: the level less its round-off (that of
        // the limit over ds) bounds the crossing's gap below when positive.
        const double low = body_gaps_[k] - (limit - ds_);
        if (low > pass_->scale * pass_->fall) {
          const Vec3 ra(x[k], x[n + k], x[2 * n + k]), rb(x[3 * n + k], x[4 * n + k], x[5 * n + k]);
          const double speed = std::max((pass_->velocity + pass_->spin.cross(ra)).norm(),
                                        (pass_->velocity + pass_->spin.cross(rb)).norm());
          if (low > pass_->reach(speed) &&
              !std::binary_search(pass_->keep_edges->begin(), pass_->keep_edges->end(), be)) {
            pass_->take(low);
            continue;
          }
        }
      }
      const BlockEdge& bedge = model_.edges[static_cast<std::size_t>(be)];
      const Vec3& p0 = world_vertex(bedge.a);
      const Vec3& p1 = world_vertex(bedge.b);
      if (std::min(p0.z(), p1.z()) > ceiling_ || !overlaps(te.box, edge_box(p0, p1, margin_))) continue;
      const std::size_t before = out_.size();
      edge_meets_ridge(pose_, be, p0, p1, patch_, te, ds_, depth_, out_);
      if (out_.size() > before) order.emplace_back(be, r);
    }
  }
  // Few crossings: an insertion sort.
  for (std::size_t i = 1; i < order.size(); ++i)
    for (std::size_t k = i; k > 0 && order[k] < order[k - 1]; --k) {
      std::swap(order[k], order[k - 1]);
      std::swap(out_[first_crossing + k], out_[first_crossing + k - 1]);
    }
}

}  // namespace

void detect_indexed(const PlacedBlock& at, const TerrainPatch& patch, double ds, double vertex_ds, double depth,
                    const TerrainPatch::Candidates& c, const Live& live, std::vector<Contact>& out,
                    MotionFilter* pass) {
  IndexedSearch search(at, patch, ds, depth, c, live, out, pass);
  search.vertex_triangle();
  search.terrain_vertex_face(vertex_ds);
  search.edge_ridge();
}

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

}  // namespace talus::dda::detail
