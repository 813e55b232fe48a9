// SPDX-License-Identifier: MIT
// Whole realizations on the SPEC §6 bench slope: determinism, the contact search
// against its brute-force reference, agreement of the two DOF paths, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <tuple>
#include <vector>

#include "contacts.hpp"
#include "dda_fixtures.hpp"
#include "narrow_phase.hpp"
#include "talus/core/error.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/synthetic.hpp"

namespace talus::dda {
namespace {

using detail::BlockBox;
using detail::TerrainPatch;

terrain::Terrain bench_slope(double sigma) {
  terrain::Terrain t = terrain::build_grid_terrain(terrain::make_synthetic(terrain::SyntheticSlope{}, "bench"),
                                                   terrain::Diagonal::alternating, 11, "bench");
  t.roughness.sigma = sigma;
  return t;
}

// A uniformly random rotation from the normal draws first … first + 3 of `rng`.
Eigen::Quaterniond random_rotation(const core::RandomStream& rng, std::uint64_t first) {
  return Eigen::Quaterniond(rng.normal(first), rng.normal(first + 1), rng.normal(first + 2), rng.normal(first + 3))
      .normalized();
}

// The contact search (distance ds, depth limit `depth`, m) of `m` at `pose`, the block's
// world vertices left in `world` and the terrain near it in `patch`.
std::vector<Contact> search_at(const Model& m, const terrain::Surface& surface, const detail::Pose& pose, double ds,
                               double depth, std::vector<Vec3>& world, TerrainPatch& patch) {
  const detail::PlacedBlock at(m, pose, world);
  std::vector<Contact> found;
  detail::detect_contacts(at, surface, ds, depth, patch, found);
  return found;
}

// A rigid pose of `m` rotated by q whose lowest vertex lies `depth` (m) under the
// ground at (x, y).
detail::Pose sunk_pose(const Model& m, const terrain::Surface& surface, const Eigen::Quaterniond& q, double x, double y,
                       double depth) {
  detail::Pose pose;
  pose.rotation = q.toRotationMatrix();
  pose.map = pose.rotation;
  pose.inverse_map = pose.rotation.transpose();
  std::size_t low = 0;
  for (std::size_t v = 1; v < m.vertices.size(); ++v)
    if ((pose.map * m.vertices[v]).z() < (pose.map * m.vertices[low]).z()) low = v;
  pose.centre = Vec3(x, y, surface.height_at(x, y)->z - depth) - pose.map * m.vertices[low];
  return pose;
}

// bench_dda's detailed block: a 1 m³ ellipsoid of diameters 1.4 × 1.2 × 1.1 m, 20·n²
// triangles, with block-gen's bumps and dents of relative height `roughness`.
geometry::Polyhedron bench_ellipsoid(int n, double roughness = 0.0) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 1.0;
  spec.dimensions = Vec3(1.4, 1.2, 1.1);
  spec.resolution = n;
  spec.roughness = roughness;
  return block::make_solid(spec, "ellipsoid");
}

Release crest_release() {
  Release r;
  r.position = Vec3(1.0, 20.0, 29.0 + 2.5);
  return r;
}

Summary realization(const terrain::Terrain& t, const Model& m, std::uint32_t i) {
  const terrain::Surface surface = terrain::Surface::realize(t, i);
  const Ground g{&surface, t.materials};
  return run(m, g, crest_release(), core::RandomStream(5, core::Stream::impact, i));
}

// Same inputs, same bits: every summary value and counter of a realization repeats.
TEST(DdaRealization, IsDeterministic) {
  const terrain::Terrain t = bench_slope(0.2);
  Settings set;
  set.max_steps = 3000;
  const Model m = Model::build(set, testing::cube(1.0));
  const Summary a = realization(t, m, 3);
  const Summary b = realization(t, m, 3);
  EXPECT_EQ(std::memcmp(a.final_position.data(), b.final_position.data(), sizeof(double) * 3), 0);
  EXPECT_EQ(a.max_speed, b.max_speed);
  EXPECT_EQ(a.max_jump_height, b.max_jump_height);
  EXPECT_EQ(a.impacts, b.impacts);
  EXPECT_EQ(a.counters.open_close_iterations, b.counters.open_close_iterations);
  const Summary c = realization(t, m, 4);
  EXPECT_NE(a.final_position, c.final_position);
  EXPECT_FALSE(is_failure(a.end)) << to_string(a.end);
  EXPECT_GT(a.impacts, 0u);
  // After landing, the centroid of a unit cube is at least half an edge above the ground
  // (less the roughness under its corners).
  EXPECT_GT(a.max_jump_height, 0.3);
  // The release drop (the centroid 2.62 m above the ground) is not counted: the recorded
  // height is the largest from the first touch on. With a sample at every step, that is the
  // largest sampled height from the first sample whose velocity is no longer that of the
  // free fall from rest (the step in which the first contact closed) on. The height at
  // the touch is not a fixed one: under a cube touching the 1:1 face on a corner the
  // centroid is up to 0.87/cos 45° = 1.22 m above the ground vertically.
  set.trajectory_interval = 1e-9;
  const Summary traced = realization(t, Model::build(set, testing::cube(1.0)), 3);
  EXPECT_EQ(traced.max_jump_height, a.max_jump_height);
  ASSERT_FALSE(traced.trajectory.empty());
  EXPECT_GT(traced.trajectory.front().height, 2.5);
  std::size_t k = 0;
  const auto falling = [&](const TrajectorySample& p) {
    return (p.velocity - Vec3(0.0, 0.0, -set.gravity * p.time)).norm() <= 1e-9 * (1.0 + set.gravity * p.time);
  };
  while (k < traced.trajectory.size() && falling(traced.trajectory[k])) ++k;
  ASSERT_LT(k, traced.trajectory.size());
  EXPECT_LT(traced.trajectory[k].height, 1.25);
  double highest = 0.0;
  for (; k < traced.trajectory.size(); ++k) highest = std::max(highest, traced.trajectory[k].height);
  EXPECT_EQ(highest, a.max_jump_height);
}

// The pruned contact search finds exactly what testing every triangle finds, over
// random poses of a tetrahedron and a cube just above a rough grid.
TEST(DdaContacts, PrunedSearchMatchesBruteForce) {
  const terrain::Terrain t = bench_slope(0.4);
  const terrain::Surface surface = terrain::Surface::realize(t, 2);
  const core::RandomStream rng(9, core::Stream::release, 0);
  std::size_t total = 0;
  TerrainPatch patch;
  for (const geometry::Polyhedron& poly : {testing::tetrahedron(2.04), testing::cube(1.0)}) {
    const Model m = Model::build(Settings{}, poly);
    for (std::uint64_t k = 0; k < 60; ++k) {
      State s;
      const double x = 2.0 + 50.0 * rng.uniform(8 * k);
      const double y = 4.0 + 32.0 * rng.uniform(8 * k + 1);
      const double ground = surface.height_at(x, y)->z;
      s.position = Vec3(x, y, ground + m.radius * (2.0 * rng.uniform(8 * k + 2) - 0.5));
      s.orientation = Eigen::Quaterniond(rng.normal(8 * k + 3), rng.normal(8 * k + 4), rng.normal(8 * k + 5),
                                         rng.normal(8 * k + 6))
                          .normalized();
      detail::Pose pose;
      pose.centre = s.position;
      pose.rotation = s.orientation.toRotationMatrix();
      pose.map = pose.rotation;
      pose.inverse_map = pose.rotation.transpose();
      std::vector<Vec3> world;
      const detail::PlacedBlock at(m, pose, world);
      std::vector<Contact> fast, slow;
      detail::detect_contacts(at, surface, 0.05, 0.1, patch, fast);
      detail::detect_contacts_brute_force(m, surface, pose, 0.05, 0.1, slow);
      const auto key = [](const Contact& c) { return std::make_tuple(c.kind, c.block_feature, c.terrain_feature); };
      const auto by_key = [&](const Contact& a, const Contact& b) { return key(a) < key(b); };
      std::sort(fast.begin(), fast.end(), by_key);
      std::sort(slow.begin(), slow.end(), by_key);
      ASSERT_EQ(fast.size(), slow.size()) << "pose " << k;
      for (std::size_t i = 0; i < fast.size(); ++i) {
        EXPECT_EQ(key(fast[i]), key(slow[i]));
        EXPECT_EQ(fast[i].gap, slow[i].gap);
      }
      total += fast.size();
    }
  }
  EXPECT_GT(total, 60u);  // the poses really touch the ground
}

// The candidate pairs a scanned block gathers at one pose serve the next steps while it
// moves less than they were widened by: along paths of small steps (a tumble down the
// rough slope, some poses stretched as on the 12-DOF path), the search through reused
// candidates finds the same contacts, in the same order and with the same numbers, as
// a search that gathers them afresh at every pose.
TEST(DdaContacts, ReusedCandidatesFindWhatAFreshSearchFinds) {
  const terrain::Terrain t = bench_slope(0.4);
  const terrain::Surface surface = terrain::Surface::realize(t, 2);
  const core::RandomStream rng(11, core::Stream::release, 0);
  std::size_t total = 0, reused = 0, steps = 0;
  for (const geometry::Polyhedron& poly : {testing::tetrahedron(2.04), testing::cube(1.0)}) {
    const Model m = Model::build(Settings{}, poly);
    for (std::uint64_t path = 0; path < 12; ++path) {
      const auto u = [&](std::uint64_t k) { return rng.uniform(64 * path + k); };
      const double x0 = 2.0 + 40.0 * u(0), y0 = 4.0 + 32.0 * u(1);
      const Vec3 axis = Vec3(u(2) - 0.5, u(3) - 0.5, u(4) - 0.5).normalized();
      Eigen::Quaterniond q = Eigen::Quaterniond(u(5) - 0.5, u(6) - 0.5, u(7) - 0.5, u(8) - 0.5).normalized();
      const bool stretched = path % 3 == 2;
      TerrainPatch reusing;
      for (int k = 0; k < 120; ++k) {
        // Steps of 4–12 mm and up to 0.6°, the height hugging the ground.
        const double x = x0 + 0.008 * k * (0.5 + u(9)), y = y0 + 0.004 * k * (u(10) - 0.5);
        const double ground = surface.height_at(x, y)->z;
        q = Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * u(11), axis)) * q;
        detail::Pose pose;
        pose.centre = Vec3(x, y, ground + m.radius * (0.55 + 0.1 * std::sin(0.2 * k)));
        pose.rotation = q.toRotationMatrix();
        Mat3 stretch = Mat3::Identity();
        if (stretched) stretch.diagonal() += Vec3(0.01, -0.005, 0.002) * std::sin(0.3 * k);
        pose.map = pose.rotation * stretch;
        pose.inverse_map = pose.map.inverse();
        std::vector<Vec3> world_a, world_b;
        const detail::PlacedBlock a(m, pose, world_a), b(m, pose, world_b);
        const double ds = 0.02 + 0.02 * std::abs(std::sin(0.1 * k));
        std::vector<Contact> kept, fresh;
        if (reusing.candidates.gathering.model == &m) ++reused;
        detail::detect_contacts(a, surface, ds, 0.1, reusing, kept);
        TerrainPatch anew;
        detail::detect_contacts(b, surface, ds, 0.1, anew, fresh);
        ++steps;
        ASSERT_EQ(kept.size(), fresh.size()) << "path " << path << " step " << k;
        for (std::size_t i = 0; i < kept.size(); ++i) {
          EXPECT_EQ(kept[i].kind, fresh[i].kind);
          EXPECT_EQ(kept[i].block_feature, fresh[i].block_feature);
          EXPECT_EQ(kept[i].terrain_feature, fresh[i].terrain_feature);
          EXPECT_EQ(kept[i].gap, fresh[i].gap);
          EXPECT_EQ(kept[i].point, fresh[i].point);
          EXPECT_EQ(kept[i].normal, fresh[i].normal);
        }
        total += kept.size();
      }
    }
  }
  EXPECT_GT(total, steps);          // the paths really touch the ground
  EXPECT_GT(reused, steps / 2);     // and mostly search through reused candidates
  EXPECT_LT(reused, steps);         // which are gathered afresh now and then
}

