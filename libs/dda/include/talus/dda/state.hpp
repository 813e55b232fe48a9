// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <string_view>
#include <utility>
#include <vector>

#include "talus/core/random.hpp"
#include "talus/dda/model.hpp"

namespace talus::dda {

/// Why a realization ended (part of the run-file format: never renumber).
enum class EndReason : std::uint8_t {
  running = 0,        ///< not ended yet
  rest = 1,           ///< kinetic energy below the threshold for the dwell time
  left_terrain = 2,   ///< the centroid left the terrain's plan bounds or fell below it
  step_limit = 3,     ///< max_steps accepted steps
  non_finite = 4,     ///< a non-finite value appeared (numerical failure)
  no_convergence = 5, ///< open–close did not settle even at the smallest Δt (numerical failure)
  penetration = 6,    ///< a contact penetrated beyond the limit (numerical failure)
};
std::string_view to_string(EndReason reason);
/// True for the three numerical-failure reasons.
bool is_failure(EndReason reason);

enum class ContactKind : std::uint8_t {
  vertex_face,  ///< block vertex against a terrain triangle
  face_vertex,  ///< terrain vertex against a block face
  edge_edge,    ///< block edge crossing a terrain edge
  /// a rounded block vertex's sphere against a terrain crest, in place of the crossings
  /// of the smooth edges around it (docs/dda.md, Smooth surface)
  vertex_ridge,
  /// a terrain crest inside a convex block deeper than its crossings hold it, held at its
  /// deepest point by the face it is least deep under (docs/dda.md, Detection)
  ridge_face,
};
enum class ContactMode : std::uint8_t { open, locked, sliding };

/// One block–terrain contact. The geometric part is recomputed each step; the mode and
/// anchors persist while the same pair of features stays in contact.
struct Contact {
  ContactKind kind = ContactKind::vertex_face;
  std::int32_t block_feature = -1;    ///< vertex, face or edge index of the block
  std::int64_t terrain_feature = -1;  ///< triangle, vertex, or edge (v_lo·2³² + v_hi)
  std::int32_t triangle = -1;         ///< a terrain triangle of the contact (its material)
  Vec3 point = Vec3::Zero();          ///< block-side point at the step start (world, m)
  Vec3 normal = Vec3::UnitZ();        ///< unit normal from the terrain toward the block
  double gap = 0.0;                   ///< signed normal distance at the step start (m), < 0 = penetration

