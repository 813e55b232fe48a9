// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>

#include "talus/core/settings.hpp"

namespace talus::dda {

/// Which unknowns a block carries.
enum class DofPath : std::uint8_t {
  rigid6,  ///< translation + rotation (the fast default)
  full12,  ///< SPEC §4: translation, rotation and six constant strains
};

/// How the impact–rebound law limits the DDA rebound (docs/dda.md).
enum class RestitutionLaw : std::uint8_t {
  off,               ///< the raw DDA rebound is kept
  scaled,            ///< |V_out| ≤ R_v·SF·|V_in| on the whole velocity (SPEC §4)
  normal_component,  ///< |V_out·n| ≤ R_v·SF·|V_in·n| on the normal component only
  point,             ///< a rigid impact at the contact point: normal restitution, Coulomb friction
};

/// Numerical and physical settings of the engine, with defaults (SI units). A driver may
/// override them (YAML, --set) through visit(); Model::build validates them.
/// How far a block may move in one nominal step, over its circumscribed diameter, at its
/// fastest before the step costs it rebound (-): a 0.1 m cube striking a plane at 50 m/s
/// (0.29) rebounded to 3.7 m at 1 ms against 8.5 m at 0.1 ms, a 0.46 m cube (0.06) to 7.7
/// against 8.5 m; 1 m³ blocks at bench-slope speeds (0.01) agree with the 0.1 ms reference
/// (docs/dda-run.md, "Time step"). The default of max_step_travel, and the share beyond
/// which dda-run warns.
inline constexpr double kMaxStepTravel = 0.03;

struct Settings {
  /// A measured trade of run time against error (docs/benchmarks.md, "Run time against
  /// error"): "screening", "design" (the defaults) or "research". Reading a preset sets
  /// the numerical fields it names (apply_preset); fields given explicitly beside it win.
  std::string preset = "design";
  std::string dof = "rigid6";               ///< "rigid6" or "full12"
  double time_step = 1e-3;                  ///< nominal Δt (s)
  /// Longest travel of a block in one nominal step, over its circumscribed diameter, at the
  /// fastest speed its scene allows (-): a scene shortens time_step for a block that would
  /// travel farther (mc::Scene::build; small fast blocks lose rebound otherwise, docs/dda-run.md,
  /// "Time step"); 0 = time_step for every block. The engine itself reads time_step only.
  double max_step_travel = kMaxStepTravel;
  double min_time_step = 1e-7;              ///< smallest Δt the step control may cut to (s)
  /// Largest vertex displacement per contact step as a fraction of the block's
  /// circumscribed diameter (-). Scaled from the block, not the terrain (docs/dda.md).
  double max_displacement_ratio = 0.02;
  double dynamic_coefficient = 1.0;         ///< velocity carried to the next step (-), 1 = fully dynamic
  /// Normal contact spring (N/m); 0 (the default) sets it from the block:
  /// k = m·(penalty_omega/time_step)², so every block of a library is equally well posed.
  double penalty_stiffness = 0.0;
  /// √(k/m)·Δt of one normal contact spring when penalty_stiffness is 0 (-): how stiff the
  /// contact is relative to the block's inertia over one nominal step (docs/dda.md).
  double penalty_omega = 20.0;
  double shear_stiffness_ratio = 2.5;       ///< normal over shear spring stiffness h₂ (-)
  /// Open–close iterations after which a contact that changes state is held in its new
  /// state for the rest of the step (-): the iteration always ends (docs/dda.md).
  std::int64_t max_open_close_iterations = 8;
  /// A contact step whose solution gains more energy than this fraction of the kinetic
  /// energy plus m·g·radius is redone with a shorter step (-); 0 = never redone (the
  /// energy limiter alone takes the gain back). Nothing in the model is a source, so the
  /// gain is the step's error (docs/dda.md, Energy limiter).
  double max_step_energy_gain = 0.01;
  /// A closed contact deeper than this fraction of the block diameter ends the run as a
  /// numerical failure (-).
  double penetration_limit_ratio = 0.05;
  double gravity = 9.81;                    ///< m/s², along −z

