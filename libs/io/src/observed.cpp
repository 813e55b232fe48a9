#include "talus/io/observed.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>

#include "talus/core/error.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/run_file.hpp"
#include "talus/io/vector.hpp"

namespace talus::io {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A CSV file's field separator, from its first line that is not a comment: a semicolon
// if it has one (then a comma inside a field is a decimal comma), else a comma, else a
// tab, else runs of spaces. One separator a file: a name with a space in it stays one field.
char separator_of(const std::string& line) {
  for (const char c : {';', ',', '\t'})
    if (line.find(c) != std::string::npos) return c;
  return ' ';
}

// The fields of a CSV line split at `sep` (' ': at runs of spaces and tabs), each with the
// spaces around it and its quotes taken off; with ';' a decimal comma becomes a point.
std::vector<std::string> fields_of(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cur;
  const auto finish = [&] {
    const auto first = cur.find_first_not_of(" \t");
    const auto last = cur.find_last_not_of(" \t");
    out.push_back(first == std::string::npos ? std::string() : cur.substr(first, last - first + 1));
    cur.clear();
  };
  bool any = false;
  for (char c : line) {
    if (c == '\r') continue;
    const bool split = sep == ' ' ? (c == ' ' || c == '\t') : c == sep;
    if (split) {
      if (sep != ' ' || any) finish();
      any = false;
      continue;
    }
    if (c == '"' || c == '\'') continue;
    if (sep == ';' && c == ',') c = '.';
    cur += c;
    any = any || (c != ' ' && c != '\t');
  }
  if (any || (sep != ' ' && !out.empty())) finish();
  return out;
}

bool parse_number(const std::string& text, double& value) {
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(value);
}

ObservedStops read_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw core::InputError(path, "cannot open the observed stop points");
  ObservedStops out;
  std::string line;
  std::size_t number = 0, c0 = 0, c1 = 1;
  bool first = true, runouts = false, with_lateral = false;
  char sep = 0;
  while (std::getline(in, line)) {
    ++number;
    const auto start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    if (sep == 0) sep = separator_of(line);
    const auto f = fields_of(line, sep);
    if (f.empty()) continue;
    double a = 0.0, b = 0.0;
    if (first) {
      first = false;
      if (!parse_number(f[0], a)) {
        bool found_x = false, found_y = false, found_runout = false, found_lateral = false;
        std::size_t cx = 0, cy = 1, cr = 0, cl = 0;
        for (std::size_t k = 0; k < f.size(); ++k) {
          const std::string name = lower(f[k]);
          if ((name == "x" || name == "easting" || name == "east") && !found_x) cx = k, found_x = true;
          if ((name == "y" || name == "northing" || name == "north") && !found_y) cy = k, found_y = true;
          if (name == "runout" && !found_runout) cr = k, found_runout = true;
          if (name == "lateral" && !found_lateral) cl = k, found_lateral = true;
        }
        if (found_x && found_y) {
          c0 = cx, c1 = cy;
        } else if (found_runout) {
          runouts = true;
          with_lateral = found_lateral;
          c0 = cr, c1 = found_lateral ? cl : cr;
        } else {
          throw core::InputError(path, "line " + std::to_string(number) +
                                           ": the header names no x and y (or easting and northing) column, nor "
                                           "a runout column");
        }
        continue;
      }
    }
    if (f.size() <= std::max(c0, c1) || !parse_number(f[c0], a) || !parse_number(f[c1], b))
      throw core::InputError(path, "line " + std::to_string(number) +
                                       (runouts ? ": expected a runout (m)" : ": expected the x and y of a stop point (m)"));
    out.rows.push_back("line " + std::to_string(number));
    if (runouts) {
      out.runout.push_back(a);
      if (with_lateral) out.lateral.push_back(b);
    } else {
      out.points.push_back({a, b});
    }
  }
  if (out.points.empty() && out.runout.empty()) throw core::InputError(path, "holds no observed stop point");
  return out;
}

bool is_csv(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".csv" || ext == ".txt" || ext == ".xy" || ext == ".xyz";
}

}  // namespace

ObservedStops read_observed_stops(const std::string& path, const std::string& layer, const std::string& terrain_crs_wkt,
                                  const std::string& key) {
  if (is_csv(path)) return read_csv(path);
  if (lower_extension(path) == ".h5") {
    // A run of dda-run (a synthetic experiment, or another model's run): its
    // realizations at rest, in the terrain's input coordinates.
    const RunFile run = read_run_file(path);
    ObservedStops out;
    for (const mc::Record& r : run.data.records)
      if (r.end == dda::EndReason::rest) {
        out.points.push_back({r.final_position.x() + run.info.origin_shift[0], r.final_position.y() + run.info.origin_shift[1]});
        out.rows.push_back("realization " + std::to_string(r.realization));
      }
    if (out.points.empty()) throw core::InputError(path, "holds no realization at rest");
    return out;
  }
  VectorRequest request;
  request.path = path;
  request.layer = layer;
  request.kind = "point";
  request.key = key;
  ObservedStops out;
  for (const mc::PlanFeature& f : read_plan_features(request, terrain_crs_wkt))
    for (const auto& part : f.parts)
      for (const auto& ring : part)
        for (const Eigen::Vector2d& p : ring) {
          out.points.push_back({p.x(), p.y()});
          out.rows.push_back(f.label);
        }
  if (out.points.empty()) throw core::InputError(path, "holds no observed stop point");
  return out;
}

}  // namespace talus::io