// A block vertex below the ground in plan is always held by a vertex–face contact. The
// case that needs the plan test: a 35° slope with a 2 m spike at one node; a vertex that
// slid over the valley line where the slope meets the spike's uphill face lies under that
// face in plan but outside the normal prisms of both faces, and without the plan test it
// sank into the spike unresisted (a terrain point 1 m inside a block in the stress soak).
TEST(DdaContacts, VertexBelowTheGroundInPlanIsHeld) {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 9, 9};
  dem.z.resize(dem.spec.point_count());
  for (std::int32_t j = 0; j < 9; ++j)
    for (std::int32_t i = 0; i < 9; ++i) dem.z[dem.spec.index(i, j)] = (8.0 - i) * std::tan(35.0 * M_PI / 180.0);
  dem.z[dem.spec.index(4, 4)] += 2.0;
  for (const terrain::Diagonal cut : {terrain::Diagonal::alternating, terrain::Diagonal::fixed}) {
    const terrain::Terrain t = terrain::build_grid_terrain(dem, cut, 1, "spike");
    const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
    const core::RandomStream rng(4, core::Stream::release, 0);
    std::size_t below = 0;
    for (const geometry::Polyhedron& poly : {testing::tetrahedron(2.04), testing::cube(1.0)}) {
      const Model m = Model::build(Settings{}, poly);
      for (std::uint64_t k = 0; k < 400; ++k) {
        // Poses around the spike's foot, the block's lowest vertex 0–5 cm under the ground.
        const Eigen::Quaterniond q = random_rotation(rng, 8 * k);
        const double x = 2.6 + 1.6 * rng.uniform(8 * k + 4), y = 3.2 + 1.6 * rng.uniform(8 * k + 5);
        std::vector<Vec3> world;
        TerrainPatch patch;
        const std::vector<Contact> found = search_at(
            m, surface, sunk_pose(m, surface, q, x, y, 0.05 * rng.uniform(8 * k + 6)), 0.05, 0.1, world, patch);
        for (std::size_t v = 0; v < world.size(); ++v) {
          const auto hit = surface.height_at(world[v].x(), world[v].y());
          const double depth = hit ? hit->z - world[v].z() : 0.0;
          if (!(depth > 1e-9 && depth < 0.05)) continue;
          ++below;
          const bool held = std::any_of(found.begin(), found.end(), [&](const Contact& c) {
            return c.kind == ContactKind::vertex_face && c.block_feature == static_cast<std::int32_t>(v) && c.gap < 0.0;
          });
          EXPECT_TRUE(held) << "pose " << k << " vertex " << v << " " << depth << " m below the ground";
        }
      }
    }
    EXPECT_GT(below, 300u);
  }
}

