// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "settings.hpp"
#include "talus/io/raster.hpp"
#include "talus/io/run_file.hpp"
#include "talus/stats/convergence.hpp"
#include "talus/stats/sample.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::stats_tool {

/// One run as analysed: a run file, or the shards of one run joined.
struct Run {
  std::string name;
  std::vector<std::string> files;  ///< the run file, or its shards
  io::RunFile file;
};

/// Reads the run files, joins the shards of each run (files whose shard is not "0/1",
/// grouped by identical settings and inputs) and names the runs. Throws core::InputError
/// naming the file when one is missing, corrupt, empty, or a shard that does not fit.
std::vector<Run> load_runs(const std::vector<std::string>& paths, const Settings& settings,
                           const core::SettingsOrigins& origins);

/// Appends one run per Settings::pools entry: the realizations of the runs it names, in
/// that order, renumbered 0, 1, … one after the other, with blocks, stop classes and
/// barriers matched by name; no hazard grid (the members' grids may differ). The runs
/// pooled must share the terrain's origin shift. Throws core::InputError naming the
/// settings when a pool names an unknown run, has a name already taken, or mixes frames.
void pool_runs(std::vector<Run>& runs, const Settings& settings, const core::SettingsOrigins& origins);

/// A statistic followed by the convergence study.
struct Followed {
  stats::Statistic statistic;
  std::vector<stats::ConvergencePoint> curve;  ///< at convergence_counts(n, points)
  double needed = 0.0;  ///< realizations to reach the target relative error (infinity if unknown)
};

/// Distribution statistics of one variable of one series.
struct VariableSummary {
  std::string name;  ///< "runout", "toe.passing_height" …
  std::string unit;
  std::vector<double> values;  ///< realization order
  std::optional<stats::Sample> sample;  ///< absent when there is no value
  std::size_t missing = 0;     ///< realizations without a value (no crossing, off the terrain)
  /// Realizations left out because they did not stop (step limit, left the terrain): their
  /// value is only a lower bound. Set for the stop-position variables (runout, lateral).
  std::optional<std::size_t> censored;
  /// censored / (values + censored): the share of the realizations with trustworthy values
  /// (no numerical failure) that the distribution left out; absent unless `censored` is set.
  std::optional<double> censored_share() const;
  std::vector<double> quantiles;          ///< at Settings::quantiles
  std::vector<stats::Interval> intervals; ///< bootstrap intervals of the quantiles (may be empty)
  double dkw_epsilon = 1.0;               ///< half-width of the CDF band at Settings::confidence
  std::vector<Followed> convergence;      ///< mean, then Settings::convergence_quantiles
};

/// A fraction of the realizations of a series (stopping in a zone, crossing a barrier …).
struct Fraction {
  std::string name;  ///< "stop:bench 1", "cross:toe", "runout>=36", "end:step_limit", "numerical_failure"
  std::uint64_t count = 0;
  double value = 0.0;  ///< count / realizations
};

/// A run, or the realizations of one block of a run.
struct Series {
  std::string run;
  std::string block;  ///< block name, or "all"
  std::size_t run_index = 0;
  std::uint64_t realizations = 0;  ///< records, numerical failures included
  std::vector<VariableSummary> variables;
  std::vector<Fraction> fractions;
  /// Final plan positions of the realizations that ended at rest, terrain coordinates (m).
  std::vector<std::array<double, 2>> stop_points;
};

/// Two-sample Kolmogorov–Smirnov comparison of one variable between two series.
struct Comparison {
  std::string variable;
  std::size_t a = 0, b = 0;  ///< series indices
  std::size_t n_a = 0, n_b = 0;
  double distance = 0.0;
  double p_value = 1.0;
};

/// One hazard raster: its file-name part, the figure's panel title, GDAL band
/// description, unit and storage (integer counts), and values on the run's hazard grid
/// (grid points = cell centres in terrain coordinates).
struct HazardLayer {
  std::string name;
  std::string title;
  io::BandInfo band;
  terrain::DemGrid grid;
};

