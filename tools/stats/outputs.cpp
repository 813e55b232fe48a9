#include "outputs.hpp"


#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>

#include "talus/core/error.hpp"
#include "talus/dda/state.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/raster.hpp"

namespace talus::stats_tool {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The shortest text that reads back to the same double ("inf", "nan" for those).
std::string number(double x) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, x);
  return ec == std::errc() ? std::string(buffer, end) : std::string("nan");
}

// RFC 4180 quoting where needed.
std::string field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string row(std::initializer_list<std::string> cells) {
  std::string out;
  for (const auto& c : cells) out += (out.empty() ? "" : ",") + field(c);
  return out + "\n";
}

std::string quantile_name(double p) { return stats::Statistic{stats::Statistic::Kind::quantile, p}.name(); }

// The statistics of a variable as (statistic, value, unit) triples, in table order.
struct Cell {
  std::string statistic;
  double value;
  std::string unit;
};
std::vector<Cell> cells_of(const VariableSummary& v, const Settings& settings) {
  std::vector<Cell> out = {{"n", static_cast<double>(v.values.size()), ""},
                           {"missing", static_cast<double>(v.missing), ""}};
  if (v.censored) {
    out.push_back({"censored", static_cast<double>(*v.censored), ""});
    out.push_back({"censored_share", *v.censored_share(), "-"});
  }
  if (!v.sample) return out;
  const stats::Sample& s = *v.sample;
  out.insert(out.end(), {{"mean", s.mean(), v.unit}, {"sd", s.sd(), v.unit}, {"min", s.min(), v.unit},
                         {"max", s.max(), v.unit}});
  for (std::size_t k = 0; k < settings.quantiles.size(); ++k) {
    const std::string q = quantile_name(settings.quantiles[k]);
    out.push_back({q, v.quantiles[k], v.unit});
    if (!v.intervals.empty()) {
      out.push_back({q + "_ci_low", v.intervals[k].lo, v.unit});
      out.push_back({q + "_ci_high", v.intervals[k].hi, v.unit});
    }
  }
  out.push_back({"dkw_epsilon", v.dkw_epsilon, "-"});
  for (const auto& f : v.convergence) {
    const std::string name = f.statistic.name();
    out.push_back({name + "_relative_error", f.curve.back().relative_error, "-"});
    out.push_back({name + "_realizations_needed", f.needed, ""});
  }
  return out;
}

}  // namespace

std::string barrier_sheet_csv(const std::vector<Run>& runs, const Analysis& a, const Settings& settings) {
  const std::string& u = settings.energy_unit;
  const double scale = u == "kJ" ? 1e-3 : 1.0;
  std::string out = row({"run", "barrier", "segment", "from_m", "to_m", "crossings", "energy_Q95_" + u,
                         "energy_Q95_low_" + u, "energy_Q95_high_" + u, "energy_Q99_" + u, "energy_Q99_low_" + u,
                         "energy_Q99_high_" + u, "height_Q95_m", "height_Q95_low_m", "height_Q95_high_m",
                         "height_Q99_m", "height_Q99_low_m", "height_Q99_high_m", "ead_class_Q99",
                         "ead_class_Q99_high"});
  for (std::size_t r = 0; r < runs.size() && r < a.runs.size(); ++r)
    for (const BarrierSegment& s : a.runs[r].barrier_sheet) {
      const auto e = [&](double x) { return number(scale * x); };
      const auto cls = [](double x) {
        const int c = ead_energy_class(x);
        return c < 0 ? std::string() : std::to_string(c);
      };
      out += row({runs[r].name, s.barrier, s.segment, number(s.from), number(s.to), std::to_string(s.crossings),
                  e(s.energy[0]), e(s.energy_ci[0].lo), e(s.energy_ci[0].hi), e(s.energy[1]), e(s.energy_ci[1].lo),
                  e(s.energy_ci[1].hi), number(s.height[0]), number(s.height_ci[0].lo), number(s.height_ci[0].hi),
                  number(s.height[1]), number(s.height_ci[1].lo), number(s.height_ci[1].hi), cls(s.energy[1]),
                  cls(s.energy_ci[1].hi)});
    }
  return out;
}