// A block edge that crosses a terrain ridge below it (gap < 0) is in contact only if the
// crossing point is inside the ground: under both triangles' planes on a crest, under
// either in a valley. Beside a crest, a block over the flat top lies under the slope's
// plane continued; its edges there were taken as penetrated contacts, with a normal
// pointing out of one side only. Poses of a scanned and a detailed block (the index's
// gathering) around a crest and a valley, the lowest vertex 0–5 cm under the ground.
TEST(DdaContacts, EdgeCrossingsBelowARidgeAreInsideTheGround) {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 10, 9};
  dem.z.resize(dem.spec.point_count());
  // Flat top (x ≤ 3), a crest at x = 3, a 35° slope down to a valley at x = 6, flat below.
  const double slope = std::tan(35.0 * M_PI / 180.0);
  for (std::int32_t j = 0; j < 9; ++j)
    for (std::int32_t i = 0; i < 10; ++i) dem.z[dem.spec.index(i, j)] = -slope * std::clamp(i - 3, 0, 3);
  const terrain::Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "crest");
  const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
  const core::RandomStream rng(6, core::Stream::release, 0);
  std::size_t below = 0;
  for (const geometry::Polyhedron& poly : {testing::cube(1.0), bench_ellipsoid(8)}) {
    const Model m = Model::build(Settings{}, poly);
    for (std::uint64_t k = 0; k < 600; ++k) {
      const Eigen::Quaterniond q = random_rotation(rng, 8 * k);
      // Half the poses about the crest, half about the valley.
      const double x = (k % 2 == 0 ? 2.0 : 5.0) + 2.0 * rng.uniform(8 * k + 4);
      const double y = 3.0 + 2.0 * rng.uniform(8 * k + 5);
      std::vector<Vec3> world;
      TerrainPatch patch;
      const std::vector<Contact> found = search_at(
          m, surface, sunk_pose(m, surface, q, x, y, 0.05 * rng.uniform(8 * k + 6)), 0.05, 0.1, world, patch);
      for (const Contact& c : found) {
        if (c.kind != ContactKind::edge_edge || !(c.gap < 0.0)) continue;
        ++below;
        const auto hit = surface.height_at(c.point.x(), c.point.y());
        ASSERT_TRUE(hit.has_value());
        EXPECT_GE(hit->z - c.point.z(), -1e-9) << "pose " << k << " (" << poly.vertices.size()
                                               << " vertices): a crossing " << c.point.z() - hit->z
                                               << " m above the ground, gap " << c.gap;
      }
    }
  }
  EXPECT_GT(below, 100u);  // the poses really cross ridges below them
}

