// SPDX-License-Identifier: MIT
// bench_bullet_peer: the realizations of a dda-run scene run by a general rigid-body
// engine (Bullet, double precision, Debian's libbullet-dev), for a cost comparison on
// Talus's own problem (docs/benchmarks.md, "Rigid-body peer").
//
//   bench_bullet_peer SCENE.yaml [--set KEY=VALUE ...] [-n REALIZATIONS]
//
// Realization i uses what dda-run's realization i uses: terrain realization i (the same
// roughness draws), the same block (a convex hull of its vertices, with its mass and
// inertia), the same release point, height and orientation, the same Δt, gravity, mean
// friction coefficient, rest threshold and time limit. It ends when the body falls
// asleep (Bullet's sleeping, thresholds set from the rest threshold), leaves the
// terrain's plan bounds or falls below it, or reaches the time limit. Prints the cost per
// realization and what the runs did (simulated time, steps, ends, runout).
#include <btBulletDynamicsCommon.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "talus/io/block_file.hpp"
#include "talus/io/settings_yaml.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/mc/realization.hpp"
#include "talus/mc/scene.hpp"

namespace {

using talus::geometry::Vec3;
using Mat3 = Eigen::Matrix3d;

btVector3 bt(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

struct Outcome {
  double time = 0.0;       // simulated (s)
  std::uint64_t steps = 0;
  int end = 0;             // 0 asleep, 1 left the terrain, 2 time limit
  double runout = 0.0;     // along the main direction from the release point (m)
};

// Settings of the peer that Talus has no counterpart for, Bullet's defaults unless said.
struct PeerSettings {
  double restitution = 0.3;  // normal restitution of a block–ground contact (-)
  double margin = 0.01;      // collision margin of the block hull (m); Bullet's default is 0.04
};

Outcome run_one(const talus::mc::Scene& scene, std::uint32_t index, const PeerSettings& peer) {
  const auto& set = scene.settings();
  const talus::terrain::Surface surface =
      scene.base_surface().realization(set.stochastic.roughness ? std::optional<std::uint32_t>(index) : std::nullopt);
  const talus::mc::ReleaseDraw draw = talus::mc::draw_release(scene, surface, index);
  const talus::dda::Model& model = scene.blocks()[static_cast<std::size_t>(draw.block)].model;
  const talus::dda::Settings& engine = model.settings;

  // Ground: every triangle of the realization, as a static BVH triangle mesh.
  btTriangleMesh mesh(true, false);
  for (std::size_t t = 0; t < surface.triangle_count(); ++t) {
    const auto p = surface.triangle_vertices(t);
    mesh.addTriangle(bt(p[0]), bt(p[1]), bt(p[2]), false);
  }
  btBvhTriangleMeshShape ground_shape(&mesh, true);
  btRigidBody::btRigidBodyConstructionInfo ground_info(0.0, nullptr, &ground_shape);
  const double mu = std::tan(scene.materials().front().friction_angle_mean_deg * M_PI / 180.0);
  ground_info.m_friction = mu;
  ground_info.m_restitution = peer.restitution;
  btRigidBody ground(ground_info);

  // Block: the convex hull of its vertices in its principal frame (Bullet takes a
  // diagonal inertia), centroid at the body origin.
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(model.inertia);
  Mat3 q = eig.eigenvectors();
  if (q.determinant() < 0.0) q.col(0) = -q.col(0);
  btConvexHullShape hull;
  for (const Vec3& v : model.vertices) hull.addPoint(bt(q.transpose() * v), false);
  hull.recalcLocalAabb();
  hull.setMargin(peer.margin);
  const Vec3 principal = eig.eigenvalues();
  const Eigen::Quaterniond orientation = draw.release.orientation * Eigen::Quaterniond(q);
  btTransform start;
  start.setOrigin(bt(draw.release.position));
  start.setRotation(btQuaternion(orientation.x(), orientation.y(), orientation.z(), orientation.w()));
  btDefaultMotionState motion(start);
  btRigidBody::btRigidBodyConstructionInfo block_info(model.mass, &motion, &hull, bt(principal));
  block_info.m_friction = 1.0;  // combined friction is the product: the ground's μ
  block_info.m_restitution = 1.0;  // combined restitution: the ground's
  // Talus's rest: kinetic energy per unit mass below rest_kinetic_energy for rest_dwell.
  block_info.m_linearSleepingThreshold = std::sqrt(2.0 * engine.rest_kinetic_energy);
  block_info.m_angularSleepingThreshold =
      std::sqrt(2.0 * engine.rest_kinetic_energy * model.mass / principal.minCoeff());
  btRigidBody block(block_info);
  // Asleep after Talus's rest dwell below the thresholds (Bullet's default is 2 s).
  gDeactivationTime = engine.rest_dwell;
  block.setLinearVelocity(bt(draw.release.velocity));
  block.setAngularVelocity(bt(draw.release.angular_velocity));

  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0.0, 0.0, -engine.gravity));
  world.addRigidBody(&ground);
  world.addRigidBody(&block);

