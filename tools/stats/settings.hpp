// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"

namespace talus::stats_tool {

/// Runs reported together as one more run: realizations of several run files (the drop
/// points of a field test, say) pooled into one series.
struct Pool {
  std::string name;               ///< the pooled run's name
  std::vector<std::string> runs;  ///< names of the runs pooled (after shards are joined); empty = all
  void visit(core::SettingsVisitor& v);
};

/// Observed stop points a series is compared with (a field campaign, a past event).
struct Observed {
  std::string file;    ///< CSV of x, y (input coordinates, m) or a vector file of points; empty = none
  std::string layer;   ///< layer of a vector file; empty = its only layer
  std::string series;  ///< run (or pool) compared, as a whole; empty = the first run
  std::vector<double> origin;     ///< [x, y] the runout is measured from (m, input coordinates)
  double main_direction_deg = 0.0;  ///< azimuth of the runout direction from +x, counter-clockwise (deg)
  void visit(core::SettingsVisitor& v);
};

/// What the stats tool computes and writes (docs/stats.md). Every field is optional in
/// the YAML; the defaults are the SPEC §5 report.
struct Settings {
  /// Run names, one per run after shards are joined, in input order; empty = file stems.
  std::vector<std::string> names;
  /// Use the shards of a run even when some are missing (otherwise an error).
  bool allow_partial = false;
  /// Pooled runs, reported after the runs given.
  std::vector<Pool> pools;
  /// Observed stop points to validate a series against (validation.csv, plots).
  Observed observed;
  /// Split a run that mixes several blocks into one series per block (R1–R4 of the
  /// reference study), besides the whole run.
  bool by_block = true;
  /// Probabilities of the quantiles reported (-), each in (0, 1).
  std::vector<double> quantiles = {0.05, 0.10, 0.25, 0.50, 0.75, 0.90, 0.95, 0.99};
  /// Level of the DKW bands and bootstrap intervals (-), in (0, 1).
  double confidence = 0.95;
  /// Bootstrap resamples per series and variable; 0 = no bootstrap intervals.
  std::int64_t bootstrap_resamples = 1000;
  /// Seed of the bootstrap resampling streams.
  std::uint64_t seed = 1;
  /// Relative-error target of the convergence study (-).
  double convergence_target = 0.01;
  /// Quantiles followed by the convergence study besides the mean (-).
  std::vector<double> convergence_quantiles = {0.50, 0.95};
  /// Points of each convergence curve.
  std::int64_t convergence_points = 20;
  /// Runout distances whose exceedance fraction is reported (m), e.g. the toe.
  std::vector<double> reach_distances;
  /// Terrain file for the origin shift of the rasters and the plan view; empty = the
  /// terrain named in the run file's provenance.
  std::string terrain;
  /// Hazard rasters from the per-cell accumulators.
  bool hazard_maps = true;
  /// Raster formats among "asc" (ESRI ASCII grid) and "tif" (GeoTIFF).
  std::vector<std::string> raster_formats = {"asc", "tif"};
  std::string energy_unit = "J";  ///< unit of the energy rasters: J or kJ
  /// Per-cell variables mapped: "energy" (kinetic, J), "height" (passing, m), "speed"
  /// (centroid, m/s); each realization's largest value in the cell.
  std::vector<std::string> hazard_variables = {"energy", "height", "speed"};
  /// Per-cell statistics mapped for each variable, among "mean", "median", "max".
  std::vector<std::string> hazard_statistics = {"mean", "max"};
  /// Probabilities of the per-cell quantiles mapped for each variable (-), each in (0, 1).
  std::vector<double> hazard_quantiles = {0.95, 0.99};
  /// Cells with fewer passages than this get no data in the statistic rasters (the
  /// counts and the reach probability are kept).
  std::int64_t hazard_min_passages = 1;
  /// Kinetic energies separating the intensity classes low | medium | high (J), two
  /// increasing values: FOEN 2016 (Swiss practice) 30 kJ and 300 kJ.
  std::vector<double> intensity_thresholds = {30e3, 300e3};
  /// Return periods separating the frequency classes high | medium | low | very low (yr),
  /// three increasing values: FOEN 2016 30, 100 and 300 years.
  std::vector<double> return_periods = {30.0, 100.0, 300.0};
  /// Release frequency of each run's zone (events per year), one per run after shards are
  /// joined; empty = no frequency, intensity or hazard-class rasters.
  std::vector<double> release_frequencies;
  /// Length of the segments of a barrier line in the design sheet (m).
  double barrier_segment_length = 10.0;
  /// Vector layers of each run (stop points, first barrier crossings, barrier lines,
  /// release zone, trajectories):
  /// "gpkg" (one GeoPackage per run), "geojson" (one GeoJSON file per layer) or "none".
  std::string vector_format = "gpkg";
  /// Plots (figures.hpp), drawn with Cairo.
  bool plots = true;
  /// Plot formats among "png" and "svg" (PNG only by default).
  std::vector<std::string> plot_formats = {"png"};
  /// Besides one map per hazard raster, the compact figure of all of a run's rasters as
  /// small panels (hazard-RUN).
  bool plot_hazard_summary = false;
  /// Trajectories drawn in each plan view at most (the first by realization index).
  std::int64_t plot_trajectories = 200;
  /// Figures drawn at once, each in its own process (0 = one per available core).
  std::int64_t plot_jobs = 0;

  void visit(core::SettingsVisitor& v);
  /// Throws core::InputError on a value out of range, naming where it was given
  /// (`origins`: the --set key, or the file and line).
  void validate(const core::SettingsOrigins& origins) const;
};

}  // namespace talus::stats_tool
