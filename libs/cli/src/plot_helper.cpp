#include "talus/cli/plot_helper.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "talus/core/error.hpp"

namespace talus::cli {

namespace fs = std::filesystem;

namespace {

// Runs a shell command with stderr captured; returns (exit code, last line of stderr).
std::pair<int, std::string> run_captured(const std::string& command) {
  const fs::path err = fs::temp_directory_path() / ("talus-plot-" + std::to_string(::getpid()) + ".err");
  const int status = std::system((command + " > /dev/null 2> " + shell_quote(err.string())).c_str());
  std::string line;
  {
    std::ifstream in(err);
    std::string text;
    // The helper's own message is its last line (a traceback, if any, comes before it).
    while (std::getline(in, text))
      if (!text.empty()) line = text;
  }
  fs::remove(err);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128, line};
}

}  // namespace

std::string python_interpreter() {
  const char* env = std::getenv("TALUS_PYTHON");
  return env && *env ? env : "/usr/bin/python3";
}

std::string plot_helper() {
  const char* env = std::getenv("TALUS_PLOT");
  if (env && *env) return env;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ((ec ? fs::path(".") : self.parent_path()) / "talus-plot").string();
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

void check_plotting() {
  const std::string python = python_interpreter();
  const auto [code, line] = run_captured(shell_quote(python) + " -c 'import matplotlib, h5py, numpy'");
  if (code == 127 || code == 126)
    throw core::RuntimeError("plots: cannot run the Python interpreter '" + python +
                             "' (set TALUS_PYTHON, or --set plots=false)");
  if (code != 0)
    throw core::RuntimeError("plots: " + python + " cannot import matplotlib, h5py and numpy (" + line +
                             "): install python3-matplotlib python3-h5py, set TALUS_PYTHON, or --set plots=false");
  if (!fs::exists(plot_helper()))
    throw core::RuntimeError("plots: the helper " + plot_helper() + " is missing (set TALUS_PLOT, or --set plots=false)");
}

void run_plot_helper(const std::string& arguments) {
  const auto [code, line] =
      run_captured(shell_quote(python_interpreter()) + " " + shell_quote(plot_helper()) + " " + arguments);
  if (code != 0)
    throw core::RuntimeError("plots: " + (line.empty() ? "talus-plot failed with exit code " + std::to_string(code) : line));
}

}  // namespace talus::cli