  const auto& b = surface.bounds();
  const double limit = engine.max_time > 0.0 ? engine.max_time
                                             : 60.0 + std::hypot(b.hi.x() - b.lo.x(), b.hi.y() - b.lo.y());
  Outcome out;
  out.end = 2;
  const double dt = engine.time_step;
  while (out.time < limit * (1.0 - 1e-12)) {
    world.stepSimulation(dt, 1, dt);
    out.time += dt;
    ++out.steps;
    const btVector3 p = block.getCenterOfMassPosition();
    if (p.x() < b.lo.x() || p.x() > b.hi.x() || p.y() < b.lo.y() || p.y() > b.hi.y() ||
        p.z() < b.lo.z() - 2.0 * model.radius) {
      out.end = 1;
      break;
    }
    if (!block.isActive()) {
      out.end = 0;
      break;
    }
  }
  const btVector3 p = block.getCenterOfMassPosition();
  const Eigen::Vector2d delta(p.x() - draw.release.position.x(), p.y() - draw.release.position.y());
  out.runout = delta.dot(scene.main_direction());
  world.removeRigidBody(&block);
  world.removeRigidBody(&ground);
  return out;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int usage() {
  std::fprintf(stderr, "usage: bench_bullet_peer SCENE.yaml [--set KEY=VALUE ...] [-n REALIZATIONS]\n"
                       "       [--restitution E] [--margin M]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene_path;
  std::vector<std::string> overrides;
  long realizations = -1;
  PeerSettings peer;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--set" && k + 1 < argc) overrides.emplace_back(argv[++k]);
    else if (a == "-n" && k + 1 < argc) realizations = std::stol(argv[++k]);
    else if (a == "--restitution" && k + 1 < argc) peer.restitution = std::stod(argv[++k]);
    else if (a == "--margin" && k + 1 < argc) peer.margin = std::stod(argv[++k]);
    else if (scene_path.empty() && !a.starts_with("-")) scene_path = a;
    else return usage();
  }
  if (scene_path.empty()) return usage();
  try {
    talus::mc::SceneSettings settings;
    talus::io::read_settings_file(scene_path, overrides, [&](talus::core::SettingsVisitor& v) { settings.visit(v); });
    const talus::mc::Scene scene = talus::mc::Scene::build(settings, talus::io::read_terrain_file(settings.terrain),
                                                           talus::io::read_block_file(settings.block_file), scene_path);
    const std::uint32_t n = realizations >= 0 ? static_cast<std::uint32_t>(realizations) : scene.realizations();
    std::vector<double> runout, time;
    std::uint64_t steps = 0;
    int ends[3] = {0, 0, 0};
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    for (std::uint32_t i = 0; i < n; ++i) {
      const Outcome o = run_one(scene, i, peer);
      runout.push_back(o.runout);
      time.push_back(o.time);
      steps += o.steps;
      ++ends[o.end];
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    double simulated = 0.0;
    for (double t : time) simulated += t;
    std::printf("bullet %d.%02d (%s precision), restitution %g, margin %g m\n", btGetVersion() / 100,
                btGetVersion() % 100, sizeof(btScalar) == 8 ? "double" : "single", peer.restitution, peer.margin);
    std::printf("realizations %u: %.3f s wall, %.3f s CPU; per realization %.2f ms wall, %.2f ms CPU; "
                "%.2f ms CPU per simulated second\n",
                n, seconds, cpu, n ? 1e3 * seconds / n : 0.0, n ? 1e3 * cpu / n : 0.0,
                simulated > 0.0 ? 1e3 * cpu / simulated : 0.0);
    std::printf("simulated time: mean %.3f s, median %.3f s; steps per realization %.0f\n",
                n ? simulated / n : 0.0, median(time), n ? static_cast<double>(steps) / n : 0.0);
    std::printf("ends: asleep %d, left_terrain %d, time_limit %d; runout median %.2f m\n", ends[0], ends[1], ends[2],
                median(runout));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_bullet_peer: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
