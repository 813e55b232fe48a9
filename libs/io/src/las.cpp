// LAS 1.0–1.4 point clouds (ASPRS LAS Specification 1.4 R15), uncompressed, point data
// record formats 0 to 10: the public header, the X, Y, Z and classification of each point
// record, and the coordinate reference system records. LAZ is refused: it needs LASzip.
#include "las_reader.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/io/paths.hpp"

namespace talus::io::detail {
namespace {

using core::format_number;
using core::InputError;

// The smallest public header of each LAS 1.x minor version (bytes): 1.0 to 1.2, 1.3
// (waveform packet start), 1.4 (extended VLRs, 64-bit counts).
std::uint64_t header_size_of_version(int minor) { return minor <= 2 ? 227 : minor == 3 ? 235 : 375; }

// The smallest record of point data record formats 0 to 10 (bytes); writers may add extra bytes.
constexpr std::array<std::uint64_t, 11> kMinRecordLength = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

constexpr std::uint64_t kVlrHeader = 54, kEvlrHeader = 60;
constexpr std::uint64_t kMaxCrsRecord = std::uint64_t{1} << 20;  // a WKT or GeoTIFF key record is far smaller

const std::string kDecompress =
    "decompress it first, e.g. las2las -i in.laz -o out.las (LAStools) or pdal translate in.laz out.las (PDAL)";

// Little-endian fields (LAS is little-endian whatever the machine).
std::uint16_t u16(const unsigned char* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t u32(const unsigned char* p) {
  return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[3]} << 24);
}
std::uint64_t u64(const unsigned char* p) { return std::uint64_t{u32(p)} | (std::uint64_t{u32(p + 4)} << 32); }
std::int32_t i32(const unsigned char* p) { return static_cast<std::int32_t>(u32(p)); }
double f64(const unsigned char* p) { return std::bit_cast<double>(u64(p)); }

// A fixed-size text field: up to its first NUL.
std::string text_field(const unsigned char* p, std::size_t size) {
  const auto* c = reinterpret_cast<const char*>(p);
  return std::string(c, std::find(c, c + size, '\0'));
}

struct LasHeader {
  int minor = 0;                     // version 1.minor
  std::uint64_t header_size = 0;     // bytes
  std::uint64_t point_offset = 0;    // byte of the first point record
  std::uint32_t vlr_count = 0;
  int format = 0;                    // point data record format, 0 to 10
  std::uint64_t record_length = 0;   // bytes
  std::uint64_t points = 0;
  std::array<double, 3> scale{}, offset{};
  std::uint64_t evlr_start = 0;      // LAS 1.4: byte of the first extended VLR
  std::uint32_t evlr_count = 0;
  std::uint64_t file_size = 0;
};

[[noreturn]] void refuse_laz(const std::string& path, const std::string& why) {
  throw InputError(path, why + ", which Talus does not read: " + kDecompress);
}

// Opens a LAS file and reads and checks its public header. Refuses LAZ.
LasHeader read_header(std::ifstream& in, const std::string& path) {
  if (lower_extension(path) == ".laz") refuse_laz(path, "LAZ is compressed LAS");
  in.open(path, std::ios::binary);
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!in || ec) throw InputError(path, "cannot open LAS file");
  LasHeader h;
  h.file_size = size;
  std::array<unsigned char, 375> b{};
  in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
  const auto got = static_cast<std::uint64_t>(in.gcount());
  in.clear();
  if (got < 4 || std::memcmp(b.data(), "LASF", 4) != 0)
    throw InputError(path, "not a LAS file: it does not start with the signature 'LASF'");
  if (got < 227)
    throw InputError(path, "truncated LAS file: " + std::to_string(got) + " bytes, less than a LAS header (227 bytes)");
  // LASzip sets bit 7 of the point data format of compressed files (early versions bit 6).
  if (b[104] & 0xC0) refuse_laz(path, "the LAS header marks the points compressed (LAZ)");
  const int major = b[24];
  h.minor = b[25];
  if (major != 1 || h.minor > 4)
    throw InputError(path, "LAS version " + std::to_string(major) + "." + std::to_string(h.minor) +
                               " is not supported (1.0 to 1.4)");
  const std::string version = "LAS 1." + std::to_string(h.minor);
  h.header_size = u16(b.data() + 94);
  if (h.header_size < header_size_of_version(h.minor))
    throw InputError(path, "header size " + std::to_string(h.header_size) + " bytes is less than the " +
                               std::to_string(header_size_of_version(h.minor)) + " of a " + version + " header");
  if (h.header_size > h.file_size)
    throw InputError(path, "truncated LAS file: " + std::to_string(h.file_size) + " bytes, less than its header (" +
                               std::to_string(h.header_size) + " bytes)");
  h.point_offset = u32(b.data() + 96);
  if (h.point_offset < h.header_size)
    throw InputError(path, "offset to point data " + std::to_string(h.point_offset) + " lies inside the header (" +
                               std::to_string(h.header_size) + " bytes)");
  if (h.point_offset > h.file_size)
    throw InputError(path, "truncated LAS file: the offset to point data " + std::to_string(h.point_offset) +
                               " lies beyond its end (" + std::to_string(h.file_size) + " bytes)");
  h.vlr_count = u32(b.data() + 100);
  h.format = b[104];
  if (h.format > 10)
    throw InputError(path, "point data record format " + std::to_string(h.format) + " is not supported (0 to 10)");
  h.record_length = u16(b.data() + 105);
  const std::uint64_t least = kMinRecordLength[static_cast<std::size_t>(h.format)];
  if (h.record_length < least)
    throw InputError(path, "point data record length " + std::to_string(h.record_length) +
                               " bytes is less than the " + std::to_string(least) + " of format " +
                               std::to_string(h.format));
  h.points = u32(b.data() + 107);  // legacy count: all there is before 1.4, 0 for formats 6 to 10
  if (h.minor >= 4) {
    h.evlr_start = u64(b.data() + 235);
    h.evlr_count = u32(b.data() + 243);
    if (const std::uint64_t count = u64(b.data() + 247); count != 0) h.points = count;
  }
  for (std::size_t c = 0; c < 3; ++c) {
    const char axis = static_cast<char>('X' + c);
    h.scale[c] = f64(b.data() + 131 + 8 * c);
    h.offset[c] = f64(b.data() + 155 + 8 * c);
    if (!std::isfinite(h.scale[c]) || h.scale[c] == 0.0)
      throw InputError(path, std::string(1, axis) + " scale factor " + format_number(h.scale[c]) +
                                 " must be finite and non-zero");
    if (!std::isfinite(h.offset[c]))
      throw InputError(path, std::string(1, axis) + " offset " + format_number(h.offset[c]) + " must be finite");
  }
  // The point records end where the extended VLRs start (LAS 1.4), else at the file's end.
  std::uint64_t end = h.file_size;
  if (h.evlr_count > 0 && h.evlr_start >= h.point_offset && h.evlr_start < end) end = h.evlr_start;
  const std::uint64_t whole = (end - h.point_offset) / h.record_length;
  if (h.points > whole)
    throw InputError(path, "truncated LAS file: the header declares " + std::to_string(h.points) + " points of " +
                               std::to_string(h.record_length) + " bytes from byte " +
                               std::to_string(h.point_offset) + ", the file holds " + std::to_string(whole) +
                               " (" + std::to_string(h.file_size) + " bytes)");
  return h;
}

