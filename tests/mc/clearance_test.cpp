// The vertical clearance of a placed block over the ground (libs/mc/src/clearance.cpp):
// closed-form cases for each kind of first contact (block vertex, terrain vertex under a
// block face, edge across edge), and random sweeps against a slow reference that clips
// every terrain triangle against every block face in plan.
#include "talus/mc/clearance.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mc_fixtures.hpp"
#include "talus/core/random.hpp"

namespace talus::mc {
namespace {

using geometry::Vec3;
using Vec2 = Eigen::Vector2d;

dda::Model model_of(const geometry::Polyhedron& p) { return dda::Model::build(dda::Settings{}, p); }

dda::Model solid(block::SolidKind kind) {
  block::SolidSpec spec;
  spec.kind = kind;
  spec.volume = 1.0;
  return model_of(block::make_solid(spec, "test"));
}

// A 2 × 2 × 2 m box whose bottom is dented upward by a square pyramid 0.5 m deep:
// concave, with convex faces. Body frame before centring: bottom rim at z = 0, dent apex
// at (0, 0, 0.5).
geometry::Polyhedron dented_box() {
  geometry::Polyhedron p;
  p.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {-1, -1, 2},
                {1, -1, 2},  {1, 1, 2},  {-1, 1, 2}, {0, 0, 0.5}};
  p.faces = {{4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7},
             {0, 3, 8},    {3, 2, 8},    {2, 1, 8},    {1, 0, 8}};
  return p;
}

// A uniform random rotation from draws k … k+2 of `rs` (Shoemake).
Eigen::Quaterniond random_rotation(const core::RandomStream& rs, std::uint64_t k) {
  const double u1 = rs.uniform(k), u2 = 2.0 * M_PI * rs.uniform(k + 1), u3 = 2.0 * M_PI * rs.uniform(k + 2);
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  return Eigen::Quaterniond(b * std::cos(u3), a * std::sin(u2), a * std::cos(u2), b * std::sin(u3)).normalized();
}

double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// Sutherland–Hodgman: the part of `subject` inside the convex counter-clockwise `clip`.
std::vector<Vec2> clip_polygon(std::vector<Vec2> subject, const std::vector<Vec2>& clip) {
  for (std::size_t k = 0; k < clip.size() && !subject.empty(); ++k) {
    const Vec2 a = clip[k], b = clip[(k + 1) % clip.size()];
    const auto inside = [&](const Vec2& p) { return cross(b - a, p - a) >= 0.0; };
    std::vector<Vec2> out;
    for (std::size_t j = 0; j < subject.size(); ++j) {
      const Vec2 p = subject[j], q = subject[(j + 1) % subject.size()];
      if (inside(p)) out.push_back(p);
      if (inside(p) != inside(q)) {
        const double t = cross(b - a, a - p) / cross(b - a, q - p);
        out.push_back(p + t * (q - p));
      }
    }
    subject = std::move(out);
  }
  return subject;
}

// The slow reference on a height field: over every (block face, terrain triangle) pair,
// the gap is linear on the overlap of their plan projections, so its minimum lies at a
// corner of the clipped polygon. Block faces must be convex.
double reference_gap(const dda::Model& m, const Vec3& position, const Eigen::Quaterniond& q,
                     const terrain::Surface& ground) {
  const geometry::Mat3 r = q.toRotationMatrix();
  double best = std::numeric_limits<double>::infinity();
  for (const dda::BlockFace& f : m.faces) {
    const Vec3 n = r * f.normal;
    if (std::abs(n.z()) < 1e-9) continue;
    std::vector<Vec2> face;
    for (const std::int32_t v : f.vertices) face.push_back((position + r * m.vertices[v]).head<2>());
    if (n.z() < 0.0) std::reverse(face.begin(), face.end());  // seen from above: counter-clockwise
    const double d = n.dot(position) + f.offset;
    for (std::size_t t = 0; t < ground.triangle_count(); ++t) {
      const auto p = ground.triangle_vertices(t);
      std::vector<Vec2> tri = {p[0].head<2>(), p[1].head<2>(), p[2].head<2>()};
      const double area = cross(tri[1] - tri[0], tri[2] - tri[0]);
      if (area < 0.0) std::swap(tri[1], tri[2]);
      for (const Vec2& c : clip_polygon(tri, face)) {
        const double w0 = cross(p[1].head<2>() - c, p[2].head<2>() - c) / area;
        const double w1 = cross(p[2].head<2>() - c, p[0].head<2>() - c) / area;
        const double zt = w0 * p[0].z() + w1 * p[1].z() + (1.0 - w0 - w1) * p[2].z();
        const double zb = (d - n.x() * c.x() - n.y() * c.y()) / n.z();
        best = std::min(best, zb - zt);
      }
    }
  }
  return best;
}

TEST(Clearance, CubeOverAFortyFiveDegreePlane) {
  // Axis-aligned unit cube over z = 20 − x: the gap of a block point is z + x − 20,
  // smallest along the uphill bottom edge (x and z both 0.5 m below the centroid's).
  const terrain::Terrain t = testing::plane_terrain(45.0);
  const terrain::Surface ground = terrain::Surface::realize(t, std::nullopt);
  const dda::Model cube = solid(block::SolidKind::cube);
  const Vec3 centroid(5.0, 5.0, 15.0 + 0.3);
  const Clearance c = vertical_clearance(cube, centroid, Eigen::Quaterniond::Identity(), ground);
  EXPECT_NEAR(c.gap, 0.3 - 1.0, 1e-12);  // round-off of sums of O(20) values
  EXPECT_NEAR(c.point.x(), 4.5, 1e-12);
  EXPECT_NEAR(c.point.z(), 14.8, 1e-12);
  // Moving the block up moves the gap by the same amount.
  const Clearance up = vertical_clearance(cube, centroid + Vec3(0, 0, 0.7), Eigen::Quaterniond::Identity(), ground);
  EXPECT_NEAR(up.gap, 0.0, 1e-12);
}

TEST(Clearance, TerrainPeakInsideAConcaveBlock) {
  // A TIN pyramid, apex (0, 0, 1), slopes 1:1, under the dented box shifted by (0.2, 0.1):
  // the apex lies under the dent's faces, 0.4 m above the rim there, and that is the
  // first contact (along the dent the gap grows by 0.5·m_b − m_t ≥ −0.1, m the plan
  // Chebyshev distances to the block's and the terrain's axes).
  geometry::TriangleMesh mesh;
  mesh.vertices = {{-2, -2, -1}, {2, -2, -1}, {2, 2, -1}, {-2, 2, -1}, {0, 0, 1}};
  mesh.triangles = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  const terrain::Surface ground = terrain::Surface::from_mesh(mesh);
  const dda::Model box = model_of(dented_box());
  const double rim = box.vertices[0].z();  // rim below the centroid (m)
  for (const double rim_z : {0.9, 0.6, 0.2}) {
    const Vec3 centroid(0.2, 0.1, rim_z - rim);
    const Clearance c = vertical_clearance(box, centroid, Eigen::Quaterniond::Identity(), ground);
    EXPECT_NEAR(c.gap, rim_z - 0.6, 1e-12) << rim_z;
    EXPECT_NEAR(c.point.x(), 0.0, 1e-12);
    EXPECT_NEAR(c.point.y(), 0.0, 1e-12);
    EXPECT_NEAR(c.point.z(), rim_z + 0.4, 1e-12);
  }
}

TEST(Clearance, BlockEdgeAcrossATerrainRidge) {
  // A roof z = 1 − |x|/2 (grid, ridge on the line x = 0) under a unit cube turned 45°
  // about x: its lowest edge runs along x, √2/2 below the centroid, and crosses the ridge
  // between two terrain vertices (y = 0.5): neither a block nor a terrain vertex touches first.
  terrain::DemGrid dem;
  dem.spec = {-3.0, -3.0, 1.0, 1.0, 7, 7};
  for (std::int32_t j = 0; j < 7; ++j)
    for (std::int32_t i = 0; i < 7; ++i) dem.z.push_back(1.0 - 0.5 * std::abs(-3.0 + i));
  const terrain::Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "test");
  const terrain::Surface ground = terrain::Surface::realize(t, std::nullopt);
  const dda::Model cube = solid(block::SolidKind::cube);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI / 4.0, Vec3::UnitX()));
  const Vec3 centroid(0.0, 0.5, 1.5);
  const Clearance c = vertical_clearance(cube, centroid, q, ground);
  EXPECT_NEAR(c.gap, 1.5 - std::sqrt(0.5) - 1.0, 1e-12);
  EXPECT_NEAR(c.point.x(), 0.0, 1e-12);
  EXPECT_NEAR(c.point.y(), 0.5, 1e-12);
  EXPECT_NEAR(reference_gap(cube, centroid, q, ground), c.gap, 1e-12);
}

