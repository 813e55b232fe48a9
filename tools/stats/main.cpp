// stats: distributions, convergence, comparisons, barrier CDFs, hazard rasters, vector layers
// and plots from dda-run run files. See docs/stats.md.
#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <vector>
#include <string>

#include "analysis.hpp"
#include "outputs.hpp"
#include "settings.hpp"
#include "figures.hpp"
#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/paths.hpp"

namespace {

using namespace talus;
namespace fs = std::filesystem;

// The files stats writes into the output directory, and its subdirectories.
const char* const kOutputFiles[] = {"summary.csv", "convergence.csv", "comparison.csv", "table.csv", "summary.h5",
                                    "validation.csv"};
const char* const kOutputDirs[] = {"hazard", "plots", "vector"};
// Files of OUTDIR itself that a run writes only when asked (validation.csv: with observed).
const char* const kOptionalFiles[] = {"validation.csv"};

// "stats/" and "./stats/" name the directory "stats": a trailing separator is dropped.
fs::path directory_path(const std::string& dir) {
  fs::path path(dir);
  while (!path.has_filename() && path.has_parent_path() && path != path.root_path()) path = path.parent_path();
  return path;
}

// Refuses an output directory whose outputs would overwrite an input.
void check_outputs(const cli::Invocation& inv, const stats_tool::Settings& settings) {
  std::vector<io::NamedPath> inputs = inv.named_inputs();
  if (!settings.terrain.empty()) inputs.push_back({"terrain file (key terrain)", settings.terrain});
  const fs::path dir = directory_path(inv.output);
  for (const auto& in : inputs) {
    if (io::same_file(in.path, dir.string()))
      throw core::UsageError("-o " + inv.output + ": is the " + in.role + " " + in.path +
                             "; -o names the output directory");
    for (const char* sub : kOutputDirs)
      if (io::inside_directory(in.path, (dir / sub).string()))
        throw core::UsageError("-o " + inv.output + ": the " + in.role + " " + in.path + " lies in " +
                               (dir / sub).string() + ", which stats rewrites (choose another -o)");
  }
  std::vector<io::NamedPath> outputs;
  for (const char* name : kOutputFiles) outputs.push_back({"output", (dir / name).string()});
  io::check_outputs_distinct(inputs, outputs);
}

// The files in stats' own subdirectories of `dir` (hazard/, vector/, plots/) and its
// optional files, with their times.
std::map<fs::path, fs::file_time_type> owned_files(const fs::path& dir) {
  std::map<fs::path, fs::file_time_type> files;
  std::error_code ec;
  for (const char* name : kOptionalFiles)
    if (fs::is_regular_file(dir / name, ec)) files[dir / name] = fs::last_write_time(dir / name, ec);
  for (const char* sub : kOutputDirs)
    for (const auto& entry : fs::directory_iterator(dir / sub, ec))
      if (entry.is_regular_file(ec)) files[entry.path()] = entry.last_write_time(ec);
  return files;
}

// Removes the files of an earlier run that this run did not rewrite (a hazard map of a
// run no longer given, plots when plots are off), so that the folder holds this run's
// outputs only; says what it removed.
void remove_stale_outputs(const std::map<fs::path, fs::file_time_type>& before) {
  std::vector<std::string> removed;
  std::error_code ec;
  for (const auto& [path, time] : before) {
    if (!fs::exists(path, ec) || fs::last_write_time(path, ec) != time) continue;
    if (fs::remove(path, ec)) removed.push_back(path.filename().string());
  }
  if (removed.empty()) return;
  std::string list;
  for (std::size_t k = 0; k < removed.size() && k < 5; ++k) list += (k ? ", " : "") + removed[k];
  if (removed.size() > 5) list += ", ...";
  core::log_notice("removed " + std::to_string(removed.size()) + " file(s) of an earlier run that this run does not write: " +
                   list);
}

// Creates the output directory (its parent must exist).
void make_output_directory(const std::string& dir) {
  const fs::path path = directory_path(dir);
  if (fs::exists(path) && !fs::is_directory(path))
    throw core::UsageError("-o " + dir + ": exists and is not a directory");
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(parent)) throw core::RuntimeError(dir + ": parent directory " + parent.string() + " does not exist");
  std::error_code ec;
  fs::create_directory(path, ec);
  if (ec) throw core::RuntimeError(dir + ": cannot create the output directory (" + ec.message() + ")");
}

}  // namespace