// The classes kept, as a table; all when `classes` is empty.
std::array<bool, 256> class_table(const std::vector<int>& classes) {
  std::array<bool, 256> keep{};
  keep.fill(classes.empty());
  for (int c : classes)
    if (c >= 0 && c < 256) keep[static_cast<std::size_t>(c)] = true;
  return keep;
}

std::string class_list(const std::vector<int>& classes) {
  std::string text;
  for (int c : classes) text += (text.empty() ? "" : ", ") + std::to_string(c);
  return text;
}

// The EPSG code of the CRS a GeoTIFF key directory (record 34735) names: "EPSG:n", or a
// problem when it is user-defined; nothing when it names none.
DeclaredCrs crs_of_geokeys(const std::vector<unsigned char>& data, const std::string& path) {
  // Header: KeyDirectoryVersion, KeyRevision, MinorRevision, NumberOfKeys; then per key
  // KeyID, TIFFTagLocation (0: the value is Value_Offset itself), Count, Value_Offset.
  if (data.size() < 8) throw InputError(path, "LAS GeoTIFF key directory record is shorter than its 8-byte header");
  const std::size_t keys = u16(data.data() + 6);
  if (data.size() < 8 + 8 * keys)
    throw InputError(path, "LAS GeoTIFF key directory record holds " + std::to_string(data.size()) +
                               " bytes, too few for its " + std::to_string(keys) + " keys");
  int model = 0, projected = 0, geographic = 0;
  for (std::size_t k = 0; k < keys; ++k) {
    const unsigned char* key = data.data() + 8 + 8 * k;
    if (u16(key + 2) != 0) continue;  // a value stored elsewhere: not a code
    const int value = u16(key + 6);
    switch (u16(key)) {
      case 1024: model = value; break;       // GTModelTypeGeoKey: 1 projected, 2 geographic
      case 2048: geographic = value; break;  // GeographicTypeGeoKey
      case 3072: projected = value; break;   // ProjectedCSTypeGeoKey
      default: break;
    }
  }
  constexpr int user_defined = 32767;
  const auto known = [](int code) { return code > 0 && code < user_defined; };
  if (known(projected)) return {"EPSG:" + std::to_string(projected), ""};
  if (model != 1 && known(geographic)) return {"EPSG:" + std::to_string(geographic), ""};
  if (projected == user_defined || model == 1 || geographic == user_defined)
    return {"", "its GeoTIFF CRS is user-defined (no EPSG code), which Talus does not read"};
  return {};
}

}  // namespace

