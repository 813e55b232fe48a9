// SPDX-License-Identifier: MIT
// The flight test's separation bound (detail::separation) against the exact distance
// between a block's hull and a terrain triangle, and its clear time (detail::FlightBound)
// against the exact free flight.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "contacts.hpp"
#include "rotation.hpp"
#include "dda_fixtures.hpp"
#include "talus/block/solids.hpp"
#include "talus/core/random.hpp"
#include "talus/dda/model.hpp"

namespace talus::dda {
namespace {

using detail::FlightBound;
using detail::separation;

// The point of triangle abc nearest to p, by minimising over a fine barycentric grid and
// the edges: a slow reference, independent of the closed form under test.
double point_triangle_distance(const Vec3& p, const std::array<Vec3, 3>& t) {
  double best = std::numeric_limits<double>::infinity();
  constexpr int n = 200;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const double u = double(i) / n, v = double(j) / n;
      const Vec3 q = t[0] + u * (t[1] - t[0]) + v * (t[2] - t[0]);
      best = std::min(best, (p - q).norm());
    }
  return best;
}

// Distance of segments p0p1 and q0q1, sampled finely along the first and closed-form
// along the second.
double segment_distance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  double best = std::numeric_limits<double>::infinity();
  const Vec3 d = q1 - q0;
  for (int i = 0; i <= 400; ++i) {
    const Vec3 p = p0 + (double(i) / 400) * (p1 - p0);
    const double t = std::clamp((p - q0).dot(d) / d.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (p - (q0 + t * d)).norm());
  }
  return best;
}

// The distance between the hull of a cube (centre, half-size h, rotated) and a triangle:
// the least of vertex–triangle, edge–edge and triangle corner–cube distances.
struct Cube {
  Vec3 centre;
  Mat3 rotation;
  double h;
  std::vector<Vec3> vertices() const {
    std::vector<Vec3> out;
    for (int k = 0; k < 8; ++k)
      out.push_back(centre + rotation * Vec3((k & 1 ? h : -h), (k & 2 ? h : -h), (k & 4 ? h : -h)));
    return out;
  }
  double distance_to_point(const Vec3& p) const {
    const Vec3 local = rotation.transpose() * (p - centre);
    const Vec3 outside = (local.cwiseAbs() - Vec3::Constant(h)).cwiseMax(0.0);
    return outside.norm();
  }
};

// A cube at the origin, of half-size 0.3–0.7 m, turned at random: from u(0) to u(4).
template <class Uniform>
Cube random_cube(const Uniform& u) {
  Cube cube;
  cube.h = 0.3 + 0.4 * u(0);
  cube.centre = Vec3(0.0, 0.0, 0.0);
  cube.rotation = Eigen::Quaterniond(Eigen::Vector4d(u(1) - 0.5, u(2) - 0.5, u(3) - 0.5, u(4) - 0.5).normalized())
                      .toRotationMatrix();
  return cube;
}

double cube_triangle_distance(const Cube& cube, const std::array<Vec3, 3>& t) {
  const std::vector<Vec3> v = cube.vertices();
  double best = std::numeric_limits<double>::infinity();
  for (const Vec3& p : v) best = std::min(best, point_triangle_distance(p, t));
  for (const Vec3& q : t) best = std::min(best, cube.distance_to_point(q));
  for (int a = 0; a < 8; ++a)
    for (int b = a + 1; b < 8; ++b) {
      if (__builtin_popcount(static_cast<unsigned>(a ^ b)) != 1) continue;  // cube edges
      for (int k = 0; k < 3; ++k) best = std::min(best, segment_distance(v[a], v[b], t[k], t[(k + 1) % 3]));
    }
  return best;
}

