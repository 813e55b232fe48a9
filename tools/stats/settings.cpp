#include "settings.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "talus/core/error.hpp"

namespace talus::stats_tool {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

void Pool::visit(core::SettingsVisitor& v) {
  v.field("name", name, "name of the pooled run");
  v.field("runs", runs, "names of the runs pooled (after shards are joined, as named by names); empty = every run");
}

void Observed::visit(core::SettingsVisitor& v) {
  v.field("file", file,
          "observed stop points: a CSV of x, y (a header naming x and y, or easting and northing; else the first two "
          "columns) or a vector file of points (GeoPackage, GeoJSON, Shapefile …), in the terrain's input coordinates; "
          "empty = no validation");
  v.field("layer", layer, "layer of a vector file; empty = its only layer");
  v.field("series", series, "run (or pool) compared, as a whole; empty = the first run");
  v.field("origin", origin, "m", "[x, y] the runout of both is measured from, in the terrain's input coordinates");
  v.field("main_direction_deg", main_direction_deg, "deg",
          "azimuth of the runout direction from +x, counter-clockwise (lateral offset: to its left, m)");
}

void Settings::visit(core::SettingsVisitor& v) {
  v.field("names", names, "run names, one per run after shards are joined; empty = the file names");
  v.field("allow_partial", allow_partial, "use the shards of a run even when some are missing");
  v.section("observed", "observed stop points a series is validated against (validation.csv, validation plot)",
            [this](core::SettingsVisitor& s) { observed.visit(s); });
  v.list_of("pools", "runs reported together as one more run (e.g. the drop points of a field test), each "
            "{name, runs}; their realizations are pooled, numbered in the order given", pools);
  v.field("by_block", by_block, "also report each block of a run that mixes several blocks");
  v.field("quantiles", quantiles, "-", "probabilities of the reported quantiles");
  v.bounded("confidence", confidence, "-", "level of the DKW bands and bootstrap intervals",
            core::Range{0.0, 1.0, true, true});
  v.bounded("bootstrap_resamples", bootstrap_resamples, "", "bootstrap resamples (0 = no intervals)",
            core::Range::closed(0.0, 1e6));
  v.field("seed", seed, "", "seed of the bootstrap resampling");
  v.bounded("convergence_target", convergence_target, "-", "relative-error target of the convergence study",
            core::Range{0.0, kInf, true, false});
  v.field("convergence_quantiles", convergence_quantiles, "-", "quantiles followed besides the mean");
  v.bounded("convergence_points", convergence_points, "", "points of each convergence curve",
            core::Range{2.0, kInf});
  v.field("reach_distances", reach_distances, "m", "runout distances whose exceedance fraction is reported");
  v.field("terrain", terrain, "terrain file (origin shift, plan view); empty = the one the run names");
  v.field("hazard_maps", hazard_maps, "write hazard rasters from the per-cell accumulators");
  v.field("raster_formats", raster_formats, "raster formats: asc (ESRI ASCII grid), tif (GeoTIFF)");
  v.choice("energy_unit", energy_unit, {"J", "kJ"}, "unit of the energy rasters and of the barrier design sheet: J or kJ");
  v.field("hazard_variables", hazard_variables,
          "per-cell variables mapped, each realization's largest value in the cell: energy (kinetic, J), height "
          "(passing, m), speed (centroid, m/s)");
  v.field("hazard_statistics", hazard_statistics,
          "per-cell statistics mapped for each variable over the passages: mean, median, max");
  v.field("hazard_quantiles", hazard_quantiles, "-",
          "probabilities of the per-cell quantiles mapped for each variable (exact order statistics, type 7, up to "
          "100 passages; sketched above)");
  v.bounded("hazard_min_passages", hazard_min_passages, "",
            "passages a cell needs for its statistic rasters; cells with fewer are no data", core::Range{1.0, kInf});
  v.field("intensity_thresholds", intensity_thresholds, "J",
          "kinetic energies separating the intensity classes low | medium | high (FOEN 2016: 30 kJ, 300 kJ)");
  v.field("return_periods", return_periods, "yr",
          "return periods separating the frequency classes high | medium | low | very low (FOEN 2016: 30, 100, 300 "
          "years)");
  v.field("release_frequencies", release_frequencies, "1/yr",
          "release frequency of each run's zone (events per year), one per run after shards are joined; empty = no "
          "frequency, intensity or hazard-class rasters");
  v.bounded("barrier_segment_length", barrier_segment_length, "m",
            "length of the segments of each barrier line in the design sheet (barrier-sheet.csv)",
            core::Range{0.0, kInf, true, false});
  v.choice("vector_format", vector_format, {"gpkg", "geojson", "none"},
           "vector layers of each run (stop points, first barrier crossings, barrier lines, release zone, "
           "trajectories; m, m/s, J, s): "
           "gpkg = one GeoPackage per run, geojson = one GeoJSON file per layer, none");
  v.field("plots", plots, "draw plots (PNG or SVG figures, drawn with Cairo)");
  v.field("plot_formats", plot_formats, "plot formats: png, svg");
  v.field("plot_hazard_summary", plot_hazard_summary,
          "also draw each run's hazard rasters as one compact figure of small panels (hazard-RUN), besides one "
          "map per raster (map-RUN-LAYER)");
  v.bounded("plot_trajectories", plot_trajectories, "", "trajectories drawn in a plan view at most",
            core::Range{0.0, kInf});
  v.bounded("plot_jobs", plot_jobs, "", "figures drawn at once, one thread each (0 = one per available core)",
            core::Range{0.0, kInf});
}

namespace {

void require_probabilities(const std::vector<double>& ps, const char* key, const core::SettingsOrigins& origins) {
  for (double p : ps)
    if (!(p > 0.0 && p < 1.0))
      throw core::InputError(origins.of(key), std::string(key) + ": " + core::format_number(p) + " is not in (0, 1)");
}

void require_subset(const std::vector<std::string>& values, std::initializer_list<const char*> allowed,
                    const char* key, const core::SettingsOrigins& origins) {
  for (const auto& value : values)
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return value == a; })) {
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw core::InputError(origins.of(key), std::string(key) + ": '" + value + "' is not one of: " + list);
    }
}

}  // namespace

