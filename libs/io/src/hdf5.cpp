#include "talus/io/hdf5.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>

#include "talus/core/error.hpp"

namespace talus::io {

std::string hdf5_description() {
  unsigned major = 0, minor = 0, release = 0;
  H5get_libversion(&major, &minor, &release);
  return "HDF5 " + std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(release);
}

void prepare_hdf5() { H5dont_atexit(); }

}  // namespace talus::io

namespace talus::io::h5 {
namespace {

using core::InputError;

// HDF5 prints its own error stack by default; Talus reports one line instead.
void silence_hdf5() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

// Owns one HDF5 identifier of any kind.
class Id {
 public:
  explicit Id(hid_t id = H5I_INVALID_HID) : id_(id) {}
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  Id(Id&& other) noexcept : id_(other.id_) { other.id_ = H5I_INVALID_HID; }
  ~Id() {
    if (id_ >= 0) H5Idec_ref(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  hid_t release() {
    const hid_t id = id_;
    id_ = H5I_INVALID_HID;
    return id;
  }

 private:
  hid_t id_;
};

// " (No space left on device)" after a failed write, from the errno the system call left.
std::string write_cause() {
  return errno != 0 ? " (" + std::string(std::strerror(errno)) + ")" : std::string();
}

// Property list for new groups and datasets: no timestamps, so files are reproducible.
Id no_times_plist(hid_t cls) {
  Id plist(H5Pcreate(cls));
  H5Pset_obj_track_times(plist.get(), 0);
  return plist;
}

template <class T> hid_t native_type();
template <> hid_t native_type<double>() { return H5T_NATIVE_DOUBLE; }
template <> hid_t native_type<float>() { return H5T_NATIVE_FLOAT; }
template <> hid_t native_type<std::int32_t>() { return H5T_NATIVE_INT32; }
template <> hid_t native_type<std::int64_t>() { return H5T_NATIVE_INT64; }
template <> hid_t native_type<std::uint8_t>() { return H5T_NATIVE_UINT8; }

Id string_type() {
  Id type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  return type;
}

}  // namespace

struct Group::Handle {
  Id id;
};

Group::Group(std::shared_ptr<Handle> handle, std::string path, std::string file_name)
    : handle_(std::move(handle)), path_(std::move(path)), file_name_(std::move(file_name)) {}

std::string Group::where(const std::string& child) const {
  return (path_ == "/" ? "/" : path_ + "/") + child;
}

File File::create(const std::string& path, const std::string& shown_as) {
  silence_hdf5();
  const std::string name = shown_as.empty() ? path : shown_as;
  Id fcpl(H5Pcreate(H5P_FILE_CREATE));
  H5Pset_obj_track_times(fcpl.get(), 0);
  Id fapl(H5Pcreate(H5P_FILE_ACCESS));
  // A strong close closes the groups still open with the file, so close() reports the
  // last metadata write at once instead of leaving it to an unchecked destructor.
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  errno = 0;
  Id id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl.get()));
  if (!id.valid()) throw core::RuntimeError(name + ": cannot create HDF5 file" + write_cause());
  auto handle = std::make_shared<Group::Handle>(Group::Handle{std::move(id)});
  return File(Group(handle, "/", name));
}

void File::close() {
  auto& handle = *root_.handle_;
  if (!handle.id.valid()) return;
  errno = 0;
  const bool flushed = H5Fflush(handle.id.get(), H5F_SCOPE_GLOBAL) >= 0;
  const std::string cause = write_cause();
  const hid_t id = handle.id.release();
  errno = 0;
  const bool closed = H5Fclose(id) >= 0;
  if (!flushed) throw core::RuntimeError(root_.file_name_ + ": cannot write output" + cause);
  if (!closed) throw core::RuntimeError(root_.file_name_ + ": cannot write output" + write_cause());
}

namespace {

// Opens an existing HDF5 file with `flags` (read-only or read-write), telling a missing
// file from one that is not HDF5.
Id open_existing(const std::string& path, unsigned flags) {
  silence_hdf5();
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw InputError(path, "cannot open file (missing or unreadable)");
    std::fclose(f);
    throw InputError(path, "not an HDF5 file (or truncated)");
  }
  Id id(H5Fopen(path.c_str(), flags, H5P_DEFAULT));
  if (!id.valid())
    throw InputError(path, flags == H5F_ACC_RDONLY ? "cannot open HDF5 file" : "cannot open HDF5 file for writing");
  return id;
}

}  // namespace