std::string validation_csv(const Validation& v, const Settings& settings) {
  std::string out = row({"series", "observed", "variable", "statistic", "value", "unit"});
  for (const auto& var : v.variables) {
    auto put = [&](const std::string& statistic, double value, const std::string& unit) {
      out += row({v.series, v.file, var.name, statistic, number(value), unit});
    };
    put("n_observed", static_cast<double>(var.observed.size()), "");
    put("n_simulated", static_cast<double>(var.simulated.size()), "");
    put("censored_share", var.censored_share, "-");
    put("ks_distance", var.ks_distance, "-");
    put("ks_p_value", var.ks_p_value, "-");
    put("inside_P5_P95", var.inside_p5_p95, "-");
    for (std::size_t k = 0; k < settings.quantiles.size(); ++k) {
      const std::string q = quantile_name(settings.quantiles[k]);
      put("observed_" + q, var.observed_quantiles[k], var.unit);
      put("simulated_" + q, var.simulated_quantiles[k], var.unit);
      put("band_low_" + q, var.band_low[k], var.unit);
      put("band_high_" + q, var.band_high[k], var.unit);
      put("inside_" + q,
          var.observed_quantiles[k] >= var.band_low[k] && var.observed_quantiles[k] <= var.band_high[k] ? 1.0 : 0.0,
          "");
    }
  }
  return out;
}

std::string summary_csv(const Analysis& a, const Settings& settings) {
  std::string out = row({"run", "block", "variable", "statistic", "value", "unit"});
  for (const auto& s : a.series) {
    out += row({s.run, s.block, "realizations", "n", number(static_cast<double>(s.realizations)), ""});
    for (const auto& v : s.variables)
      for (const auto& c : cells_of(v, settings)) out += row({s.run, s.block, v.name, c.statistic, number(c.value), c.unit});
    for (const auto& f : s.fractions) {
      out += row({s.run, s.block, f.name, "count", number(static_cast<double>(f.count)), ""});
      out += row({s.run, s.block, f.name, "fraction", number(f.value), "-"});
    }
  }
  return out;
}

std::string convergence_csv(const Analysis& a) {
  std::string out = row({"run", "block", "variable", "statistic", "n", "estimate", "relative_error"});
  for (const auto& s : a.series)
    for (const auto& v : s.variables)
      for (const auto& f : v.convergence)
        for (const auto& p : f.curve)
          out += row({s.run, s.block, v.name, f.statistic.name(), std::to_string(p.n), number(p.estimate),
                      number(p.relative_error)});
  return out;
}

std::string comparison_csv(const Analysis& a) {
  std::string out =
      row({"variable", "run_a", "block_a", "run_b", "block_b", "n_a", "n_b", "ks_distance", "p_value"});
  for (const auto& c : a.comparisons) {
    const Series& x = a.series[c.a];
    const Series& y = a.series[c.b];
    out += row({c.variable, x.run, x.block, y.run, y.block, std::to_string(c.n_a), std::to_string(c.n_b),
                number(c.distance), number(c.p_value)});
  }
  return out;
}