// The ranges the fields declare (the reader checks them on what it reads, naming the line
// or --set key), then the lists'.
void Settings::validate(const core::SettingsOrigins& origins) const {
  Settings declared = *this;
  core::check_ranges([&](core::SettingsVisitor& v) { declared.visit(v); }, origins);
  require_probabilities(quantiles, "quantiles", origins);
  require_probabilities(convergence_quantiles, "convergence_quantiles", origins);
  for (double d : reach_distances)
    if (!std::isfinite(d)) throw core::InputError(origins.of("reach_distances"), "reach_distances must be finite");
  if (!observed.file.empty()) {
    if (observed.origin.size() != 2 || !std::isfinite(observed.origin[0]) || !std::isfinite(observed.origin[1]))
      throw core::InputError(origins.of({"observed.origin", "observed.file"}),
                             "observed.origin must be [x, y] (m, finite) when observed.file is set");
    if (!std::isfinite(observed.main_direction_deg))
      throw core::InputError(origins.of("observed.main_direction_deg"), "observed.main_direction_deg must be finite");
  }
  require_subset(raster_formats, {"asc", "tif"}, "raster_formats", origins);
  require_subset(hazard_variables, {"energy", "height", "speed"}, "hazard_variables", origins);
  require_subset(hazard_statistics, {"mean", "median", "max"}, "hazard_statistics", origins);
  require_probabilities(hazard_quantiles, "hazard_quantiles", origins);
  const auto increasing = [&origins](const std::vector<double>& v, std::size_t n, const char* key,
                                     const char* unit) {
    bool ok = v.size() == n;
    for (std::size_t k = 0; ok && k < n; ++k) ok = std::isfinite(v[k]) && v[k] > 0.0 && (k == 0 || v[k] > v[k - 1]);
    if (!ok)
      throw core::InputError(origins.of(key), std::string(key) + " must be " + std::to_string(n) +
                                                  " increasing positive values (" + unit + ")");
  };
  increasing(intensity_thresholds, 2, "intensity_thresholds", "J");
  increasing(return_periods, 3, "return_periods", "yr");
  for (double f : release_frequencies)
    if (!(f > 0.0) || !std::isfinite(f))
      throw core::InputError(origins.of("release_frequencies"), "release_frequencies: " + core::format_number(f) +
                                                                   " is not a positive frequency (events per year)");
  require_subset(plot_formats, {"png", "svg"}, "plot_formats", origins);
}

}  // namespace talus::stats_tool