// A separation the bound reports is never more than the true distance: random cubes near
// random triangles (some steep, some beside the cube), reach from 0 to 0.4 m. The bound
// is also tight enough to matter: it separates a block from a triangle whose plane,
// continued, passes through the block.
TEST(DdaFlight, SeparationBoundNeverExceedsTheDistance) {
  const core::RandomStream rng(5, core::Stream::release, 3);
  int separated_count = 0, plane_blocked = 0;
  for (std::uint64_t i = 0; i < 400; ++i) {
    const auto u = [&](std::uint64_t k) { return rng.uniform(20 * i + k); };
    const Cube cube = random_cube(u);
    const Vec3 at(3.0 * (u(5) - 0.5), 3.0 * (u(6) - 0.5), -0.5 - 1.5 * u(7));
    std::array<Vec3, 3> tri;
    for (int k = 0; k < 3; ++k)
      tri[static_cast<std::size_t>(k)] =
          at + Vec3(1.5 * (u(8 + 3 * k) - 0.5), 1.5 * (u(9 + 3 * k) - 0.5), 1.5 * (u(10 + 3 * k) - 0.5));
    const double reach = 0.4 * u(17);
    const std::vector<Vec3> block = cube.vertices();
    if (!(separation(block, cube.centre, tri) > reach)) continue;
    ++separated_count;
    const double distance = cube_triangle_distance(cube, tri);
    // The reference samples the triangle and the edges on grids of 1/200 and 1/400.
    EXPECT_GT(distance + 0.02, reach) << "case " << i;
    const Vec3 normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalized();
    const auto side = [&](const Vec3& p) { return normal.dot(p - tri[0]); };
    const auto [lo, hi] = std::minmax_element(block.begin(), block.end(),
                                              [&](const Vec3& a, const Vec3& b) { return side(a) < side(b); });
    if (side(*lo) <= reach && side(*hi) >= -reach) ++plane_blocked;
  }
  EXPECT_GT(separated_count, 100);
  EXPECT_GT(plane_blocked, 20);  // pairs the plane alone would not separate
}

// A triangle the block touches is not separated from it; one below it by its gap.
TEST(DdaFlight, TouchingTriangleIsNeverSeparated) {
  const std::vector<Vec3> block = {Vec3(-1, -1, -1), Vec3(1, -1, -1), Vec3(-1, 1, -1), Vec3(1, 1, -1),
                                   Vec3(-1, -1, 1),  Vec3(1, -1, 1),  Vec3(-1, 1, 1),  Vec3(1, 1, 1)};
  const std::array<Vec3, 3> tri = {Vec3(-3, -3, -1), Vec3(3, -3, -1), Vec3(0, 3, -1)};
  EXPECT_LE(separation(block, Vec3::Zero(), tri), 0.0);
  const std::array<Vec3, 3> low = {Vec3(-3, -3, -1.5), Vec3(3, -3, -1.5), Vec3(0, 3, -1.5)};
  EXPECT_NEAR(separation(block, Vec3::Zero(), low), 0.5, 1e-12);
}

// Free flight of `block` from (centre, v, ω), stepped as the engine steps a flight (the
// exact parabola and spin per step of `dt`, then the velocity and spin scaled by
// `damping`), for up to 1 s against the plane {n·x = offset}: the lowest signed height a
// vertex has at the step ends up to `until`, and the first step end at which one is on
// or under the plane (infinity if none).
struct Flown {
  double lowest = std::numeric_limits<double>::infinity();
  double touch = std::numeric_limits<double>::infinity();
};
Flown fly(std::vector<Vec3> block, Vec3 centre, Vec3 v, Vec3 w, double damping, const Vec3& n, double offset,
          double until, double dt) {
  const Vec3 g(0.0, 0.0, -9.81);
  Flown out;
  for (int k = 0;; ++k) {
    const double time = k * dt;
    double low = std::numeric_limits<double>::infinity();
    for (const Vec3& p : block) low = std::min(low, n.dot(p) - offset);
    if (time <= until) out.lowest = std::min(out.lowest, low);
    if (low <= 0.0 && !std::isfinite(out.touch)) out.touch = time;
    if (time >= 1.0 || (time > until && std::isfinite(out.touch))) break;
    const Vec3 shift = v * dt + 0.5 * g * dt * dt;
    const double angle = w.norm() * dt;
    const Mat3 turn = angle > 0.0 ? Eigen::AngleAxisd(angle, w.normalized()).toRotationMatrix() : Mat3::Identity();
    for (Vec3& p : block) p = centre + shift + turn * (p - centre);
    centre += shift;
    v = damping * (v + g * dt);
    w *= damping;
  }
  return out;
}

