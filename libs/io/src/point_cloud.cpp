#include "talus/io/point_cloud.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "talus/core/error.hpp"

namespace talus::io {

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

bool is_text_cloud_extension(const std::string& ext) {
  return ext == ".xyz" || ext == ".txt" || ext == ".pts" || ext == ".csv";
}

geometry::Vec3 place(double x, double y, double z, const PointCloudOptions& options) {
  geometry::Vec3 q(x, y, z);
  if (options.up == UpAxis::y) q = geometry::Vec3(x, -z, y);
  return q * options.scale;
}

std::vector<geometry::Vec3> read_text_cloud(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path);
  if (!in) throw core::InputError(path, "cannot open point cloud file");
  std::vector<geometry::Vec3> points;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::replace(line.begin(), line.end(), '\t', ' ');
    const auto first = line.find_first_not_of(" \r");
    if (first == std::string::npos || line[first] == '#' || line.compare(first, 2, "//") == 0) continue;
    const char* p = line.c_str();
    std::array<double, 3> xyz{};
    for (double& v : xyz) {
      char* end = nullptr;
      v = std::strtod(p, &end);
      if (end == p) throw core::InputError(path, "line " + std::to_string(number) + ": expected x y z numbers");
      p = end;
    }
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
      throw core::InputError(path, "line " + std::to_string(number) + ": non-finite coordinate");
    points.push_back(place(xyz[0], xyz[1], xyz[2], options));
  }
  return points;
}

struct PlyProperty {
  std::string name;
  std::string type;  // char uchar short ushort int uint float double (and int8 … float64)
  bool list = false;
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};
struct PlyHeader {
  std::string format;  // ascii, binary_little_endian, binary_big_endian
  std::vector<PlyElement> elements;
};

std::size_t type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

PlyHeader read_ply_header(std::istream& in, const std::string& path) {
  std::string line;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0) throw core::InputError(path, "not a PLY file (no 'ply' magic)");
  PlyHeader h;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (word == "end_header") return h;
    if (word == "format") s >> h.format;
    else if (word == "element") {
      PlyElement e;
      s >> e.name >> e.count;
      if (!s) throw core::InputError(path, "bad PLY element line '" + line + "'");
      h.elements.push_back(e);
    } else if (word == "property") {
      if (h.elements.empty()) throw core::InputError(path, "PLY property before any element");
      PlyProperty p;
      s >> p.type;
      if (p.type == "list") {
        std::string count_type, item_type;
        s >> count_type >> item_type;
        p.list = true;
        p.type = count_type + " " + item_type;
      }
      s >> p.name;
      h.elements.back().properties.push_back(p);
    }
  }
  throw core::InputError(path, "PLY header has no end_header");
}

double read_binary(std::istream& in, const std::string& type, bool big_endian) {
  std::array<unsigned char, 8> b{};
  const std::size_t n = type_size(type);
  in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(n));
  if (big_endian) std::reverse(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
  auto as = [&](auto value) {
    std::memcpy(&value, b.data(), sizeof value);
    return static_cast<double>(value);
  };
  if (type == "char" || type == "int8") return as(std::int8_t{});
  if (type == "uchar" || type == "uint8") return as(std::uint8_t{});
  if (type == "short" || type == "int16") return as(std::int16_t{});
  if (type == "ushort" || type == "uint16") return as(std::uint16_t{});
  if (type == "int" || type == "int32") return as(std::int32_t{});
  if (type == "uint" || type == "uint32") return as(std::uint32_t{});
  if (type == "float" || type == "float32") return as(float{});
  return as(double{});
}

std::vector<geometry::Vec3> read_ply_cloud(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw core::InputError(path, "cannot open point cloud file");
  const PlyHeader h = read_ply_header(in, path);
  const bool ascii = h.format == "ascii";
  const bool big = h.format == "binary_big_endian";
  if (!ascii && !big && h.format != "binary_little_endian")
    throw core::InputError(path, "unknown PLY format '" + h.format + "'");
  std::vector<geometry::Vec3> points;
  for (const PlyElement& e : h.elements) {
    const bool vertex = e.name == "vertex";
    std::array<int, 3> slot{-1, -1, -1};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const auto& p = e.properties[k];
      if (!p.list && type_size(p.type) == 0) throw core::InputError(path, "unknown PLY property type '" + p.type + "'");
      if (vertex && !p.list && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z')
        slot[static_cast<std::size_t>(p.name[0] - 'x')] = static_cast<int>(k);
    }
    if (vertex && (slot[0] < 0 || slot[1] < 0 || slot[2] < 0))
      throw core::InputError(path, "PLY vertex element lacks x, y or z");
    if (!vertex && !ascii) {
      // Only the vertex element matters; binary elements after it need not be parsed.
      bool fixed = std::none_of(e.properties.begin(), e.properties.end(), [](const auto& p) { return p.list; });
      if (!fixed) break;
    }
    for (std::size_t i = 0; i < e.count; ++i) {
      std::array<double, 3> xyz{};
      if (ascii) {
        std::string line;
        while (std::getline(in, line) && line.find_first_not_of(" \t\r") == std::string::npos) {
        }
        if (!in) throw core::InputError(path, "PLY file ends inside element '" + e.name + "'");
        if (!vertex) continue;
        std::istringstream s(line);
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          double v = 0.0;
          if (!(s >> v)) throw core::InputError(path, "bad PLY vertex " + std::to_string(i));
          for (int c = 0; c < 3; ++c)
            if (slot[static_cast<std::size_t>(c)] == static_cast<int>(k)) xyz[static_cast<std::size_t>(c)] = v;
        }
      } else {
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const double v = read_binary(in, e.properties[k].type, big);
          for (int c = 0; c < 3; ++c)
            if (slot[static_cast<std::size_t>(c)] == static_cast<int>(k)) xyz[static_cast<std::size_t>(c)] = v;
        }
        if (!in) throw core::InputError(path, "PLY file ends inside element '" + e.name + "'");
      }
      if (!vertex) continue;
      if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
        throw core::InputError(path, "non-finite coordinate in PLY vertex " + std::to_string(i));
      points.push_back(place(xyz[0], xyz[1], xyz[2], options));
    }
    if (vertex) break;
  }
  return points;
}

}  // namespace

std::vector<geometry::Vec3> read_point_cloud(const std::string& path, const PointCloudOptions& options) {
  if (!std::filesystem::is_regular_file(path)) throw core::InputError(path, "cannot open point cloud file");
  const std::string ext = lower_extension(path);
  std::vector<geometry::Vec3> points;
  if (ext == ".ply") points = read_ply_cloud(path, options);
  else if (is_text_cloud_extension(ext)) points = read_text_cloud(path, options);
  else throw core::InputError(path, "unknown point cloud extension '" + ext + "' (use .xyz, .txt, .pts, .csv or .ply)");
  if (points.empty()) throw core::InputError(path, "empty point cloud: no points");
  return points;
}

bool is_point_cloud_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (is_text_cloud_extension(ext)) return true;
  if (ext != ".ply") return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  try {
    const PlyHeader h = read_ply_header(in, path);
    return std::none_of(h.elements.begin(), h.elements.end(),
                        [](const PlyElement& e) { return e.name == "face" && e.count > 0; });
  } catch (const core::InputError&) {
    return false;
  }
}

}  // namespace talus::io