TEST(Clearance, AgreesWithClippingOnRandomPlacements) {
  // Blocks in random orientations over a rough bench slope (grid) and over a rough TIN of
  // the same slope: the clearance equals the slow reference to round-off of O(30) values.
  terrain::Terrain bench = testing::bench_terrain(0.3);
  const terrain::Surface grid = terrain::Surface::realize(bench, 5);
  const terrain::Surface tin = terrain::Surface::from_mesh(grid.to_mesh());
  const std::vector<dda::Model> blocks = {solid(block::SolidKind::cube), solid(block::SolidKind::tetrahedron),
                                          solid(block::SolidKind::octahedron), model_of(dented_box())};
  const core::RandomStream rs(3, core::Stream::release, 0);
  int below = 0;
  for (std::uint64_t k = 0; k < 120; ++k) {
    const dda::Model& m = blocks[k % blocks.size()];
    const Eigen::Quaterniond q = random_rotation(rs, 8 * k);
    const double x = 2.0 + 54.0 * rs.uniform(8 * k + 3), y = 3.0 + 14.0 * rs.uniform(8 * k + 4);
    const Vec3 centroid(x, y, grid.height_at(x, y)->z + 3.0 * rs.uniform(8 * k + 5) - 0.3);
    for (const terrain::Surface* s : {&grid, &tin}) {
      const Clearance c = vertical_clearance(m, centroid, q, *s);
      EXPECT_NEAR(c.gap, reference_gap(m, centroid, q, *s), 1e-9) << k;
      below += c.gap < 0.0 ? 1 : 0;
    }
  }
  EXPECT_GT(below, 40);  // both cases are exercised
  EXPECT_LT(below, 200);
}

