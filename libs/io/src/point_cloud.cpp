#include "talus/io/point_cloud.hpp"
#include "talus/io/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>

#include "las_reader.hpp"
#include "mesh_text_readers.hpp"
#include "talus/core/error.hpp"
#include "talus/io/paths.hpp"

namespace talus::io {

namespace {

bool is_text_cloud_extension(const std::string& ext) {
  return ext == ".xyz" || ext == ".txt" || ext == ".pts" || ext == ".csv";
}

geometry::Vec3 place(double x, double y, double z, const PointCloudOptions& options) {
  geometry::Vec3 q(x, y, z);
  if (options.up == UpAxis::y) q = geometry::Vec3(x, -z, y);
  return q * options.scale;
}

// Columns of a text cloud line: runs of spaces, tabs and commas separate them, and a column
// may be quoted ("X" or 'X', as in the header lines PDAL writes).
void split_columns(std::string_view line, std::vector<std::string_view>& columns) {
  columns.clear();
  const auto separator = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; };
  std::size_t i = 0;
  while (i < line.size()) {
    if (separator(line[i])) {
      ++i;
      continue;
    }
    if (line[i] == '"' || line[i] == '\'') {
      const std::size_t close = line.find(line[i], i + 1);
      const std::size_t end = close == std::string_view::npos ? line.size() : close;
      columns.push_back(line.substr(i + 1, end - i - 1));
      i = end + 1;
      continue;
    }
    const std::size_t start = i;
    while (i < line.size() && !separator(line[i])) ++i;
    columns.push_back(line.substr(start, i - start));
  }
}

// The number a column holds, if all of it is one. Columns end at a separator, a quote or
// the end of the line, where strtod stops too.
std::optional<double> column_number(std::string_view column) {
  if (column.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(column.data(), &end);
  if (end != column.data() + column.size()) return std::nullopt;
  return v;
}

std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// A line for a message: at most 60 characters, without the line end.
std::string quoted_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
  return "'" + (line.size() > 60 ? std::string(line.substr(0, 57)) + "..." : std::string(line)) + "'";
}

// The columns of X, Y and Z a header line names (any letter case), or an error naming the
// file and line.
std::array<std::size_t, 3> header_columns(const std::vector<std::string_view>& columns, std::string_view line,
                                          const std::string& where) {
  constexpr std::size_t none = std::numeric_limits<std::size_t>::max();
  std::array<std::size_t, 3> slot{none, none, none};
  for (std::size_t k = 0; k < columns.size(); ++k) {
    const std::string name = lower(columns[k]);
    if (name.size() != 1 || name[0] < 'x' || name[0] > 'z') continue;
    std::size_t& s = slot[static_cast<std::size_t>(name[0] - 'x')];
    if (s != none)
      throw core::InputError(where, "the header names column " + std::string(1, static_cast<char>(std::toupper(name[0]))) +
                                        " twice (columns " + std::to_string(s + 1) + " and " + std::to_string(k + 1) +
                                        ")");
    s = k;
  }
  if (slot[0] == none && slot[1] == none && slot[2] == none)
    throw core::InputError(where, "expected x y z numbers or a header naming the X, Y and Z columns, got " +
                                      quoted_line(line));
  std::string missing;
  for (std::size_t c = 0; c < 3; ++c)
    if (slot[c] == none) missing += std::string(missing.empty() ? "" : " or ") + static_cast<char>('X' + c);
  if (!missing.empty()) throw core::InputError(where, "the header " + quoted_line(line) + " names no " + missing + " column");
  return slot;
}

std::vector<geometry::Vec3> read_text_cloud(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path);
  if (!in) throw core::InputError(path, "cannot open point cloud file");
  std::vector<geometry::Vec3> points;
  std::string line;
  std::size_t number = 0;
  // Set by a header line: the columns of x, y and z, the header's line, the columns a row needs.
  std::optional<std::array<std::size_t, 3>> header;
  std::size_t header_line = 0, needed = 0;
  bool first = true;
  const bool pts = lower_extension(path) == ".pts";
  std::vector<std::string_view> columns;
  while (std::getline(in, line)) {
    ++number;
    if (number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 byte order mark
    const auto start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#' || line.compare(start, 2, "//") == 0) continue;
    const std::string where = path + ": line " + std::to_string(number);
    if (first) {
      first = false;
      split_columns(line, columns);
      // A Leica .pts file starts with its point count, alone on the first line.
      if (pts && columns.size() == 1 && line.find_first_not_of("0123456789 \t\r") == std::string::npos) continue;
      if (columns.empty() || !column_number(columns.front())) {
        header = header_columns(columns, line, where);
        header_line = number;
        needed = 1 + std::max({(*header)[0], (*header)[1], (*header)[2]});
        continue;
      }
    }
    std::array<double, 3> xyz{};
    if (header) {
      split_columns(line, columns);
      if (columns.size() < needed)
        throw core::InputError(where, std::to_string(columns.size()) + " columns, expected at least " +
                                          std::to_string(needed) + " (the header on line " +
                                          std::to_string(header_line) + " puts X, Y, Z in columns " +
                                          std::to_string((*header)[0] + 1) + ", " + std::to_string((*header)[1] + 1) +
                                          ", " + std::to_string((*header)[2] + 1) + ")");
      for (std::size_t c = 0; c < 3; ++c) {
        const std::string_view column = columns[(*header)[c]];
        const std::optional<double> v = column_number(column);
        if (!v)
          throw core::InputError(where, std::string(1, static_cast<char>('X' + c)) + " (column " +
                                            std::to_string((*header)[c] + 1) + ") is not a number: '" +
                                            std::string(column) + "'");
        xyz[c] = *v;
      }
    } else {
      // No header: x y z are the first three numbers (further columns are ignored).
      std::replace(line.begin(), line.end(), ',', ' ');
      std::replace(line.begin(), line.end(), '\t', ' ');
      const char* p = line.c_str();
      for (double& v : xyz) {
        char* end = nullptr;
        v = std::strtod(p, &end);
        if (end == p) throw core::InputError(where, "expected x y z numbers");
        p = end;
      }
    }
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
      throw core::InputError(where, "non-finite coordinate");
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
  std::size_t lines = 0;  // the header's lines, end_header included
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
  h.lines = 1;
  while (std::getline(in, line)) {
    ++h.lines;
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

// Vertices (x, y, z of the vertex element) and faces (the vertex_indices list of the
// face element) of a PLY file, ASCII or binary.
struct PlyData {
  std::vector<geometry::Vec3> points;
  std::vector<std::vector<std::int64_t>> faces;
};

PlyData read_ply(const std::string& path, const PointCloudOptions& options, bool want_faces) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw core::InputError(path, "cannot open file");
  const PlyHeader h = read_ply_header(in, path);
  const bool ascii = h.format == "ascii";
  const bool big = h.format == "binary_big_endian";
  if (!ascii && !big && h.format != "binary_little_endian")
    throw core::InputError(path, "unknown PLY format '" + h.format + "'");
  PlyData data;
  std::istringstream words;
  // The line of the ASCII body being read, counted in the file (the header's lines first).
  std::size_t body_line = h.lines;
  // The next number of the body, whatever its layout. An ASCII word that is not a
  // number (or not a finite one) is named with its line of the body.
  auto next_value = [&](const std::string& type) -> double {
    if (!ascii) {
      const double v = read_binary(in, type, big);
      if (!in) throw core::InputError(path, "PLY file ends early");
      return v;
    }
    std::string word;
    while (!(words >> word)) {
      std::string line;
      if (!std::getline(in, line)) throw core::InputError(path, "PLY file ends early");
      ++body_line;
      words.clear();
      words.str(line);
    }
    const char* begin = word.c_str();
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    const std::string where = "line " + std::to_string(body_line) + ": ";
    if (end == begin || *end != '\0') throw core::InputError(path, where + "'" + word + "' is not a number");
    if (!std::isfinite(v)) throw core::InputError(path, where + "non-finite value '" + word + "'");
    return v;
  };
  for (const PlyElement& e : h.elements) {
    const bool vertex = e.name == "vertex", face = e.name == "face";
    std::array<int, 3> slot{-1, -1, -1};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const auto& p = e.properties[k];
      const std::string item = p.list ? p.type.substr(p.type.find(' ') + 1) : p.type;
      const std::string count = p.list ? p.type.substr(0, p.type.find(' ')) : p.type;
      if (type_size(item) == 0 || type_size(count) == 0)
        throw core::InputError(path, "unknown PLY property type '" + p.type + "'");
      if (vertex && !p.list && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z')
        slot[static_cast<std::size_t>(p.name[0] - 'x')] = static_cast<int>(k);
    }
    if (vertex && (slot[0] < 0 || slot[1] < 0 || slot[2] < 0))
      throw core::InputError(path, "PLY vertex element lacks x, y or z");
    for (std::size_t i = 0; i < e.count; ++i) {
      std::array<double, 3> xyz{};
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const auto& p = e.properties[k];
        if (p.list) {
          const std::string item = p.type.substr(p.type.find(' ') + 1);
          const double n = next_value(p.type.substr(0, p.type.find(' ')));
          if (!(n >= 0.0 && n < 1e6)) throw core::InputError(path, "bad PLY list length in element '" + e.name + "'");
          std::vector<std::int64_t> list;
          for (int j = 0; j < static_cast<int>(n); ++j) list.push_back(static_cast<std::int64_t>(next_value(item)));
          if (face && (p.name == "vertex_indices" || p.name == "vertex_index")) data.faces.push_back(std::move(list));
        } else {
          const double v = next_value(p.type);
          for (int c = 0; c < 3; ++c)
            if (slot[static_cast<std::size_t>(c)] == static_cast<int>(k)) xyz[static_cast<std::size_t>(c)] = v;
        }
      }
      if (!vertex) continue;
      if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
        throw core::InputError(path, "non-finite coordinate in PLY vertex " + std::to_string(i));
      data.points.push_back(place(xyz[0], xyz[1], xyz[2], options));
    }
    if (vertex && !want_faces) break;
  }
  return data;
}

// Adds polygon `face` (0-based indices) to `mesh` as a fan of triangles.
// Indices out of range are named as the file gives them: `one_based` (OBJ) or from 0 (PLY).
void add_polygon(geometry::TriangleMesh& mesh, const std::vector<std::int64_t>& face, const std::string& path,
                 bool one_based) {
  const auto n = static_cast<std::int64_t>(mesh.vertices.size());
  for (std::int64_t q : face)
    if (q < 0 || q >= n)
      throw core::InputError(path, one_based ? "face refers to vertex " + std::to_string(q + 1) + " of " + std::to_string(n)
                                             : "face refers to vertex index " + std::to_string(q) +
                                                   ", but the vertices are numbered 0 to " + std::to_string(n - 1));
  for (std::size_t k = 1; k + 1 < face.size(); ++k)
    mesh.triangles.push_back({static_cast<std::int32_t>(face[0]), static_cast<std::int32_t>(face[k]),
                              static_cast<std::int32_t>(face[k + 1])});
}

geometry::TriangleMesh read_obj(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path);
  if (!in) throw core::InputError(path, "cannot open mesh file");
  geometry::TriangleMesh mesh;
  std::string line, word;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream s(line);
    if (!(s >> word)) continue;
    if (word == "v") {
      double x = 0, y = 0, z = 0;
      if (!(s >> x >> y >> z)) throw core::InputError(path, "line " + std::to_string(number) + ": bad vertex");
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        throw core::InputError(path, "line " + std::to_string(number) + ": non-finite vertex coordinate");
      mesh.vertices.push_back(place(x, y, z, options));
    } else if (word == "f") {
      std::vector<std::int64_t> face;
      while (s >> word) {
        // "v", "v/vt", "v//vn" or "v/vt/vn"; negative indices count back from the last vertex.
        const long long v = std::strtoll(word.c_str(), nullptr, 10);
        if (v == 0) throw core::InputError(path, "line " + std::to_string(number) + ": bad face index '" + word + "'");
        face.push_back(v > 0 ? v - 1 : static_cast<std::int64_t>(mesh.vertices.size()) + v);
      }
      add_polygon(mesh, face, path + ": line " + std::to_string(number), true);
    }
  }
  return mesh;
}

