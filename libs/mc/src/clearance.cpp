#include "talus/mc/clearance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "talus/mc/scene.hpp"

namespace talus::mc {
namespace {

using geometry::Aabb;
using geometry::Vec3;
using Vec2 = Eigen::Vector2d;

double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// A non-vertical block face seen from above: its plan polygon and the height of its plane.
struct PlanFace {
  std::vector<Vec2> polygon;
  Vec2 lo, hi;          // plan bounding box (m)
  Vec3 normal;          // world unit normal
  double offset = 0.0;  // normal · x on the plane (m)
  double z_lo = 0.0, z_hi = 0.0;
  bool covers(const Vec2& p) const {
    return p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y() && point_in_polygon(polygon, p);
  }
  // The plane's height over p, kept within the face's own height range (a steep face
  // divides by a small normal z).
  double z_at(const Vec2& p) const {
    return std::clamp((offset - normal.x() * p.x() - normal.y() * p.y()) / normal.z(), z_lo, z_hi);
  }
};

struct TerrainVertex {
  std::int32_t id;
  Vec3 p;
};
struct TerrainEdge {
  std::int32_t a, b;  // a < b
  Vec3 pa, pb;
};

}  // namespace

Clearance vertical_clearance(const dda::Model& model, const Vec3& position, const Eigen::Quaterniond& orientation,
                             const terrain::Surface& ground, bool prune) {
  const geometry::Mat3 rotation = orientation.normalized().toRotationMatrix();
  std::vector<Vec3> world;
  world.reserve(model.vertices.size());
  Aabb box;
  for (const Vec3& v : model.vertices) {
    world.push_back(position + rotation * v);
    box.add(world.back());
  }

  Clearance best;
  const auto consider = [&best](double gap, const Vec3& point) {
    if (gap < best.gap) {
      best.gap = gap;
      best.point = point;
    }
  };
  // On a height field the terrain feature's own height is the ground there; a TIN may
  // have an overhang above it, and the ground is everything below the highest surface.
  const bool tin = !ground.is_height_field();
  const auto ground_z = [&](double x, double y, double feature_z) {
    if (!tin) return feature_z;
    const auto hit = ground.height_at(x, y);
    return hit ? std::max(feature_z, hit->z) : feature_z;
  };

  // The terrain vertices and edges under the block's plan box (every triangle a vertical
  // through the box can hit is among those found).
  const Aabb& bounds = ground.bounds();
  const Aabb query{Vec3(box.lo.x(), box.lo.y(), bounds.lo.z()), Vec3(box.hi.x(), box.hi.y(), bounds.hi.z())};
  std::vector<std::int32_t> triangles;
  ground.triangles_in_box(query, triangles);
  std::vector<TerrainVertex> vertices;
  std::vector<TerrainEdge> edges;
  Vec3 normal_sum = Vec3::Zero();
  for (const std::int32_t t : triangles) {
    const auto ids = ground.triangle(static_cast<std::size_t>(t));
    const auto p = ground.triangle_vertices(static_cast<std::size_t>(t));
    normal_sum += (p[1] - p[0]).cross(p[2] - p[0]);
    for (int k = 0; k < 3; ++k) {
      vertices.push_back({ids[k], p[k]});
      const int m = (k + 1) % 3;
      if (ids[k] < ids[m])
        edges.push_back({ids[k], ids[m], p[k], p[m]});
      else
        edges.push_back({ids[m], ids[k], p[m], p[k]});
    }
  }
  std::sort(vertices.begin(), vertices.end(), [](const auto& x, const auto& y) { return x.id < y.id; });
  vertices.erase(std::unique(vertices.begin(), vertices.end(), [](const auto& x, const auto& y) { return x.id == y.id; }),
                 vertices.end());
  std::sort(edges.begin(), edges.end(), [](const auto& x, const auto& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; });
  edges.erase(std::unique(edges.begin(), edges.end(), [](const auto& x, const auto& y) { return x.a == y.a && x.b == y.b; }),
              edges.end());

  // Pruning, which never changes the result. Every ground height the tests below read
  // lies on a triangle found, so under the plane z = a·x + b·y + top, a slope (a, b)
  // from the triangles' mean normal and `top` the largest z − a·x − b·y of their
  // vertices. A block point p then has a gap of at least its height over the slope,
  // p_z − a·p_x − b·p_y, less `top`, and a candidate whose bound (less an allowance for
  // round-off) exceeds the gap of the vertex lowest over the slope (`upper`, one of the
  // candidates, so no less than the smallest gap), or is no less than the smallest gap
  // found so far, can be neither the smallest gap nor the first to reach it.
  double slope_x = 0.0, slope_y = 0.0, top = -std::numeric_limits<double>::infinity();
  if (normal_sum.z() > 1e-3 * normal_sum.norm()) {
    slope_x = -normal_sum.x() / normal_sum.z();
    slope_y = -normal_sum.y() / normal_sum.z();
  }
  const auto over_slope = [&](const Vec3& p) { return p.z() - slope_x * p.x() - slope_y * p.y(); };
  double magnitude = std::max(box.lo.cwiseAbs().maxCoeff(), box.hi.cwiseAbs().maxCoeff());
  for (const TerrainVertex& q : vertices) {
    top = std::max(top, over_slope(q.p));
    magnitude = std::max(magnitude, q.p.cwiseAbs().maxCoeff());
  }
  prune = prune && !vertices.empty();
  const double allowance = 1e-9 * (1.0 + magnitude * (1.0 + std::abs(slope_x) + std::abs(slope_y)));
  std::vector<double> height(world.size());
  std::size_t lowest = 0;
  for (std::size_t i = 0; i < world.size(); ++i) {
    height[i] = over_slope(world[i]);
    if (height[i] < height[lowest]) lowest = i;
  }
  double upper = std::numeric_limits<double>::infinity();
  if (prune && !world.empty())
    if (const auto hit = ground.height_at(world[lowest].x(), world[lowest].y())) upper = world[lowest].z() - hit->z;
  const auto beaten = [&](double bound) {
    if (!prune) return false;
    const double gap_bound = bound - top - allowance;
    return gap_bound > upper || gap_bound >= best.gap;
  };

  // Block vertices over terrain triangles.
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Vec3& p = world[i];
    if (beaten(height[i])) continue;
    if (const auto hit = ground.height_at(p.x(), p.y())) consider(p.z() - hit->z, p);
  }

