#include "talus/cli/tool.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <new>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/version.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/raster.hpp"

namespace talus::cli {

io::Provenance Invocation::provenance(const std::string& tool, std::uint64_t seed) const {
  io::Provenance p;
  p.tool = tool;
  p.tool_version = std::string(core::version());
  p.settings_yaml = settings_yaml;
  p.command_line = command_line;
  p.seed = seed;
  for (const auto& input : inputs) p.inputs += input + "\n";
  return p;
}

std::vector<io::NamedPath> Invocation::named_inputs() const {
  std::vector<io::NamedPath> named;
  for (const auto& input : inputs) named.push_back({"input", input});
  if (!config_path.empty()) named.push_back({"settings file (-c)", config_path});
  return named;
}

namespace {

// "unknown option '--sett' (did you mean '--set'?)" for the first option word of the
// command line that the tool does not know; empty when every option word is known.
std::string unknown_option_message(const CLI::App& app, int argc, char** argv) {
  std::vector<std::string> known;
  for (const CLI::Option* opt : app.get_options()) {
    for (const auto& l : opt->get_lnames()) known.push_back("--" + l);
    for (const auto& s : opt->get_snames()) known.push_back("-" + s);
  }
  for (int i = 1; i < argc; ++i) {
    std::string word = argv[i];
    if (word == "--") break;
    if (word.size() < 2 || word[0] != '-' || (word[1] >= '0' && word[1] <= '9') || word[1] == '.') continue;
    word = word.substr(0, word.find('='));
    if (std::find(known.begin(), known.end(), word) != known.end()) continue;
    if (word[1] != '-' && word.size() > 2) continue;  // -vq style or a value
    std::string hint;
    std::size_t best = 3;
    for (const auto& k : known) {
      const std::size_t d = core::edit_distance(word, k);
      if (d < best) {
        best = d;
        hint = " (did you mean '" + k + "'?)";
      }
    }
    return "unknown option '" + word + "'" + hint + " (see --help)";
  }
  return {};
}

int fail(const ToolSpec& spec, core::ExitCode code, const std::string& message) {
  std::fprintf(stderr, "%s: error: %s\n", spec.name.c_str(), message.c_str());
  return static_cast<int>(code);
}

}  // namespace

int run_tool(int argc, char** argv, const ToolSpec& spec) {
  // Past a file-size limit (ulimit -f) a write then fails with EFBIG and is reported like
  // a full disk, instead of the default SIGXFSZ killing the tool without a word.
  std::signal(SIGXFSZ, SIG_IGN);
  io::prepare_hdf5();
  core::set_log_prefix(spec.name);
  CLI::App app{spec.summary, spec.name};
  app.get_formatter()->column_width(34);
  Invocation inv;
  std::vector<std::string> overrides;
  bool print_config = false;
  bool quiet = false;
  bool verbose = false;
  std::string log_level = "warn";

  app.set_version_flag("--version", [&spec] {
    std::string text = spec.name + " (Talus) " + std::string(core::version()) + "\n";
    if (!spec.build_notes.empty()) text += spec.build_notes + "\n";
    text += "built with: " + io::gdal_description() + ", " + io::hdf5_description();
    return text;
  });
  app.add_option("-c,--config", inv.config_path, "YAML settings file")->option_text("FILE");
  const std::string set_doc = "override one setting" +
                              (spec.set_example.empty() ? std::string() : ", e.g. --set " + spec.set_example) +
                              " (repeatable)";
  app.add_option("--set", overrides, set_doc)
      ->option_text("KEY=VALUE")
      ->allow_extra_args(false);  // one KEY=VALUE per --set; later words are inputs
  app.add_option("-o,--output", inv.output, "output file (written under a temporary name, renamed when complete)")
      ->option_text("FILE");
  app.add_flag("--print-config", print_config, "print the effective settings (defaults included) and exit");
  app.add_option("--log-level", log_level, "error, warn, info or debug (default warn)")->option_text("LEVEL");
  app.add_flag("-q,--quiet", quiet, "log errors only");
  app.add_flag("-v,--verbose", verbose, "log progress (same as --log-level info)");
  for (const auto& f : spec.flags) app.add_flag(f.name, *f.value, f.doc);
  for (const auto& o : spec.options) app.add_option(o.name, *o.value, o.doc)->option_text(o.placeholder);
  app.add_option("inputs", inv.inputs, spec.inputs_doc.empty() ? "input files" : spec.inputs_doc)
      ->option_text("INPUT ...");
  app.footer("Exit codes: 0 success, 1 runtime failure, 2 usage error, 3 bad input. See docs/cli.md.");

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::ParseError& e) {
    const std::string unknown = unknown_option_message(app, argc, argv);
    if (!unknown.empty()) return fail(spec, core::ExitCode::usage, unknown);
    return fail(spec, core::ExitCode::usage, std::string(e.what()) + " (see --help)");
  }

  for (int i = 0; i < argc; ++i) inv.command_line += (i ? " " : "") + std::string(argv[i]);

  try {
    core::LogLevel level = core::LogLevel::warn;
    if (!core::parse_log_level(log_level, level))
      throw core::UsageError("--log-level must be error, warn, info or debug, got '" + log_level + "'");
    if (verbose) level = core::LogLevel::info;
    if (quiet) level = core::LogLevel::error;
    core::set_log_level(level);

    inv.overrides = overrides;
    inv.origins = core::SettingsOrigins(inv.config_path.empty() ? "settings" : inv.config_path);
    if (!inv.config_path.empty()) io::read_settings_file(inv.config_path, overrides, spec.settings, &inv.origins);
    else io::read_settings("", "--set", overrides, spec.settings, &inv.origins);
    inv.settings_yaml = io::write_settings(spec.settings, false);
    if (print_config) {
      std::fputs(io::write_settings(spec.settings, true).c_str(), stdout);
      return 0;
    }
    if (inv.inputs.size() < spec.min_inputs)
      throw core::UsageError("expected at least " + std::to_string(spec.min_inputs) + " input file(s) (see --help)");
    if (inv.inputs.size() > spec.max_inputs)
      throw core::UsageError("expected at most " + std::to_string(spec.max_inputs) + " input file(s), got " +
                             std::to_string(inv.inputs.size()));
    if (spec.check) spec.check(inv);
    else if (spec.needs_output && inv.output.empty())
      throw core::UsageError("no output file given (-o FILE)");
    spec.run(inv);
    return 0;
  } catch (const core::Error& e) {
    return fail(spec, e.code(), e.what());
  } catch (const std::bad_alloc&) {
    return fail(spec, core::ExitCode::runtime_failure, "out of memory");
  } catch (const std::exception& e) {
    return fail(spec, core::ExitCode::runtime_failure, std::string("internal error: ") + e.what());
  }
}

unsigned parse_threads(const std::string& text) {
  if (text.empty()) return 0;
  unsigned value = 0;
  const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (err != std::errc() || end != text.data() + text.size() || value > 4096)
    throw core::UsageError("--threads expects a count (0 = all cores), got '" + text + "'");
  return value;
}

bool started_by_mpi_launcher() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
}

double progress_interval(bool tty) {
  const char* text = std::getenv("TALUS_PROGRESS_INTERVAL");
  return text ? std::max(0.0, std::strtod(text, nullptr)) : tty ? 10.0 : 30.0;
}

}  // namespace talus::cli
