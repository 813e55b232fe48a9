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
};

struct TrajectorySample {
  double time = 0.0;               ///< s
  Vec3 position = Vec3::Zero();    ///< centroid (m)
  Vec3 velocity = Vec3::Zero();    ///< centroid (m/s)
  double height = 0.0;             ///< centroid above the terrain surface (m), NaN off terrain
  double energy = 0.0;             ///< kinetic + potential (J), potential from z = 0
};

/// A detailed block's box (the box of its world vertices) at the pose it was computed at,
/// reused at later poses close to it (scratch: the contacts never depend on it).
struct BlockBox {
  const void* model = nullptr;  ///< the Model it was computed for; null: none
  Vec3 centre = Vec3::Zero();   ///< the pose: x = centre + map·r
  Mat3 map = Mat3::Identity();
  geometry::Aabb box;           ///< m
  bool rigid = false;           ///< map is a rotation (the 6-DOF path)
};

/// The terrain features near the block, gathered once and reused by the contact search
/// of the following steps while the block's search box stays inside `box` (scratch: the
/// result never depends on it).
struct TerrainPatch {
  const void* surface = nullptr;     ///< the Surface it was gathered from
  geometry::Aabb box;                ///< the queried box (m)
  struct Triangle {
    std::int32_t index = -1;
    std::array<std::int32_t, 3> ids{};
    std::array<Vec3, 3> p;           ///< corners (m)
    Vec3 normal = Vec3::UnitZ();     ///< unit, up / outward
    geometry::Aabb box;
  };
  struct Vertex {
    std::int32_t id = -1;
    std::int32_t triangle = -1;      ///< one triangle using it (material)
    Vec3 p = Vec3::Zero();
    /// Its neighbours: unit directions towards the other corners of its triangles, in
    /// `neighbours` from `first` (count `count`).
    std::int32_t first = 0, count = 0;
  };
  /// An edge between two non-coplanar triangles (a crest or a valley), or on the patch
  /// border.
  struct Ridge {
    std::int32_t a = -1, b = -1;     ///< vertex ids, a < b
    Vec3 pa = Vec3::Zero(), pb = Vec3::Zero();
    Vec3 normal_sum = Vec3::Zero();  ///< sum of the adjacent triangles' normals
    std::array<Vec3, 2> normals{Vec3::Zero(), Vec3::Zero()};  ///< the first two of those normals
    std::int32_t normal_count = 0;   ///< the number of adjacent triangles (in the patch)
    /// Two triangles that bend down from each other across the edge (a crest): the ground
    /// there is under both planes, not under either as in a valley.
    bool convex = false;
    std::int32_t triangle = -1;
    geometry::Aabb box;
    /// The unit direction of normal_sum across the edge (its part along the edge taken
    /// out; zero where it has none): a block edge with both ends more than a distance
    /// above the edge along it crosses the edge's line no nearer (contacts.cpp,
    /// detect_indexed).
    Vec3 out = Vec3::Zero();
    double out_allowance = 0.0;  ///< round-off of values along `out` (m): 1e-9 of the coordinates
    /// Two triangles that bend up from each other across the edge (a valley): only a
    /// block that crosses valleys (Model::crosses_valleys) searches it.
    bool valley() const { return normal_count == 2 && !convex; }
    /// The edge as an edge–edge contact's terrain feature: its vertex ids a and b.
    std::int64_t key() const { return (static_cast<std::int64_t>(a) << 32) | static_cast<std::int64_t>(b); }
  };
  std::vector<Triangle> triangles;
  std::vector<Vertex> vertices;
  std::vector<Vec3> neighbours;      ///< see Vertex::first
  std::vector<Ridge> ridges;
  std::vector<std::int32_t> query;   ///< scratch for Surface::triangles_in_box
  /// The feature pairs a block of few vertices may form contacts with, gathered at one
  /// pose with wider distances than a step asks, and tested afresh at every step while the
  /// block has moved less than the difference: every pair the step's search would find
  /// is among them, in the order it would find them (docs/dda.md, Detection). A detailed
  /// block's are gathered per terrain triangle and ridge (Pairs; docs/dda.md, "Reusing the
  /// pairs"). Indices into the lists above and into the block's features.
  struct Candidates {
    /// The pose and distances pairs were gathered at.
    struct Gathering {
      const void* model = nullptr;       ///< the Model they were gathered for; null: none
      Vec3 centre = Vec3::Zero();        ///< the pose they were gathered at: x = centre + map·r
      Mat3 map = Mat3::Identity();
      bool rigid = false;                ///< map is a rotation (the 6-DOF path)
      double ds = 0.0, depth = 0.0;      ///< search distance and depth limit gathered with (m)
      /// A detailed block's: how far its points may move from that pose (m) while the
      /// pairs serve (their prism and plane tests were widened by it); ∞ for a scanned one.
      double motion = std::numeric_limits<double>::infinity();
      /// A detailed block's triangles or ridges were taken by their boxes within this of
      /// its box (m): they serve while that distance, less its motion, holds the search's.
      double box_margin = 0.0;
    };
    /// A detailed convex block's vertex walk that pairs came from (docs/dda.md, "Reusing
    /// the pairs"). Every vertex the walk under a plane left out lies above that plane by
    /// at least `rise` times its body-frame distance from `pivot` over `reach`, so while
    /// the block turns by less than rise/reach the walk's pairs serve as long as the
    /// points within `reach` of `pivot` move by no more than the gathering's motion.
    struct Cap {
      Vec3 pivot = Vec3::Zero();  ///< the walk's lowest vertex (body frame, m)
      double reach = 0.0;         ///< every vertex walked and its edges lie within it of pivot (m)
      double rise = 0.0;          ///< the plane's level over the pivot (m)
    };
    /// A detailed block's pairs with one triangle (its vertices) or one ridge (its convex
    /// edges), gathered on their own, and what their reuse rests on.
    struct Pairs : Gathering {
      enum class Basis : std::uint8_t {
        none,     ///< not gathered yet
        above,    ///< the block lies wholly above the triangle's plane, by `room` (m)
        beside,   ///< the block lies wholly beside the triangle's prisms, by `room` (m)
        apart,    ///< the block lies apart from the ridge, `room` (m) for margin and motion
        walked,   ///< found by the walk of `cap`
        queried,  ///< found by a tree query: every point's motion counts
      };
      Basis basis = Basis::none;
      std::uint64_t search = 0;  ///< the search that gathered them (Candidates::searches)
      double travelled = 0.0;    ///< Candidates::travelled then (m)
      double room = 0.0;
      /// The last search that tested their reuse on the two poses (detect_contacts): the
      /// motion since they were gathered it found, that of the walk's pivot and the turn
      /// (m, m, -; Motion), with Candidates::travelled and turned then. Later searches bound
      /// these by adding what the sums grew by since, and test on the poses only when
      /// that bound does not show them to serve.
      struct Checked {
        double moved = std::numeric_limits<double>::infinity();
        double pivot = 0.0, turn = 0.0;
        double travelled = 0.0, turned = 0.0;
      };
      Checked checked;
      Cap cap;
      std::vector<std::int32_t> features;  ///< block vertices or edges, ascending
      /// The features' body-frame points by coordinate, for the search's first tests in
      /// one pass each (m): of vertices x of each, then y, then z; of edges the same for
      /// their ends a, then for their ends b.
      std::vector<double> coordinates;
    };
    /// Of all the pairs of a scanned block; of a detailed block's triangles, by their boxes.
    Gathering gathering;
    /// Of a detailed block's ridges, by their boxes.
    Gathering ridge_gathering;
    std::vector<std::int32_t> triangles;                          ///< may meet the block's box
    /// A scanned block's (triangle, block vertex) pairs.
    std::vector<std::pair<std::int32_t, std::int32_t>> vertex_triangle;
    std::vector<std::int32_t> vertices;                           ///< a scanned block's terrain vertices
    std::vector<std::int32_t> ridges;                             ///< may meet the block's box
    std::vector<std::pair<std::int32_t, std::int32_t>> edge_ridge;  ///< a scanned block's (block edge, ridge)
    /// A detailed block's pairs with each of `triangles` and of `ridges` (at the same place).
    std::vector<Pairs> triangle_pairs, ridge_pairs;
    /// A detailed block's searches so far: pairs gathered in one search share its pose.
    std::uint64_t searches = 0;
    /// The sum, over a detailed block's searches, of how far its points moved at most
    /// since the search before (m), and the pose of the last search: the difference of
    /// two sums bounds every point's motion between those searches.
    double travelled = 0.0;
    /// The same sum of how far the block turned at most since the search before (the
    /// bound ‖ΔF‖ of Motion::turn), which bounds its turn between those searches.
    double turned = 0.0;
    Gathering last_search;
  };
  Candidates candidates;
};