namespace {

// Rows of the side-by-side table: (variable, statistic, unit, value per series).
struct WideRow {
  std::string variable, statistic, unit;
  std::vector<std::string> values;
};
std::vector<WideRow> wide_rows(const Analysis& a) {
  std::vector<WideRow> rows;
  const auto find_row = [&](const std::string& variable, const std::string& statistic,
                            const std::string& unit) -> WideRow& {
    for (auto& r : rows)
      if (r.variable == variable && r.statistic == statistic) return r;
    rows.push_back({variable, statistic, unit, std::vector<std::string>(a.series.size())});
    return rows.back();
  };
  // An undefined statistic (the sd of one value) stays empty: "-" in the printed table.
  const auto shown = [](double x) {
    if (std::isnan(x)) return std::string();
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.4g", x);
    return std::string(buffer);
  };
  for (std::size_t k = 0; k < a.series.size(); ++k) {
    const Series& s = a.series[k];
    find_row("realizations", "n", "").values[k] = std::to_string(s.realizations);
    for (const auto& v : s.variables) {
      // Which realizations a stop-position distribution holds, and how many it left out.
      if (v.censored) {
        find_row(v.name, "n", "").values[k] = std::to_string(v.values.size());
        find_row(v.name, "censored", "").values[k] = std::to_string(*v.censored);
        find_row(v.name, "censored_share", "-").values[k] = shown(*v.censored_share());
      }
      if (!v.sample) continue;
      find_row(v.name, "mean", v.unit).values[k] = shown(v.sample->mean());
      find_row(v.name, "sd", v.unit).values[k] = shown(v.sample->sd());
      find_row(v.name, "P50", v.unit).values[k] = shown(v.sample->quantile(0.5));
      find_row(v.name, "P95", v.unit).values[k] = shown(v.sample->quantile(0.95));
      find_row(v.name, "max", v.unit).values[k] = shown(v.sample->max());
    }
    for (const auto& f : s.fractions) find_row(f.name, "fraction", "-").values[k] = shown(f.value);
  }
  return rows;
}

std::string series_label(const Series& s) { return s.block == "all" ? s.run : s.run + "/" + s.block; }

}  // namespace

std::string side_by_side_csv(const Analysis& a) {
  std::string out = "variable,statistic,unit";
  for (const auto& s : a.series) out += "," + field(series_label(s));
  out += "\n";
  for (const auto& r : wide_rows(a)) {
    out += field(r.variable) + "," + field(r.statistic) + "," + field(r.unit);
    for (const auto& v : r.values) out += "," + v;
    out += "\n";
  }
  return out;
}

std::string side_by_side_text(const Analysis& a) {
  const auto rows = wide_rows(a);
  std::size_t first = 9;
  for (const auto& r : rows) first = std::max(first, r.variable.size() + r.statistic.size() + r.unit.size() + 4);
  std::vector<std::size_t> width;
  for (const auto& s : a.series) width.push_back(std::max<std::size_t>(series_label(s).size(), 10));
  const auto pad = [](const std::string& s, std::size_t w) { return std::string(w > s.size() ? w - s.size() : 0, ' ') + s; };
  std::string out = std::string("variable") + std::string(first - 8, ' ');
  for (std::size_t k = 0; k < a.series.size(); ++k) out += "  " + pad(series_label(a.series[k]), width[k]);
  out += "\n";
  for (const auto& r : rows) {
    std::string label = r.variable + " " + r.statistic + (r.unit.empty() ? "" : " (" + r.unit + ")");
    out += label + std::string(first > label.size() ? first - label.size() : 0, ' ');
    for (std::size_t k = 0; k < r.values.size(); ++k) out += "  " + pad(r.values[k].empty() ? "-" : r.values[k], width[k]);
    out += "\n";
  }
  return out;
}

