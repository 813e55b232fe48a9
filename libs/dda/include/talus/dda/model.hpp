// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "talus/dda/settings.hpp"
#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/types.hpp"

namespace talus::dda {

using geometry::Mat3;
using geometry::Vec3;
using Mat12 = Eigen::Matrix<double, 12, 12>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

namespace detail {
struct BlockIndex;
}

/// One face of the block in its body frame (centroid at the origin).
struct BlockFace {
  std::vector<std::int32_t> vertices;  ///< CCW seen from outside
  Vec3 normal = Vec3::Zero();          ///< outward unit normal (body frame)
  Vec3 u = Vec3::Zero();               ///< in-plane unit axis (body frame)
  Vec3 v = Vec3::Zero();               ///< normal × u
  double offset = 0.0;                 ///< normal · x for points x of the face plane (m)
  std::vector<Eigen::Vector2d> polygon;  ///< vertices in (u, v) coordinates (m)
};

/// One edge of the block: the two vertices and whether the solid is convex there
/// (only convex edges can touch terrain edge to edge).
struct BlockEdge {
  std::int32_t a = 0;
  std::int32_t b = 0;
  bool convex = true;
};

/// The immutable description of one block and the numerical settings: everything a
/// realization reads and never writes. Build it with Model::build.
struct Model {
  Settings settings;
  DofPath dof = DofPath::rigid6;
  RestitutionLaw restitution = RestitutionLaw::scaled;
  /// The scaled law removes at most the kinetic energy of an impact's normal approach.
  bool bound_by_normal_approach = true;

  std::vector<Vec3> vertices;   ///< body frame: polyhedron vertices minus the centroid (m)
  std::vector<BlockFace> faces;
  std::vector<BlockEdge> edges;
  double longest_edge = 0.0;    ///< length of the longest edge, body frame (m)
  double volume = 0.0;          ///< m³
  double mass = 0.0;            ///< kg
  Mat3 second_moments = Mat3::Zero();  ///< ρ-free ∫ r rᵀ dV about the centroid, body frame (m⁵)
  Mat3 inertia = Mat3::Zero();  ///< inertia tensor about the centroid, body frame (kg m²)
  /// Principal moments of inertia, ascending (kg m²), and their axes as the columns of a
  /// proper rotation (body frame): the frame of Euler's equations.
  Vec3 principal_moments = Vec3::Zero();
  Mat3 principal_axes = Mat3::Identity();
  /// The principal moments agree within 1e-9 of the largest (the Platonic solids): the
  /// gyroscopic torque ω × Jω vanishes and free spin keeps ω.
  bool isotropic = false;
  double radius = 0.0;          ///< circumscribed radius about the centroid (m)
  /// Length that scales the step control (m): the circumscribed diameter, but never more
  /// than twice the block's thickness (the width along its thinnest principal axis,
  /// √(12·λ_min/V), the edge of a box), so a needle or a plate cannot move by its own
  /// thickness in one step.
  double size = 0.0;
  /// Elastic matrix (Pa) mapping (εx εy εz γyz γzx γxy) to (σx σy σz τyz τzx τxy).
  Mat6 elasticity = Mat6::Zero();
  /// Normal contact spring stiffness in use (N/m): Settings::penalty_stiffness, or from
  /// the mass and penalty_omega when that is 0.
  double stiffness = 0.0;
  /// The solid bends inwards at no edge: every edge is convex, or flat between two
  /// triangles on one plane (decided exactly).
  bool convex = true;
  /// The curved surface the facets stand for (docs/dda.md, Smooth surface), per vertex in
  /// the body frame: the unit normal (adjacent face normals weighted by their angles at
  /// the vertex), the radius ρ of the sphere tangent there that holds the neighbouring
  /// vertices on average (m; 0 at a corner: faces turning by smooth_turn_deg or more, or a
  /// vertex not convex), and the neighbours along edges (CSR: neighbours of v are
  /// vertex_neighbours[neighbour_offsets[v] .. neighbour_offsets[v + 1]]). Empty when
  /// smooth_turn_deg is 0.
  std::vector<Vec3> vertex_normals;
  std::vector<double> vertex_rounding;
  /// Per vertex, the largest angle between its normal and its faces' normals (rad): the
  /// vertex's part of the smooth surface is the cap of its sphere within this angle of
  /// the normal.
  std::vector<double> vertex_cone;
  std::vector<std::int32_t> neighbour_offsets, vertex_neighbours;
  /// The faces around each vertex (CSR, like the neighbours).
  std::vector<std::int32_t> face_offsets, vertex_faces;
  /// The most a rounded vertex contact lies below its vertex, max ρ·(1 − cos 2α) with α
  /// its vertex_cone (m): every contact search is widened by it.
  double rounding_reach = 0.0;
  /// Box trees over the vertices, convex edges and faces (body frame), through which
  /// contact detection and the step control find the features they need in logarithmic
  /// time (docs/dda.md, Detection); null for a block of few vertices, which is scanned.
  std::shared_ptr<const detail::BlockIndex> index;

  /// Validates `settings` and `block` and builds the model. Throws core::InputError
  /// (source "dda settings" or "block") with a one-line reason on bad values, an open,
  /// inside-out or degenerate polyhedron.
  static Model build(const Settings& settings, const geometry::Polyhedron& block);

  /// Largest vertex displacement allowed in one contact step (m).
  double max_step_displacement() const { return settings.max_displacement_ratio * size; }
  /// Deepest closed-contact penetration before the run fails (m).
  double penetration_limit() const { return settings.penetration_limit_ratio * 2.0 * radius; }
  /// Whether the contact search crosses the block's edges with the terrain's valleys
  /// (docs/dda.md, Detection): only for a block with an edge as long as the penetration
  /// limit. A shorter edge's ends, whose vertex contacts are as near as any crossing of a
  /// valley line, are never deeper than the crossing by that much.
  bool crosses_valleys() const { return !(longest_edge < penetration_limit()); }
};

/// The 3×12 displacement matrix T(r) of SPEC §4 at the point r = x − x₀ (world frame,
/// relative to the centroid): u(x) = T(r)·D. The first six columns are the rigid part.
Eigen::Matrix<double, 3, 12> displacement_matrix(const Vec3& r);

/// The 12×12 DDA mass matrix ρ∫T(r)ᵀT(r)dV of a block whose world-frame second moments
/// about its centroid are `second_moments` (m⁵) and volume `volume` (m³), density ρ
/// (kg/m³). Exact for the polyhedron because T is linear in r (simplex integration gives
/// the moments). Its top-left 6×6 block is diag(m, m, m, J).
Mat12 mass_matrix(double density, double volume, const Mat3& second_moments);

/// Isotropic elastic matrix in the (εx εy εz γyz γzx γxy) order (Pa).
Mat6 isotropic_elasticity(double young_modulus, double poisson_ratio);

/// Rotation matrix of the rotation vector θ (rad): exact (Rodrigues), not I + [θ]×.
Mat3 rotation_matrix(const Vec3& theta);

}  // namespace talus::dda