geometry::TriangleMesh read_off(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path);
  if (!in) throw core::InputError(path, "cannot open mesh file");
  // Comments run from '#' to the end of the line.
  std::string text, line;
  while (std::getline(in, line)) text += line.substr(0, line.find('#')) + "\n";
  std::istringstream s(text);
  std::string magic;
  std::size_t nv = 0, nf = 0, ne = 0;
  if (!(s >> magic) || magic != "OFF" || !(s >> nv >> nf >> ne)) throw core::InputError(path, "bad OFF header");
  geometry::TriangleMesh mesh;
  for (std::size_t i = 0; i < nv; ++i) {
    double x = 0, y = 0, z = 0;
    if (!(s >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw core::InputError(path, "bad OFF vertex " + std::to_string(i));
    mesh.vertices.push_back(place(x, y, z, options));
  }
  for (std::size_t f = 0; f < nf; ++f) {
    std::size_t n = 0;
    if (!(s >> n) || n > 1000000) throw core::InputError(path, "bad OFF face " + std::to_string(f));
    std::vector<std::int64_t> face(n);
    for (auto& q : face)
      if (!(s >> q)) throw core::InputError(path, "bad OFF face " + std::to_string(f));
    std::getline(s, line);  // colours, if any
    add_polygon(mesh, face, path, false);
  }
  return mesh;
}

geometry::TriangleMesh read_ascii_stl(const std::string& path, const PointCloudOptions& options) {
  std::ifstream in(path);
  geometry::TriangleMesh mesh;
  std::string word;
  while (in >> word) {
    if (word != "vertex") continue;
    double x = 0, y = 0, z = 0;
    if (!(in >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw core::InputError(path, "bad STL vertex");
    mesh.vertices.push_back(place(x, y, z, options));
    if (mesh.vertices.size() % 3 == 0) {
      const auto b = static_cast<std::int32_t>(mesh.vertices.size() - 3);
      mesh.triangles.push_back({b, b + 1, b + 2});
    }
  }
  return mesh;
}

// OFF variants with colours or normals (COFF, NOFF …) are left to assimp.
bool is_plain_off(const std::string& path) {
  std::ifstream in(path);
  std::string magic;
  return (in >> magic) && magic == "OFF";
}

bool is_ascii_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(512, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return head.rfind("solid", 0) == 0 && head.find("facet") != std::string::npos;
}

}  // namespace

std::vector<geometry::Vec3> read_point_cloud(const std::string& path, const PointCloudOptions& options) {
  if (!std::filesystem::is_regular_file(path)) throw core::InputError(path, "cannot open point cloud file");
  const std::string ext = lower_extension(path);
  std::vector<geometry::Vec3> points;
  if (ext == ".ply") points = read_ply(path, options, false).points;
  else if (is_text_cloud_extension(ext)) points = read_text_cloud(path, options);
  else if (detail::is_las_extension(ext)) {
    points = detail::read_las(path, options.las_classes);
    for (geometry::Vec3& p : points) p = place(p.x(), p.y(), p.z(), options);
  } else
    throw core::InputError(path, "unknown point cloud extension '" + ext + "' (use .xyz, .txt, .pts, .csv, .las or .ply)");
  if (points.empty()) throw core::InputError(path, "empty point cloud: no points");
  check_coordinates(points, path, "point");
  return points;
}

bool is_point_cloud_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (is_text_cloud_extension(ext) || detail::is_las_extension(ext)) return true;
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

DeclaredCrs point_cloud_crs(const std::string& path) {
  if (detail::is_las_extension(lower_extension(path))) return detail::las_crs(path);
  return {};
}

namespace detail {

std::optional<geometry::TriangleMesh> read_mesh_in_double(const std::string& path, double scale, UpAxis up) {
  const std::string ext = lower_extension(path);
  const bool own = ext == ".obj" || (ext == ".off" && is_plain_off(path)) || ext == ".ply" ||
                   (ext == ".stl" && is_ascii_stl(path));
  if (!own) return std::nullopt;
  PointCloudOptions placement;
  placement.scale = scale;
  placement.up = up;
  if (ext == ".obj") return read_obj(path, placement);
  if (ext == ".off") return read_off(path, placement);
  if (ext == ".stl") return read_ascii_stl(path, placement);
  PlyData ply = read_ply(path, placement, true);
  geometry::TriangleMesh mesh;
  mesh.vertices = std::move(ply.points);
  for (const auto& face : ply.faces) add_polygon(mesh, face, path, false);
  return mesh;
}

}  // namespace detail

}  // namespace talus::io