/// The hazard rasters of a run, in this order: reach_probability, passage_count,
/// deposition_count, then for each of Settings::hazard_variables its statistics
/// (VARIABLE_mean, VARIABLE_median, VARIABLE_pXX for each hazard quantile, VARIABLE_max,
/// those asked for).
struct HazardMaps {
  std::vector<HazardLayer> layers;
  /// The layer of that name (throws std::out_of_range when there is none).
  const HazardLayer& layer(const std::string& name) const;
};

/// What is drawn in the plan view of a run, in terrain coordinates.
struct PlanView {
  std::vector<double> terrain_x, terrain_y, terrain_z;  ///< base terrain vertices (m), empty if unknown
  std::vector<std::array<std::int32_t, 3>> terrain_triangles;
  std::vector<std::int64_t> trajectory_realization;  ///< per point
  std::vector<std::array<double, 3>> trajectory_position;  ///< m
  std::vector<std::vector<std::array<double, 2>>> barrier_lines;  ///< m
  std::vector<std::string> barrier_names;
  /// Per barrier, the side of the line (from its first vertex) the terrain falls to:
  /// +1 left, −1 right, 0 unknown (level, off the terrain, or no terrain read).
  std::vector<int> barrier_downslope;
  /// The map background: a hillshade of the smooth terrain, 0 (shadow) … 1 (lit), grid
  /// points at cell centres in input coordinates, NaN off the terrain; empty without
  /// terrain or plots.
  terrain::DemGrid hillshade;
  /// The release zone: "point", "line" or "polygon", and each feature's rings (m, input
  /// coordinates; a point is a ring of one vertex).
  std::string release_kind;
  std::vector<std::vector<std::array<double, 2>>> release_rings;
  /// The name of the terrain's CRS ("CH1903+ / LV95 (EPSG:2056)"), "" when it has none.
  std::string crs_name;
};

/// One segment of a barrier line (or the whole line) in the design sheet: the first
/// crossings of the realizations without numerical failure whose crossing point lies in
/// it, and the Q95 and Q99 of their kinetic energy (J) and passing height (m), each with
/// its percentile-bootstrap interval (NaN when undefined: no value, or one).
struct BarrierSegment {
  std::string barrier;
  std::string segment;      ///< "1", "2", … from the line's first vertex, or "all"
  double from = 0.0, to = 0.0;  ///< m along the line from its first vertex
  std::size_t crossings = 0;
  std::array<double, 2> energy{}, height{};  ///< at 0.95, 0.99
  std::array<stats::Interval, 2> energy_ci{}, height_ci{};
};

struct RunResult {
  std::optional<HazardMaps> hazard;
  std::vector<BarrierSegment> barrier_sheet;  ///< per barrier: its segments, then "all"
  PlanView plan;
  std::array<double, 3> origin_shift = {0.0, 0.0, 0.0};  ///< m, added to the run's local coordinates
  std::string terrain_file;  ///< the terrain used for the shift ("" if none)
  std::string crs_wkt;       ///< that terrain's CRS (WKT; "" if none or not known)
  /// That terrain, kept when observed stops are compared (they must lie on it).
  std::shared_ptr<const terrain::Terrain> terrain;
};

/// One variable of the comparison of a series with observed stop points.
struct ValidationVariable {
  std::string name;  ///< "runout" or "lateral"
  std::string unit;  ///< "m"
  std::vector<double> observed, simulated;  ///< sorted
  double ks_distance = 0.0;
  double ks_p_value = 1.0;
  /// At Settings::quantiles: the observed and simulated quantiles and the simulated
  /// quantile band [Q(p − ε), Q(p + ε)] from the DKW band ε of the simulated CDF.
  std::vector<double> observed_quantiles, simulated_quantiles, band_low, band_high;
  double inside_p5_p95 = 0.0;  ///< share of observed values within the simulated [P5, P95] (-)
  double censored_share = 0.0;  ///< of the series' realizations, left out of `simulated` (VariableSummary)
};