// Flies `block` (damped: stepped at 1 ms with the velocity scaled by 0.9 each step;
// undamped flight is the same motion at any step: sampled at 0.1 ms) and checks that no
// vertex reaches the plane before the time `clear` a bound gave; counts the flights that
// touch within a second and those the bound clears for a third of their time or more.
struct Tightness {
  int touching = 0, tight = 0;
  void check(const std::vector<Vec3>& block, const Vec3& centre, const Vec3& v, const Vec3& w, bool damped,
             const Vec3& n, double offset, double clear, std::uint64_t i) {
    const Flown flown = fly(block, centre, v, w, damped ? 0.9 : 1.0, n, offset, clear, damped ? 1e-3 : 1e-4);
    EXPECT_GE(flown.lowest, -1e-12) << "case " << i;
    if (!std::isfinite(flown.touch)) return;
    ++touching;
    EXPECT_LE(clear, flown.touch) << "case " << i;
    if (clear >= flown.touch / 3.0) ++tight;
  }
};

// No vertex of a tumbling cube reaches a plane before the time the bound gives, whatever
// the plane's tilt (overhangs included), the speed (to 15 m/s) and the spin (to 15 rad/s),
// undamped and damped (stepped at 1 ms, velocity scaled by 0.9 each
// step); and the bound is tight enough to matter: for most cases that do reach the plane
// within a second, it gives at least a third of the time they take.
TEST(DdaFlight, ClearTimeNeverPassesTheFirstTouch) {
  const core::RandomStream rng(7, core::Stream::release, 4);
  Tightness tally;
  for (std::uint64_t i = 0; i < 400; ++i) {
    const auto u = [&](std::uint64_t k) { return rng.uniform(20 * i + k); };
    const Cube cube = random_cube(u);
    const Vec3 v = 15.0 * u(5) * Vec3(u(6) - 0.5, u(7) - 0.5, u(8) - 0.5).normalized();
    const Vec3 w = 15.0 * u(9) * Vec3(u(10) - 0.5, u(11) - 0.5, u(12) - 0.5).normalized();
    const Vec3 n = Vec3(u(13) - 0.5, u(14) - 0.5, 1.5 * u(15) - 0.5).normalized();
    const std::vector<Vec3> block = cube.vertices();
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vec3& p : block) lowest = std::min(lowest, n.dot(p));
    const double offset = lowest - 0.01 - 0.5 * u(16);  // 1 cm to 51 cm below the cube
    const bool damped = i % 4 == 3;
    FlightBound bound;
    bound.reset(block, cube.centre, v, w, 9.81, damped, 1e-9);
    const double clear = bound.plane_time(n, offset, 1.0);
    ASSERT_GT(clear, 0.0) << "case " << i;
    tally.check(block, cube.centre, v, w, damped, n, offset, clear, i);
  }
  EXPECT_GT(tally.touching, 150);
  EXPECT_GT(tally.tight, tally.touching * 3 / 5);
}

// The bound of a detailed block (FlightBound's second form) never passes the first touch
// either and is never longer than the bound of the same vertices scanned one by one: the
// same flights as above, with 1 m³ ellipsoids of 1 280 triangles. For a concave block
// (rough) it is that bound, each vertex's time by branch and bound over the vertex tree,
// to 1e-6 (its round-off allowance is wider); for a convex one (smooth) it comes from
// support queries (VertexClimb) with every vertex's curvature taken at the radius, to a
// thousandth of the limit, and still clears most touching flights for a third of their
// time or more.
struct DetailedBounds {
  Tightness tally;
  int compared = 0, close = 0;
  double least_ratio = 1.0;  ///< the least clear / scanned among the flights that touch
};