int main(int argc, char** argv) {
  stats_tool::Settings settings;
  bool print_table = false;
  cli::ToolSpec spec;
  spec.name = "stats";
  spec.summary = "CDFs, quantiles, convergence, comparisons, barrier CDFs, hazard rasters, vector layers and plots of run files";
  spec.inputs_doc = "run files of dda-run: whole runs and/or shards of runs (shards of one run are joined)";
  spec.min_inputs = 1;
  spec.set_example = "plots=false";
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.flags = {{"--print-table", "print the side-by-side summary table on standard output", &print_table}};
  spec.check = [&](const cli::Invocation& inv) {
    if (inv.output.empty()) throw core::UsageError("-o OUTDIR is required");
    settings.validate(inv.origins);
    check_outputs(inv, settings);
  };
  spec.run = [&](const cli::Invocation& inv) {
    auto runs = stats_tool::load_runs(inv.inputs, settings, inv.origins);
    stats_tool::pool_runs(runs, settings, inv.origins);
    auto analysis = stats_tool::analyze(runs, settings);
    analysis.validation = stats_tool::validate_against_observed(analysis, settings, inv.origins);
    make_output_directory(inv.output);
    const fs::path dir = directory_path(inv.output);
    const auto earlier = owned_files(dir);
    // The figures need only the analysis: they are drawn while the files below are written.
    std::future<std::vector<std::string>> figures;
    if (settings.plots) {
      const fs::path plots = dir / "plots";
      io::make_directories(plots.string());
      figures = std::async(std::launch::async,
                           [&, plots] { return stats_tool::draw_figures(runs, analysis, settings, plots.string()); });
    }
    io::write_text_file((dir / "summary.csv").string(), stats_tool::summary_csv(analysis, settings));
    io::write_text_file((dir / "convergence.csv").string(), stats_tool::convergence_csv(analysis));
    io::write_text_file((dir / "comparison.csv").string(), stats_tool::comparison_csv(analysis));
    io::write_text_file((dir / "table.csv").string(), stats_tool::side_by_side_csv(analysis));
    io::write_text_file((dir / "barrier-sheet.csv").string(), stats_tool::barrier_sheet_csv(runs, analysis, settings));
    if (analysis.validation)
      io::write_text_file((dir / "validation.csv").string(), stats_tool::validation_csv(*analysis.validation, settings));
    const std::string summary = (dir / "summary.h5").string();
    stats_tool::write_summary_file(summary, runs, analysis, settings, inv.provenance("stats", settings.seed));
    if (settings.hazard_maps) {
      const auto rasters = stats_tool::write_hazard_rasters((dir / "hazard").string(), runs, analysis, settings);
      core::log_info("wrote " + std::to_string(rasters.size()) + " hazard rasters");
    }
    const auto layers = stats_tool::write_vector_layers((dir / "vector").string(), runs, analysis, settings);
    if (!layers.empty()) core::log_info("wrote " + std::to_string(layers.size()) + " vector files");
    if (figures.valid()) core::log_info("wrote " + std::to_string(figures.get().size()) + " plot files");
    remove_stale_outputs(earlier);
    for (const std::string& warning : analysis.warnings) core::log_warn(warning);
    if (print_table) std::fputs(stats_tool::side_by_side_text(analysis).c_str(), stdout);
    core::log_info("wrote " + inv.output + ": " + std::to_string(analysis.series.size()) + " series of " +
                   std::to_string(runs.size()) + " runs");
  };
  return cli::run_tool(argc, argv, spec);
}
