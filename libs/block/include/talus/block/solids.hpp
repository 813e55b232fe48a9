// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/types.hpp"

namespace talus::block {

/// The named solids block-gen makes without an input file.
enum class SolidKind { tetrahedron, cube, octahedron, dodecahedron, icosahedron, box, ellipsoid, rock };

std::optional<SolidKind> parse_solid_kind(std::string_view name);
std::string_view solid_name(SolidKind kind);

struct SolidSpec {
  SolidKind kind = SolidKind::cube;
  /// Target volume (m³). The Platonic solids and rocks need it; a box or ellipsoid keeps
  /// its `dimensions` when it is ≤ 0 and is scaled uniformly to it otherwise.
  double volume = 1.0;
  /// Box edges or ellipsoid diameters along x, y, z (m).
  geometry::Vec3 dimensions = geometry::Vec3::Ones();
  /// Ellipsoid: geodesic frequency n, giving 20·n² triangles (n ≥ 1).
  int resolution = 8;
  /// Ellipsoid: standard deviation of the relative height of 40 random smooth bumps and
  /// dents (−), up to 0.3; 0 gives a smooth convex ellipsoid, more a rough, concave rock
  /// (the same rock at every resolution).
  double roughness = 0.0;
  /// Rock: target L2/L1 along the principal axes (−), in (0, 1].
  double elongation = 0.7;
  /// Rock: target L3/L2 along the principal axes (−), in (0, 1].
  double flatness = 0.7;
  /// Rock: number of random points whose convex hull is the rock (≥ 8).
  int points = 40;
  /// Seed and index of the Stream::block_shape draws (rock, rough ellipsoid).
  std::uint64_t seed = 1;
  std::uint32_t index = 0;
};

/// Builds a named solid: closed, outward, planar convex faces (the Platonic solids and
/// boxes have their true polygon faces). Throws core::InputError(source, …) for
/// parameters out of range.
geometry::Polyhedron make_solid(const SolidSpec& spec, const std::string& source);

/// Convex hull of a handful of points (up to a few dozen) by brute force over vertex
/// triples, faces as true polygons: exact face structure for symmetric solids whose
/// coplanar vertices are only coplanar to round-off. `tolerance` in m.
geometry::Polyhedron small_convex_hull(const std::vector<geometry::Vec3>& points, double tolerance);

}  // namespace talus::block
