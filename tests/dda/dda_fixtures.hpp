// SPDX-License-Identifier: MIT
// Small blocks and planar terrains shared by the DDA tests and benchmarks.
#pragma once
#include <cmath>
#include <vector>

#include "talus/dda/engine.hpp"
#include "talus/geometry/polyhedron.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::dda::testing {

/// Axis-aligned box centred at the origin (m), faces CCW from outside.
inline geometry::Polyhedron box(double ax, double ay, double az) {
  geometry::Polyhedron p;
  for (int k = 0; k < 8; ++k)
    p.vertices.emplace_back((k & 1 ? 0.5 : -0.5) * ax, (k & 2 ? 0.5 : -0.5) * ay, (k & 4 ? 0.5 : -0.5) * az);
  p.faces = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  return p;
}
inline geometry::Polyhedron cube(double side) { return box(side, side, side); }

/// Regular tetrahedron of edge `edge` (m), centroid at the origin.
inline geometry::Polyhedron tetrahedron(double edge) {
  const double s = edge / (2.0 * std::sqrt(2.0));
  geometry::Polyhedron p;
  p.vertices = {{s, s, s}, {s, -s, -s}, {-s, s, -s}, {-s, -s, s}};
  p.faces = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  return p;
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

}  // namespace talus::dda::testing