DetailedBounds detailed_bounds(const Model& m, std::uint64_t seed) {
  EXPECT_NE(m.index, nullptr);
  const core::RandomStream rng(seed, core::Stream::release, 4);
  DetailedBounds out;
  for (std::uint64_t i = 0; i < 200; ++i) {
    const auto u = [&](std::uint64_t k) { return rng.uniform(20 * i + k); };
    detail::Pose pose;
    pose.centre = Vec3(10.0 * u(0), 10.0 * u(1), 5.0 * u(2));
    pose.rotation = Eigen::Quaterniond(u(3) - 0.5, u(4) - 0.5, u(17) - 0.5, u(18) - 0.5).normalized().toRotationMatrix();
    pose.map = pose.rotation;
    pose.inverse_map = pose.rotation.transpose();
    std::vector<Vec3> storage, scanned_storage;
    const detail::PlacedBlock at(m, pose, storage);
    const detail::PlacedBlock scanned(m, pose, scanned_storage, true);
    const Vec3 v = 15.0 * u(5) * Vec3(u(6) - 0.5, u(7) - 0.5, u(8) - 0.5).normalized();
    const Vec3 w = 15.0 * u(9) * Vec3(u(10) - 0.5, u(11) - 0.5, u(12) - 0.5).normalized();
    const Vec3 n = Vec3(u(13) - 0.5, u(14) - 0.5, 1.5 * u(15) - 0.5).normalized();
    const std::vector<Vec3>& block = scanned.vertices();
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vec3& p : block) lowest = std::min(lowest, n.dot(p));
    const double offset = lowest - 0.01 - 0.5 * u(16);  // 1 cm to 51 cm below the block
    const bool damped = i % 4 == 3;
    FlightBound bound, reference;
    bound.reset(at, v, w, 9.81, damped, 1e-9);
    reference.reset(block, pose.centre, v, w, 9.81, damped, 1e-9);
    const double clear = bound.plane_time(n, offset, 1.0);
    const double clear_scanned = reference.plane_time(n, offset, 1.0);
    EXPECT_GT(clear, 0.0) << "case " << i;
    EXPECT_LE(clear, clear_scanned) << "case " << i;
    ++out.compared;
    if (clear >= clear_scanned * (1.0 - 1e-6)) ++out.close;
    if (clear_scanned < 1.0) out.least_ratio = std::min(out.least_ratio, clear / clear_scanned);
    out.tally.check(block, pose.centre, v, w, damped, n, offset, clear, i);
  }
  return out;
}

DetailedBounds detailed_bounds(double roughness, std::uint64_t seed) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 1.0;
  spec.dimensions = Vec3(1.4, 1.2, 1.1);
  spec.resolution = 8;
  spec.roughness = roughness;
  const Model m = Model::build(Settings{}, block::make_solid(spec, "test"));
  EXPECT_EQ(m.convex, roughness == 0.0);
  return detailed_bounds(m, seed);
}

