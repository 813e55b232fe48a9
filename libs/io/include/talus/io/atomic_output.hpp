// SPDX-License-Identifier: MIT
#pragma once
#include <cstddef>
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

/// Removes the temporaries of `final_path` left by processes of this host that no longer
/// run (killed during a final write); returns how many it removed.
std::size_t remove_stale_temporaries(const std::string& final_path);

/// An advisory lock on an output (flock on OUTPUT.lock), held for the lifetime of the
/// object: a second process writing the same output is refused with a message naming the
/// holder. The lock file is removed when the lock is released; one left by a killed
/// process holds no lock and is reused.
class OutputLock {
 public:
  explicit OutputLock(const std::string& output);
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

/// The lock file of an output ("run.h5" → "run.h5.lock").
std::string lock_path(const std::string& output);

/// " (No space left on device)": the cause a failed write left in errno, or "" if none.
std::string write_cause();

/// Writes `text` to `path` atomically (see AtomicOutput).
void write_text_file(const std::string& path, const std::string& text);

}  // namespace talus::io