// Every candidate found already penetrated (gap < 0) lies inside the ground: a block
// vertex under the surface, an edge crossing under it. 12 000 poses of a tetrahedron, a
// cube and a smooth and a rough (concave) 1 280-face ellipsoid on the roughest bench
// slope, the lowest vertex 0–6 cm under the ground, searched with the study's distances.
// Before: 1 755 crossings beside crests lay above the ground, and then 14 within |gap| of
// a ridge's end, over a third triangle (docs/dda.md, Detection).
TEST(DdaContacts, PenetratedCandidatesAreInsideTheGround) {
  const terrain::Terrain t = bench_slope(0.4);
  const terrain::Surface surface = terrain::Surface::realize(t, 3);
  const core::RandomStream rng(11, core::Stream::release, 0);
  std::size_t vertices = 0, crossings = 0, crests = 0;
  for (const geometry::Polyhedron& poly :
       {testing::tetrahedron(2.04), testing::cube(1.0), bench_ellipsoid(8), bench_ellipsoid(8, 0.15)}) {
    const Model m = Model::build(testing::faceted_settings(), poly);
    for (std::uint64_t k = 0; k < 3000; ++k) {
      const double x = 2.0 + 50.0 * rng.uniform(8 * k);
      const double y = 4.0 + 32.0 * rng.uniform(8 * k + 1);
      const Eigen::Quaterniond q = random_rotation(rng, 8 * k + 3);
      std::vector<Vec3> world;
      TerrainPatch patch;
      const std::vector<Contact> found = search_at(m, surface, sunk_pose(m, surface, q, x, y, 0.06 * rng.uniform(8 * k + 2)),
                                                   0.03, m.penetration_limit(), world, patch);
      for (const Contact& c : found) {
        if (!(c.gap < 0.0) || c.kind == ContactKind::face_vertex) continue;
        if (c.kind == ContactKind::ridge_face) {
          // The crest's point held lies on the ground, the contact's depth inside the block.
          ++crests;
          const Vec3 crest = c.point - c.gap * c.normal;
          const auto hit = surface.height_at(crest.x(), crest.y());
          ASSERT_TRUE(hit.has_value());
          EXPECT_NEAR(crest.z(), hit->z, 1e-9) << "pose " << k << ", crest with gap " << c.gap;
          continue;
        }
        ++(c.kind == ContactKind::edge_edge ? crossings : vertices);
        const auto hit = surface.height_at(c.point.x(), c.point.y());
        ASSERT_TRUE(hit.has_value());
        EXPECT_LE(c.point.z() - hit->z, 1e-9) << "pose " << k << " (" << poly.vertices.size() << " vertices), "
                                              << (c.kind == ContactKind::edge_edge ? "edge crossing" : "vertex")
                                              << " with gap " << c.gap;
      }
    }
  }
  EXPECT_GT(vertices, 100000u);
  EXPECT_GT(crossings, 30000u);
  EXPECT_GT(crests, 0u);
}

