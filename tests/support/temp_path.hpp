// SPDX-License-Identifier: MIT
#pragma once
// Scratch file names for tests. CTest runs each test case as its own process, several at
// once, and several build trees may run their suites at the same time: a fixed name in
// the temporary directory would be shared between them, so every name carries the pid.
#include <unistd.h>

#include <filesystem>
#include <string>

namespace talus::testing {

/// "<tmp>/talus_<suite>_<pid>_<name>".
inline std::string temp_path(const std::string& suite, const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("talus_" + suite + "_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

}  // namespace talus::testing
