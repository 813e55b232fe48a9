// SPDX-License-Identifier: MIT
#pragma once
#include <string>

namespace talus::io {

/// Writes an output under a temporary name in the same directory and renames it to the
/// final name only on commit(), so a crash or an error never leaves a half-written file
/// under the final name. An uncommitted temporary is removed on destruction.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::string final_path);
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  ~AtomicOutput();

  /// Where to write now.
  const std::string& temp_path() const { return temp_path_; }
  const std::string& final_path() const { return final_path_; }
  /// Renames the temporary to the final name; throws core::RuntimeError on failure.
  void commit();

 private:
  std::string final_path_;
  std::string temp_path_;
  bool committed_ = false;
};

/// Writes `text` to `path` atomically (see AtomicOutput).
void write_text_file(const std::string& path, const std::string& text);

}  // namespace talus::io