/// The terrain triangles the flight test last gathered from the surface (when the block's
/// swept box lies outside the contact search's patch), with what the test reads of each.
struct FlightPatch {
  const void* surface = nullptr;     ///< the Surface it was gathered from
  geometry::Aabb box;                ///< the queried box (m)
  struct Triangle {
    geometry::Aabb box;              ///< of its corners (m)
    Vec3 normal = Vec3::UnitZ();     ///< Surface::normal
    std::array<Vec3, 3> p;           ///< corners (m)
  };
  std::vector<Triangle> triangles;
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

/// Everything of one realization that changes: a checkpoint is a copy of it.
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

  // Scratch buffers, kept to avoid allocations per step. A State is stepped with one
  // Ground throughout (the patch is re-gathered if the surface changes).
  TerrainPatch patch;
  FlightPatch flight_patch;
  std::vector<std::int32_t> scratch_triangles;
  std::vector<Contact> scratch_contacts;
  /// The search distance (m) of the contact search whose candidates scratch_contacts
  /// holds for the current pose (the flight test's, which a contact step from the same
  /// pose with the same distance reuses), or a negative value when it holds none.
  double scratch_reach = -1.0;
  /// What that search passed over (detail::PassOver, a rigid detailed block's near search
  /// with no contact carried): how many candidates, and the least bound of their gaps (m).
  std::size_t scratch_passed = 0;
  double scratch_least_gap = std::numeric_limits<double>::infinity();
  std::vector<Vec3> scratch_vertices;  ///< world vertices of a scanned block (m)
  BlockBox scratch_box;                ///< a detailed block's box at an earlier pose
};

}  // namespace talus::dda