namespace {

using io::h5::Group;

void write_vector(const Group& g, const std::string& name, const std::vector<double>& v, const std::string& unit) {
  if (!v.empty()) g.write(name, v.data(), {v.size()}, unit, v.size() > 4096);
}

void write_pairs(const Group& g, const std::string& name, const std::vector<std::array<double, 2>>& v) {
  if (!v.empty()) g.write(name, v.front().data(), {v.size(), 2}, "m", v.size() > 2048);
}

std::string group_name(std::string s) {
  for (char& c : s)
    if (c == '/' || c == '.') c = '_';
  return s;
}

void write_variable(const Group& parent, const VariableSummary& v, const Settings& settings) {
  const Group g = parent.create_group(group_name(v.name));
  g.set_attr("name", v.name);
  g.set_attr("unit", v.unit);
  g.set_attr("n", static_cast<std::int64_t>(v.values.size()));
  g.set_attr("missing", static_cast<std::int64_t>(v.missing));
  if (v.censored) {
    g.set_attr("censored", static_cast<std::int64_t>(*v.censored));
    g.set_attr("censored_share", *v.censored_share());
  }
  if (!v.sample) return;
  const stats::Sample& s = *v.sample;
  g.set_attr("mean", s.mean());
  g.set_attr("sd", s.sd());
  g.set_attr("min", s.min());
  g.set_attr("max", s.max());
  g.set_attr("dkw_epsilon", v.dkw_epsilon);
  write_vector(g, "values", v.values, v.unit);
  write_vector(g, "sorted", s.sorted(), v.unit);
  write_vector(g, "quantile_p", settings.quantiles, "-");
  write_vector(g, "quantile", v.quantiles, v.unit);
  if (!v.intervals.empty()) {
    std::vector<double> lo, hi;
    for (const auto& i : v.intervals) {
      lo.push_back(i.lo);
      hi.push_back(i.hi);
    }
    write_vector(g, "quantile_ci_low", lo, v.unit);
    write_vector(g, "quantile_ci_high", hi, v.unit);
  }
  if (v.convergence.empty()) return;
  const Group c = g.create_group("convergence");
  for (const auto& f : v.convergence) {
    const Group h = c.create_group(f.statistic.name());
    std::vector<std::int64_t> n;
    std::vector<double> estimate, error;
    for (const auto& p : f.curve) {
      n.push_back(static_cast<std::int64_t>(p.n));
      estimate.push_back(p.estimate);
      error.push_back(p.relative_error);
    }
    h.write("n", n.data(), {n.size()});
    write_vector(h, "estimate", estimate, v.unit);
    write_vector(h, "relative_error", error, "-");
    h.set_attr("realizations_needed", f.needed);
  }
}

void write_grid(const Group& g, const std::string& name, const terrain::DemGrid& dem, const std::string& unit) {
  g.write(name, dem.z.data(), {static_cast<std::uint64_t>(dem.spec.ny), static_cast<std::uint64_t>(dem.spec.nx)},
          unit, true);
}

void write_run(const Group& g, const Run& run, const RunResult& r) {
  g.set_attr("name", run.name);
  g.set_attr("terrain_file", r.terrain_file);
  g.set_attr("realizations", static_cast<std::int64_t>(run.file.data.records.size()));
  g.write_strings("files", run.files);
  g.write("origin_shift", r.origin_shift.data(), {3}, "m");
  if (r.hazard) {
    const Group h = g.create_group("hazard");
    const auto& spec = r.hazard->layers.front().grid.spec;
    h.set_attr("x0", spec.x0);
    h.set_attr("y0", spec.y0);
    h.set_attr("cell_size", spec.dx);
    std::vector<std::string> names;
    for (const auto& layer : r.hazard->layers) {
      names.push_back(layer.name);
      // HDF5 unit attributes use "-" for dimensionless values and "" for counts.
      const std::string& u = layer.band.unit;
      write_grid(h, layer.name, layer.grid, u == "1" ? "-" : u == "count" ? "" : u);
      h.set_dataset_attr(layer.name, "description", layer.band.description);
    }
    h.write_strings("layers", names);
  }
  const PlanView& p = r.plan;
  if (!p.terrain_x.empty()) {
    const Group t = g.create_group("terrain");
    write_vector(t, "x", p.terrain_x, "m");
    write_vector(t, "y", p.terrain_y, "m");
    write_vector(t, "z", p.terrain_z, "m");
    t.write("triangles", p.terrain_triangles.front().data(), {p.terrain_triangles.size(), 3}, {}, true);
  }
  if (!p.trajectory_realization.empty()) {
    const Group t = g.create_group("trajectories");
    t.write("realization", p.trajectory_realization.data(), {p.trajectory_realization.size()}, {}, true);
    t.write("position", p.trajectory_position.front().data(), {p.trajectory_position.size(), 3}, "m", true);
  }
  if (!p.barrier_names.empty()) {
    const Group b = g.create_group("barriers");
    b.write_strings("names", p.barrier_names);
    std::vector<std::array<double, 2>> vertices;
    std::vector<std::int64_t> offsets = {0};
    for (const auto& line : p.barrier_lines) {
      vertices.insert(vertices.end(), line.begin(), line.end());
      offsets.push_back(static_cast<std::int64_t>(vertices.size()));
    }
    write_pairs(b, "vertices", vertices);
    b.write("offsets", offsets.data(), {offsets.size()});
  }
}

}  // namespace

