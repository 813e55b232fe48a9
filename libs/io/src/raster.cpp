#include "talus/io/raster.hpp"

#include <cpl_string.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>
#include <type_traits>

#include "talus/core/error.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/atomic_output.hpp"
#include "gdal_support.hpp"

namespace talus::io {
namespace {

using core::InputError;
using terrain::DemGrid;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Limits of what a raster may hold: elevations (m; the Earth's relief spans 2e4 m, a
// raster in millimetres 2e7), origin coordinates (m) and points (8 GB of doubles).
constexpr double kMaxElevation = 1e6;
constexpr double kMaxCoordinate = 1e9;
constexpr double kMaxRasterPoints = 1e9;

std::string lower(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "cannot open file (missing or not a regular file)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open file (unreadable)");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "cannot read file");
  return text;
}

// Parses the whole token as a double (from_chars is locale-independent and exact);
// accepts a leading '+', which from_chars does not.
std::optional<double> parse_double(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

// Shortest text that reads back as the same double.
std::string shortest(double value) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, ec == std::errc() ? end : buffer);
}

// Splits ESRI ASCII text into white-space separated tokens, tracking line numbers.
class Tokenizer {
 public:
  explicit Tokenizer(std::string_view text) : text_(text) {}
  struct Token {
    std::string_view text;
    std::size_t line = 0;
  };
  // The next token, or an empty one at the end of the text.
  Token next() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return {text_.substr(start, pos_ - start), line_};
  }
  Token peek() {
    const std::size_t pos = pos_, line = line_;
    const Token t = next();
    pos_ = pos;
    line_ = line;
    return t;
  }
  std::size_t line() const { return line_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

// A header line starts with a key: a letter, but not a spelled-out non-finite value
// (those are data, reported as non-finite).
bool starts_header_key(std::string_view token) {
  if (token.empty() || !std::isalpha(static_cast<unsigned char>(token[0]))) return false;
  const std::string t = lower(token);
  return t != "nan" && t != "inf" && t != "infinity";
}

struct AsciiHeader {
  struct Entry {
    double value = 0.0;
    std::size_t line = 0;
  };
  std::optional<Entry> ncols, nrows, xllcorner, xllcenter, yllcorner, yllcenter, cellsize, dx, dy, nodata;

  std::optional<Entry>* slot(const std::string& key) {
    if (key == "ncols") return &ncols;
    if (key == "nrows") return &nrows;
    if (key == "xllcorner") return &xllcorner;
    if (key == "xllcenter") return &xllcenter;
    if (key == "yllcorner") return &yllcorner;
    if (key == "yllcenter") return &yllcenter;
    if (key == "cellsize") return &cellsize;
    if (key == "dx") return &dx;
    if (key == "dy") return &dy;
    if (key == "nodata_value") return &nodata;
    return nullptr;
  }
};

// A token of the file as a message may show it: at most 32 characters, bytes other than
// printable ASCII as \xNN, so a binary file never fills the terminal with raw bytes.
std::string shown(std::string_view token) {
  std::string out;
  for (std::size_t k = 0; k < token.size() && k < 32; ++k) {
    const auto c = static_cast<unsigned char>(token[k]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  if (token.size() > 32) out += "...";
  return out;
}

std::string at_line(const std::string& path, std::size_t line) {
  return path + ":" + std::to_string(line);
}

std::int32_t grid_count(const std::string& path, const AsciiHeader::Entry& e, const char* key) {
  const double v = e.value;
  if (!(v >= 1.0) || v != std::floor(v) || v > std::numeric_limits<std::int32_t>::max())
    throw InputError(at_line(path, e.line),
                     std::string(key) + " must be a positive integer, got " + core::format_number(v));
  return static_cast<std::int32_t>(v);
}

double cell_size(const std::string& path, const AsciiHeader::Entry& e, const char* key) {
  if (!(e.value > 0.0))
    throw InputError(at_line(path, e.line),
                     std::string(key) + " must be positive, got " + core::format_number(e.value));
  return e.value;
}

// Lower-left grid point (a cell centre) from either the corner or the centre key.
double lower_left_centre(const std::string& path, const std::optional<AsciiHeader::Entry>& corner,
                         const std::optional<AsciiHeader::Entry>& centre, double size,
                         const char* axis, std::size_t header_end) {
  const std::string c = std::string(axis) + "llcorner", m = std::string(axis) + "llcenter";
  if (corner && centre)
    throw InputError(at_line(path, centre->line), "both " + c + " and " + m + " are given");
  if (corner) return corner->value + 0.5 * size;
  if (centre) return centre->value;
  throw InputError(at_line(path, header_end), "missing header key " + c + " (or " + m + ")");
}

}  // namespace

DemGrid read_esri_ascii(const std::string& path) {
  const std::string text = read_whole_file(path);
  // A UTF-8 byte-order mark (as some Windows editors save) is not part of the first key.
  const bool bom = text.compare(0, 3, "\xEF\xBB\xBF") == 0;
  Tokenizer tokens(std::string_view(text).substr(bom ? 3 : 0));
  AsciiHeader header;

  // Header: "key value" lines until the first numeric token.
  while (starts_header_key(tokens.peek().text)) {
    const auto key_token = tokens.next();
    const std::string key = lower(key_token.text);
    auto* slot = header.slot(key);
    if (!slot) throw InputError(at_line(path, key_token.line), "unknown header key '" + shown(key_token.text) + "'");
    if (*slot)
      throw InputError(at_line(path, key_token.line), "duplicate header key '" + shown(key_token.text) +
                                                          "' (first on line " + std::to_string((*slot)->line) + ")");
    const auto value_token = tokens.next();
    if (value_token.text.empty() || value_token.line != key_token.line)
      throw InputError(at_line(path, key_token.line), "header key '" + shown(key_token.text) + "' has no value");
    const auto value = parse_double(value_token.text);
    if (!value)
      throw InputError(at_line(path, key_token.line), "header key '" + shown(key_token.text) + "': '" +
                                                          shown(value_token.text) + "' is not a number");
    if (std::isnan(*value) && key != "nodata_value")
      throw InputError(at_line(path, key_token.line), "header key '" + shown(key_token.text) + "' is not finite");
    if (std::isinf(*value))
      throw InputError(at_line(path, key_token.line), "header key '" + shown(key_token.text) + "' is not finite");
    *slot = AsciiHeader::Entry{*value, key_token.line};
  }
  const std::size_t header_end = tokens.peek().text.empty() ? tokens.line() : tokens.peek().line;
  if (text.find_first_not_of(" \t\r\n\f\v") == std::string::npos) throw InputError(path, "empty file");

  auto require_key = [&](const std::optional<AsciiHeader::Entry>& e, const char* key) {
    if (!e) throw InputError(at_line(path, header_end), std::string("missing header key ") + key);
    return *e;
  };
  const std::int32_t nx = grid_count(path, require_key(header.ncols, "ncols"), "ncols");
  const std::int32_t ny = grid_count(path, require_key(header.nrows, "nrows"), "nrows");
  double dx = 0.0, dy = 0.0;
  if (header.cellsize) {
    if (header.dx || header.dy)
      throw InputError(at_line(path, (header.dx ? header.dx : header.dy)->line), "both cellsize and dx/dy are given");
    dx = dy = cell_size(path, *header.cellsize, "cellsize");
  } else if (header.dx || header.dy) {
    dx = cell_size(path, require_key(header.dx, "dx (with dy)"), "dx");
    dy = cell_size(path, require_key(header.dy, "dy (with dx)"), "dy");
  } else {
    throw InputError(at_line(path, header_end), "missing header key cellsize (or dx and dy)");
  }

  DemGrid dem;
  dem.spec.nx = nx;
  dem.spec.ny = ny;
  dem.spec.dx = dx;
  dem.spec.dy = dy;
  dem.spec.x0 = lower_left_centre(path, header.xllcorner, header.xllcenter, dx, "x", header_end);
  dem.spec.y0 = lower_left_centre(path, header.yllcorner, header.yllcenter, dy, "y", header_end);
  const bool has_nodata = header.nodata.has_value();
  const double nodata = has_nodata ? header.nodata->value : 0.0;

  for (const auto& [v, key] : {std::pair{dem.spec.x0, "x"}, std::pair{dem.spec.y0, "y"}})
    if (std::abs(v) > kMaxCoordinate)
      throw InputError(at_line(path, header_end), std::string("the lower-left ") + key + " " + core::format_number(v) +
                                                      " m is outside [-1e9, 1e9] m");
  const std::size_t expected = dem.spec.point_count();
  // Each value takes at least two characters: a header promising more than the file can
  // hold is refused before memory is reserved for it.
  if (expected > text.size() / 2 + 1)
    throw InputError(at_line(path, header.ncols->line),
                     "ncols " + std::to_string(nx) + " x nrows " + std::to_string(ny) + " = " +
                         std::to_string(expected) + " values cannot be in a file of " + std::to_string(text.size()) +
                         " bytes");
  dem.z.assign(expected, kNaN);
  std::size_t count = 0;
  for (auto token = tokens.next(); !token.text.empty(); token = tokens.next()) {
    if (count == expected)
      throw InputError(at_line(path, token.line),
                       "too many values: expected " + std::to_string(expected) + " (ncols " + std::to_string(nx) +
                           " x nrows " + std::to_string(ny) + "), extra value '" + shown(token.text) + "'");
    const auto value = parse_double(token.text);
    if (!value) throw InputError(at_line(path, token.line), "'" + shown(token.text) + "' is not a number");
    double z = *value;
    const bool is_nodata = has_nodata && (z == nodata || (std::isnan(z) && std::isnan(nodata)));
    if (is_nodata) z = kNaN;
    else if (!std::isfinite(z))
      throw InputError(at_line(path, token.line), "non-finite value '" + shown(token.text) + "'");
    else if (std::abs(z) > kMaxElevation)
      throw InputError(at_line(path, token.line), "value " + shown(token.text) + " is outside [-1e6, 1e6] m");
    // File rows run north to south; grid row j = 0 is the southernmost.
    const std::size_t row = count / static_cast<std::size_t>(nx), col = count % static_cast<std::size_t>(nx);
    dem.z[dem.spec.index(static_cast<std::int32_t>(col), ny - 1 - static_cast<std::int32_t>(row))] = z;
    ++count;
  }
  if (count < expected)
    throw InputError(at_line(path, tokens.line()),
                     "too few values: expected " + std::to_string(expected) + " (ncols " + std::to_string(nx) +
                         " x nrows " + std::to_string(ny) + "), found " + std::to_string(count));
  return dem;
}

void write_esri_ascii(const std::string& path, const DemGrid& dem, double nodata) {
  const auto& s = dem.spec;
  if (s.nx < 1 || s.ny < 1 || dem.z.size() != s.point_count())
    throw core::RuntimeError(path + ": cannot write an empty or inconsistent grid");
  if (!std::isfinite(nodata)) throw core::RuntimeError(path + ": the NODATA value must be finite");
  std::string text;
  text.reserve(s.point_count() * 10 + 200);
  text += "ncols " + std::to_string(s.nx) + "\nnrows " + std::to_string(s.ny) + "\n";
  text += "xllcenter " + shortest(s.x0) + "\nyllcenter " + shortest(s.y0) + "\n";
  if (s.dx == s.dy) text += "cellsize " + shortest(s.dx) + "\n";
  else text += "dx " + shortest(s.dx) + "\ndy " + shortest(s.dy) + "\n";
  text += "NODATA_value " + shortest(nodata) + "\n";
  for (std::int32_t j = s.ny - 1; j >= 0; --j) {
    for (std::int32_t i = 0; i < s.nx; ++i) {
      const double z = dem.z[s.index(i, j)];
      if (i) text += ' ';
      text += shortest(std::isnan(z) ? nodata : z);
    }
    text += '\n';
  }
  write_text_file(path, text);
}

namespace {

using gdal::DatasetPtr;
using gdal::name_of;
using gdal::parse_srs;
using gdal::SrsPtr;
using gdal::take_string;
using QuietGdal = gdal::Quiet;

}  // namespace

std::string gdal_description() {
  gdal::register_drivers();
  const bool gtiff = GDALGetDriverByName("GTiff") != nullptr;
  return std::string("GDAL ") + GDALVersionInfo("RELEASE_NAME") + (gtiff ? " (GeoTIFF read/write)" : " (no GeoTIFF driver)");
}

DemCrs dem_crs(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".asc") {
    for (const char* prj : {".prj", ".PRJ"}) {
      const std::filesystem::path side = std::filesystem::path(path).replace_extension(prj);
      std::error_code ec;
      if (!std::filesystem::is_regular_file(side, ec)) continue;
      std::ifstream in(side, std::ios::binary);
      std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (!in.good() && !in.eof()) throw InputError(side.string(), "cannot be read");
      // gdalsrsinfo -o wkt_esri writes a blank line first.
      while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
      const auto start = std::find_if(text.begin(), text.end(), [](unsigned char c) { return !std::isspace(c); });
      text.erase(text.begin(), start);
      if (text.empty()) throw InputError(side.string(), "is empty (a .prj file holds the CRS as WKT)");
      return {text, side.string()};
    }
    return {};
  }
  QuietGdal quiet;
  DatasetPtr ds(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!ds) throw InputError(path, "cannot be opened as a raster" + QuietGdal::last_message());
  const char* wkt = GDALGetProjectionRef(static_cast<GDALDatasetH>(ds.get()));
  if (wkt == nullptr || *wkt == '\0') return {};
  return {std::string(wkt), path};
}

std::string resolve_crs(const std::string& text, const std::string& source, CrsData data) {
  QuietGdal quiet;
  const SrsPtr srs = parse_srs(text);
  // On one line: a .prj's WKT may span several.
  std::string flat;
  for (const char c : text) {
    const bool space = std::isspace(static_cast<unsigned char>(c)) != 0;
    if (!space) flat += c;
    else if (!flat.empty() && flat.back() != ' ') flat += ' ';
  }
  while (!flat.empty() && flat.back() == ' ') flat.pop_back();
  const std::string shown = flat.size() > 60 ? flat.substr(0, 57) + "..." : flat;
  if (!srs)
    throw InputError(source, "CRS '" + shown + "' is not a coordinate reference system GDAL knows (give EPSG:nnnn, "
                             "WKT or a .prj file)" + QuietGdal::last_message());
  const std::string name = name_of(srs.get());
  const std::string hint =
      data == CrsData::point_cloud
          ? "reproject the point cloud to a projected CRS in metres first, e.g. pdal translate in.las out.las "
            "reprojection --filters.reprojection.out_srs=EPSG:32632 (the UTM zone or national grid of the site)"
          : "reproject the DEM to a projected CRS in metres first, e.g. gdalwarp -t_srs EPSG:32632 -tr 5 5 -r "
            "bilinear in.tif out.tif (the UTM zone or national grid of the site)";
  if (OSRIsGeographic(srs.get()))
    throw InputError(source, "CRS " + name + " is geographic (degrees); Talus computes in metres: " + hint);
  if (!OSRIsProjected(srs.get()))
    throw InputError(source, "CRS " + name + " is not a projected CRS; Talus computes in metres: " + hint);
  const double metres = OSRGetLinearUnits(srs.get(), nullptr);
  if (std::abs(metres - 1.0) > 1e-9)
    throw InputError(source, "CRS " + name + " measures in units of " + std::to_string(metres) +
                                 " m; Talus computes in metres: " + hint);
  char* wkt = nullptr;
  const char* options[] = {"FORMAT=WKT2_2019", "MULTILINE=NO", nullptr};
  if (OSRExportToWktEx(srs.get(), &wkt, options) != OGRERR_NONE)
    throw InputError(source, "CRS " + name + " cannot be written as WKT" + QuietGdal::last_message());
  return take_string(wkt);
}

std::string crs_name(const std::string& wkt) {
  if (wkt.empty()) return "none";
  QuietGdal quiet;
  const SrsPtr srs = parse_srs(wkt);
  return srs ? name_of(srs.get()) : "unreadable";
}

void write_prj(const std::string& path, const std::string& wkt) {
  if (wkt.empty()) return;
  QuietGdal quiet;
  const SrsPtr srs = parse_srs(wkt);
  if (!srs) throw core::RuntimeError(path + ": the CRS cannot be written as a .prj file");
  char* esri = nullptr;
  const char* options[] = {"FORMAT=WKT1_ESRI", nullptr};
  if (OSRExportToWktEx(srs.get(), &esri, options) != OGRERR_NONE)
    throw core::RuntimeError(path + ": the CRS cannot be written as a .prj file" + QuietGdal::last_message());
  write_text_file(path, take_string(esri) + "\n");
}

DemGrid read_geotiff(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "cannot open file (missing or not a regular file)");
  QuietGdal quiet;
  DatasetPtr ds(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!ds) throw InputError(path, "cannot read raster" + QuietGdal::last_message());
  const auto h = static_cast<GDALDatasetH>(ds.get());
  if (GDALGetRasterCount(h) < 1) throw InputError(path, "raster has no band");
  const int nx = GDALGetRasterXSize(h), ny = GDALGetRasterYSize(h);
  if (nx < 1 || ny < 1) throw InputError(path, "raster is empty");
  std::array<double, 6> gt{};
  if (GDALGetGeoTransform(h, gt.data()) != CE_None)
    throw InputError(path, "raster has no geotransform (georeferencing)");
  if (gt[2] != 0.0 || gt[4] != 0.0)
    throw InputError(path, "rotated or sheared geotransform is not supported (rotation terms " +
                               core::format_number(gt[2]) + ", " + core::format_number(gt[4]) + ")");
  for (double v : gt)
    if (!std::isfinite(v)) throw InputError(path, "geotransform is not finite");
  if (!(gt[1] > 0.0))
    throw InputError(path, "pixel width must be positive, got " + core::format_number(gt[1]));
  if (gt[5] == 0.0) throw InputError(path, "pixel height is zero");

  if (static_cast<double>(nx) * static_cast<double>(ny) > kMaxRasterPoints)
    throw InputError(path, "raster of " + std::to_string(nx) + " x " + std::to_string(ny) +
                               " points is larger than 1e9 points");
  if (std::abs(gt[0]) > kMaxCoordinate || std::abs(gt[3]) > kMaxCoordinate)
    throw InputError(path, "raster origin (" + core::format_number(gt[0]) + ", " + core::format_number(gt[3]) +
                               ") m is outside [-1e9, 1e9] m");
  GDALRasterBandH band = GDALGetRasterBand(h, 1);
  std::vector<double> rows(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  if (GDALRasterIO(band, GF_Read, 0, 0, nx, ny, rows.data(), nx, ny, GDT_Float64, 0, 0) != CE_None)
    throw InputError(path, "cannot read band 1" + QuietGdal::last_message());
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);

  DemGrid dem;
  dem.spec.nx = nx;
  dem.spec.ny = ny;
  dem.spec.dx = gt[1];
  dem.spec.dy = std::abs(gt[5]);
  dem.spec.x0 = gt[0] + 0.5 * gt[1];
  // North-up rasters (negative pixel height) store the northernmost row first.
  const bool north_up = gt[5] < 0.0;
  dem.spec.y0 = north_up ? gt[3] + (static_cast<double>(ny) - 0.5) * gt[5] : gt[3] + 0.5 * gt[5];
  dem.z.resize(rows.size());
  for (int r = 0; r < ny; ++r) {
    const int j = north_up ? ny - 1 - r : r;
    for (int i = 0; i < nx; ++i) {
      double z = rows[static_cast<std::size_t>(r) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)];
      if (std::isnan(z) || (has_nodata && z == nodata)) z = kNaN;
      else if (!std::isfinite(z))
        throw InputError(path, "non-finite value at row " + std::to_string(r + 1) + ", column " + std::to_string(i + 1));
      else if (std::abs(z) > kMaxElevation)
        throw InputError(path, "value " + core::format_number(z) + " at row " + std::to_string(r + 1) + ", column " +
                                   std::to_string(i + 1) + " is outside [-1e6, 1e6] m");
      dem.z[dem.spec.index(i, j)] = z;
    }
  }
  return dem;
}