// A terrain vertex inside a convex block deeper than the search distance is held by the
// face it is least deep under, even where it is no spike (here a node of flat ground under
// a cube sunk into it); within the search distance the block's own vertices carry it.
TEST(DdaContacts, TerrainVertexDeepInsideIsHeldByTheNearestFace) {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 7, 7};
  dem.z.assign(dem.spec.point_count(), 0.0);
  const terrain::Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "flat");
  const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  for (const double sunk : {0.005, 0.03}) {
    detail::Pose pose;
    pose.centre = Vec3(3.2, 3.3, 0.5 - sunk);  // node (3, 3) under the bottom face
    std::vector<Vec3> world;
    const detail::PlacedBlock at(m, pose, world);
    TerrainPatch patch;
    std::vector<Contact> found;
    detail::detect_contacts(at, surface, 0.01, 0.1, patch, found);
    const auto node = std::find_if(found.begin(), found.end(), [&](const Contact& c) {
      return c.kind == ContactKind::face_vertex && c.terrain_feature == static_cast<std::int64_t>(dem.spec.index(3, 3));
    });
    if (sunk < 0.01) {
      EXPECT_EQ(node, found.end());
    } else {
      ASSERT_NE(node, found.end());
      EXPECT_NEAR(node->gap, -sunk, 1e-12);
      EXPECT_NEAR(node->normal.z(), 1.0, 1e-12);
    }
    // The four bottom vertices are held either way.
    EXPECT_EQ(std::count_if(found.begin(), found.end(),
                            [](const Contact& c) { return c.kind == ContactKind::vertex_face && c.gap < 0.0; }),
              4);
  }
}

// A roof on a 7 × 7 m grid: its crest along y at x = 3 m, 0.5 m high, flanks falling 1 in 2.
terrain::Terrain roof() {
  terrain::DemGrid dem;
  dem.spec = {0.0, 0.0, 1.0, 1.0, 7, 7};
  dem.z.resize(dem.spec.point_count());
  for (std::size_t iy = 0; iy < 7; ++iy)
    for (std::size_t ix = 0; ix < 7; ++ix)
      dem.z[dem.spec.index(static_cast<std::int32_t>(ix), static_cast<std::int32_t>(iy))] =
          0.5 - 0.5 * std::abs(static_cast<double>(ix) - 3.0);
  return terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "roof");
}

// A terrain crest inside a convex block that no crossing holds is held at its deepest point
// by the face it is least deep under; one its crossings hold where it is deepest gets
// nothing more. Here a roof-shaped crest along y under a cube's bottom face, the cube sunk
// `sunk` into it: the crossings of the bottom edges hold it.
TEST(DdaContacts, CrestDeepInsideIsHeldWhereNoCrossingHoldsIt) {
  const terrain::Terrain t = roof();
  const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  const double ds = 0.01, depth = 0.1;
  for (const double sunk : {0.0002, 0.03}) {
    detail::Pose pose;
    pose.centre = Vec3(3.1, 3.3, 1.0 - sunk);  // the crest x = 3 under the bottom face
    std::vector<Vec3> world;
    TerrainPatch patch;
    const std::vector<Contact> found = search_at(m, surface, pose, ds, depth, world, patch);
    EXPECT_EQ(std::count_if(found.begin(), found.end(), [](const Contact& c) { return c.kind == ContactKind::ridge_face; }), 0);
    EXPECT_EQ(std::count_if(found.begin(), found.end(),
                            [](const Contact& c) { return c.kind == ContactKind::edge_edge && c.gap < 0.0; }),
              2);
    // Without the crossings, each crest segment under the face is held at depth `sunk`
    // (deeper than a twentieth of ds), pushed up along the face's normal.
    const detail::PlacedBlock at(m, pose, world);
    std::vector<Contact> alone;
    detail::deep_ridge_contacts(at, patch, patch.candidates.ridges, ds, depth, 0, alone);
    if (sunk < 0.05 * ds) {
      EXPECT_TRUE(alone.empty());
      continue;
    }
    ASSERT_EQ(alone.size(), 2u);
    for (const Contact& c : alone) {
      EXPECT_EQ(c.kind, ContactKind::ridge_face);
      EXPECT_NEAR(c.gap, -sunk, 1e-12);
      EXPECT_NEAR(c.normal.z(), 1.0, 1e-12);
      EXPECT_NEAR(c.point.z(), 0.5 - sunk, 1e-12);
      const Vec3 crest = c.point - c.gap * c.normal;
      EXPECT_NEAR(crest.x(), 3.0, 1e-12);
      EXPECT_NEAR(crest.z(), 0.5, 1e-12);
    }
  }
}

// A crest that passes under a block edge, deep, is deepest where the two faces of the edge
// are equally deep: it is held across itself, at the edge's distance, whichever face the
// search meets first. Here the roof's crest along y under the lowest edge (along x) of a
// cube tilted 20° about x, 3 cm below the crest. Either face alone pushed the block along
// its own normal, one of them down onto the crest; a cube resting on a spike sank by that.
TEST(DdaContacts, CrestUnderABlockEdgeIsHeldAcrossItself) {
  const terrain::Terrain t = roof();
  const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  const double ds = 0.01, depth = 0.1, sunk = 0.03;
  for (const double tilt : {20.0, 20.0 + 1e-7, 20.0 - 1e-7, -35.0}) {
    detail::Pose pose;
    pose.rotation = Eigen::AngleAxisd(tilt * std::numbers::pi / 180.0, Vec3::UnitX()).toRotationMatrix();
    pose.map = pose.rotation;
    pose.inverse_map = pose.rotation.transpose();
    std::size_t low = 0;
    for (std::size_t v = 1; v < m.vertices.size(); ++v)
      if ((pose.map * m.vertices[v]).z() < (pose.map * m.vertices[low]).z()) low = v;
    const Vec3 corner = pose.map * m.vertices[low];
    pose.centre = Vec3(3.1, 3.5 - corner.y(), 0.5 - sunk - corner.z());  // the edge's middle over x = 3
    std::vector<Vec3> world;
    TerrainPatch patch;
    search_at(m, surface, pose, ds, depth, world, patch);
    const detail::PlacedBlock at(m, pose, world);
    std::vector<Contact> alone;
    detail::deep_ridge_contacts(at, patch, patch.candidates.ridges, ds, depth, 0, alone);
    ASSERT_EQ(alone.size(), 1u) << tilt;
    const Contact& c = alone[0];
    EXPECT_EQ(c.kind, ContactKind::ridge_face);
    EXPECT_NEAR(c.normal.z(), 1.0, 1e-9) << tilt;
    EXPECT_NEAR(c.gap, -sunk, 1e-9) << tilt;
    const Vec3 crest = c.point - c.gap * c.normal;
    EXPECT_NEAR(crest.x(), 3.0, 1e-9);
    EXPECT_NEAR(crest.z(), 0.5, 1e-9);
  }
}

