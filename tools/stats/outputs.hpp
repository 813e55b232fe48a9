// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "analysis.hpp"
#include "talus/io/file_header.hpp"
#include "talus/io/vector.hpp"

namespace talus::stats_tool {

/// The tidy table: one row per run × block × variable × statistic (docs/stats.md).
std::string summary_csv(const Analysis& analysis, const Settings& settings);
/// Convergence curves: one row per run × block × variable × statistic × n.
std::string convergence_csv(const Analysis& analysis);
/// Two-sample KS distances and p-values of comparable series.
std::string comparison_csv(const Analysis& analysis);
/// The side-by-side table: one row per variable × statistic, one column per series.
std::string side_by_side_csv(const Analysis& analysis);
/// The same as aligned text for a terminal.
std::string side_by_side_text(const Analysis& analysis);

/// The comparison with observed stop points: one row per variable × statistic
/// (n_observed, n_simulated, ks_distance, ks_p_value, inside_P5_P95, and per quantile the
/// observed and simulated value, the simulated band and whether the observed one is in it).
std::string validation_csv(const Validation& validation, const Settings& settings);

/// The barrier design sheet: one row per run × barrier × segment (then the whole line),
/// energies in Settings::energy_unit (docs/stats.md, "Barrier design sheet").
std::string barrier_sheet_csv(const std::vector<Run>& runs, const Analysis& analysis, const Settings& settings);

/// Writes the HDF5 summary (docs/formats.md, "Stats summary file") atomically.
void write_summary_file(const std::string& path, const std::vector<Run>& runs, const Analysis& analysis,
                        const Settings& settings, const io::Provenance& provenance);

/// Writes the hazard rasters of each run into `dir` (RUN-reach_probability.asc …); returns the paths.
std::vector<std::string> write_hazard_rasters(const std::string& dir, const std::vector<Run>& runs,
                                              const Analysis& analysis, const Settings& settings);

/// Writes the vector layers of each run into `dir` (docs/stats.md, "Vector layers"):
/// stop points, first barrier crossings and, when the run holds them, trajectories, in
/// terrain coordinates with the terrain's CRS, as RUN.gpkg or RUN-LAYER.geojson
/// (settings.vector_format); returns the paths.
std::vector<std::string> write_vector_layers(const std::string& dir, const std::vector<Run>& runs,
                                             const Analysis& analysis, const Settings& settings);

/// The layers of one run as write_vector_layers writes them (exposed for tests).
std::vector<io::VectorLayer> vector_layers(const Run& run, const RunResult& result);

}  // namespace talus::stats_tool