bool is_las_extension(const std::string& ext) { return ext == ".las" || ext == ".laz"; }

std::vector<geometry::Vec3> read_las(const std::string& path, const std::vector<int>& classes) {
  std::ifstream in;
  const LasHeader h = read_header(in, path);
  if (h.points == 0) throw InputError(path, "empty point cloud: the LAS header declares no points");
  const std::array<bool, 256> keep = class_table(classes);
  // Formats 0 to 5 keep the class in the low 5 bits of byte 15 (flags above it); 6 to 10
  // in all of byte 16.
  const std::size_t class_byte = h.format <= 5 ? 15 : 16;
  const unsigned class_mask = h.format <= 5 ? 0x1Fu : 0xFFu;
  std::array<std::uint64_t, 256> seen{};
  std::vector<geometry::Vec3> points;
  if (classes.empty()) points.reserve(static_cast<std::size_t>(h.points));
  in.seekg(static_cast<std::streamoff>(h.point_offset));
  const std::uint64_t per_read = std::max<std::uint64_t>(1, (std::uint64_t{1} << 20) / h.record_length);
  std::vector<unsigned char> buffer;
  for (std::uint64_t done = 0; done < h.points;) {
    const std::uint64_t n = std::min(per_read, h.points - done);
    buffer.resize(static_cast<std::size_t>(n * h.record_length));
    in.read(reinterpret_cast<char*>(buffer.data()), static_cast<std::streamsize>(buffer.size()));
    if (!in) throw InputError(path, "cannot read LAS point records from point " + std::to_string(done));
    for (std::size_t r = 0; r < n; ++r) {
      const unsigned char* record = buffer.data() + r * h.record_length;
      const unsigned cls = record[class_byte] & class_mask;
      ++seen[cls];
      if (!keep[cls]) continue;
      points.emplace_back(static_cast<double>(i32(record)) * h.scale[0] + h.offset[0],
                          static_cast<double>(i32(record + 4)) * h.scale[1] + h.offset[1],
                          static_cast<double>(i32(record + 8)) * h.scale[2] + h.offset[2]);
    }
    done += n;
  }
  if (points.empty()) {
    std::string present;
    for (std::size_t c = 0; c < seen.size(); ++c)
      if (seen[c] > 0)
        present += (present.empty() ? "" : ", ") + std::to_string(c) + " (" + std::to_string(seen[c]) +
                   (seen[c] == 1 ? " point)" : " points)");
    throw InputError(path, std::string("no point of class") + (classes.size() > 1 ? "es " : " ") +
                               class_list(classes) + " among its " + std::to_string(h.points) +
                               " points; its classes: " + present);
  }
  return points;
}