void write_summary_file(const std::string& path, const std::vector<Run>& runs, const Analysis& a,
                        const Settings& settings, const io::Provenance& provenance) {
  io::AtomicOutput out(path);
  {
    io::h5::File file = io::h5::File::create(out.temp_path(), path);
    const Group root = file.root();
    io::write_header(root, "stats-summary", {1, 0}, provenance);
    root.set_attr("confidence", settings.confidence);
    root.set_attr("convergence_target", settings.convergence_target);
    const Group all_runs = root.create_group("runs");
    for (std::size_t r = 0; r < runs.size(); ++r) write_run(all_runs.create_group(std::to_string(r)), runs[r], a.runs[r]);
    const Group all_series = root.create_group("series");
    for (std::size_t k = 0; k < a.series.size(); ++k) {
      const Series& s = a.series[k];
      const Group g = all_series.create_group(std::to_string(k));
      g.set_attr("run", s.run);
      g.set_attr("block", s.block);
      g.set_attr("run_index", static_cast<std::int64_t>(s.run_index));
      g.set_attr("realizations", static_cast<std::int64_t>(s.realizations));
      std::vector<std::string> names;
      for (const auto& v : s.variables) names.push_back(v.name);
      g.write_strings("variables", names);
      const Group vars = g.create_group("variable");
      for (const auto& v : s.variables) write_variable(vars, v, settings);
      std::vector<std::string> fnames;
      std::vector<std::int64_t> counts;
      std::vector<double> values;
      for (const auto& f : s.fractions) {
        fnames.push_back(f.name);
        counts.push_back(static_cast<std::int64_t>(f.count));
        values.push_back(f.value);
      }
      g.write_strings("fraction_names", fnames);
      g.write("fraction_count", counts.data(), {counts.size()});
      write_vector(g, "fraction", values, "-");
      write_pairs(g, "stop_points", s.stop_points);
    }
    if (a.validation) {
      const Group g = root.create_group("validation");
      g.set_attr("series", a.validation->series);
      g.set_attr("observed", a.validation->file);
      for (const auto& var : a.validation->variables) {
        const Group vg = g.create_group(var.name);
        write_vector(vg, "observed", var.observed, var.unit);
        write_vector(vg, "simulated", var.simulated, var.unit);
        vg.set_attr("ks_distance", var.ks_distance);
        vg.set_attr("ks_p_value", var.ks_p_value);
        vg.set_attr("inside_p5_p95", var.inside_p5_p95);
        vg.set_attr("dkw_epsilon", stats::dkw_epsilon(var.simulated.size(), 1.0 - settings.confidence));
      }
    }
    if (!a.comparisons.empty()) {
      const Group c = root.create_group("comparisons");
      std::vector<std::string> variable;
      std::vector<std::int64_t> sa, sb, na, nb;
      std::vector<double> d, p;
      for (const auto& x : a.comparisons) {
        variable.push_back(x.variable);
        sa.push_back(static_cast<std::int64_t>(x.a));
        sb.push_back(static_cast<std::int64_t>(x.b));
        na.push_back(static_cast<std::int64_t>(x.n_a));
        nb.push_back(static_cast<std::int64_t>(x.n_b));
        d.push_back(x.distance);
        p.push_back(x.p_value);
      }
      c.write_strings("variable", variable);
      c.write("series_a", sa.data(), {sa.size()});
      c.write("series_b", sb.data(), {sb.size()});
      c.write("n_a", na.data(), {na.size()});
      c.write("n_b", nb.data(), {nb.size()});
      write_vector(c, "ks_distance", d, "-");
      write_vector(c, "p_value", p, "-");
    }
    file.close();
  }
  out.commit();
}

