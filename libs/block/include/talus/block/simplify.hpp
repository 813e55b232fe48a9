// SPDX-License-Identifier: MIT
#pragma once
#include <cstddef>
#include <string>

#include "talus/block/block.hpp"
#include "talus/geometry/polyhedron.hpp"

namespace talus::block {

/// What a level-of-detail reduction changed, so users can weigh detail against speed.
struct SimplifyReport {
  std::size_t faces_before = 0;   ///< polygon faces
  std::size_t faces_after = 0;
  double volume_change = 0.0;     ///< (V_after − V_before) / V_before (−)
  double inertia_change = 0.0;    ///< ‖J_after − J_before‖_F / ‖J_before‖_F, about each centroid (−)
  double sphericity_change = 0.0; ///< ψ_after − ψ_before (−)
  std::string describe() const;   ///< one line
};

/// Reduces a closed triangle-faced polyhedron to at most `target_faces` triangles by
/// edge collapse (Lindstrom–Turk placement, which preserves volume to first order), then
/// re-validates it. Throws core::InputError(source, …) if the target is below 4 or the
/// result is no longer a valid solid.
geometry::Polyhedron simplify_to_faces(const geometry::Polyhedron& poly, std::size_t target_faces,
                                       const std::string& source);

/// Replaces a polyhedron by the convex hull of its vertices.
geometry::Polyhedron simplify_to_hull(const geometry::Polyhedron& poly, const std::string& source);

/// Compares two blocks (before, after).
SimplifyReport compare(const Block& before, const Block& after);

}  // namespace talus::block