TEST(Clearance, PrunedAsTheExhaustiveSearch) {
  // The bound by the ground's mean slope passes over candidates that cannot be the
  // smallest gap or the first to reach it: the gap and the point are those of the search
  // that tests every candidate, to the bit, for blocks of 4 to 5 120 faces in random
  // orientations, from high over the ground to deep in it, on a rough grid and TIN, also
  // in projected coordinates (the TIN moved to x ≈ 2.6e6 m, y ≈ 1.2e6 m).
  terrain::Terrain bench = testing::bench_terrain(0.3);
  const terrain::Surface grid = terrain::Surface::realize(bench, 5);
  geometry::TriangleMesh mesh = grid.to_mesh();
  const Vec3 far(2.6e6, 1.2e6, 850.0);
  for (Vec3& v : mesh.vertices) v += far;
  const terrain::Surface tin = terrain::Surface::from_mesh(grid.to_mesh());
  const terrain::Surface far_tin = terrain::Surface::from_mesh(mesh);
  block::SolidSpec detailed;
  detailed.kind = block::SolidKind::ellipsoid;
  detailed.volume = 1.0;
  detailed.dimensions = Vec3(1.4, 1.2, 1.1);
  detailed.resolution = 16;
  const std::vector<dda::Model> blocks = {solid(block::SolidKind::cube), solid(block::SolidKind::tetrahedron),
                                          model_of(dented_box()), model_of(block::make_solid(detailed, "e5120"))};
  ASSERT_EQ(blocks.back().faces.size(), 5120u);
  const core::RandomStream rs(5, core::Stream::release, 0);
  int below = 0, missed = 0, settled = 0;
  for (std::uint64_t k = 0; k < 160; ++k) {
    const dda::Model& m = blocks[k % blocks.size()];
    const Eigen::Quaterniond q = random_rotation(rs, 8 * k);
    const double x = 2.0 + 54.0 * rs.uniform(8 * k + 3), y = 3.0 + 14.0 * rs.uniform(8 * k + 4);
    const Vec3 centroid(x, y, grid.height_at(x, y)->z + 3.0 * rs.uniform(8 * k + 5) - 0.3);
    for (const auto& [s, shift] : {std::pair{&grid, Vec3::Zero().eval()}, std::pair{&tin, Vec3::Zero().eval()},
                                   std::pair{&far_tin, far}}) {
      const Clearance fast = vertical_clearance(m, centroid + shift, q, *s);
      const Clearance every = vertical_clearance(m, centroid + shift, q, *s, false);
      EXPECT_EQ(fast.gap, every.gap) << k;
      EXPECT_EQ(fast.point, every.point) << k;
      // The bound that settles releases clear of the ground lies below the clearance,
      // within the block's diameter and the relief under it (3 m here at most).
      const double bound = clearance_lower_bound(m, centroid + shift, *s);
      EXPECT_LE(bound, fast.gap) << k;
      EXPECT_GT(bound, fast.gap - 2.0 * m.radius - 3.0) << k;
      settled += bound >= 0.0 ? 1 : 0;
      below += fast.gap < 0.0 ? 1 : 0;
      missed += std::isfinite(fast.gap) ? 0 : 1;
    }
  }
  EXPECT_GT(below, 60);  // in the ground and over it
  EXPECT_LT(below, 420);
  EXPECT_EQ(missed, 0);  // every placement is over the terrain
  EXPECT_GT(settled, 20);  // the bound settles the placements high over the ground
}