/// A series against observed stop points (Settings::observed).
struct Validation {
  std::string series;  ///< the run compared (its block "all")
  std::string file;    ///< the observed file
  std::vector<ValidationVariable> variables;
};

struct Analysis {
  std::vector<Series> series;
  std::optional<Validation> validation;
  std::vector<Comparison> comparisons;
  std::vector<RunResult> runs;  ///< parallel to the runs
  /// One line each, printed once every output is written (so an error stays one line).
  std::vector<std::string> warnings;
};

/// Every statistic of docs/stats.md for the runs.
Analysis analyze(const std::vector<Run>& runs, const Settings& settings);

/// The summary of one variable's values (NaN = missing), exposed for tests.
VariableSummary summarize(std::string name, std::string unit, std::vector<double> values, const Settings& settings);

/// The hazard rasters of a run (HazardMaps), cell centres shifted by `origin_shift` (x,
/// y), energies in Settings::energy_unit, statistic layers no data below
/// Settings::hazard_min_passages. Exposed for tests.
/// With a release frequency (events per year) the frequency, intensity and hazard-class
/// layers follow (add_intensity_layers).
HazardMaps hazard_maps(const io::RunFile& run, const std::array<double, 3>& origin_shift, const Settings& settings,
                       std::optional<double> release_frequency = std::nullopt);

/// The side of a barrier line (plan vertices, the terrain's local frame, m) the terrain
/// falls to: +1 left of the line as digitised, −1 right, 0 when its two sides are level or
/// off the terrain. Sums, along the line, the elevation difference between points
/// `offset` m right and left of it, so a bent line still has one downslope side.
int downslope_side(const terrain::Surface& ground, const std::vector<std::array<double, 2>>& line, double offset);

/// A hillshade of `ground` (the smooth surface, local frame) on cells of about 1/800 of
/// the longer side of its plan extent (no finer than `finest`, m), lit from the
/// north-west 45° above the horizon as GIS software draws them: the cosine of the angle
/// between the surface normal and the light, 0 … 1, NaN where there is no ground. Grid
/// points are cell centres shifted by `shift` (x, y).
terrain::DemGrid hillshade(const terrain::Surface& ground, double finest, const std::array<double, 3>& shift);

/// Appends to `maps` the layers of Settings::intensity_thresholds and return_periods for a
/// run whose zone releases `release_frequency` events per year (docs/stats.md,
/// "Intensity and hazard classes"): frequency_low, frequency_medium, frequency_high
/// (1/yr), intensity_TXX for each return period and hazard_class (class codes, Int32).
void add_intensity_layers(HazardMaps& maps, const io::RunFile& run, const std::array<double, 3>& origin_shift,
                          const Settings& settings, double release_frequency);

/// The EAD 340059-00-0106 (formerly ETAG 027) energy class a net needs to hold `energy`
/// (J) at its maximum energy level: the smallest class whose MEL is at least `energy`
/// (0: 100 kJ, 1: 250, 2: 500, 3: 1000, 4: 2000, 5: 3000, 6: 4500 kJ; 7 above). −1 for NaN.
int ead_energy_class(double energy);

/// The comparison with the observed stop points of Settings::observed (none when its file
/// is empty): runout and lateral offset of the observed points and of the series' stop
/// points (realizations at rest) from the same origin along the same direction. Throws
/// core::InputError naming the file (unreadable, no point, a row without x and y, a
/// vector layer in another CRS, a point off the run's terrain, where no simulated block
/// can stop) or the settings (unknown series, no simulated stop).
std::optional<Validation> validate_against_observed(const Analysis& a, const Settings& settings,
                                                   const core::SettingsOrigins& origins);

}  // namespace talus::stats_tool