// Blocks whose inertia is not isotropic precess and tumble in flight (Euler's equations,
// detail::rotate_free); the bound takes the rotation's curvature κ (rotation_curvature)
// for |ω|². No vertex of a 2 × 1 × 0.5 m slab (scanned) or of a 1.6 × 1.1 × 0.8 m
// ellipsoid of 1 280 triangles (detailed, convex: support queries) reaches a plane before
// the bound's time, flown at 0.1 ms with the engine's own rotation, spins to 15 rad/s.
TEST(DdaFlight, ClearTimeOfTumblingBlocksNeverPassesTheFirstTouch) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 0.0;
  spec.dimensions = Vec3(1.6, 1.1, 0.8);
  spec.resolution = 8;
  const Model models[] = {Model::build(Settings{}, dda::testing::box(2.0, 1.0, 0.5)),
                          Model::build(Settings{}, block::make_solid(spec, "test"))};
  const core::RandomStream rng(9, core::Stream::release, 5);
  int limited = 0;
  for (const Model& m : models) {
    ASSERT_FALSE(m.isotropic);
    for (std::uint64_t i = 0; i < 150; ++i) {
      const auto u = [&](std::uint64_t k) { return rng.uniform(20 * i + k); };
      detail::Pose pose;
      pose.centre = Vec3(10.0 * u(0), 10.0 * u(1), 5.0 * u(2));
      const Eigen::Quaterniond q0 = Eigen::Quaterniond(u(3) - 0.5, u(4) - 0.5, u(17) - 0.5, u(18) - 0.5).normalized();
      pose.rotation = q0.toRotationMatrix();
      pose.map = pose.rotation;
      pose.inverse_map = pose.rotation.transpose();
      std::vector<Vec3> storage;
      const detail::PlacedBlock at(m, pose, storage);
      std::vector<Vec3> block;
      for (const Vec3& r : m.vertices) block.push_back(pose.centre + pose.rotation * r);
      const Vec3 v = 15.0 * u(5) * Vec3(u(6) - 0.5, u(7) - 0.5, u(8) - 0.5).normalized();
      const Vec3 w = 15.0 * u(9) * Vec3(u(10) - 0.5, u(11) - 0.5, u(12) - 0.5).normalized();
      const Vec3 n = Vec3(u(13) - 0.5, u(14) - 0.5, 1.5 * u(15) - 0.5).normalized();
      double lowest = std::numeric_limits<double>::infinity();
      for (const Vec3& p : block) lowest = std::min(lowest, n.dot(p));
      const double offset = lowest - 0.01 - 0.5 * u(16);
      FlightBound bound;
      const double kappa = detail::rotation_curvature(m, pose.rotation, w);
      if (m.index != nullptr) bound.reset(at, v, w, 9.81, false, 1e-9, kappa);
      else bound.reset(block, pose.centre, v, w, 9.81, false, 1e-9, kappa);
      const double clear = bound.plane_time(n, offset, 1.0);
      ASSERT_GT(clear, 0.0) << "case " << i;
      // The engine's flight up to the bound's time: the parabola and Euler's rotation,
      // sampled at 0.1 ms; no vertex on or under the plane.
      Eigen::Quaterniond q = q0;
      Vec3 spin = w;
      const double dt = 1e-4;
      double lowest_height = std::numeric_limits<double>::infinity();
      for (int k = 0; k * dt <= clear; ++k) {
        const double t = k * dt;
        const Vec3 c = pose.centre + v * t + 0.5 * Vec3(0.0, 0.0, -9.81) * t * t;
        const Mat3 r = q.toRotationMatrix();
        for (const Vec3& b : m.vertices) lowest_height = std::min(lowest_height, n.dot(c + r * b) - offset);
        detail::rotate_free(m, q, spin, dt);
      }
      EXPECT_GT(lowest_height, 0.0) << "case " << i;
      if (clear < 1.0) ++limited;
    }
  }
  EXPECT_GT(limited, 200);  // flights the plane limits, not the horizon
}

