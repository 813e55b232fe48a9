// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace talus::io {
/// "HDF5 1.10.8", for --version.
std::string hdf5_description();

/// Keeps HDF5 from closing, at process exit, files whose close already failed (a full
/// disk): HDF5 1.10 crashes on them. Call before any other HDF5 use; every file Talus
/// opens is closed by its owner before exit.
void prepare_hdf5();
}  // namespace talus::io

namespace talus::io::h5 {

/// Shape of a row-major dataset.
using Shape = std::vector<std::uint64_t>;

/// A group of an open HDF5 file (the root group is a Group too). A thin, typed wrapper
/// over the HDF5 C API; every failure throws core::InputError naming the file and object.
/// Objects carry no timestamps, so equal content gives byte-identical files.
class Group {
 public:
  Group create_group(const std::string& name) const;
  /// Opens a child group; throws InputError naming the file if it is missing.
  Group open_group(const std::string& name) const;
  bool has(const std::string& name) const;
  /// Names of the direct children (groups and datasets), sorted.
  std::vector<std::string> children() const;

  // Datasets. `unit` (when not empty) is stored as the dataset's "unit" attribute.
  // `compress` stores it chunked and deflated.
  void write(const std::string& name, const double* data, const Shape& shape,
             std::string_view unit = {}, bool compress = false) const;
  void write(const std::string& name, const float* data, const Shape& shape,
             std::string_view unit = {}, bool compress = false) const;
  void write(const std::string& name, const std::int32_t* data, const Shape& shape,
             std::string_view unit = {}, bool compress = false) const;
  void write(const std::string& name, const std::int64_t* data, const Shape& shape,
             std::string_view unit = {}, bool compress = false) const;
  void write(const std::string& name, const std::uint8_t* data, const Shape& shape,
             std::string_view unit = {}, bool compress = false) const;
  void write_strings(const std::string& name, const std::vector<std::string>& values) const;

  // Appendable datasets: chunked, deflated, unlimited along the first axis, for outputs
  // that grow as work finishes (crash-safe journals). Rows are `columns` values wide
  // (columns = 0 makes a 1-D dataset). Appending to a missing dataset or with the wrong
  // element type throws core::RuntimeError.
  enum class Element { f64, i64, i32, u8 };
  void create_appendable(const std::string& name, Element element, std::uint64_t columns = 0,
                         std::string_view unit = {}, std::uint64_t chunk_rows = 1024) const;
  /// Appends `rows` rows (rows × max(columns, 1) values, row-major) to an appendable dataset.
  void append(const std::string& name, const double* data, std::uint64_t rows) const;
  void append(const std::string& name, const std::int64_t* data, std::uint64_t rows) const;
  void append(const std::string& name, const std::int32_t* data, std::uint64_t rows) const;
  void append(const std::string& name, const std::uint8_t* data, std::uint64_t rows) const;
  /// Cuts an appendable dataset back to its first `rows` rows (no-op if it has fewer).
  void truncate_rows(const std::string& name, std::uint64_t rows) const;

  /// Shape of a dataset; throws if it is missing.
  Shape shape(const std::string& name) const;
  /// Reads a dataset, converting to the requested type. If `expected` is given, the
  /// dataset's shape must match it (0 in `expected` matches any extent).
  std::vector<double> read_doubles(const std::string& name, const Shape& expected = {}) const;
  std::vector<float> read_floats(const std::string& name, const Shape& expected = {}) const;
  std::vector<std::int32_t> read_int32(const std::string& name, const Shape& expected = {}) const;
  std::vector<std::int64_t> read_int64(const std::string& name, const Shape& expected = {}) const;
  std::vector<std::uint8_t> read_uint8(const std::string& name, const Shape& expected = {}) const;
  std::vector<std::string> read_strings(const std::string& name) const;

  // Attributes of this group.
  void set_attr(const std::string& name, double value) const;
  void set_attr(const std::string& name, std::int64_t value) const;
  void set_attr(const std::string& name, const std::string& value) const;
  void set_attr(const std::string& name, const char* value) const { set_attr(name, std::string(value)); }
  bool has_attr(const std::string& name) const;
  double attr_double(const std::string& name) const;
  std::int64_t attr_int(const std::string& name) const;
  std::string attr_string(const std::string& name) const;
  // Attributes of a dataset of this group.
  void set_dataset_attr(const std::string& dataset, const std::string& name,
                        const std::string& value) const;
  std::string dataset_attr_string(const std::string& dataset, const std::string& name) const;

  /// "/a/b" path of this group inside its file.
  const std::string& path() const { return path_; }
  /// File name, for messages.
  const std::string& file_name() const { return file_name_; }

 private:
  friend class File;
  struct Handle;
  Group(std::shared_ptr<Handle> handle, std::string path, std::string file_name);
  std::string where(const std::string& child) const;
  std::shared_ptr<Handle> handle_;
  std::string path_;
  std::string file_name_;
};

/// An HDF5 file. Closed when the File and every Group taken from it are gone.
class File {
 public:
  /// Creates (truncates) a file for writing; messages name it `shown_as` when given (the
  /// final name of an output written under a temporary one).
  static File create(const std::string& path, const std::string& shown_as = {});
  /// Opens an existing file read-only; throws InputError if it is missing or not HDF5.
  static File open(const std::string& path);
  /// Opens an existing file for reading and appending (resuming a journal); throws
  /// InputError if it is missing, not HDF5, or cannot be opened for writing.
  static File open_rw(const std::string& path);
  Group root() const { return root_; }
  /// Flushes buffered data to disk; throws core::RuntimeError if a write fails.
  void flush() const;
  /// Writes what is buffered and closes the file with every Group taken from it; throws
  /// core::RuntimeError naming the file and the cause (disk full, file too large) if a
  /// write fails. A file written as an output must end with close() before it is kept.
  void close();

 private:
  explicit File(Group root) : root_(std::move(root)) {}
  Group root_;
};

}  // namespace talus::io::h5