  // Terrain vertices under block faces. Vertical faces are left to their edges. A face's
  // points lie no lower than its lowest vertex, and over its plan box no higher along
  // the slope than that box's highest corner.
  std::vector<PlanFace> faces;
  std::vector<double> face_bound;
  for (const dda::BlockFace& f : model.faces) {
    PlanFace pf;
    pf.normal = rotation * f.normal;
    if (!(std::abs(pf.normal.z()) > 1e-12)) continue;
    pf.offset = pf.normal.dot(position) + f.offset;
    pf.lo = pf.hi = world[static_cast<std::size_t>(f.vertices.front())].head<2>();
    pf.z_lo = pf.z_hi = world[static_cast<std::size_t>(f.vertices.front())].z();
    for (const std::int32_t v : f.vertices) {
      const Vec3& p = world[static_cast<std::size_t>(v)];
      pf.lo = pf.lo.cwiseMin(p.head<2>());
      pf.hi = pf.hi.cwiseMax(p.head<2>());
      pf.z_lo = std::min(pf.z_lo, p.z());
      pf.z_hi = std::max(pf.z_hi, p.z());
    }
    const double bound = pf.z_lo - std::max(slope_x * pf.lo.x(), slope_x * pf.hi.x()) -
                         std::max(slope_y * pf.lo.y(), slope_y * pf.hi.y());
    if (beaten(bound)) continue;
    for (const std::int32_t v : f.vertices) pf.polygon.push_back(world[static_cast<std::size_t>(v)].head<2>());
    faces.push_back(std::move(pf));
    face_bound.push_back(bound);
  }
  for (const TerrainVertex& q : vertices) {
    const Vec2 xy = q.p.head<2>();
    if (xy.x() < box.lo.x() || xy.x() > box.hi.x() || xy.y() < box.lo.y() || xy.y() > box.hi.y()) continue;
    double zg = 0.0;
    bool known = false;
    for (std::size_t k = 0; k < faces.size(); ++k) {
      const PlanFace& f = faces[k];
      if (beaten(face_bound[k]) || !f.covers(xy)) continue;
      if (!known) {
        zg = ground_z(xy.x(), xy.y(), q.p.z());
        known = true;
      }
      const double zb = f.z_at(xy);
      consider(zb - zg, Vec3(xy.x(), xy.y(), zb));
    }
  }