TEST(DdaFlight, DetailedBlockClearTimeNeverPassesTheFirstTouch) {
  // 200 flights of each. Measured: 68 of 94 touching flights cleared for a third of their
  // time or more, and every time within 1e-6 of the scan's.
  const DetailedBounds concave = detailed_bounds(0.15, 8);
  EXPECT_GT(concave.tally.touching, 80);
  EXPECT_GT(concave.tally.tight, concave.tally.touching * 7 / 10);
  EXPECT_EQ(concave.close, concave.compared);
  // Measured: 70 of 93, and at least 0.88 of the scanned bound's time.
  const DetailedBounds convex = detailed_bounds(0.0, 8);
  EXPECT_GT(convex.tally.touching, 80);
  EXPECT_GT(convex.tally.tight, convex.tally.touching * 7 / 10);
  EXPECT_GT(convex.least_ratio, 0.8);
  std::printf("detailed flight bound, concave block (vertex tree): %d of %d touching flights cleared for a third "
              "of their time or more; %d of %d within 1e-6 of the scanned bound\n",
              concave.tally.tight, concave.tally.touching, concave.close, concave.compared);
  std::printf("detailed flight bound, convex block (support queries): %d of %d touching flights cleared for a third "
              "of their time or more; least ratio to the scanned bound %.3f\n",
              convex.tally.tight, convex.tally.touching, convex.least_ratio);
  // A convex block of flat faces split into triangles (climbs over flat regions).
  // Measured: 68 of 90, and at least 0.975 of the scanned bound's time.
  const Model facets = Model::build(Settings{}, dda::testing::faceted_box(6));
  ASSERT_TRUE(facets.convex);
  const DetailedBounds faceted = detailed_bounds(facets, 9);
  EXPECT_GT(faceted.tally.touching, 80);
  EXPECT_GT(faceted.least_ratio, 0.5);
  std::printf("detailed flight bound, faceted box (support queries): %d of %d touching flights cleared for a third "
              "of their time or more; least ratio to the scanned bound %.3f\n",
              faceted.tally.tight, faceted.tally.touching, faceted.least_ratio);
}

// A triangle beside the block, whose plane passes through it, is cleared along the
// separation direction for as long as the block takes to cover the gap towards it.
TEST(DdaFlight, ClearTimeOfATriangleBesideTheBlock) {
  const std::vector<Vec3> block = {Vec3(-1, -1, -1), Vec3(1, -1, -1), Vec3(-1, 1, -1), Vec3(1, 1, -1),
                                   Vec3(-1, -1, 1),  Vec3(1, -1, 1),  Vec3(-1, 1, 1),  Vec3(1, 1, 1)};
  // A vertical triangle in the plane x = 2, 1 m from the block's face, facing it.
  const std::array<Vec3, 3> wall = {Vec3(2, -3, -3), Vec3(2, 3, -3), Vec3(2, 0, 3)};
  const Vec3 normal = (wall[1] - wall[0]).cross(wall[2] - wall[0]).normalized();
  FlightBound bound;
  // Moving at 2 m/s along +x without spin or gravity: 0.5 s to touch the wall.
  bound.reset(block, Vec3::Zero(), Vec3(2, 0, 0), Vec3::Zero(), 0.0, false, 0.0);
  EXPECT_NEAR(bound.triangle_time(normal.x() < 0.0 ? normal : Vec3(-normal), wall, 10.0), 0.5, 1e-12);
  // A triangle whose plane cuts the block but which lies 1 m beside it: the separation.
  const std::array<Vec3, 3> beside = {Vec3(2, -3, -1.5), Vec3(5, -3, -1.5), Vec3(2, 3, 0.5)};
  const Vec3 up = (beside[1] - beside[0]).cross(beside[2] - beside[0]).normalized();
  bound.reset(block, Vec3::Zero(), Vec3(-2, 0, 0), Vec3::Zero(), 0.0, false, 0.0);
  EXPECT_EQ(bound.plane_time(up.z() > 0 ? up : Vec3(-up), (up.z() > 0 ? up : Vec3(-up)).dot(beside[0]), 10.0), 0.0);
  EXPECT_EQ(bound.triangle_time(up.z() > 0 ? up : Vec3(-up), beside, 10.0), 10.0);  // moving away: never
  bound.reset(block, Vec3::Zero(), Vec3(2, 0, 0), Vec3::Zero(), 0.0, false, 0.0);
  const double t = bound.triangle_time(up.z() > 0 ? up : Vec3(-up), beside, 10.0);
  EXPECT_GT(t, 0.0);
  EXPECT_LE(t, 0.5);  // it covers the 1 m to the triangle's nearest corner line in 0.5 s
}

}  // namespace
}  // namespace talus::dda