std::vector<std::string> write_hazard_rasters(const std::string& dir, const std::vector<Run>& runs,
                                              const Analysis& a, const Settings& settings) {
  std::vector<std::string> written;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (!a.runs[r].hazard) continue;
    io::make_directories(dir);
    for (const HazardLayer& layer : a.runs[r].hazard->layers)
      for (const auto& format : settings.raster_formats) {
        const terrain::DemGrid* grid = &layer.grid;
        const std::string path = (fs::path(dir) / (runs[r].name + "-" + layer.name + "." + format)).string();
        const std::string& crs = a.runs[r].crs_wkt;
        if (format == "asc") {
          io::write_esri_ascii(path, *grid);
          if (!crs.empty()) {
            // The CRS beside the grid, as GIS software looks for it.
            const std::string prj = fs::path(path).replace_extension(".prj").string();
            io::write_prj(prj, crs);
            written.push_back(prj);
          }
        } else {
          io::write_geotiff(path, *grid, -9999.0, crs, layer.band);
        }
        written.push_back(path);
      }
  }
  return written;
}

namespace {

// The plan point `position` metres along a polyline from its first vertex (a barrier
// crossing's position); the last vertex beyond its end.
std::array<double, 2> point_along(const std::vector<std::array<double, 2>>& line, double position) {
  double walked = 0.0;
  for (std::size_t k = 1; k < line.size(); ++k) {
    const double dx = line[k][0] - line[k - 1][0], dy = line[k][1] - line[k - 1][1];
    const double len = std::hypot(dx, dy);
    if (position <= walked + len || k + 1 == line.size()) {
      const double f = len > 0.0 ? std::clamp((position - walked) / len, 0.0, 1.0) : 0.0;
      return {line[k - 1][0] + f * dx, line[k - 1][1] + f * dy};
    }
    walked += len;
  }
  return line.empty() ? std::array<double, 2>{kNaN, kNaN} : line.back();
}

std::string name_at(const std::vector<std::string>& names, std::int64_t index) {
  return index >= 0 && static_cast<std::size_t>(index) < names.size() ? names[static_cast<std::size_t>(index)]
                                                                       : std::to_string(index);
}

}  // namespace

