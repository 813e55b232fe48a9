// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "talus/core/random.hpp"
#include "talus/dda/model.hpp"
#include "talus/dda/state.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::dda {

/// The fixed ground of a realization: one terrain realization and its materials
/// (indexed by Surface::material). Both must outlive every step that uses them.
struct Ground {
  const terrain::Surface* surface = nullptr;
  std::span<const terrain::Material> materials;
};

/// Switches between the engine's fast paths and the slower reference paths they must equal
/// to the bit, for the tests that compare them (docs/dda.md, "Reference paths"). The
/// defaults are the engine's own paths.
struct ReferencePaths {
  /// How many times its point's motion at the step-start motion a candidate's gap may be
  /// before a contact step sets it aside (-): ∞ keeps every candidate in the solve, a tiny
  /// value sets almost all aside and makes the step widen again and again.
  double set_aside_scale = 2.0;
  /// A near search passes over the candidates a step would set aside; false: none.
  bool pass_over = true;
  /// Every block's edges are crossed with the terrain's valleys, whatever their length
  /// (Model::crosses_valleys); the reference a search without them is compared with.
  bool cross_every_valley = false;
};

namespace detail {
struct Scratch;
}

/// What a realization's steps keep from one step to the next only to go faster (the
/// terrain features near the block, the feature pairs gathered from them, buffers): no
/// result depends on it, and a checkpoint (a copy of the State) does not hold it. One per
/// realization, used with one Ground throughout.
class Workspace {
 public:
  explicit Workspace(const ReferencePaths& paths = {});
  ~Workspace();
  Workspace(Workspace&&) noexcept;
  Workspace& operator=(Workspace&&) noexcept;
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;
  /// The engine's own view of it.
  detail::Scratch& scratch() { return *impl_; }

 private:
  std::unique_ptr<detail::Scratch> impl_;
};

/// The initial state of a realization: the block at `release`, per-impact draws from
/// `impact_stream` (core::Stream::impact of the realization). Throws core::InputError
/// ("release") on a non-finite release or a zero main direction.
State start(const Model& model, const Release& release, core::RandomStream impact_stream);

/// Advances `state` by one accepted step (or ends it; see State::end). Phases: flight
/// test (exact parabola when no contact is possible), contact detection, assembly,
/// open–close iteration with solves, update. Never throws for numerical trouble: that
/// ends the realization with a failure reason. Throws core::InputError ("terrain") if a
/// triangle names a material that `ground` lacks. Does nothing once ended. `workspace`
/// is the realization's own (Workspace).
void step(const Model& model, const Ground& ground, State& state, Workspace& workspace);

/// Per-realization result.
struct Summary {
  EndReason end = EndReason::running;
  double time = 0.0;                     ///< simulated time at the end (s)
  std::uint64_t steps = 0;
  Vec3 final_position = Vec3::Zero();    ///< centroid (m)
  double runout = 0.0;     ///< along the main direction from the release point (m)
  double lateral = 0.0;    ///< across it, positive to the left of the main direction (m)
  double max_speed = 0.0;  ///< centroid (m/s)
  double max_jump_height = 0.0;  ///< centroid above the terrain surface, vertically, from the first touch on (m)
  /// Centroid distance to the plane of the triangle below it, along that triangle's
  /// normal, from the first touch on (m): the jump measured normal to the slope.
  double max_normal_jump_height = 0.0;
  std::uint64_t impacts = 0;
  /// With Settings::check_invariants: the largest one-step rise of the total energy
  /// (kinetic + potential + contact springs) (J) and the deepest overlap of terrain and
  /// block (m) seen in the run.
  double max_energy_gain = 0.0;
  double max_depth = 0.0;
  double energy_removed = 0.0;  ///< kinetic energy the energy limiter took back (J, see docs/dda.md)
  Counters counters;
  PhaseTimes times;
  std::vector<TrajectorySample> trajectory;  ///< empty unless trajectory_interval > 0
};

/// Summary of `state` (runout and lateral from the release point).
Summary summarize(const State& state);

/// Runs one realization to its end: start, step until ended, summarize. A pure function
/// of its arguments (same bits at any thread count).
Summary run(const Model& model, const Ground& ground, const Release& release,
            core::RandomStream impact_stream);

/// The block's vertices in the world frame (m), in the order of Model::vertices.
std::vector<Vec3> world_vertices(const Model& model, const State& state);

/// Kinetic energy ½ vᵀMv of the state (J).
double kinetic_energy(const Model& model, const State& state);
/// Kinetic plus gravitational potential energy (z = 0 reference) (J).
double mechanical_energy(const Model& model, const State& state);

}  // namespace talus::dda
