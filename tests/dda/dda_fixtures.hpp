// SPDX-License-Identifier: MIT
// Blocks and planar terrains shared by the DDA tests and benchmarks.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <vector>

#include "talus/block/solids.hpp"
#include "talus/dda/engine.hpp"
#include "talus/geometry/polyhedron.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::dda::testing {

/// Default settings but the block touching through its polyhedron only: every vertex a
/// corner (no smooth surface) and no rolling resistance. The tests of how the contacts of a
/// polyhedron are found and carried use it.
inline Settings faceted_settings() {
  Settings set;
  set.smooth_turn_deg = 0.0;
  set.rolling_resistance = 0.0;
  return set;
}

/// Axis-aligned box centred at the origin, edges ax, ay, az (m).
inline geometry::Polyhedron box(double ax, double ay, double az) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::box;
  spec.volume = 0.0;
  spec.dimensions = Vec3(ax, ay, az);
  return block::make_solid(spec, "test");
}
/// Axis-aligned cube of edge `side` (m) centred at the origin.
inline geometry::Polyhedron cube(double side) {
  block::SolidSpec spec;
  spec.kind = block::SolidKind::cube;
  spec.volume = side * side * side;
  return block::make_solid(spec, "test");
}
/// A named solid of volume `volume` (m³) centred at its centroid.
inline geometry::Polyhedron solid(block::SolidKind kind, double volume) {
  block::SolidSpec spec;
  spec.kind = kind;
  spec.volume = volume;
  return block::make_solid(spec, "test");
}
/// Regular tetrahedron of edge `edge` (m).
inline geometry::Polyhedron tetrahedron(double edge) {
  return solid(block::SolidKind::tetrahedron, edge * edge * edge / (6.0 * std::sqrt(2.0)));
}

/// Plane z = −x·tan(θ) (descending along +x) over [−half, half]², two triangles split
/// along the y = −x diagonal.
inline terrain::Surface incline(double theta_deg, double half = 20.0) {
  const double t = std::tan(theta_deg * M_PI / 180.0);
  geometry::TriangleMesh mesh;
  for (const auto& [x, y] : {std::pair{-half, -half}, {half, -half}, {half, half}, {-half, half}})
    mesh.vertices.emplace_back(x, y, -x * t);
  mesh.triangles = {{0, 1, 3}, {1, 2, 3}};
  return terrain::Surface::from_mesh(mesh);
}

/// Unit normal of incline(θ).
inline Vec3 incline_normal(double theta_deg) {
  const double th = theta_deg * M_PI / 180.0;
  return Vec3(std::sin(th), 0.0, std::cos(th));
}
/// Unit downslope direction of incline(θ).
inline Vec3 incline_down(double theta_deg) {
  const double th = theta_deg * M_PI / 180.0;
  return Vec3(std::cos(th), 0.0, -std::sin(th));
}

/// A release of a cube of side `a` resting (gap 0) on incline(θ), centred over (x, y).
inline Release on_incline(double theta_deg, double a, double x, double y) {
  Release r;
  const double th = theta_deg * M_PI / 180.0;
  const Vec3 foot(x, y, -x * std::tan(th));
  r.position = foot + 0.5 * a * incline_normal(theta_deg);
  r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(th, Vec3::UnitY()));
  return r;
}

/// One material with fixed (zero-sd) properties.
inline terrain::Material material(double friction_coefficient, double restitution = 0.95,
                                  double scale = 12.0) {
  terrain::Material m;
  m.friction_angle_mean_deg = std::atan(friction_coefficient) * 180.0 / M_PI;
  m.friction_coefficient_sd = 0.0;
  m.restitution_mean = restitution;
  m.restitution_sd = 0.0;
  m.restitution_scale = scale;
  m.lateral_tilt_sd_deg = 0.0;
  return m;
}

/// A box of 1.2 × 1.0 × 0.8 m whose faces are grids of n × n squares, each split into two
/// triangles: a convex block whose flat faces are made of many triangles, as meshes and
/// hulls have them (the edges inside a face are flat, exactly: no convex edges, and no
/// reflex ones), with ties along the axes.
inline geometry::Polyhedron faceted_box(int n) {
  const Vec3 half(0.6, 0.5, 0.4);
  geometry::Polyhedron poly;
  std::map<std::array<int, 3>, std::int32_t> ids;
  const auto vertex = [&](std::array<int, 3> g) {
    const auto [it, fresh] = ids.emplace(g, static_cast<std::int32_t>(poly.vertices.size()));
    if (fresh) {
      Vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = half[k] * (2.0 * g[static_cast<std::size_t>(k)] / n - 1.0);
      poly.vertices.push_back(p);
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      // (u, v, axis) right-handed: u × v points out on the upper side, in on the lower.
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          std::array<std::int32_t, 4> corner{};
          const int di[4] = {0, 1, 1, 0}, dj[4] = {0, 0, 1, 1};
          for (int c = 0; c < 4; ++c) {
            std::array<int, 3> g{};
            g[static_cast<std::size_t>(axis)] = side * n;
            g[static_cast<std::size_t>(u)] = i + di[c];
            g[static_cast<std::size_t>(v)] = j + dj[c];
            corner[static_cast<std::size_t>(c)] = vertex(g);
          }
          if (side == 1) {
            poly.faces.push_back({corner[0], corner[1], corner[2]});
            poly.faces.push_back({corner[0], corner[2], corner[3]});
          } else {
            poly.faces.push_back({corner[0], corner[2], corner[1]});
            poly.faces.push_back({corner[0], corner[3], corner[2]});
          }
        }
    }
  return poly;
}

}  // namespace talus::dda::testing