void write_geotiff(const std::string& path, const DemGrid& dem, double nodata, const std::string& crs_wkt,
                   const BandInfo& info) {
  const auto& s = dem.spec;
  if (s.nx < 1 || s.ny < 1 || dem.z.size() != s.point_count())
    throw core::RuntimeError(path + ": cannot write an empty or inconsistent grid");
  if (!std::isfinite(nodata)) throw core::RuntimeError(path + ": the nodata value must be finite");
  AtomicOutput out(path);
  QuietGdal quiet;
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  if (!driver) throw core::RuntimeError(path + ": GDAL has no GTiff driver");
  char** options = nullptr;
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  options = CSLSetNameValue(options, "PREDICTOR", info.integer ? "2" : "3");
  const GDALDataType type = info.integer ? GDT_Int32 : GDT_Float64;
  DatasetPtr ds(GDALCreate(driver, out.temp_path().c_str(), s.nx, s.ny, 1, type, options));
  CSLDestroy(options);
  if (!ds) throw core::RuntimeError(path + ": cannot create GeoTIFF" + QuietGdal::last_message());
  const auto h = static_cast<GDALDatasetH>(ds.get());
  // North-up: the first row is the northernmost grid row; the transform gives pixel edges.
  const double top = s.y0 + static_cast<double>(s.ny - 1) * s.dy;
  std::array<double, 6> gt{s.x0 - 0.5 * s.dx, s.dx, 0.0, top + 0.5 * s.dy, 0.0, -s.dy};
  bool ok = GDALSetGeoTransform(h, gt.data()) == CE_None;
  if (ok && !crs_wkt.empty()) ok = GDALSetProjection(h, crs_wkt.c_str()) == CE_None;
  GDALRasterBandH band = GDALGetRasterBand(h, 1);
  ok = ok && GDALSetRasterNoDataValue(band, nodata) == CE_None;
  if (ok && !info.description.empty()) GDALSetDescription(band, info.description.c_str());
  if (ok && !info.unit.empty()) ok = GDALSetRasterUnitType(band, info.unit.c_str()) == CE_None;
  std::vector<double> rows(dem.z.size());
  for (std::int32_t r = 0; r < s.ny; ++r)
    for (std::int32_t i = 0; i < s.nx; ++i) {
      const double z = dem.z[s.index(i, s.ny - 1 - r)];
      rows[static_cast<std::size_t>(r) * static_cast<std::size_t>(s.nx) + static_cast<std::size_t>(i)] =
          std::isnan(z) ? nodata : z;
    }
  ok = ok && GDALRasterIO(band, GF_Write, 0, 0, s.nx, s.ny, rows.data(), s.nx, s.ny, GDT_Float64, 0, 0) == CE_None;
  if (!ok) throw core::RuntimeError(path + ": cannot write GeoTIFF" + QuietGdal::last_message());
  ds.reset();  // closing flushes the file
  if (CPLGetLastErrorType() >= CE_Failure)
    throw core::RuntimeError(path + ": cannot write GeoTIFF" + QuietGdal::last_message());
  out.commit();
}

BandInfo read_band_info(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "cannot open file (missing or not a regular file)");
  QuietGdal quiet;
  DatasetPtr ds(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!ds) throw InputError(path, "cannot read raster" + QuietGdal::last_message());
  const auto h = static_cast<GDALDatasetH>(ds.get());
  if (GDALGetRasterCount(h) < 1) throw InputError(path, "raster has no band");
  GDALRasterBandH band = GDALGetRasterBand(h, 1);
  const char* description = GDALGetDescription(band);
  const char* unit = GDALGetRasterUnitType(band);
  return {description ? description : "", unit ? unit : ""};
}

bool is_dem_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".asc" || ext == ".tif" || ext == ".tiff";
}

DemGrid read_dem(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".asc") return read_esri_ascii(path);
  if (ext == ".tif" || ext == ".tiff") return read_geotiff(path);
  throw InputError(path, "unknown DEM format '" + ext + "' (expected .asc, .tif or .tiff)");
}

}  // namespace talus::io
