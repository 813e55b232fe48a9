// SPDX-License-Identifier: MIT
#pragma once
// Small LAS files for tests, written byte by byte after the ASPRS LAS 1.4 R15 layout (the
// same offsets for 1.0 to 1.3, whose headers are prefixes of 1.4's): public header, VLRs,
// point records, and for 1.4 extended VLRs after the points.
#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

namespace talus::testing {

struct LasTestPoint {
  std::int32_t x = 0, y = 0, z = 0;  ///< stored integers: coordinate = integer × scale + offset
  std::uint8_t classification = 1;   ///< class byte: 15 (formats 0–5, flags in bits 5–7 kept) or 16 (6–10)
};

/// A variable-length record (extended when `extended`, LAS 1.4 only: after the points).
struct LasTestRecord {
  std::string user = "LASF_Projection";
  std::uint16_t id = 2112;
  std::string data;
  bool extended = false;
};

struct LasTestFile {
  int major = 1, minor = 2;
  int format = 1;
  std::uint16_t record_length = 0;  ///< 0: the format's minimum
  std::array<double, 3> scale{0.01, 0.01, 0.01};
  std::array<double, 3> offset{0.0, 0.0, 0.0};
  std::vector<LasTestPoint> points;
  std::vector<LasTestRecord> records;
  bool compressed = false;                    ///< sets bit 7 of the point data format (LAZ)
  std::optional<std::uint64_t> stated_points; ///< the count written in the header; default: points.size()
  std::string signature = "LASF";
};

inline std::size_t las_min_record_length(int format) {
  static const std::size_t sizes[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return format >= 0 && format <= 10 ? sizes[format] : 20;
}

/// The bytes of the file `f` describes.
inline std::string las_bytes(const LasTestFile& f) {
  const auto put = [](std::string& s, std::size_t at, const void* v, std::size_t n) {
    if (s.size() < at + n) s.resize(at + n, '\0');
    std::memcpy(s.data() + at, v, n);  // the tests run on little-endian machines, like LAS
  };
  const auto u8 = [&](std::string& s, std::size_t at, std::uint8_t v) { put(s, at, &v, 1); };
  const auto u16 = [&](std::string& s, std::size_t at, std::uint16_t v) { put(s, at, &v, 2); };
  const auto u32 = [&](std::string& s, std::size_t at, std::uint32_t v) { put(s, at, &v, 4); };
  const auto u64 = [&](std::string& s, std::size_t at, std::uint64_t v) { put(s, at, &v, 8); };
  const auto f64 = [&](std::string& s, std::size_t at, double v) { put(s, at, &v, 8); };
  const auto text = [&](std::string& s, std::size_t at, const std::string& t, std::size_t n) {
    std::string padded = t.substr(0, n);
    padded.resize(n, '\0');
    put(s, at, padded.data(), n);
  };

  const std::size_t header = f.minor <= 2 ? 227 : f.minor == 3 ? 235 : 375;
  std::string vlrs;
  std::uint32_t vlr_count = 0;
  for (const auto& r : f.records) {
    if (r.extended) continue;
    const std::size_t at = vlrs.size();
    u16(vlrs, at, 0);
    text(vlrs, at + 2, r.user, 16);
    u16(vlrs, at + 18, r.id);
    u16(vlrs, at + 20, static_cast<std::uint16_t>(r.data.size()));
    text(vlrs, at + 22, "test record", 32);
    put(vlrs, at + 54, r.data.data(), r.data.size());
    ++vlr_count;
  }
  const std::size_t record = f.record_length ? f.record_length : las_min_record_length(f.format);
  const std::size_t offset = header + vlrs.size();
  const std::uint64_t count = f.stated_points.value_or(f.points.size());

  std::string s(header, '\0');
  text(s, 0, f.signature, 4);
  text(s, 26, "talus test", 32);
  text(s, 58, "las_writer.hpp", 32);
  u8(s, 24, static_cast<std::uint8_t>(f.major));
  u8(s, 25, static_cast<std::uint8_t>(f.minor));
  u16(s, 94, static_cast<std::uint16_t>(header));
  u32(s, 96, static_cast<std::uint32_t>(offset));
  u32(s, 100, vlr_count);
  u8(s, 104, static_cast<std::uint8_t>(f.format | (f.compressed ? 0x80 : 0)));
  u16(s, 105, static_cast<std::uint16_t>(record));
  // Formats 6 to 10 leave the legacy count at 0; LAS 1.4 gives the 64-bit count.
  u32(s, 107, f.format >= 6 ? 0u : static_cast<std::uint32_t>(count));
  for (int c = 0; c < 3; ++c) {
    f64(s, 131 + 8 * static_cast<std::size_t>(c), f.scale[static_cast<std::size_t>(c)]);
    f64(s, 155 + 8 * static_cast<std::size_t>(c), f.offset[static_cast<std::size_t>(c)]);
  }
  if (f.minor >= 4) u64(s, 247, count);
  s += vlrs;
  for (const auto& p : f.points) {
    const std::size_t at = s.size();
    s.resize(at + record, '\0');
    u32(s, at, static_cast<std::uint32_t>(p.x));
    u32(s, at + 4, static_cast<std::uint32_t>(p.y));
    u32(s, at + 8, static_cast<std::uint32_t>(p.z));
    u8(s, at + (f.format >= 6 ? 16 : 15), p.classification);
  }
  std::uint32_t evlr_count = 0;
  const std::size_t evlr_start = s.size();
  for (const auto& r : f.records) {
    if (!r.extended) continue;
    const std::size_t at = s.size();
    u16(s, at, 0);
    text(s, at + 2, r.user, 16);
    u16(s, at + 18, r.id);
    u64(s, at + 20, r.data.size());
    text(s, at + 28, "test record", 32);
    put(s, at + 60, r.data.data(), r.data.size());
    ++evlr_count;
  }
  if (evlr_count > 0) {
    u64(s, 235, evlr_start);
    u32(s, 243, evlr_count);
  }
  return s;
}

/// A GeoTIFF key directory (LASF_Projection record 34735) holding `keys` as
/// {key id, value} pairs stored in place.
inline std::string geokey_directory(const std::vector<std::array<std::uint16_t, 2>>& keys) {
  std::vector<std::uint16_t> words = {1, 1, 0, static_cast<std::uint16_t>(keys.size())};
  for (const auto& k : keys) words.insert(words.end(), {k[0], 0, 1, k[1]});
  std::string data(words.size() * 2, '\0');
  std::memcpy(data.data(), words.data(), data.size());
  return data;
}

}  // namespace talus::testing