File File::open(const std::string& path) {
  auto handle = std::make_shared<Group::Handle>(Group::Handle{open_existing(path, H5F_ACC_RDONLY)});
  return File(Group(handle, "/", path));
}

File File::open_rw(const std::string& path) {
  auto handle = std::make_shared<Group::Handle>(Group::Handle{open_existing(path, H5F_ACC_RDWR)});
  return File(Group(handle, "/", path));
}

void File::flush() const {
  errno = 0;
  if (H5Fflush(root_.handle_->id.get(), H5F_SCOPE_GLOBAL) < 0)
    throw core::RuntimeError(root_.file_name_ + ": cannot write output" + write_cause());
}

Group Group::create_group(const std::string& name) const {
  Id gcpl = no_times_plist(H5P_GROUP_CREATE);
  Id id(H5Gcreate2(handle_->id.get(), name.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT));
  if (!id.valid()) throw core::RuntimeError(file_name_ + ": cannot create group " + where(name));
  return Group(std::make_shared<Handle>(Handle{std::move(id)}), where(name), file_name_);
}

Group Group::open_group(const std::string& name) const {
  if (!has(name)) throw InputError(file_name_, "missing group " + where(name));
  Id id(H5Gopen2(handle_->id.get(), name.c_str(), H5P_DEFAULT));
  if (!id.valid()) throw InputError(file_name_, where(name) + " is not a group");
  return Group(std::make_shared<Handle>(Handle{std::move(id)}), where(name), file_name_);
}

bool Group::has(const std::string& name) const {
  return H5Lexists(handle_->id.get(), name.c_str(), H5P_DEFAULT) > 0;
}

std::vector<std::string> Group::children() const {
  std::vector<std::string> names;
  H5Literate(handle_->id.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
              [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
                static_cast<std::vector<std::string>*>(data)->emplace_back(name);
                return 0;
              },
              &names);
  std::sort(names.begin(), names.end());
  return names;
}