  ContactMode mode = ContactMode::open;
  /// The mode a contact that opened for a moment resumes when it closes again: the
  /// penalty spring's micro-oscillation must not reset a locked anchor (creep) or a
  /// sliding contact's direction.
  ContactMode resume = ContactMode::locked;
  /// Penetration found when the contact was first detected (m, ≤ 0): the spring acts on
  /// the gap below it, so pushing out a penetration never injects energy.
  double gap_offset = 0.0;
  bool anchored = false;
  Vec3 body_anchor = Vec3::Zero();    ///< block material point of a locked contact (body frame, m)
  Vec3 ground_anchor = Vec3::Zero();  ///< terrain point of a locked contact (world, m)
  Vec3 slip_direction = Vec3::Zero(); ///< unit tangential slip direction of a sliding contact
  double normal_force = 0.0;          ///< at the end of the last accepted step (N)
  /// Normal force at the end of the last step the contact was closed (N): bounds the
  /// shear stretch its anchor may keep (μ·F/k_s).
  double anchor_force = 0.0;
  /// The last solve's end-of-step state of the springs: normal gap below the offset (m,
  /// ≤ 0) and shear spring force (N, infinite when not locked); a carried contact
  /// resumes from them, never from a deeper state the geometry update left.
  double spring_gap = 0.0;
  double spring_shear = std::numeric_limits<double>::infinity();
  /// The point lies on the smooth surface at a rounded vertex (docs/dda.md, Smooth
  /// surface): it moves over the block as the block rolls, and a locked contact's anchors
  /// move with it, keeping their stretch.
  bool rolling = false;
};

/// Wall-clock seconds spent per phase (filled when Settings::time_phases is on).
struct PhaseTimes {
  double flight = 0.0;      ///< flight test and exact parabola steps
  double detect = 0.0;      ///< contact detection
  double assemble = 0.0;    ///< mass, gravity, inertia terms
  double open_close = 0.0;  ///< contact terms and state judgement (excluding solves)
  double solve = 0.0;       ///< dense solves
  double update = 0.0;      ///< geometry, velocity, episodes, bookkeeping
};

/// Event counters (always on, cheap).
struct Counters {
  std::uint64_t steps = 0;            ///< accepted steps
  std::uint64_t flight_steps = 0;     ///< accepted steps advanced on the exact parabola
  std::uint64_t contact_steps = 0;    ///< accepted steps with contact search
  std::uint64_t redone_steps = 0;     ///< steps redone with a smaller Δt
  std::uint64_t impact_cuts = 0;      ///< steps shortened to end at the moment of an impact
  std::uint64_t energy_cuts = 0;      ///< steps redone with a smaller Δt because they gained energy
  std::uint64_t open_close_iterations = 0;
  std::uint64_t contacts = 0;         ///< contact candidates found, summed over steps
  /// Of those, the candidates set aside as out of the step's reach (not in the solve).
  std::uint64_t set_aside_contacts = 0;
  /// Steps solved again because their solution would have closed a candidate set aside.
  std::uint64_t widened_steps = 0;
  /// Contact steps of a detailed block whose solution moved a point as far as the near
  /// search distance, so that the full search was made after all.
  std::uint64_t far_searches = 0;
  /// Contact steps solved again without passing over candidates (contact_step, PassOver).
  std::uint64_t unpassed_steps = 0;
  /// Candidates the flight test's near search passed over (PassOver), summed over its
  /// searches.
  std::uint64_t flight_passed = 0;
  std::uint64_t offset_contacts = 0;  ///< contacts first found already penetrated
  std::uint64_t impacts_rescaled = 0; ///< rebounds the restitution law reduced
  std::uint64_t held_contacts = 0;    ///< contacts held in a state to end an open–close cycle
  std::uint64_t energy_limited = 0;   ///< contact steps whose energy gain was taken back
  /// Steps that broke an invariant (only with Settings::check_invariants).
  std::uint64_t energy_violations = 0;  ///< total energy rose beyond round-off
  std::uint64_t depth_violations = 0;   ///< terrain and block overlapped beyond the penetration limit
};

/// The contact episode in progress (an impact when its approach speed is high enough).
struct Episode {
  bool active = false;
  bool impact = false;           ///< restitution law applies at its end
  Vec3 velocity_in = Vec3::Zero();  ///< centroid velocity at the start (m/s)
  double kinetic_in = 0.0;       ///< rigid kinetic energy (translation and spin) at the start (J)
  Vec3 normal = Vec3::UnitZ();   ///< ground normal at the start, tilted laterally
  double approach_speed = 0.0;   ///< centroid speed towards the ground along the untilted normal (m/s)
  /// Kinetic energy of the fastest closing contact point's normal approach, on the block's
  /// effective mass at that point (J): what a plastic impact at that point removes.
  double point_approach_energy = 0.0;
  double restitution = 1.0;      ///< R_v drawn for this impact (-)
  double tilt_deg = 0.0;         ///< lateral tilt drawn for this impact (deg)
  double restitution_scale = 12.0;  ///< K of the material hit (m/s)
  double ploughing = 0.0;           ///< of the material hit (-)
  // What the contact-point law (RestitutionLaw::point) needs of the impact.
  Vec3 spin_in = Vec3::Zero();   ///< angular velocity at the start, world frame (rad/s)
  Vec3 point_in = Vec3::Zero();  ///< fastest closing point at the start, from the centroid (m)
  double impulse = 0.0;          ///< normal impulse of the impact's contacts so far (N·s)
  Vec3 impulse_moment = Vec3::Zero();  ///< Σ impulse × contact point from the centroid (N·s·m)
};

/// What the block is doing at a trajectory sample (part of the run-file format).
enum class Motion : std::uint8_t {
  flight = 0,   ///< no contact closed
  impact = 1,   ///< inside an impact, before the restitution law has set the rebound
  contact = 2,  ///< rolling, sliding or resting on the ground
};

struct TrajectorySample {
  double time = 0.0;               ///< s
  Vec3 position = Vec3::Zero();    ///< centroid (m)
  Vec3 velocity = Vec3::Zero();    ///< centroid (m/s)
  double height = 0.0;             ///< centroid above the terrain surface (m), NaN off terrain
  double energy = 0.0;             ///< kinetic + potential (J), potential from z = 0
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< body → world
  Vec3 angular_velocity = Vec3::Zero();  ///< world frame (rad/s)
  Motion motion = Motion::flight;
};

/// Release conditions of one realization.
struct Release {
  Vec3 position = Vec3::Zero();  ///< centroid (m)
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< body → world
  Vec3 velocity = Vec3::Zero();          ///< centroid velocity (m/s)
  Vec3 angular_velocity = Vec3::Zero();  ///< world frame (rad/s)
  /// Horizontal main slope direction for runout and lateral displacement (normalized).
  Eigen::Vector2d main_direction = Eigen::Vector2d::UnitX();
};

/// Everything of one realization that changes: a checkpoint is a copy of it. What a
/// step keeps only to go faster (terrain patches, caches, buffers) is in the Workspace
/// it is stepped with (engine.hpp), never here.
struct State {
  double time = 0.0;                  ///< s
  double dt = 0.0;                    ///< Δt of the next step (s)
  Vec3 position = Vec3::Zero();       ///< centroid (m)
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Mat3 stretch = Mat3::Identity();    ///< full12: body-frame deformation U (x = c + R U r_body)
  /// [v (m/s), ω (rad/s), strain rates (1/s)] in the world frame; rigid6 uses the first six.
  Vec12 velocity = Vec12::Zero();