// Runouts of n realizations of the bench slope on one DOF path.
std::vector<double> runouts(const terrain::Terrain& t, const char* dof, int n, std::int64_t max_steps) {
  Settings set;
  set.dof = dof;
  set.max_steps = max_steps;
  const Model m = Model::build(set, testing::cube(1.0));
  std::vector<double> out;
  for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(n); ++i) {
    const Summary s = realization(t, m, i);
    EXPECT_FALSE(is_failure(s.end)) << dof << " " << i << " " << to_string(s.end);
    out.push_back(s.runout);
  }
  return out;
}

// Both DOF paths run bench-slope realizations to a regular end (no numerical failure).
TEST(DdaRealization, BothDofPathsRunTheBenchSlope) {
  const terrain::Terrain t = bench_slope(0.2);
  for (const char* dof : {"rigid6", "full12"}) {
    const std::vector<double> r = runouts(t, dof, 6, 3000);
    EXPECT_GT(*std::max_element(r.begin(), r.end()), 2.0) << dof;  // the blocks do move off the crest
  }
}

// The 12-DOF and 6-DOF paths agree on the runout distribution within the stochastic
// scatter: the mean runouts after up to 8 s differ by less than three standard errors. (With impact_strains on, the 12-DOF block keeps most of each impact's energy
// as strain vibration and the paths differ by 3–4 standard errors; docs/dda.md.)
TEST(DdaRealization, DofPathsAgreeWithinScatter) {
  const terrain::Terrain t = bench_slope(0.2);
  // 10 realizations of at most 8 s of motion (most have stopped by then): the test stays
  // within seconds under the sanitizers.
  constexpr int n = 10;
  const std::vector<double> x6 = runouts(t, "rigid6", n, 8000);
  const std::vector<double> x12 = runouts(t, "full12", n, 8000);
  const auto mean_var = [](const std::vector<double>& v) {
    double mean = 0.0, var = 0.0;
    for (double x : v) mean += x / static_cast<double>(v.size());
    for (double x : v) var += (x - mean) * (x - mean) / static_cast<double>(v.size() - 1);
    return std::pair{mean, var};
  };
  const auto [m6, v6] = mean_var(x6);
  const auto [m12, v12] = mean_var(x12);
  const double se = std::sqrt(v6 / n + v12 / n);
  std::printf("runout: rigid6 %.2f ± %.2f m, full12 %.2f ± %.2f m (n = %d)\n", m6, std::sqrt(v6), m12, std::sqrt(v12), n);
  EXPECT_LT(std::abs(m6 - m12), 3.0 * se);
}

TEST(DdaRealization, BadInputIsOneLineError) {
  const terrain::Surface plane = testing::incline(10.0);
  const std::vector<terrain::Material> none;
  const Ground g{&plane, none};
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  Release r = testing::on_incline(10.0, 1.0, 0.0, 3.0);
  r.velocity = Vec3(0.0, 0.0, -3.0);
  try {
    run(m, g, r, core::RandomStream(1, core::Stream::impact, 0));
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "terrain: triangle 1 names material 0 but only 0 are defined");
  }
  r.position.x() = std::nan("");
  try {
    start(m, r, core::RandomStream(1, core::Stream::impact, 0));
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "release: non-finite release position, orientation or velocity");
  }
}

// A block released off the terrain ends as left_terrain, and the step limit is honoured.
TEST(DdaRealization, EndReasons) {
  const terrain::Surface plane = testing::incline(0.0, 5.0);
  const std::vector<terrain::Material> mats{testing::material(0.3)};
  const Ground g{&plane, mats};
  Settings set;
  const Model m = Model::build(set, testing::cube(1.0));
  Release r;
  r.position = Vec3(4.0, 0.0, 3.0);
  r.velocity = Vec3(5.0, 0.0, 0.0);
  EXPECT_EQ(run(m, g, r, core::RandomStream(1, core::Stream::impact, 0)).end, EndReason::left_terrain);
  set.max_steps = 10;
  const Model m10 = Model::build(set, testing::cube(1.0));
  const Summary s = run(m10, g, r, core::RandomStream(1, core::Stream::impact, 0));
  EXPECT_EQ(s.end, EndReason::step_limit);
  EXPECT_EQ(s.steps, 10u);
  // A cube set down on flat ground comes to rest after the dwell time.
  const Summary rest = run(m, g, testing::on_incline(0.0, 1.0, 0.0, 0.0), core::RandomStream(1, core::Stream::impact, 0));
  EXPECT_EQ(rest.end, EndReason::rest);
  EXPECT_NEAR(rest.time, set.rest_dwell, 2e-3);
}

