// SPDX-License-Identifier: MIT
#pragma once
#include <stdexcept>
#include <string>

namespace talus::core {

/// Exit codes shared by every Talus tool (documented in docs/cli.md).
enum class ExitCode : int {
  success = 0,
  runtime_failure = 1,  ///< the input was fine but the work failed (I/O error, numerical failure)
  usage = 2,            ///< the command line is wrong
  bad_input = 3,        ///< an input file or a setting is wrong
};

/// Base of the errors Talus throws at its boundaries; `what()` is one line.
class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

/// The command line is malformed (unknown flag, missing output, bad --set syntax).
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::usage, message) {}
};

/// An input (file or setting) is wrong. `source` names the file (or "--set", "settings").
class InputError : public Error {
 public:
  InputError(const std::string& source, const std::string& message)
      : Error(ExitCode::bad_input, source.empty() ? message : source + ": " + message),
        source_(source), detail_(message) {}
  const std::string& source() const { return source_; }
  const std::string& detail() const { return detail_; }

 private:
  std::string source_;
  std::string detail_;
};

/// Valid input but the work could not be done (cannot write the output, solver failure).
class RuntimeError : public Error {
 public:
  explicit RuntimeError(const std::string& message) : Error(ExitCode::runtime_failure, message) {}
};

/// Throws InputError(source, message) unless `condition` holds.
inline void require(bool condition, const std::string& source, const std::string& message) {
  if (!condition) throw InputError(source, message);
}

/// Formats a double for messages with up to 10 significant digits.
std::string format_number(double value);

}  // namespace talus::core