  // Block edges crossing terrain edges in plan (parameters on both closed segments, with
  // a little slack so a crossing at an endpoint is never lost to rounding).
  constexpr double slack = 1e-12;
  for (const dda::BlockEdge& e : model.edges) {
    if (beaten(std::min(height[static_cast<std::size_t>(e.a)], height[static_cast<std::size_t>(e.b)]))) continue;
    const Vec3& a = world[static_cast<std::size_t>(e.a)];
    const Vec3& b = world[static_cast<std::size_t>(e.b)];
    const Vec2 d = (b - a).head<2>();
    if (d.squaredNorm() == 0.0) continue;  // a vertical edge: its lower vertex was tested
    const Vec2 lo = a.head<2>().cwiseMin(b.head<2>()), hi = a.head<2>().cwiseMax(b.head<2>());
    for (const TerrainEdge& t : edges) {
      const Vec2 s = t.pa.head<2>();
      const Vec2 f = (t.pb - t.pa).head<2>();
      const Vec2 tlo = s.cwiseMin(t.pb.head<2>()), thi = s.cwiseMax(t.pb.head<2>());
      if (thi.x() < lo.x() || tlo.x() > hi.x() || thi.y() < lo.y() || tlo.y() > hi.y()) continue;
      const double denom = cross(d, f);
      // Parallel in plan: the smallest gap along them lies at an endpoint, a vertex.
      if (!(std::abs(denom) > 1e-14 * std::sqrt(d.squaredNorm() * f.squaredNorm()))) continue;
      const double u = cross(s - a.head<2>(), f) / denom;
      const double v = cross(s - a.head<2>(), d) / denom;
      if (u < -slack || u > 1.0 + slack || v < -slack || v > 1.0 + slack) continue;
      const double uc = std::clamp(u, 0.0, 1.0), vc = std::clamp(v, 0.0, 1.0);
      const Vec3 p = a + uc * (b - a);
      consider(p.z() - ground_z(p.x(), p.y(), t.pa.z() + vc * (t.pb.z() - t.pa.z())), p);
    }
  }
  return best;
}

double clearance_lower_bound(const dda::Model& model, const Vec3& position, const terrain::Surface& ground) {
  const Aabb& bounds = ground.bounds();
  const double r = model.radius;
  const Aabb query{Vec3(position.x() - r, position.y() - r, bounds.lo.z()),
                   Vec3(position.x() + r, position.y() + r, bounds.hi.z())};
  thread_local std::vector<std::int32_t> triangles;
  triangles.clear();
  ground.triangles_in_box(query, triangles);
  if (triangles.empty()) return std::numeric_limits<double>::infinity();
  double top = -std::numeric_limits<double>::infinity();
  double magnitude = std::abs(position.z()) + r;
  for (const std::int32_t t : triangles)
    for (const Vec3& p : ground.triangle_vertices(static_cast<std::size_t>(t))) {
      top = std::max(top, p.z());
      magnitude = std::max(magnitude, std::abs(p.z()));
    }
  // A rotated vertex keeps its distance from the centroid to a few ulps of the radius,
  // and the exact clearance's differences are within a few ulps of the values.
  return position.z() - r - top - 1e-9 * magnitude;
}

}  // namespace talus::mc