// A plane rising at `slope_deg` from its rim y = −5 (x, y in [−5, 5]): a TIN of two
// triangles, or a grid of 0.5 m cells.
terrain::Terrain cross_slope(double slope_deg, bool grid) {
  const double t = std::tan(slope_deg * M_PI / 180.0);
  if (grid) {
    terrain::DemGrid dem;
    dem.spec = terrain::GridSpec{-5.0, -5.0, 0.5, 0.5, 21, 21};
    for (std::int32_t j = 0; j < 21; ++j)
      for (std::int32_t i = 0; i < 21; ++i) dem.z.push_back(0.5 * j * t);
    terrain::Terrain out = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 1, "cross");
    out.materials = {testing::material(0.8)};
    return out;
  }
  terrain::Terrain out;
  for (const auto& [x, y] : {std::pair{-5.0, -5.0}, {5.0, -5.0}, {5.0, 5.0}, {-5.0, 5.0}})
    out.mesh.vertices.emplace_back(x, y, (y + 5.0) * t);
  out.mesh.triangles = {{0, 1, 3}, {1, 2, 3}};
  out.material_of_triangle = {0, 0};
  out.materials = {testing::material(0.8)};
  return out;
}

// A slab of 2 × 2 × 0.5 m resting flat on cross_slope(θ), overhanging the rim by
// `overhang` (m, along the plane), turning about the rim at `spin` (rad/s, > 0 turns its
// outer side down).
Release over_rim(double slope_deg, double overhang, double spin) {
  const double th = slope_deg * M_PI / 180.0;
  const double foot_y = -5.0 + (1.0 - overhang) * std::cos(th);
  Release r;
  r.position = Vec3(0.3, foot_y, (foot_y + 5.0) * std::tan(th)) + 0.25 * Vec3(0.0, -std::sin(th), std::cos(th));
  r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(th, Vec3::UnitX()));
  r.angular_velocity = Vec3(spin, 0.0, 0.0);
  r.velocity = r.angular_velocity.cross(r.position - Vec3(0.3, -5.0, 0.0));
  return r;
}

// The terrain ends at its rim with nothing beyond. A block that only overhangs it rests
// (its outer vertices lie on the ground's continued plane); a block that tips over it
// leaves the terrain as soon as a vertex beyond the rim sinks deeper under the continued
// ground, and below the rim, than the penetration limit, while its centroid is still
// inside: it never swings under the sheet, and terrain and block never overlap beyond the
// limit. A block over a crest, where the continued ground rises, stays. On a TIN and on a
// grid, flat and on 20° cross slopes.
TEST(DdaRealization, TippingOverTheRimLeavesTheTerrain) {
  Settings set;
  set.check_invariants = true;
  const Model m = Model::build(set, testing::box(2.0, 2.0, 0.5));
  for (const bool grid : {false, true}) {
    for (const double slope : {0.0, 20.0}) {
      const terrain::Terrain t = cross_slope(slope, grid);
      const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
      const Ground g{&surface, t.materials};
      const std::string where = std::string(grid ? "grid" : "TIN") + " slope " + std::to_string(slope);
      // Overhanging by 0.1 m, with the gravity line inside: rest, where it was put.
      const Release hang = over_rim(slope, 0.1, 0.0);
      const Summary rest = run(m, g, hang, core::RandomStream(1, core::Stream::impact, 0));
      EXPECT_EQ(rest.end, EndReason::rest) << where;
      EXPECT_LT((rest.final_position - hang.position).norm(), 1e-3) << where;
      EXPECT_EQ(rest.counters.depth_violations, 0u) << where;
      // Overhanging by 0.6 m and turning outwards: over the rim, ended with the centroid
      // inside.
      const Summary tip = run(m, g, over_rim(slope, 0.6, 3.0), core::RandomStream(1, core::Stream::impact, 0));
      EXPECT_EQ(tip.end, EndReason::left_terrain) << where;
      EXPECT_GT(tip.final_position.y(), -5.0) << where;
      EXPECT_LT(tip.time, 0.5) << where;
      EXPECT_EQ(tip.counters.depth_violations, 0u) << where;
      EXPECT_EQ(tip.counters.energy_violations, 0u) << where;
      // Turning inwards about its inner edge (flat ground), it lifts its overhang, falls
      // back and stays on the terrain.
      if (slope == 0.0) {
        Release in = over_rim(slope, 0.6, 0.0);
        in.angular_velocity = Vec3(-2.0, 0.0, 0.0);
        in.velocity = in.angular_velocity.cross(in.position - Vec3(0.3, -3.6, 0.0));
        const Summary back = run(m, g, in, core::RandomStream(1, core::Stream::impact, 0));
        EXPECT_EQ(back.end, EndReason::rest) << where;
        EXPECT_EQ(back.counters.depth_violations, 0u) << where;
      }
    }
    // At a crest (the ground falls away from the rim at 20°, its continued plane rises
    // beyond it), a slab dropped from 0.5 m overhanging by 0.6 m lands and rests on it.
    const terrain::Terrain t = cross_slope(-20.0, grid);
    const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
    const Ground g{&surface, t.materials};
    Release drop = over_rim(-20.0, 0.6, 0.0);
    drop.position.z() += 0.5;
    const Summary crest = run(m, g, drop, core::RandomStream(1, core::Stream::impact, 0));
    EXPECT_EQ(crest.end, EndReason::rest) << (grid ? "grid" : "TIN");
    EXPECT_GT(crest.final_position.y(), -5.0) << (grid ? "grid" : "TIN");
    EXPECT_EQ(crest.counters.depth_violations, 0u) << (grid ? "grid" : "TIN");
  }
}

