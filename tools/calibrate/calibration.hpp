// SPDX-License-Identifier: MIT
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "settings.hpp"
#include "talus/block/block.hpp"
#include "talus/mc/scene.hpp"
#include "talus/stats/abc.hpp"
#include "talus/stats/summary.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::calibrate {

/// The variables a summary statistic can be of, in the order of Simulated::blocks.
enum class SummaryVariable { runout = 0, lateral = 1, speed = 2, jump = 3 };

/// One published summary of a case, ready to compare: the target and what it is of.
struct CaseSummary {
  stats::SummaryTarget target;
  SummaryVariable variable = SummaryVariable::runout;
  std::string label;  ///< "share_above runout > 35 m", "max runout of 250": how outputs name it
};

/// An observed case ready to simulate: its scene settings (scene file, then the common
/// and the group's overrides), its observed stops measured from its origin (or its
/// published summaries), and the terrain and blocks it shares with the other cases.
struct Case {
  std::string name;
  mc::SceneSettings scene;
  core::SettingsOrigins origins;           ///< where each scene setting was given, for messages
  const terrain::Terrain* terrain = nullptr;
  const std::vector<block::Block>* library = nullptr;
  mc::SceneVectors vectors;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();     ///< terrain input coordinates (m)
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX(); ///< unit runout direction
  std::vector<std::vector<double>> observed;            ///< [n][variables] (m); empty for summaries
  std::vector<CaseSummary> summaries;                   ///< published summaries instead of stops
  bool has_summaries() const { return !summaries.empty(); }
};

/// One simulation of a case: the compared values of its realizations (at rest, and unless
/// unstopped is "drop" those that ended elsewhere, where they ended), how many ended
/// elsewhere (left the terrain, step limit) and how many in a numerical failure (left out
/// of the comparison, and reported).
struct Simulated {
  std::vector<std::vector<double>> values;  ///< [compared realizations][variables] (m)
  /// Every realization without a numerical failure, in realization order, wherever it
  /// ended: runout and lateral offset of its final position (m), its largest speed (m/s)
  /// and jump height (m), indexed by SummaryVariable. What summary statistics are of.
  std::array<std::vector<double>, 4> blocks;
  std::int64_t at_rest = 0;
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
  /// infinite when a case has fewer than 2 realizations at rest. For cases of summaries,
  /// the mean of their discrepancies √(mean z²) (stats::summary_distance); infinite when
  /// a case has fewer than 2 realizations without a numerical failure.
  double distance(const std::vector<double>& theta) const;
  /// Each published summary of case `c` against simulation `sim` of it.
  std::vector<stats::SummaryComparison> compare(std::size_t c, const Simulated& sim) const;
  /// True when the cases give summaries (they are all of one kind).
  bool summaries() const { return cases_.front().has_summaries(); }
  /// The scene settings of case `c` (or of the scene without the group overrides, c =
  /// npos) with `theta` as material overrides.
  mc::SceneSettings with_parameters(const mc::SceneSettings& base, const std::vector<double>& theta) const;
  /// The scene file and common overrides, without any group's.
  const mc::SceneSettings& base_scene() const { return base_scene_; }

  /// The compared values of a point at plan offset d (m) from case c's origin.
  std::vector<double> compared(const Case& c, const Eigen::Vector2d& d) const;

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
