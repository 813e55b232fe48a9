// SPDX-License-Identifier: MIT
#pragma once
#include <chrono>

namespace talus::core {

/// Wall-clock stopwatch (steady clock), for reporting only — never for results.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  /// Seconds since construction or the last restart().
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace talus::core