  std::string restitution = "scaled";       ///< "scaled", "normal_component", "point" or "off"
  /// An episode whose normal approach speed is below this is rolling/sliding, not an
  /// impact: no restitution limit, no draws, no 12-DOF strain hold (m/s).
  double impact_min_normal_speed = 0.5;
  /// "normal_approach": the scaled law removes at most the kinetic energy of the
  /// impact's normal approach, ½·m·(V_in·n)² (docs/dda.md); "none": no bound.
  std::string restitution_bound = "normal_approach";
  /// A block's facets stand for a curved surface where the faces around a vertex turn by
  /// less than this (deg): vertex contacts lie on the surface blended from the spheres
  /// tangent at the vertices (docs/dda.md, Smooth surface); 0 = the polyhedron exactly,
  /// every vertex a corner. 40 (default) keeps every Platonic solid a polyhedron.
  double smooth_turn_deg = 40.0;
  /// Rolling resistance coefficient μ_r (-): a contact closed through a step resists the
  /// block's rotation relative to the ground with a torque of at most μ_r·r·F_n (r the
  /// contact's distance from the centroid), which stops a rotation and never reverses it;
  /// a ball rolls down θ with (5/7)·g·(sin θ − μ_r·cos θ) (docs/dda.md, Rolling
  /// resistance). 0 = none.
  double rolling_resistance = 0.1;
  /// full12 only: let the strains respond during impact episodes (the reference model's
  /// behaviour; the strain mode then keeps most of the impact energy, docs/dda.md).
  bool impact_strains = false;

  double rest_kinetic_energy = 1e-3;        ///< rest threshold on kinetic energy per unit mass (J/kg)
  double rest_dwell = 0.5;                  ///< time below the threshold that means rest (s)
  /// Longest contact step of a rigid6 block that is slow (slow_kinetic_energy) or has
  /// been below the rest threshold for a fifth of rest_dwell, over time_step (-): such a
  /// block moves too little for the nominal step to matter, and its steps grow (×1.3 a
  /// step) up to this; 1 = no growth. The springs keep their stiffness (set from
  /// time_step), docs/dda.md, Step control.
  double rest_step_ratio = 4.0;
  /// Longest flight step of a rigid6 block, over time_step (-): within the time the
  /// flight test proves the block clear of the terrain the motion is the exact parabola
  /// and spin whatever the step, so it is taken in steps of up to this many nominal
  /// ones; what they sample (heights, hazard cells) is measured in docs/benchmarks.md.
  /// 1 = nominal flight steps.
  double flight_step_ratio = 8.0;
  /// Kinetic energy per unit mass (translation and spin) below which a rigid6 block
  /// outside an impact grows its contact steps like a settling one, up to
  /// rest_step_ratio·time_step (J/kg); 0 = only blocks in the rest dwell grow them.
  /// Default ½·(0.5 m/s)²: no approach of such a block is an impact's (docs/dda.md).
  double slow_kinetic_energy = 0.125;
  /// Simulated-time limit of a realization (s); 0 = from the terrain: 60 s plus the time
  /// to cross the terrain's plan diagonal at 1 m/s.
  double max_time = 0.0;
  std::int64_t max_steps = 0;               ///< limit on accepted steps (-), 0 = none
  double trajectory_interval = 0.0;         ///< sampled trajectory spacing (s), 0 = none

  double density = 2800.0;                  ///< block density (kg/m³)
  double young_modulus = 3.0e10;            ///< block E (Pa), full12 only
  double poisson_ratio = 0.2;               ///< block ν (-), full12 only

  /// Check the physical invariants at every step (no terrain point deeper in the block,
  /// nor block vertex deeper in the terrain, than the penetration limit; no rise of the
  /// total energy): counted in Counters, slow, for stress tests.
  bool check_invariants = false;
  /// Test before each step with no closed contact whether any contact can close in it,
  /// and move the block on its free motion without a contact search when none can
  /// (docs/dda.md, The step). Off, every step is a contact step (a search, and a solve
  /// that gives the free motion to round-off when nothing closes): the records part as
  /// chaotic trajectories do; for measuring what the test saves (docs/benchmarks.md).
  bool flight_test = true;
  bool time_phases = false;                 ///< time each phase with steady_clock (costs ~0.1 µs/step)

  void visit(core::SettingsVisitor& v);
};

/// Sets the numerical fields of `preset` ("screening", "design" or "research") in `s`;
/// throws core::InputError for another name.
void apply_preset(Settings& s, const std::string& preset);

}  // namespace talus::dda
