// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"

namespace talus::calibrate {

/// One fitted parameter: a material property of the terrain's ground, with its prior.
struct FittedParameter {
  std::string material;                       ///< name of a terrain material (none for roughness_sigma)
  std::string parameter = "restitution_mean"; ///< one of the six material properties, or roughness_sigma
  std::string prior = "uniform";              ///< "uniform" on [min, max], or "normal" truncated to it
  // No defaults: a prior is the user's statement (NaN: not given).
  double min = std::numeric_limits<double>::quiet_NaN();   ///< in the parameter's unit
  double max = std::numeric_limits<double>::quiet_NaN();
  double mean = std::numeric_limits<double>::quiet_NaN();  ///< normal prior
  double sd = std::numeric_limits<double>::quiet_NaN();    ///< normal prior, > 0
  void visit(core::SettingsVisitor& v);
  /// "talus.restitution_mean" (or "terrain.roughness_sigma"): how outputs name it.
  std::string label() const { return (is_roughness() ? std::string("terrain") : material) + "." + parameter; }
  bool is_roughness() const { return parameter == "roughness_sigma"; }
};

/// One published summary of an observed case (docs/calibration.md, "Summary statistics"):
/// a statistic of one variable over the case's blocks, with its stated uncertainty.
struct Summary {
  std::string statistic;                  ///< share_above, quantile, max or min
  std::string variable = "runout";        ///< runout (m), lateral (m), speed (m/s) or jump (m)
  std::optional<double> threshold;        ///< share_above: values above it count (the variable's unit)
  std::optional<double> p;                ///< quantile: its probability (-), in (0, 1)
  std::optional<double> value;            ///< the published value (the variable's unit; a share: -, in [0, 1])
  std::optional<double> sd;               ///< its standard uncertainty, > 0 (the value's unit)
  std::optional<double> count;            ///< share_above: blocks above the threshold, of n (instead of value and sd)
  std::optional<double> n;                ///< max, min: blocks the extreme is over; share_above: blocks counted (-)
  void visit(core::SettingsVisitor& v);
};

/// One observed case: the scene as run for it and the stops, or the summaries, observed.
struct Group {
  std::string name;                       ///< names the case in outputs; empty: "group K"
  std::vector<std::string> set;           ///< scene overrides of this case (KEY=VALUE, as dda-run --set)
  std::string observed;                   ///< observed stops: CSV of x, y or of runout[, lateral], or a vector file of points
  std::vector<Summary> summaries;         ///< or published summary statistics instead of stops
  std::string layer;                      ///< layer of a vector file; empty: its only layer
  /// Where runout is measured from ([x, y], m, the terrain's input coordinates); empty:
  /// the scene's first release point.
  std::vector<double> origin;
  /// Azimuth of the runout direction (deg from +x, counter-clockwise); none: the scene's
  /// release.main_direction_deg.
  std::optional<double> main_direction_deg;
  void visit(core::SettingsVisitor& v);
};

/// What `calibrate` fits and how (docs/calibration.md).
struct Settings {
  std::string scene;                      ///< the dda-run scene file (terrain, blocks, release, engine)
  std::vector<std::string> set;           ///< scene overrides for every group (KEY=VALUE)
  std::vector<Group> groups;              ///< observed cases, at least one
  std::vector<FittedParameter> parameters;
  /// Compared: "runout_lateral" (stop points in plan), "runout" (along the runout
  /// direction) or "distance" (horizontal distance from the group's origin).
  std::string variables = "runout_lateral";
  /// Simulated blocks not at rest (left the terrain, step limit): "count" them where they
  /// ended (a block that left the terrain at its exit) or "drop" them from the comparison.
  std::string unstopped = "count";
  std::int64_t realizations = 100;        ///< realizations per simulation and group
  std::int64_t particles = 100;           ///< ABC population size
  std::int64_t generations = 6;           ///< generations after the prior's
  double quantile = 0.5;                  ///< tolerance = this quantile of the previous generation's distances
  double min_acceptance = 0.05;           ///< stop once a generation accepts fewer of its proposals
  std::int64_t max_simulations = 0;       ///< simulations (parameter sets) at most, 0 = no limit
  std::uint64_t seed = 1;                 ///< proposals and simulations
  std::int64_t predictive_draws = 40;     ///< posterior draws of a prediction (--predict)
  bool plots = true;                      ///< draw plots with talus-plot (Python 3, matplotlib, h5py)
  void visit(core::SettingsVisitor& v);
};

}  // namespace talus::calibrate
