// SPDX-License-Identifier: MIT
#pragma once
// Running a built Talus tool from an end-to-end test: one place for the shell quoting,
// the capture of standard output and error, and the exit code.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace talus::testing {

/// The whole content of a file ("" if it cannot be read).
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// `text` as one single-quoted shell word.
inline std::string shell_quote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Path of the executable `name` built with the tests (TALUS_BIN at test time).
inline std::string tool_path(const std::string& name) {
  const char* bin = std::getenv("TALUS_BIN");
  return (std::filesystem::path(bin ? bin : TALUS_BINARY_DIR "/bin") / name).string();
}

/// What one run of a tool gave.
struct ToolOutcome {
  int code = -1;    ///< exit code (-1 if the process did not exit normally)
  std::string out;  ///< standard output
  std::string err;  ///< standard error
};

/// Runs `tool args...` in directory `cwd`, with `env` (e.g. "OMP_NUM_THREADS=2", may be
/// empty) and `launcher` (e.g. an MPI launcher, may be empty) in front. Standard output
/// and error are captured through two hidden files in `cwd`, removed afterwards.
inline ToolOutcome run_tool(const std::string& tool, const std::vector<std::string>& args,
                            const std::filesystem::path& cwd, const std::string& env = {},
                            const std::string& launcher = {}) {
  const std::filesystem::path out = cwd / ".tool_stdout", err = cwd / ".tool_stderr";
  std::string command = "cd " + shell_quote(cwd.string()) + " && " + env + " " + launcher + " " + shell_quote(tool);
  for (const auto& a : args) command += " " + shell_quote(a);
  command += " > " + shell_quote(out.string()) + " 2> " + shell_quote(err.string());
  const int status = std::system(command.c_str());
  ToolOutcome r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

}  // namespace talus::testing