std::vector<io::VectorLayer> vector_layers(const Run& run, const RunResult& result) {
  using io::FieldType;
  const auto& info = run.file.info;
  const auto& data = run.file.data;
  const auto& shift = result.origin_shift;
  std::map<std::uint32_t, const mc::Record*> record_of;
  for (const auto& r : data.records) record_of[r.realization] = &r;
  const auto block_of = [&](std::uint32_t realization) -> io::FieldValue {
    const auto it = record_of.find(realization);
    if (it == record_of.end()) return std::monostate{};
    return name_at(info.blocks, it->second->block);
  };
  const auto end_of = [&](std::uint32_t realization) -> io::FieldValue {
    const auto it = record_of.find(realization);
    if (it == record_of.end()) return std::monostate{};
    return std::string(dda::to_string(it->second->end));
  };
  std::vector<io::VectorLayer> layers;

  // Every realization where its centroid ended (failed ones too: end_reason tells them).
  io::VectorLayer& stops = layers.emplace_back();
  stops.name = "stop_points";
  stops.geometry = io::VectorGeometry::point_z;
  stops.fields = {{"realization", FieldType::integer},     {"block", FieldType::text},
                  {"end_reason", FieldType::text},         {"stop_class", FieldType::text},
                  {"runout", FieldType::real},             {"lateral", FieldType::real},
                  {"max_speed", FieldType::real},          {"max_jump_height", FieldType::real},
                  {"max_kinetic_energy", FieldType::real}, {"time", FieldType::real}};
  for (const auto& r : data.records) {
    const geometry::Vec3& p = r.final_position;
    stops.features.push_back(
        {{{p.x() + shift[0], p.y() + shift[1], p.z() + shift[2]}},
         {static_cast<std::int64_t>(r.realization), name_at(info.blocks, r.block), std::string(dda::to_string(r.end)),
          name_at(info.stop_classes, r.stop_class), r.runout, r.lateral, r.max_speed, r.max_jump_height,
          r.max_kinetic_energy, r.time}});
  }

  // The first crossing of each barrier by each realization, as the statistics use it.
  io::VectorLayer& crossings = layers.emplace_back();
  crossings.name = "barrier_crossings";
  crossings.geometry = io::VectorGeometry::point;
  crossings.fields = {{"realization", FieldType::integer}, {"block", FieldType::text},
                      {"end_reason", FieldType::text},     {"barrier", FieldType::text},
                      {"position", FieldType::real},       {"time", FieldType::real},
                      {"passing_height", FieldType::real}, {"speed", FieldType::real},
                      {"kinetic_energy", FieldType::real}, {"direction", FieldType::integer}};
  std::set<std::pair<std::uint32_t, std::int32_t>> seen;
  for (const auto& c : data.crossings) {
    if (!seen.insert({c.realization, c.barrier}).second) continue;  // rows are in time order per realization
    std::array<double, 2> xy = {kNaN, kNaN};
    if (c.barrier >= 0 && static_cast<std::size_t>(c.barrier) < info.barrier_lines.size())
      xy = point_along(info.barrier_lines[static_cast<std::size_t>(c.barrier)], c.position);
    // The run records +1 for a crossing from the line's right to its left; the side the
    // terrain falls to makes it +1 downslope whichever way the line was digitised.
    io::FieldValue direction;
    const auto& downslope = result.plan.barrier_downslope;
    if (c.barrier >= 0 && static_cast<std::size_t>(c.barrier) < downslope.size() && downslope[static_cast<std::size_t>(c.barrier)] != 0)
      direction = static_cast<std::int64_t>(c.direction * downslope[static_cast<std::size_t>(c.barrier)]);
    crossings.features.push_back({{{xy[0] + shift[0], xy[1] + shift[1], 0.0}},
                                  {static_cast<std::int64_t>(c.realization), block_of(c.realization),
                                   end_of(c.realization), name_at(info.barriers, c.barrier), c.position, c.time,
                                   c.height, c.velocity.norm(), c.kinetic_energy, direction}});
  }

  // The barrier lines, with the side they face downslope and their first crossings.
  io::VectorLayer& barriers = layers.emplace_back();
  barriers.name = "barriers";
  barriers.geometry = io::VectorGeometry::line_string;
  barriers.fields = {{"barrier", FieldType::text},
                     {"length", FieldType::real},
                     {"downslope_side", FieldType::text},
                     {"crossings", FieldType::integer}};
  for (std::size_t b = 0; b < result.plan.barrier_lines.size(); ++b) {
    io::VectorFeature f;
    double length = 0.0;
    const auto& line = result.plan.barrier_lines[b];
    for (std::size_t k = 0; k < line.size(); ++k) {
      f.vertices.push_back({line[k][0], line[k][1], 0.0});
      if (k > 0) length += std::hypot(line[k][0] - line[k - 1][0], line[k][1] - line[k - 1][1]);
    }
    const int side = b < result.plan.barrier_downslope.size() ? result.plan.barrier_downslope[b] : 0;
    std::int64_t count = 0;
    for (const BarrierSegment& s : result.barrier_sheet)
      if (s.segment == "all" && s.barrier == name_at(info.barriers, static_cast<std::int64_t>(b)))
        count = static_cast<std::int64_t>(s.crossings);
    f.values = {name_at(info.barriers, static_cast<std::int64_t>(b)), length,
                std::string(side > 0 ? "left" : side < 0 ? "right" : "unknown"), count};
    barriers.features.push_back(std::move(f));
  }

  // The release zone as the run drew from it: one feature per point, line or polygon.
  if (!info.release.empty()) {
    io::VectorLayer& release = layers.emplace_back();
    release.name = "release";
    release.geometry = info.release_kind == "point"  ? io::VectorGeometry::multi_point
                       : info.release_kind == "line" ? io::VectorGeometry::multi_line_string
                                                     : io::VectorGeometry::multi_polygon;
    release.fields = {{"feature", FieldType::integer}, {"probability", FieldType::real}};
    for (std::size_t k = 0; k < info.release.size(); ++k) {
      io::VectorFeature f;
      for (const auto& part : info.release[k].parts) {
        auto& rings = f.parts.emplace_back();
        for (const auto& ring : part) {
          auto& out = rings.emplace_back();
          for (const auto& p : ring) out.push_back({p[0] + shift[0], p[1] + shift[1], 0.0});
        }
      }
      f.values = {static_cast<std::int64_t>(k + 1), info.release[k].probability};
      release.features.push_back(std::move(f));
    }
  }

  // One 3-D polyline per realization of its sampled centroid positions.
  if (!data.trajectories.empty()) {
    io::VectorLayer& paths = layers.emplace_back();
    paths.name = "trajectories";
    paths.geometry = io::VectorGeometry::line_string_z;
    paths.fields = {{"realization", FieldType::integer}, {"block", FieldType::text}, {"end_reason", FieldType::text},
                    {"points", FieldType::integer},      {"duration", FieldType::real}};
    std::size_t k = 0;
    const auto& t = data.trajectories;
    while (k < t.size()) {
      const std::uint32_t i = t[k].realization;
      io::VectorFeature f;
      const double start = t[k].sample.time;
      double end = start;
      for (; k < t.size() && t[k].realization == i; ++k) {
        const geometry::Vec3& p = t[k].sample.position;
        // A point off the engine's finite states (a failed step) would void the line.
        if (!p.allFinite()) continue;
        f.vertices.push_back({p.x() + shift[0], p.y() + shift[1], p.z() + shift[2]});
        end = t[k].sample.time;
      }
      const auto points = static_cast<std::int64_t>(f.vertices.size());
      if (points < 2) f.vertices.clear();  // a line needs two points: no geometry
      f.values = {static_cast<std::int64_t>(i), block_of(i), end_of(i), points, end - start};
      paths.features.push_back(std::move(f));
    }
  }
  return layers;
}

std::vector<std::string> write_vector_layers(const std::string& dir, const std::vector<Run>& runs, const Analysis& a,
                                             const Settings& settings) {
  std::vector<std::string> written;
  if (settings.vector_format == "none") return written;
  io::make_directories(dir);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const std::vector<io::VectorLayer> layers = vector_layers(runs[r], a.runs[r]);
    const std::string& crs = a.runs[r].crs_wkt;
    if (settings.vector_format == "gpkg") {
      const std::string path = (fs::path(dir) / (runs[r].name + ".gpkg")).string();
      io::write_vector_file(path, "gpkg", layers, crs);
      written.push_back(path);
      continue;
    }
    for (const auto& layer : layers) {
      const std::string path = (fs::path(dir) / (runs[r].name + "-" + layer.name + ".geojson")).string();
      io::write_vector_file(path, "geojson", {layer}, crs);
      written.push_back(path);
    }
  }
  return written;
}

}  // namespace talus::stats_tool