// A surveyed TIN's footprint may have holes. A 40 × 20 m slope of 1 m cells falling at
// 20° along x, with the 6 × 6 cells at x, y in [6, 12] left out.
terrain::Terrain slope_with_hole() {
  const double t = std::tan(20.0 * M_PI / 180.0);
  terrain::Terrain out;
  constexpr int nx = 41, ny = 21;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) out.mesh.vertices.emplace_back(i, j, (40.0 - i) * t);
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      if (i >= 6 && i < 12 && j >= 6 && j < 12) continue;
      const int a = j * nx + i;
      out.mesh.triangles.push_back({a, a + 1, a + nx + 1});
      out.mesh.triangles.push_back({a, a + nx + 1, a + nx});
    }
  out.material_of_triangle.assign(out.mesh.triangles.size(), 0);
  out.materials = {testing::material(0.8)};
  return out;
}

// A block that rolls into a hole of a TIN's footprint has left the terrain once it lies
// lower than the hole's rim by the penetration limit, though its bounding sphere is then
// clear of the rim: it ends at the hole's edge, not after falling through it. One thrown
// across the hole high above it flies over and lands beyond.
TEST(DdaRealization, FallingIntoAHoleOfTheFootprintLeavesTheTerrain) {
  Settings set;
  set.check_invariants = true;
  const Model m = Model::build(set, testing::box(0.5, 0.5, 0.5));
  const terrain::Terrain t = slope_with_hole();
  const terrain::Surface surface = terrain::Surface::realize(t, std::nullopt);
  const Ground g{&surface, t.materials};
  const double slope = std::tan(20.0 * M_PI / 180.0);
  // Thrown from 1 m above the slope uphill of the hole, it comes down inside the hole,
  // clear of its rim.
  Release roll;
  roll.position = Vec3(4.0, 9.0, (40.0 - 4.0) * slope + 1.0);
  roll.velocity = Vec3(6.0, 0.0, 0.0);
  const Summary in = run(m, g, roll, core::RandomStream(1, core::Stream::impact, 0));
  EXPECT_EQ(in.end, EndReason::left_terrain);
  // The hole's rim is no lower than its downhill edge (x = 12); the block ends within
  // its own size of that, metres above where falling on would have taken it.
  EXPECT_GT(in.final_position.z(), (40.0 - 12.0) * slope - 1.0);
  EXPECT_LT(in.final_position.x(), 12.5);
  EXPECT_EQ(in.counters.depth_violations, 0u);
  EXPECT_EQ(in.counters.energy_violations, 0u);
  // Thrown over the hole from its uphill edge, 3 m above the slope: it flies across,
  // lands near x = 17.7 and goes on down the slope (to rest, or off its lower end).
  Release fly = roll;
  fly.position = Vec3(5.0, 9.0, (40.0 - 5.0) * slope + 3.0);
  fly.velocity = Vec3(8.0, 0.0, 3.0);
  const Summary over = run(m, g, fly, core::RandomStream(1, core::Stream::impact, 0));
  EXPECT_GT(over.final_position.x(), 14.0);
  if (over.end == EndReason::left_terrain) {
    EXPECT_GT(over.final_position.x(), 40.0);
  }
  EXPECT_EQ(over.counters.depth_violations, 0u);
}

}  // namespace
}  // namespace talus::dda

namespace talus::dda {
namespace {

// The physical invariants hold at every step of bench-slope realizations on the
// roughest level: no step gains energy beyond round-off, terrain and block never overlap
// beyond the penetration limit, and no realization ends in a numerical failure.
TEST(DdaRealization, InvariantsHoldAtEveryStep) {
  const terrain::Terrain t = bench_slope(0.4);
  Settings set;
  set.max_time = 3.0;
  set.check_invariants = true;
  for (const double volume : {1e-3, 1.0}) {
    const Model m = Model::build(set, testing::cube(std::cbrt(volume)));
    for (std::uint32_t i = 0; i < 6; ++i) {
      const Summary s = realization(t, m, i);
      EXPECT_FALSE(is_failure(s.end)) << to_string(s.end) << " volume " << volume << " realization " << i;
      EXPECT_EQ(s.counters.energy_violations, 0u) << "gain " << s.max_energy_gain << " J, realization " << i;
      EXPECT_EQ(s.counters.depth_violations, 0u) << "overlap " << s.max_depth << " m, realization " << i;
      EXPECT_GT(s.counters.contact_steps, 0u);
    }
  }
}

}  // namespace
}  // namespace talus::dda