TEST(Clearance, LowerBoundOfABlockBesideTheTerrainIsInfinite) {
  const terrain::Terrain t = testing::plane_terrain(45.0);
  const terrain::Surface ground = terrain::Surface::realize(t, std::nullopt);
  const dda::Model cube = solid(block::SolidKind::cube);
  const Vec3 beside(ground.bounds().hi.x() + 5.0, 5.0, 3.0);
  EXPECT_TRUE(std::isinf(clearance_lower_bound(cube, beside, ground)));
  EXPECT_TRUE(std::isinf(vertical_clearance(cube, beside, Eigen::Quaterniond::Identity(), ground).gap));
}

// Generalized winding number of the closed block surface around p: 1 inside, 0 outside
// (faces fan-triangulated; Van Oosterom–Strackee solid angles).
double winding(const dda::Model& m, const Vec3& position, const Eigen::Quaterniond& q, const Vec3& p) {
  const geometry::Mat3 r = q.toRotationMatrix();
  double total = 0.0;
  for (const dda::BlockFace& f : m.faces)
    for (std::size_t k = 1; k + 1 < f.vertices.size(); ++k) {
      const Vec3 a = position + r * m.vertices[f.vertices[0]] - p;
      const Vec3 b = position + r * m.vertices[f.vertices[k]] - p;
      const Vec3 c = position + r * m.vertices[f.vertices[k + 1]] - p;
      const double la = a.norm(), lb = b.norm(), lc = c.norm();
      total += 2.0 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
    }
  return total / (4.0 * M_PI);
}

TEST(Clearance, LoweredByItsGapABlockTouchesWithoutEnteringTheGround) {
  // Lowered by its clearance, a block has no vertex below the ground and no terrain
  // vertex inside it (tested 1e-9 m below each, as touching vertices lie on its surface),
  // and lowered 1 mm more it enters the ground.
  terrain::Terrain bench = testing::bench_terrain(0.3);
  const terrain::Surface ground = terrain::Surface::realize(bench, 2);
  const std::vector<dda::Model> blocks = {solid(block::SolidKind::cube), model_of(dented_box())};
  const core::RandomStream rs(4, core::Stream::release, 0);
  for (std::uint64_t k = 0; k < 40; ++k) {
    const dda::Model& m = blocks[k % 2];
    const Eigen::Quaterniond q = random_rotation(rs, 8 * k);
    const double x = 2.0 + 54.0 * rs.uniform(8 * k + 3), y = 3.0 + 14.0 * rs.uniform(8 * k + 4);
    Vec3 centroid(x, y, ground.height_at(x, y)->z + 0.5);
    centroid.z() -= vertical_clearance(m, centroid, q, ground).gap;
    EXPECT_NEAR(vertical_clearance(m, centroid, q, ground).gap, 0.0, 1e-12) << k;
    const geometry::Mat3 r = q.toRotationMatrix();
    for (const Vec3& v : m.vertices) {
      const Vec3 p = centroid + r * v;
      EXPECT_GE(p.z() - ground.height_at(p.x(), p.y())->z, -1e-12) << k;
    }
    std::vector<std::int32_t> near;
    ground.triangles_in_box(geometry::Aabb{centroid - Vec3::Constant(3.0), centroid + Vec3::Constant(3.0)}, near);
    for (const std::int32_t t : near)
      for (const Vec3& p : ground.triangle_vertices(static_cast<std::size_t>(t)))
        EXPECT_LT(winding(m, centroid, q, p - Vec3(0, 0, 1e-9)), 0.5) << k;
    const Vec3 lower = centroid - Vec3(0, 0, 1e-3);
    EXPECT_NEAR(vertical_clearance(m, lower, q, ground).gap, -1e-3, 1e-12) << k;
  }
}

}  // namespace
}  // namespace talus::mc