namespace {

template <class T>
void write_dataset(hid_t parent, const std::string& file, const std::string& where,
                   const std::string& name, const T* data, const Shape& shape,
                   std::string_view unit, bool compress) {
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Id dcpl = no_times_plist(H5P_DATASET_CREATE);
  std::uint64_t count = 1;
  for (auto d : shape) count *= d;
  if (compress && count > 0) {
    // Chunks of about 64 k elements along the first axis.
    std::vector<hsize_t> chunk(dims);
    std::uint64_t row = count / std::max<std::uint64_t>(dims[0], 1);
    chunk[0] = std::clamp<hsize_t>(65536 / std::max<std::uint64_t>(row, 1), 1, dims[0]);
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 4);
  }
  Id set(H5Dcreate2(parent, name.c_str(), native_type<T>(), space.get(), H5P_DEFAULT, dcpl.get(),
                    H5P_DEFAULT));
  if (!set.valid()) throw core::RuntimeError(file + ": cannot create dataset " + where);
  errno = 0;
  if (count > 0 &&
      H5Dwrite(set.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw core::RuntimeError(file + ": cannot write dataset " + where + write_cause());
  if (!unit.empty()) {
    Id type = string_type();
    Id scalar(H5Screate(H5S_SCALAR));
    Id attr(H5Acreate2(set.get(), "unit", type.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
    std::string text(unit);
    const char* ptr = text.c_str();
    H5Awrite(attr.get(), type.get(), &ptr);
  }
}

Id open_dataset(hid_t parent, const std::string& file, const std::string& where,
                const std::string& name) {
  if (H5Lexists(parent, name.c_str(), H5P_DEFAULT) <= 0)
    throw InputError(file, "missing dataset " + where);
  Id set(H5Dopen2(parent, name.c_str(), H5P_DEFAULT));
  if (!set.valid()) throw InputError(file, where + " is not a dataset");
  return set;
}

Shape dataset_shape(hid_t set) {
  Id space(H5Dget_space(set));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return Shape(dims.begin(), dims.end());
}

std::string shape_text(const Shape& shape) {
  std::string text = "[";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i) text += " x ";
    text += shape[i] == 0 ? std::string("*") : std::to_string(shape[i]);
  }
  return text + "]";
}

template <class T>
std::vector<T> read_dataset(hid_t parent, const std::string& file, const std::string& where,
                            const std::string& name, const Shape& expected) {
  Id set = open_dataset(parent, file, where, name);
  const Shape shape = dataset_shape(set.get());
  if (!expected.empty()) {
    bool ok = shape.size() == expected.size();
    for (std::size_t i = 0; ok && i < shape.size(); ++i)
      ok = expected[i] == 0 || expected[i] == shape[i];
    if (!ok)
      throw InputError(file, where + " has shape " + shape_text(shape) + ", expected " +
                                 shape_text(expected));
  }
  std::uint64_t count = 1;
  for (auto d : shape) count *= d;
  Id type(H5Dget_type(set.get()));
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_INTEGER && cls != H5T_FLOAT)
    throw InputError(file, where + " is not numeric");
  std::vector<T> values(count);
  if (count > 0 &&
      H5Dread(set.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
    throw InputError(file, "cannot read dataset " + where + " (corrupt or truncated file?)");
  return values;
}

Id open_attr(hid_t object, const std::string& file, const std::string& where,
             const std::string& name) {
  if (H5Aexists(object, name.c_str()) <= 0)
    throw InputError(file, "missing attribute '" + name + "' of " + where);
  return Id(H5Aopen(object, name.c_str(), H5P_DEFAULT));
}

void write_string_attr(hid_t object, const std::string& name, const std::string& value) {
  if (H5Aexists(object, name.c_str()) > 0) H5Adelete(object, name.c_str());
  Id type = string_type();
  Id scalar(H5Screate(H5S_SCALAR));
  Id attr(H5Acreate2(object, name.c_str(), type.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  const char* ptr = value.c_str();
  H5Awrite(attr.get(), type.get(), &ptr);
}

std::string read_string_attr(hid_t object, const std::string& file, const std::string& where,
                             const std::string& name) {
  Id attr = open_attr(object, file, where, name);
  Id stored(H5Aget_type(attr.get()));
  if (H5Tget_class(stored.get()) != H5T_STRING)
    throw InputError(file, "attribute '" + name + "' of " + where + " is not a string");
  if (H5Tis_variable_str(stored.get()) > 0) {
    Id type = string_type();
    char* ptr = nullptr;
    if (H5Aread(attr.get(), type.get(), &ptr) < 0 || ptr == nullptr)
      throw InputError(file, "cannot read attribute '" + name + "' of " + where);
    std::string value(ptr);
    H5free_memory(ptr);
    return value;
  }
  const std::size_t size = H5Tget_size(stored.get());
  std::string value(size, '\0');
  H5Aread(attr.get(), stored.get(), value.data());
  value.resize(std::strlen(value.c_str()));
  return value;
}

}  // namespace

#define TALUS_H5_WRITE(T)                                                                  \
  void Group::write(const std::string& name, const T* data, const Shape& shape,             \
                    std::string_view unit, bool compress) const {                          \
    write_dataset<T>(handle_->id.get(), file_name_, where(name), name, data, shape, unit,   \
                     compress);                                                            \
  }
TALUS_H5_WRITE(double)
TALUS_H5_WRITE(float)
TALUS_H5_WRITE(std::int32_t)
TALUS_H5_WRITE(std::int64_t)
TALUS_H5_WRITE(std::uint8_t)
#undef TALUS_H5_WRITE

void Group::write_strings(const std::string& name, const std::vector<std::string>& values) const {
  const hsize_t dims[1] = {values.size()};
  Id space(H5Screate_simple(1, dims, nullptr));
  Id type = string_type();
  Id dcpl = no_times_plist(H5P_DATASET_CREATE);
  Id set(H5Dcreate2(handle_->id.get(), name.c_str(), type.get(), space.get(), H5P_DEFAULT,
                    dcpl.get(), H5P_DEFAULT));
  if (!set.valid()) throw core::RuntimeError(file_name_ + ": cannot create dataset " + where(name));
  std::vector<const char*> ptrs;
  for (const auto& v : values) ptrs.push_back(v.c_str());
  errno = 0;
  if (!values.empty() && H5Dwrite(set.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
    throw core::RuntimeError(file_name_ + ": cannot write dataset " + where(name) + write_cause());
}

namespace {

hid_t element_type(Group::Element element) {
  switch (element) {
    case Group::Element::f64: return H5T_NATIVE_DOUBLE;
    case Group::Element::i64: return H5T_NATIVE_INT64;
    case Group::Element::i32: return H5T_NATIVE_INT32;
    case Group::Element::u8: return H5T_NATIVE_UINT8;
  }
  return H5T_NATIVE_DOUBLE;
}

template <class T>
void append_rows(hid_t parent, const std::string& file, const std::string& where,
                 const std::string& name, const T* data, std::uint64_t rows) {
  if (H5Lexists(parent, name.c_str(), H5P_DEFAULT) <= 0)
    throw core::RuntimeError(file + ": cannot append to missing dataset " + where);
  Id set(H5Dopen2(parent, name.c_str(), H5P_DEFAULT));
  Id stored(H5Dget_type(set.get()));
  if (!set.valid() || H5Tequal(stored.get(), native_type<T>()) <= 0)
    throw core::RuntimeError(file + ": " + where + " is not an appendable dataset of this type");
  if (rows == 0) return;
  Shape shape = dataset_shape(set.get());
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  std::vector<hsize_t> start(dims.size(), 0);
  std::vector<hsize_t> count(dims);
  start[0] = dims[0];
  count[0] = rows;
  dims[0] += rows;
  if (H5Dset_extent(set.get(), dims.data()) < 0)
    throw core::RuntimeError(file + ": cannot extend dataset " + where);
  Id space(H5Dget_space(set.get()));
  H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  Id memory(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  errno = 0;
  if (H5Dwrite(set.get(), native_type<T>(), memory.get(), space.get(), H5P_DEFAULT, data) < 0)
    throw core::RuntimeError(file + ": cannot append to dataset " + where + write_cause());
}

}  // namespace

void Group::create_appendable(const std::string& name, Element element, std::uint64_t columns,
                              std::string_view unit, std::uint64_t chunk_rows) const {
  std::vector<hsize_t> dims = {0};
  std::vector<hsize_t> max_dims = {H5S_UNLIMITED};
  std::vector<hsize_t> chunk = {std::max<hsize_t>(chunk_rows, 1)};
  if (columns > 0) {
    dims.push_back(columns);
    max_dims.push_back(columns);
    chunk.push_back(columns);
  }
  Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max_dims.data()));
  Id dcpl = no_times_plist(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
  H5Pset_shuffle(dcpl.get());
  H5Pset_deflate(dcpl.get(), 4);
  Id set(H5Dcreate2(handle_->id.get(), name.c_str(), element_type(element), space.get(), H5P_DEFAULT,
                    dcpl.get(), H5P_DEFAULT));
  if (!set.valid()) throw core::RuntimeError(file_name_ + ": cannot create dataset " + where(name));
  if (!unit.empty()) write_string_attr(set.get(), "unit", std::string(unit));
}

#define TALUS_H5_APPEND(T)                                                                  \
  void Group::append(const std::string& name, const T* data, std::uint64_t rows) const {    \
    append_rows<T>(handle_->id.get(), file_name_, where(name), name, data, rows);           \
  }
TALUS_H5_APPEND(double)
TALUS_H5_APPEND(std::int64_t)
TALUS_H5_APPEND(std::int32_t)
TALUS_H5_APPEND(std::uint8_t)
#undef TALUS_H5_APPEND

void Group::truncate_rows(const std::string& name, std::uint64_t rows) const {
  Id set = open_dataset(handle_->id.get(), file_name_, where(name), name);
  const Shape shape = dataset_shape(set.get());
  if (shape.empty() || shape[0] <= rows) return;
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  dims[0] = rows;
  if (H5Dset_extent(set.get(), dims.data()) < 0)
    throw core::RuntimeError(file_name_ + ": cannot truncate dataset " + where(name));
}

Shape Group::shape(const std::string& name) const {
  Id set = open_dataset(handle_->id.get(), file_name_, where(name), name);
  return dataset_shape(set.get());
}

std::vector<double> Group::read_doubles(const std::string& name, const Shape& expected) const {
  return read_dataset<double>(handle_->id.get(), file_name_, where(name), name, expected);
}
std::vector<float> Group::read_floats(const std::string& name, const Shape& expected) const {
  return read_dataset<float>(handle_->id.get(), file_name_, where(name), name, expected);
}
std::vector<std::int32_t> Group::read_int32(const std::string& name, const Shape& expected) const {
  return read_dataset<std::int32_t>(handle_->id.get(), file_name_, where(name), name, expected);
}
std::vector<std::int64_t> Group::read_int64(const std::string& name, const Shape& expected) const {
  return read_dataset<std::int64_t>(handle_->id.get(), file_name_, where(name), name, expected);
}
std::vector<std::uint8_t> Group::read_uint8(const std::string& name, const Shape& expected) const {
  return read_dataset<std::uint8_t>(handle_->id.get(), file_name_, where(name), name, expected);
}

std::vector<std::string> Group::read_strings(const std::string& name) const {
  Id set = open_dataset(handle_->id.get(), file_name_, where(name), name);
  const Shape shape = dataset_shape(set.get());
  if (shape.size() != 1) throw InputError(file_name_, where(name) + " is not a list of strings");
  Id stored(H5Dget_type(set.get()));
  if (H5Tget_class(stored.get()) != H5T_STRING || H5Tis_variable_str(stored.get()) <= 0)
    throw InputError(file_name_, where(name) + " is not a list of strings");
  Id type = string_type();
  std::vector<char*> ptrs(shape[0], nullptr);
  if (!ptrs.empty() && H5Dread(set.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
    throw InputError(file_name_, "cannot read dataset " + where(name));
  std::vector<std::string> values;
  for (char* p : ptrs) {
    values.emplace_back(p ? p : "");
    if (p) H5free_memory(p);
  }
  return values;
}

void Group::set_attr(const std::string& name, double value) const {
  hid_t obj = handle_->id.get();
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  Id scalar(H5Screate(H5S_SCALAR));
  Id attr(H5Acreate2(obj, name.c_str(), H5T_NATIVE_DOUBLE, scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value);
}

void Group::set_attr(const std::string& name, std::int64_t value) const {
  hid_t obj = handle_->id.get();
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  Id scalar(H5Screate(H5S_SCALAR));
  Id attr(H5Acreate2(obj, name.c_str(), H5T_NATIVE_INT64, scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  H5Awrite(attr.get(), H5T_NATIVE_INT64, &value);
}

void Group::set_attr(const std::string& name, const std::string& value) const {
  write_string_attr(handle_->id.get(), name, value);
}

bool Group::has_attr(const std::string& name) const {
  return H5Aexists(handle_->id.get(), name.c_str()) > 0;
}

double Group::attr_double(const std::string& name) const {
  Id attr = open_attr(handle_->id.get(), file_name_, path_, name);
  double value = 0.0;
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &value) < 0)
    throw InputError(file_name_, "attribute '" + name + "' of " + path_ + " is not a number");
  return value;
}

std::int64_t Group::attr_int(const std::string& name) const {
  Id attr = open_attr(handle_->id.get(), file_name_, path_, name);
  std::int64_t value = 0;
  Id type(H5Aget_type(attr.get()));
  if (H5Tget_class(type.get()) != H5T_INTEGER ||
      H5Aread(attr.get(), H5T_NATIVE_INT64, &value) < 0)
    throw InputError(file_name_, "attribute '" + name + "' of " + path_ + " is not an integer");
  return value;
}

std::string Group::attr_string(const std::string& name) const {
  return read_string_attr(handle_->id.get(), file_name_, path_, name);
}

void Group::set_dataset_attr(const std::string& dataset, const std::string& name,
                             const std::string& value) const {
  Id set = open_dataset(handle_->id.get(), file_name_, where(dataset), dataset);
  write_string_attr(set.get(), name, value);
}

std::string Group::dataset_attr_string(const std::string& dataset, const std::string& name) const {
  Id set = open_dataset(handle_->id.get(), file_name_, where(dataset), dataset);
  return read_string_attr(set.get(), file_name_, where(dataset), name);
}

}  // namespace talus::io::h5