  /// Contacts of the last accepted step: the closed ones, and those that opened by less
  /// than a micro-gap and keep their memory.
  std::vector<Contact> contacts;
  double clear_until = -1.0;          ///< no terrain contact is possible before this time (s)
  bool last_step_contact = false;     ///< the last accepted step searched for contacts
  Episode episode;
  double friction = 0.0;              ///< friction coefficient in force (drawn per impact)
  bool friction_drawn = false;
  core::RandomSequence impacts_rng{core::RandomStream(0, core::Stream::impact, 0)};

  // Realization bookkeeping.
  /// Kinetic energy ½vᵀMv of the state (J), kept current by start() and every step.
  double kinetic = 0.0;
  /// Centroid above the terrain surface at `time`, vertically (m); NaN off the terrain
  /// and before the first step.
  double height = std::numeric_limits<double>::quiet_NaN();
  Release release;
  std::uint64_t impacts = 0;
  double max_speed = 0.0;             ///< centroid (m/s)
  bool touched = false;               ///< a contact has closed (the block has touched the terrain)
  double max_jump_height = 0.0;       ///< centroid above the terrain, vertically, after the first touch (m)
  double max_normal_jump_height = 0.0;  ///< centroid above the triangle below, along its normal, after the first touch (m)
  double rest_time = 0.0;             ///< time spent below the rest threshold (s)
  /// Energy held by the contact springs at the end of the last step (J).
  double stored_energy = 0.0;
  double energy_removed = 0.0;        ///< kinetic energy taken back by the energy limiter (J)
  // Invariant checks (Settings::check_invariants).
  double checked_energy = std::numeric_limits<double>::quiet_NaN();  ///< total energy after the last step (J)
  double max_energy_gain = 0.0;       ///< largest rise of the total energy in one step (J)
  double max_depth = 0.0;             ///< deepest overlap of terrain and block (m)
  double time_limit = std::numeric_limits<double>::infinity();  ///< simulated-time limit (s), set at the first step
  EndReason end = EndReason::running;
  Counters counters;
  PhaseTimes times;
  std::vector<TrajectorySample> trajectory;
  double next_sample_time = 0.0;
};

}  // namespace talus::dda
