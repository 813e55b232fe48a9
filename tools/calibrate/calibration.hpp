// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "settings.hpp"
#include "talus/block/block.hpp"
#include "talus/mc/scene.hpp"
#include "talus/stats/abc.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::calibrate {

/// An observed case ready to simulate: its scene settings (scene file, then the common
/// and the group's overrides), its observed stops measured from its origin, and the
/// terrain and blocks it shares with the other cases.
struct Case {
  std::string name;
  mc::SceneSettings scene;
  core::SettingsOrigins origins;           ///< where each scene setting was given, for messages
  const terrain::Terrain* terrain = nullptr;
  const std::vector<block::Block>* library = nullptr;
  mc::SceneVectors vectors;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();     ///< terrain input coordinates (m)
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX(); ///< unit runout direction
  std::vector<std::vector<double>> observed;            ///< [n][variables] (m)
};

/// One simulation of a case: the compared values of its realizations at rest, how many
/// ended elsewhere (left the terrain, step limit) and how many in a numerical failure
/// (both left out of the comparison, and reported).
struct Simulated {
  std::vector<std::vector<double>> values;  ///< [realizations at rest][variables] (m)
  std::int64_t not_at_rest = 0;
  std::int64_t failures = 0;
};

/// The calibration problem: the cases, the fitted parameters, and the simulator.
class Problem {
 public:
  /// Reads the scene of every group, its terrain and blocks (each file once), its
  /// observed stops; checks every name and value. `origins` says where each setting was
  /// given (the settings file and line, or the --set key), for errors.
  Problem(const Settings& settings, const core::SettingsOrigins& origins, unsigned threads);

  const std::vector<Case>& cases() const { return cases_; }
  const std::vector<stats::Prior>& priors() const { return priors_; }
  /// "runout" or "runout", "lateral".
  const std::vector<std::string>& variables() const { return variables_; }
  /// The scale of each compared variable: the sd of the observed values of every case (m).
  const std::vector<double>& scale() const { return scale_; }
  const Settings& settings() const { return settings_; }

  /// Simulates case `c` with parameters `theta` (in the order of settings.parameters);
  /// the simulation's seed is a pure function of (seed, case, draw, θ), so a parameter
  /// set gives the same values however the calibration is threaded or resumed.
  Simulated simulate(const std::vector<double>& theta, std::size_t c, std::uint64_t draw = 0) const;
  /// The distance of one parameter set: the mean over the cases of the energy distance
  /// between simulated and observed values (each variable divided by its scale);
  /// infinite when a case has fewer than 2 realizations at rest.
  double distance(const std::vector<double>& theta) const;
  /// The scene settings of case `c` (or of the scene without the group overrides, c =
  /// npos) with `theta` as material overrides.
  mc::SceneSettings with_parameters(const mc::SceneSettings& base, const std::vector<double>& theta) const;
  /// The scene file and common overrides, without any group's.
  const mc::SceneSettings& base_scene() const { return base_scene_; }

  /// Realizations simulated and numerical failures among them, so far.
  std::int64_t realizations_run() const { return realizations_run_; }
  std::int64_t failures() const { return failures_; }
  std::int64_t not_at_rest() const { return not_at_rest_; }

 private:
  Settings settings_;
  unsigned threads_;
  std::vector<stats::Prior> priors_;
  std::vector<std::string> variables_;
  std::vector<double> scale_;
  mc::SceneSettings base_scene_;
  std::map<std::string, std::unique_ptr<terrain::Terrain>> terrains_;
  std::map<std::string, std::unique_ptr<std::vector<block::Block>>> libraries_;
  std::vector<Case> cases_;
  mutable std::int64_t realizations_run_ = 0;
  mutable std::int64_t failures_ = 0;
  mutable std::int64_t not_at_rest_ = 0;
};

/// Weighted summary of one parameter in a generation.
struct ParameterSummary {
  double mean = 0.0, sd = 0.0, p05 = 0.0, p50 = 0.0, p95 = 0.0;
};
std::vector<ParameterSummary> summarize(const stats::AbcGeneration& g);

}  // namespace talus::calibrate
