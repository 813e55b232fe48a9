// SPDX-License-Identifier: MIT
#pragma once
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "talus/core/settings.hpp"
#include "talus/io/file_header.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/settings_yaml.hpp"

namespace talus::cli {

/// What a tool was asked to do, after the command line and settings were read.
struct Invocation {
  std::vector<std::string> inputs;  ///< positional input files
  std::string output;               ///< -o (empty if the tool needs none)
  std::string config_path;          ///< -c (empty if none)
  std::string settings_yaml;        ///< effective settings, defaults included
  std::string command_line;         ///< the invocation, for provenance
  std::vector<std::string> overrides;  ///< the --set KEY=VALUE arguments, in order
  /// Where each setting was given, for a message about its value: "--set KEY", the
  /// settings file and line, else the file (or "settings" without one) for a default.
  core::SettingsOrigins origins;

  /// The positional inputs and the settings file, for io::check_outputs_distinct.
  std::vector<io::NamedPath> named_inputs() const;
  /// Provenance for an output file of `tool`.
  io::Provenance provenance(const std::string& tool, std::uint64_t seed) const;
};

/// An extra flag or option of one tool (beyond the shared conventions).
struct ExtraFlag {
  std::string name;  ///< e.g. "--info"
  std::string doc;
  bool* value;
};
struct ExtraOption {
  std::string name;  ///< e.g. "--export-mesh"
  std::string doc;
  std::string* value;
  std::string placeholder = "VALUE";  ///< shown in --help, e.g. "FILE", "N"
};

/// The shared command-line conventions of every Talus tool (docs/cli.md):
///   TOOL [-c SETTINGS.yaml] [--set key=value …] [INPUT …] -o OUTPUT
/// with --help, --version, --print-config, --log-level/-q/-v.
struct ToolSpec {
  std::string name;          ///< "terrain-gen"
  std::string summary;       ///< one line for --help
  std::string inputs_doc;    ///< what the positional inputs are
  std::string set_example;   ///< a valid KEY=VALUE of this tool, shown by --help for --set
  std::string build_notes;   ///< optional parts of this tool's build for --version ("MPI: no ...")
  bool needs_output = true;  ///< -o is required (unless --print-config or a tool flag says otherwise)
  std::size_t min_inputs = 0;
  std::size_t max_inputs = std::numeric_limits<std::size_t>::max();
  io::SettingsBody settings;  ///< binds the tool's settings object
  std::vector<ExtraFlag> flags;
  std::vector<ExtraOption> options;
  /// Checks the invocation before run (e.g. flags that make -o optional); may throw.
  std::function<void(const Invocation&)> check;
  /// Does the work. Throws core::Error subclasses for failures.
  std::function<void(const Invocation&)> run;
};

/// The value of a tool's --threads option: a count of worker threads, 0 (or empty) = every
/// available core. Throws core::UsageError for anything else or a count above 4096.
unsigned parse_threads(const std::string& text);

/// Whether an MPI launcher (mpirun, srun with PMI) started this process: the tools built
/// with MPI start it only then, so a plain start stays a one-process run.
bool started_by_mpi_launcher();

/// Seconds between whole progress lines (docs/errors.md, "Progress"): 10 on a terminal
/// (`tty`), 30 in logs, or TALUS_PROGRESS_INTERVAL when set.
double progress_interval(bool tty);

/// Parses the command line, reads settings, runs the tool and maps every failure to a
/// one-line message "TOOL: error: …" on stderr and a documented exit code. Never throws.
int run_tool(int argc, char** argv, const ToolSpec& spec);

}  // namespace talus::cli
