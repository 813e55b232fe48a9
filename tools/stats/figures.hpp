// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

#include "analysis.hpp"

namespace talus::stats_tool {

/// Draws the figures of docs/stats.md ("Plots") into `dir` in each of
/// settings.plot_formats, `settings.plot_jobs` at a time (0: one per available core):
/// cdf-VARIABLE, convergence-VARIABLE, barrier-NAME, sheet-RUN-NAME, plan-RUN,
/// map-RUN-LAYER, hazard-RUN (with plot_hazard_summary) and validation.
/// The files are the same whatever the count. Returns the paths written, in figure order;
/// throws core::RuntimeError naming the file that could not be written.
std::vector<std::string> draw_figures(const std::vector<Run>& runs, const Analysis& analysis, const Settings& settings,
                                      const std::string& dir);

}  // namespace talus::stats_tool
