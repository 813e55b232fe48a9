// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <vector>

#include "talus/geometry/types.hpp"

namespace talus::geometry {

/// A closed polyhedron with polygonal faces (vertices in m). Each face lists vertex
/// indices counter-clockwise seen from outside; faces may be non-convex polygons only if
/// planar. This is the plain exchange form; block-gen builds and validates it through a
/// half-edge structure.
struct Polyhedron {
  std::vector<Vec3> vertices;
  std::vector<std::vector<std::int32_t>> faces;
};

/// Properties of a homogeneous solid of unit density, by simplex integration over a fan
/// triangulation of each face (double arithmetic).
struct MassProperties {
  double volume = 0.0;            ///< m³
  Vec3 centroid = Vec3::Zero();   ///< m
  /// ∫ (x−c)(x−c)ᵀ dV about the centroid (m⁵): the second moments the 12-DOF DDA
  /// matrices are built from.
  Mat3 second_moments = Mat3::Zero();
  /// Inertia tensor about the centroid per unit density (m⁵): tr(S)·I − S.
  Mat3 inertia = Mat3::Zero();
  double surface_area = 0.0;      ///< m²
};

MassProperties mass_properties(const Polyhedron& poly);

/// Wadell sphericity ψ = π^(1/3) (6V)^(2/3) / A (−): 1 for a sphere.
double sphericity(double volume, double surface_area);

}  // namespace talus::geometry
