// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/types.hpp"

namespace talus::block {

/// Reference rock density (SPEC §4), kg/m³.
inline constexpr double kDefaultDensity = 2800.0;
/// Volumes a block may have (m³): from a pebble of 1 cm³ to a rock mass of 1e6 m³.
/// Outside them the exact volume and the engine's scales leave the double range.
inline constexpr double kMinVolume = 1e-6;
inline constexpr double kMaxVolume = 1e6;
/// The least ratio of a block's smallest to its largest principal extent: below it the
/// block is a sheet, which the contact model cannot hold (terrain points pass through it;
/// a 6 × 5 m hull 0.56 mm thick cut the step to 4 µs, and a realization would have run
/// for hours).
inline constexpr double kMinThicknessRatio = 1e-3;

/// A rock as the DDA engine consumes it: a closed, 2-manifold, outward-oriented
/// polyhedron in its centroid frame and its mass properties. Every property except
/// `centroid` is about the centroid; tensors and axes are expressed in the input axes
/// (the centroid frame is the input frame translated, `rotation` is the identity for
/// blocks built by Talus).
struct Block {
  std::string name;
  /// Vertices in the centroid frame (m); faces CCW seen from outside, planar and convex.
  geometry::Polyhedron polyhedron;

  double volume_exact = 0.0;      ///< m³: exact rational simplex integration, rounded
  std::string volume_rational;    ///< m³: the same exact value as "p/q"
  double volume = 0.0;            ///< m³: double-precision simplex integration
  geometry::Vec3 centroid = geometry::Vec3::Zero();  ///< m, in the input frame
  /// ∫ x xᵀ dV about the centroid (m⁵): the second moments the 12-DOF matrices use.
  geometry::Mat3 second_moments = geometry::Mat3::Zero();
  geometry::Mat3 inertia_per_density = geometry::Mat3::Zero();  ///< m⁵: tr(S)·I − S
  geometry::Mat3 inertia = geometry::Mat3::Zero();              ///< kg·m²: density × the above
  geometry::Vec3 principal_moments = geometry::Vec3::Zero();    ///< kg·m², ascending
  /// Columns are the unit principal axes matching `principal_moments` (right-handed).
  geometry::Mat3 principal_axes = geometry::Mat3::Identity();
  double surface_area = 0.0;      ///< m²
  double sphericity = 0.0;        ///< Wadell ψ = π^(1/3) (6V)^(2/3) / A (−)
  /// Extents along the principal axes, sorted L1 ≥ L2 ≥ L3 (m). Where principal moments
  /// tie (isotropic blocks such as the Platonic solids) the axes inside the tied
  /// subspace point to the vertex farthest from the centroid, so the values do not
  /// depend on how the input was rotated.
  geometry::Vec3 dimensions = geometry::Vec3::Zero();
  double density = kDefaultDensity;  ///< kg/m³
  double mass = 0.0;                 ///< kg
  /// Back to the input frame: x_input = rotation · x_block + translation (m).
  geometry::Mat3 rotation = geometry::Mat3::Identity();
  geometry::Vec3 translation = geometry::Vec3::Zero();
  double weight = 1.0;               ///< relative sampling weight in a block library (−)
  std::string source;                ///< what it was made from (a solid name or a file)
  std::vector<std::string> notes;    ///< repairs and simplifications made, one line each
};

/// The exact volume of a polyhedron (fan-triangulated faces) from its double
/// coordinates: every coordinate is a dyadic rational, so the simplex sum is evaluated
/// exactly in GMP integers.
struct ExactVolume {
  double value = 0.0;    ///< m³, the exact value rounded toward zero to a double
  std::string rational;  ///< m³, "p/q" in lowest terms
};
ExactVolume exact_volume(const geometry::Polyhedron& poly);

/// Builds a block from a valid polyhedron given in the input frame (closed, outward,
/// see check_mesh): computes the properties and moves the vertices to the centroid frame.
/// Throws core::InputError(source, …) if the volume is not positive or the density is
/// not positive and finite.
Block make_block(const std::string& name, const geometry::Polyhedron& input_frame, double density,
                 const std::string& source);

/// Extents of a polyhedron along its principal axes (see Block::dimensions).
struct PrincipalBox {
  geometry::Vec3 lengths = geometry::Vec3::Zero();  ///< L1 ≥ L2 ≥ L3 (m)
  geometry::Mat3 axes = geometry::Mat3::Identity();  ///< column i: direction of length i
};
/// `centred` has its centroid at the origin; `inertia` is its inertia tensor (any scale).
PrincipalBox principal_box(const geometry::Polyhedron& centred, const geometry::Mat3& inertia);

/// Sets density-dependent fields (inertia, principal moments, mass) from `density`.
void set_density(Block& block, double density);

/// Uniform scale factor that brings `volume` to `target_volume` (both m³).
double scale_to_volume(double volume, double target_volume);

}  // namespace talus::block