DeclaredCrs las_crs(const std::string& path) {
  std::ifstream in;
  const LasHeader h = read_header(in, path);
  std::vector<unsigned char> wkt, geokeys;
  // Reads the record at `at` of `length` bytes when it is one of the CRS records.
  const auto take = [&](const std::string& user, std::uint16_t record, std::uint64_t at, std::uint64_t length) {
    if (user != "LASF_Projection" || (record != 2112 && record != 34735)) return;
    if (length > kMaxCrsRecord)
      throw InputError(path, "LAS CRS record " + std::to_string(record) + " of " + std::to_string(length) +
                                 " bytes is implausibly long");
    std::vector<unsigned char>& data = record == 2112 ? wkt : geokeys;
    data.resize(static_cast<std::size_t>(length));
    in.seekg(static_cast<std::streamoff>(at));
    in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
    if (!in) throw InputError(path, "cannot read LAS CRS record " + std::to_string(record));
  };
  std::array<unsigned char, kEvlrHeader> head{};
  std::uint64_t at = h.header_size;
  for (std::uint32_t k = 0; k < h.vlr_count; ++k) {
    const std::string where = "LAS VLR " + std::to_string(k) + " (at byte " + std::to_string(at) + ")";
    if (at + kVlrHeader > h.point_offset)
      throw InputError(path, where + " runs past the start of the point data (byte " + std::to_string(h.point_offset) + ")");
    in.seekg(static_cast<std::streamoff>(at));
    in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(kVlrHeader));
    if (!in) throw InputError(path, "cannot read " + where);
    const std::uint64_t length = u16(head.data() + 20);
    if (at + kVlrHeader + length > h.point_offset)
      throw InputError(path, where + " runs past the start of the point data (byte " + std::to_string(h.point_offset) + ")");
    take(text_field(head.data() + 2, 16), u16(head.data() + 18), at + kVlrHeader, length);
    at += kVlrHeader + length;
  }
  if (h.minor >= 4 && h.evlr_count > 0) {
    at = h.evlr_start;
    for (std::uint32_t k = 0; k < h.evlr_count; ++k) {
      const std::string where = "LAS extended VLR " + std::to_string(k) + " (at byte " + std::to_string(at) + ")";
      if (at > h.file_size || h.file_size - at < kEvlrHeader)
        throw InputError(path, where + " runs past the end of the file (" + std::to_string(h.file_size) + " bytes)");
      in.seekg(static_cast<std::streamoff>(at));
      in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(kEvlrHeader));
      if (!in) throw InputError(path, "cannot read " + where);
      const std::uint64_t length = u64(head.data() + 20);
      if (length > h.file_size - at - kEvlrHeader)
        throw InputError(path, where + " runs past the end of the file (" + std::to_string(h.file_size) + " bytes)");
      take(text_field(head.data() + 2, 16), u16(head.data() + 18), at + kEvlrHeader, length);
      at += kEvlrHeader + length;
    }
  }
  if (!wkt.empty()) {
    std::string text(wkt.begin(), std::find(wkt.begin(), wkt.end(), '\0'));  // the record is NUL-terminated
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
    if (!text.empty()) return {text, ""};
  }
  if (!geokeys.empty()) return crs_of_geokeys(geokeys, path);
  return {};
}

}  // namespace talus::io::detail
