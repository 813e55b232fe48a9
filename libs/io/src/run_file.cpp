#include "talus/io/run_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/xdmf.hpp"

namespace talus::io {
namespace {

using core::InputError;
using Element = h5::Group::Element;

// One column of a table: its element type, width (0 = 1-D), unit and values.
struct Column {
  Element element = Element::f64;
  bool optional = false;  ///< may be absent from files of earlier versions (read as empty)
  std::uint64_t width = 0;
  std::string unit;
  std::vector<double> f64;
  std::vector<std::int64_t> i64;
  std::vector<std::int32_t> i32;
  std::vector<std::uint8_t> u8;
};
// Columns by name: the one description of each table, used to create the journal's
// appendable datasets, to append to them and to write the final file.
using Table = std::map<std::string, Column>;

Column& col(Table& t, const std::string& name, Element e, std::uint64_t width = 0, const std::string& unit = {}) {
  Column& c = t[name];
  c.element = e;
  c.width = width;
  c.unit = unit;
  return c;
}
void put3(std::vector<double>& v, const geometry::Vec3& p) { v.insert(v.end(), {p.x(), p.y(), p.z()}); }

Table record_table(const std::vector<mc::Record>& records) {
  Table t;
  auto& realization = col(t, "realization", Element::i64).i64;
  auto& block = col(t, "block", Element::i32).i32;
  auto& end = col(t, "end_reason", Element::u8).u8;
  auto& stop = col(t, "stop_class", Element::i32).i32;
  auto& impacts = col(t, "impacts", Element::i64).i64;
  auto& steps = col(t, "steps", Element::i64).i64;
  auto& time = col(t, "time", Element::f64, 0, "s").f64;
  auto& release = col(t, "release_position", Element::f64, 3, "m").f64;
  auto& final_position = col(t, "final_position", Element::f64, 3, "m").f64;
  auto& runout = col(t, "runout", Element::f64, 0, "m").f64;
  auto& lateral = col(t, "lateral", Element::f64, 0, "m").f64;
  auto& speed = col(t, "max_speed", Element::f64, 0, "m/s").f64;
  auto& jump = col(t, "max_jump_height", Element::f64, 0, "m").f64;
  auto& normal_jump = col(t, "max_normal_jump_height", Element::f64, 0, "m").f64;
  auto& energy = col(t, "max_kinetic_energy", Element::f64, 0, "J").f64;
  auto& violations = col(t, "invariant_violations", Element::i64).i64;
  auto& gain = col(t, "max_energy_gain", Element::f64, 0, "J").f64;
  auto& overlap = col(t, "max_overlap", Element::f64, 0, "m").f64;
  auto& removed = col(t, "energy_removed", Element::f64, 0, "J").f64;
  for (const auto& r : records) {
    realization.push_back(r.realization);
    block.push_back(r.block);
    end.push_back(static_cast<std::uint8_t>(r.end));
    stop.push_back(r.stop_class);
    impacts.push_back(static_cast<std::int64_t>(r.impacts));
    steps.push_back(static_cast<std::int64_t>(r.steps));
    time.push_back(r.time);
    put3(release, r.release_position);
    put3(final_position, r.final_position);
    runout.push_back(r.runout);
    lateral.push_back(r.lateral);
    speed.push_back(r.max_speed);
    jump.push_back(r.max_jump_height);
    normal_jump.push_back(r.max_normal_jump_height);
    energy.push_back(r.max_kinetic_energy);
    violations.push_back(static_cast<std::int64_t>(r.invariant_violations));
    gain.push_back(r.max_energy_gain);
    overlap.push_back(r.max_overlap);
    removed.push_back(r.energy_removed);
  }
  return t;
}

Table crossing_table(const std::vector<mc::Crossing>& crossings) {
  Table t;
  auto& realization = col(t, "realization", Element::i64).i64;
  auto& barrier = col(t, "barrier", Element::i32).i32;
  auto& position = col(t, "position", Element::f64, 0, "m").f64;
  auto& time = col(t, "time", Element::f64, 0, "s").f64;
  auto& height = col(t, "height", Element::f64, 0, "m").f64;
  auto& velocity = col(t, "velocity", Element::f64, 3, "m/s").f64;
  auto& energy = col(t, "kinetic_energy", Element::f64, 0, "J").f64;
  auto& direction = col(t, "direction", Element::i32).i32;
  for (const auto& c : crossings) {
    realization.push_back(c.realization);
    barrier.push_back(c.barrier);
    position.push_back(c.position);
    time.push_back(c.time);
    height.push_back(c.height);
    put3(velocity, c.velocity);
    energy.push_back(c.kinetic_energy);
    direction.push_back(c.direction);
  }
  return t;
}

Table trajectory_table(const std::vector<mc::TrajectoryPoint>& points) {
  Table t;
  auto& realization = col(t, "realization", Element::i64).i64;
  auto& time = col(t, "time", Element::f64, 0, "s").f64;
  auto& position = col(t, "position", Element::f64, 3, "m").f64;
  auto& velocity = col(t, "velocity", Element::f64, 3, "m/s").f64;
  auto& height = col(t, "height", Element::f64, 0, "m").f64;
  auto& energy = col(t, "energy", Element::f64, 0, "J").f64;
  // Columns added after the first schema: absent from earlier files (read as empty).
  auto& orientation = col(t, "orientation", Element::f64, 4, "1").f64;
  auto& spin = col(t, "angular_velocity", Element::f64, 3, "rad/s").f64;
  auto& motion = col(t, "motion", Element::u8).u8;
  t["orientation"].optional = t["angular_velocity"].optional = t["motion"].optional = true;
  for (const auto& p : points) {
    realization.push_back(p.realization);
    time.push_back(p.sample.time);
    put3(position, p.sample.position);
    put3(velocity, p.sample.velocity);
    height.push_back(p.sample.height);
    energy.push_back(p.sample.energy);
    const Eigen::Quaterniond& q = p.sample.orientation;
    orientation.insert(orientation.end(), {q.w(), q.x(), q.y(), q.z()});
    put3(spin, p.sample.angular_velocity);
    motion.push_back(static_cast<std::uint8_t>(p.sample.motion));
  }
  return t;
}

Table hazard_table(const mc::HazardAccumulator::Table& h) {
  Table t;
  col(t, "cell", Element::i64).i64 = h.cell;
  col(t, "reach", Element::i64).i64 = h.reach;
  col(t, "energy_zero", Element::i64).i64 = h.energy_zero;
  col(t, "height_zero", Element::i64).i64 = h.height_zero;
  col(t, "speed_max", Element::f64, 0, "m/s").f64 = h.speed_max;
  col(t, "height_max", Element::f64, 0, "m").f64 = h.height_max;
  t["speed_max"].optional = t["height_max"].optional = true;
  // Columns added after the first schema: absent from earlier files (read as empty).
  col(t, "energy_max", Element::f64, 0, "J").f64 = h.energy_max;
  col(t, "speed_zero", Element::i64).i64 = h.speed_zero;
  t["energy_max"].optional = t["speed_zero"].optional = true;
  col(t, "energy_bucket_cell", Element::i64).i64 = h.energy_cell;
  col(t, "energy_bucket_index", Element::i32).i32 = h.energy_index;
  col(t, "energy_bucket_count", Element::i64).i64 = h.energy_count;
  col(t, "height_bucket_cell", Element::i64).i64 = h.height_cell;
  col(t, "height_bucket_index", Element::i32).i32 = h.height_index;
  col(t, "height_bucket_count", Element::i64).i64 = h.height_count;
  col(t, "speed_bucket_cell", Element::i64).i64 = h.speed_cell;
  col(t, "speed_bucket_index", Element::i32).i32 = h.speed_index;
  col(t, "speed_bucket_count", Element::i64).i64 = h.speed_count;
  col(t, "exact_cell", Element::i64).i64 = h.exact_cell;
  col(t, "exact_energy", Element::f64, 0, "J").f64 = h.exact_energy;
  col(t, "exact_height", Element::f64, 0, "m").f64 = h.exact_height;
  col(t, "exact_speed", Element::f64, 0, "m/s").f64 = h.exact_speed;
  for (const char* name : {"speed_bucket_cell", "speed_bucket_index", "speed_bucket_count", "exact_cell",
                           "exact_energy", "exact_height", "exact_speed"})
    t[name].optional = true;
  return t;
}

std::uint64_t rows(const Column& c) {
  const std::uint64_t w = std::max<std::uint64_t>(c.width, 1);
  switch (c.element) {
    case Element::f64: return c.f64.size() / w;
    case Element::i64: return c.i64.size() / w;
    case Element::i32: return c.i32.size() / w;
    case Element::u8: return c.u8.size() / w;
  }
  return 0;
}

enum class Mode { create_appendable, append, write };

void store(const h5::Group& g, const Table& table, Mode mode) {
  for (const auto& [name, c] : table) {
    const std::uint64_t n = rows(c);
    if (mode == Mode::create_appendable) {
      g.create_appendable(name, c.element, c.width, c.unit);
    } else if (mode == Mode::append) {
      switch (c.element) {
        case Element::f64: g.append(name, c.f64.data(), n); break;
        case Element::i64: g.append(name, c.i64.data(), n); break;
        case Element::i32: g.append(name, c.i32.data(), n); break;
        case Element::u8: g.append(name, c.u8.data(), n); break;
      }
    } else {
      h5::Shape shape = {n};
      if (c.width > 0) shape.push_back(c.width);
      switch (c.element) {
        case Element::f64: g.write(name, c.f64.data(), shape, c.unit, true); break;
        case Element::i64: g.write(name, c.i64.data(), shape, c.unit, true); break;
        case Element::i32: g.write(name, c.i32.data(), shape, c.unit, true); break;
        case Element::u8: g.write(name, c.u8.data(), shape, c.unit, true); break;
      }
    }
  }
}

void truncate(Column& c, std::uint64_t n) {
  const std::uint64_t size = n * std::max<std::uint64_t>(c.width, 1);
  if (c.f64.size() > size) c.f64.resize(size);
  if (c.i64.size() > size) c.i64.resize(size);
  if (c.i32.size() > size) c.i32.resize(size);
  if (c.u8.size() > size) c.u8.resize(size);
}

// Reads the columns of `layout` from `g`, checking that every column has the same rows.
// A journal killed in the middle of an append may have longer columns than others
// (`torn`): they are cut to the shortest, and the chunk table decides what counts.
Table load(const h5::Group& g, Table layout, bool torn = false) {
  std::uint64_t n = std::numeric_limits<std::uint64_t>::max();
  bool first = true;
  for (auto& [name, c] : layout) {
    if (c.optional && !g.has(name)) continue;
    const h5::Shape expected = c.width > 0 ? h5::Shape{0, c.width} : h5::Shape{0};
    switch (c.element) {
      case Element::f64: c.f64 = g.read_doubles(name, expected); break;
      case Element::i64: c.i64 = g.read_int64(name, expected); break;
      case Element::i32: c.i32 = g.read_int32(name, expected); break;
      case Element::u8: c.u8 = g.read_uint8(name, expected); break;
    }
    if (torn) n = std::min(n, rows(c));
    else if (first) n = rows(c);
    else if (rows(c) != n)
      throw InputError(g.file_name(), g.path() + "/" + name + " has " + std::to_string(rows(c)) +
                                          " rows, expected " + std::to_string(n));
    first = false;
  }
  if (torn)
    for (auto& [name, c] : layout) truncate(c, n);
  return layout;
}

geometry::Vec3 get3(const std::vector<double>& v, std::size_t k) { return {v[3 * k], v[3 * k + 1], v[3 * k + 2]}; }

std::uint32_t realization_of(std::int64_t value, const h5::Group& g, std::uint64_t total) {
  if (value < 0 || static_cast<std::uint64_t>(value) >= total)
    throw InputError(g.file_name(), g.path() + ": realization " + std::to_string(value) + " is outside 0.." +
                                        std::to_string(total == 0 ? 0 : total - 1));
  return static_cast<std::uint32_t>(value);
}

std::vector<mc::Record> decode_records(const h5::Group& g, const RunInfo& info, bool torn = false) {
  Table t = load(g, record_table({}), torn);
  std::vector<mc::Record> out(rows(t["realization"]));
  for (std::size_t k = 0; k < out.size(); ++k) {
    mc::Record& r = out[k];
    r.realization = realization_of(t["realization"].i64[k], g, info.realizations);
    r.block = t["block"].i32[k];
    const std::uint8_t end = t["end_reason"].u8[k];
    if (end > static_cast<std::uint8_t>(dda::EndReason::penetration))
      throw InputError(g.file_name(), "unknown end reason " + std::to_string(end) + " in " + g.path());
    r.end = static_cast<dda::EndReason>(end);
    r.stop_class = t["stop_class"].i32[k];
    if (r.block < 0 || static_cast<std::size_t>(r.block) >= info.blocks.size() || r.stop_class < 0 ||
        static_cast<std::size_t>(r.stop_class) >= info.stop_classes.size())
      throw InputError(g.file_name(), "block or stop class index out of range in " + g.path());
    r.impacts = static_cast<std::uint64_t>(t["impacts"].i64[k]);
    r.steps = static_cast<std::uint64_t>(t["steps"].i64[k]);
    r.time = t["time"].f64[k];
    r.release_position = get3(t["release_position"].f64, k);
    r.final_position = get3(t["final_position"].f64, k);
    r.runout = t["runout"].f64[k];
    r.lateral = t["lateral"].f64[k];
    r.max_speed = t["max_speed"].f64[k];
    r.max_jump_height = t["max_jump_height"].f64[k];
    r.max_normal_jump_height = t["max_normal_jump_height"].f64[k];
    r.max_kinetic_energy = t["max_kinetic_energy"].f64[k];
    r.invariant_violations = static_cast<std::uint64_t>(t["invariant_violations"].i64[k]);
    r.max_energy_gain = t["max_energy_gain"].f64[k];
    r.max_overlap = t["max_overlap"].f64[k];
    r.energy_removed = t["energy_removed"].f64[k];
  }
  return out;
}

std::vector<mc::Crossing> decode_crossings(const h5::Group& g, const RunInfo& info, bool torn = false) {
  Table t = load(g, crossing_table({}), torn);
  std::vector<mc::Crossing> out(rows(t["realization"]));
  for (std::size_t k = 0; k < out.size(); ++k) {
    mc::Crossing& c = out[k];
    c.realization = realization_of(t["realization"].i64[k], g, info.realizations);
    c.barrier = t["barrier"].i32[k];
    if (c.barrier < 0 || static_cast<std::size_t>(c.barrier) >= info.barriers.size())
      throw InputError(g.file_name(), "barrier index out of range in " + g.path());
    c.position = t["position"].f64[k];
    c.time = t["time"].f64[k];
    c.height = t["height"].f64[k];
    c.velocity = get3(t["velocity"].f64, k);
    c.kinetic_energy = t["kinetic_energy"].f64[k];
    c.direction = t["direction"].i32[k];
  }
  return out;
}

std::vector<mc::TrajectoryPoint> decode_trajectories(const h5::Group& g, const RunInfo& info, bool torn = false) {
  Table t = load(g, trajectory_table({}), torn);
  std::vector<mc::TrajectoryPoint> out(rows(t["realization"]));
  for (std::size_t k = 0; k < out.size(); ++k) {
    mc::TrajectoryPoint& p = out[k];
    p.realization = realization_of(t["realization"].i64[k], g, info.realizations);
    p.sample.time = t["time"].f64[k];
    p.sample.position = get3(t["position"].f64, k);
    p.sample.velocity = get3(t["velocity"].f64, k);
    p.sample.height = t["height"].f64[k];
    p.sample.energy = t["energy"].f64[k];
    // A file of schema 1.1 or earlier has no pose: identity and zero, motion unknown (flight).
    if (!t["orientation"].f64.empty()) {
      const std::vector<double>& q = t["orientation"].f64;
      p.sample.orientation = Eigen::Quaterniond(q[4 * k], q[4 * k + 1], q[4 * k + 2], q[4 * k + 3]);
    }
    if (!t["angular_velocity"].f64.empty()) p.sample.angular_velocity = get3(t["angular_velocity"].f64, k);
    if (!t["motion"].u8.empty()) {
      const std::uint8_t m = t["motion"].u8[k];
      if (m > static_cast<std::uint8_t>(dda::Motion::contact))
        throw InputError(g.file_name(), g.path() + "/motion has the unknown value " + std::to_string(m));
      p.sample.motion = static_cast<dda::Motion>(m);
    }
  }
  return out;
}

mc::HazardAccumulator::Table decode_hazard(const Table& t) {
  mc::HazardAccumulator::Table h;
  h.cell = t.at("cell").i64;
  h.reach = t.at("reach").i64;
  h.energy_zero = t.at("energy_zero").i64;
  h.height_zero = t.at("height_zero").i64;
  h.speed_max = t.at("speed_max").f64;
  h.height_max = t.at("height_max").f64;
  h.energy_max = t.at("energy_max").f64;
  h.speed_zero = t.at("speed_zero").i64;
  h.speed_cell = t.at("speed_bucket_cell").i64;
  h.speed_index = t.at("speed_bucket_index").i32;
  h.speed_count = t.at("speed_bucket_count").i64;
  h.exact_cell = t.at("exact_cell").i64;
  h.exact_energy = t.at("exact_energy").f64;
  h.exact_height = t.at("exact_height").f64;
  h.exact_speed = t.at("exact_speed").f64;
  h.energy_cell = t.at("energy_bucket_cell").i64;
  h.energy_index = t.at("energy_bucket_index").i32;
  h.energy_count = t.at("energy_bucket_count").i64;
  h.height_cell = t.at("height_bucket_cell").i64;
  h.height_index = t.at("height_bucket_index").i32;
  h.height_count = t.at("height_bucket_count").i64;
  return h;
}

// The hazard table's columns have five different row counts; load them by group.
Table load_hazard(const h5::Group& g, bool torn = false) {
  Table layout = hazard_table({});
  Table out;
  const std::vector<std::string> groups = {"energy_bucket_", "height_bucket_", "speed_bucket_", "exact_"};
  for (const std::string prefix : {"", "energy_bucket_", "height_bucket_", "speed_bucket_", "exact_"}) {
    Table part;
    for (auto& [name, c] : layout) {
      const bool grouped =
          std::any_of(groups.begin(), groups.end(), [&](const std::string& p) { return name.rfind(p, 0) == 0; });
      if (prefix.empty() ? !grouped : name.rfind(prefix, 0) == 0) part[name] = c;
    }
    for (auto& [name, c] : load(g, part, torn)) out[name] = std::move(c);
  }
  return out;
}

// The release zone as flat arrays: vertices, then offsets of rings (into vertices), parts
// (into rings) and features (into parts), and each feature's probability.
void write_release(const h5::Group& run, const RunInfo& info) {
  const h5::Group g = run.create_group("release");
  g.set_attr("kind", info.release_kind);
  std::vector<double> vertices, probability;
  std::vector<std::int64_t> rings = {0}, parts = {0}, features = {0};
  for (const ReleaseArea& area : info.release) {
    for (const auto& part : area.parts) {
      for (const auto& ring : part) {
        for (const auto& p : ring) vertices.insert(vertices.end(), {p[0], p[1]});
        rings.push_back(static_cast<std::int64_t>(vertices.size() / 2));
      }
      parts.push_back(static_cast<std::int64_t>(rings.size() - 1));
    }
    features.push_back(static_cast<std::int64_t>(parts.size() - 1));
    probability.push_back(area.probability);
  }
  g.write("vertices", vertices.data(), {vertices.size() / 2, 2}, "m");
  g.write("ring_offsets", rings.data(), {rings.size()});
  g.write("part_offsets", parts.data(), {parts.size()});
  g.write("feature_offsets", features.data(), {features.size()});
  g.write("probability", probability.data(), {probability.size()}, "-");
}

void read_release(const h5::Group& run, RunInfo& info) {
  const h5::Group g = run.open_group("release");
  info.release_kind = g.attr_string("kind");
  const auto vertices = g.read_doubles("vertices", {0, 2});
  const auto rings = g.read_int64("ring_offsets", {0});
  const auto parts = g.read_int64("part_offsets", {0});
  const auto features = g.read_int64("feature_offsets", {0});
  // Each offset list starts at 0, never decreases and ends within what it indexes.
  const auto valid = [](const std::vector<std::int64_t>& o, std::size_t end) {
    if (o.empty() || o.front() != 0 || static_cast<std::uint64_t>(o.back()) > end) return false;
    return std::is_sorted(o.begin(), o.end());
  };
  if (!valid(rings, vertices.size() / 2) || !valid(parts, rings.size() - 1) || !valid(features, parts.size() - 1))
    throw InputError(run.file_name(), "/run/release offsets are inconsistent");
  const auto probability = g.read_doubles("probability", {features.size() - 1});
  if (features.size() == 1 && !probability.empty())
    throw InputError(run.file_name(), "/run/release/probability does not match its features");
  const auto at = [](const std::vector<std::int64_t>& o, std::size_t k) { return static_cast<std::size_t>(o[k]); };
  for (std::size_t f = 0; f + 1 < features.size(); ++f) {
    ReleaseArea& area = info.release.emplace_back();
    area.probability = probability[f];
    for (std::size_t p = at(features, f); p < at(features, f + 1); ++p) {
      auto& part = area.parts.emplace_back();
      for (std::size_t r = at(parts, p); r < at(parts, p + 1); ++r) {
        auto& ring = part.emplace_back();
        for (std::size_t v = at(rings, r); v < at(rings, r + 1); ++v) ring.push_back({vertices[2 * v], vertices[2 * v + 1]});
      }
    }
  }
}

void write_info(const h5::Group& root, const RunInfo& info) {
  const h5::Group run = root.create_group("run");
  run.set_attr("realizations", static_cast<std::int64_t>(info.realizations));
  run.set_attr("shard", info.shard);
  run.write_strings("blocks", info.blocks);
  run.write_strings("stop_classes", info.stop_classes);
  run.write_strings("barriers", info.barriers);
  std::vector<double> vertices;
  std::vector<std::int64_t> offsets = {0};
  for (const auto& line : info.barrier_lines) {
    for (const auto& p : line) vertices.insert(vertices.end(), {p[0], p[1]});
    offsets.push_back(static_cast<std::int64_t>(vertices.size() / 2));
  }
  run.write("barrier_vertices", vertices.data(), {vertices.size() / 2, 2}, "m");
  run.write("barrier_offsets", offsets.data(), {offsets.size()});
  run.set_attr("hazard_x0", info.hazard.x0);
  run.set_attr("hazard_y0", info.hazard.y0);
  run.set_attr("hazard_cell_size", info.hazard.size);
  run.set_attr("hazard_nx", static_cast<std::int64_t>(info.hazard.nx));
  run.set_attr("hazard_ny", static_cast<std::int64_t>(info.hazard.ny));
  run.set_attr("hazard_relative_accuracy", info.hazard_relative_accuracy);
  if (!info.terrain_fingerprint.empty()) run.set_attr("terrain_fingerprint", info.terrain_fingerprint);
  if (!info.terrain_file.empty()) run.set_attr("terrain_file", info.terrain_file);
  run.write("origin_shift", info.origin_shift.data(), {3}, "m");
  if (!info.release.empty()) write_release(run, info);
}

RunInfo read_info(const h5::Group& root) {
  RunInfo info;
  info.provenance = read_provenance(root);
  const h5::Group run = root.open_group("run");
  const std::int64_t total = run.attr_int("realizations");
  // dda-run numbers realizations with 32 bits (its realizations setting stops there).
  if (total <= 0 || total > 4294967295LL)
    throw InputError(root.file_name(), "/run: realizations is " + std::to_string(total) + ", must be in [1, 4294967295]");
  info.realizations = static_cast<std::uint64_t>(total);
  info.shard = run.attr_string("shard");
  {
    const auto slash = info.shard.find('/');
    std::uint64_t k = 0, n = 0;
    const bool digits = slash != std::string::npos && slash > 0 && slash + 1 < info.shard.size() &&
                        info.shard.find_first_not_of("0123456789/") == std::string::npos &&
                        info.shard.find('/', slash + 1) == std::string::npos && slash < 10 &&
                        info.shard.size() - slash - 1 < 10;
    if (digits) {
      k = std::stoull(info.shard.substr(0, slash));
      n = std::stoull(info.shard.substr(slash + 1));
    }
    if (!digits || n == 0 || k >= n)
      throw InputError(root.file_name(), "/run: shard '" + info.shard + "' is not K/N with 0 <= K < N");
  }
  info.blocks = run.read_strings("blocks");
  info.stop_classes = run.read_strings("stop_classes");
  info.barriers = run.read_strings("barriers");
  // Barrier names name the statistics of their crossings (stats' columns and groups).
  for (std::size_t k = 0; k < info.barriers.size(); ++k)
    for (std::size_t j = 0; j < k; ++j)
      if (info.barriers[j] == info.barriers[k])
        throw InputError(root.file_name(), "/run/barriers: the name '" + info.barriers[k] +
                                               "' is given to two barriers; barrier names must differ");
  const auto vertices = run.read_doubles("barrier_vertices", {0, 2});
  const auto offsets = run.read_int64("barrier_offsets", {info.barriers.size() + 1});
  for (std::size_t k = 0; k < info.barriers.size(); ++k) {
    if (offsets[k] < 0 || offsets[k] > offsets[k + 1] || static_cast<std::size_t>(offsets[k + 1]) * 2 > vertices.size())
      throw InputError(root.file_name(), "/run/barrier_offsets are inconsistent");
    std::vector<std::array<double, 2>> line;
    for (auto j = offsets[k]; j < offsets[k + 1]; ++j)
      line.push_back({vertices[2 * static_cast<std::size_t>(j)], vertices[2 * static_cast<std::size_t>(j) + 1]});
    info.barrier_lines.push_back(std::move(line));
  }
  info.hazard.x0 = run.attr_double("hazard_x0");
  info.hazard.y0 = run.attr_double("hazard_y0");
  info.hazard.size = run.attr_double("hazard_cell_size");
  info.hazard.nx = static_cast<std::int32_t>(run.attr_int("hazard_nx"));
  info.hazard.ny = static_cast<std::int32_t>(run.attr_int("hazard_ny"));
  info.hazard_relative_accuracy = run.attr_double("hazard_relative_accuracy");
  if (run.has_attr("terrain_fingerprint")) info.terrain_fingerprint = run.attr_string("terrain_fingerprint");
  if (run.has_attr("terrain_file")) info.terrain_file = run.attr_string("terrain_file");
  if (run.has("origin_shift")) {
    const auto shift = run.read_doubles("origin_shift", {3});
    info.origin_shift = {shift[0], shift[1], shift[2]};
  }
  if (run.has("release")) read_release(run, info);
  if (info.hazard.size < 0.0 || info.hazard.nx < 0 || info.hazard.ny < 0 ||
      !(info.hazard_relative_accuracy > 0.0 && info.hazard_relative_accuracy < 0.5))
    throw InputError(root.file_name(), "/run: invalid hazard grid");
  return info;
}

mc::HazardAccumulator empty_hazard(const RunInfo& info) {
  return mc::HazardAccumulator(info.hazard, info.hazard_relative_accuracy);
}

// Settings that leave a run's records unchanged, ignored when files are matched as parts
// of one run: outputs.chunk only sets how many finished realizations the journal writes
// together.
const std::vector<std::vector<std::string>> kRecordNeutralSettings = {{"outputs", "chunk"}};

// A run's settings as a tree without the record-neutral ones; null when the text is not
// YAML (then it is compared as text).
YAML::Node result_settings(const std::string& settings_yaml) {
  YAML::Node root;
  try {
    root = YAML::Load(settings_yaml);
  } catch (const YAML::Exception&) {
    return YAML::Node();
  }
  for (const auto& path : kRecordNeutralSettings) {
    // Nodes are references: reset() moves to the section, an assignment would overwrite it.
    YAML::Node map = root;
    bool found = true;
    for (std::size_t k = 0; k + 1 < path.size() && found; ++k) {
      const YAML::Node& parent = map;
      const YAML::Node section = parent.IsMap() ? parent[path[k]] : YAML::Node();
      found = section.IsDefined() && section.IsMap();
      if (found) map.reset(section);
    }
    if (found && map.IsMap()) map.remove(path.back());
  }
  return root;
}

// The first key where two settings trees differ ("engine.max_steps"), or "" when they
// agree: maps key by key, anything else (a value, a list) as a whole.
std::string first_difference(const YAML::Node& a, const YAML::Node& b, const std::string& path) {
  if (a.IsMap() && b.IsMap()) {
    const auto key_path = [&](const YAML::Node& key) { return path.empty() ? key.Scalar() : path + "." + key.Scalar(); };
    for (const auto& entry : a) {
      const YAML::Node other = b[entry.first.Scalar()];
      if (!other) return key_path(entry.first);
      if (std::string d = first_difference(entry.second, other, key_path(entry.first)); !d.empty()) return d;
    }
    for (const auto& entry : b)
      if (!a[entry.first.Scalar()]) return key_path(entry.first);
    return {};
  }
  return YAML::Dump(a) == YAML::Dump(b) ? std::string() : path.empty() ? std::string("settings") : path;
}

// Why file `b` is not part of the run of `a` ("" when it is): a setting that changes the
// records, the inputs read, the realization count or the terrain differ.
std::string run_difference(const RunInfo& a, const RunInfo& b) {
  if (run_identity(a) == run_identity(b)) return {};
  if (a.realizations != b.realizations)
    return "it is of a run of " + std::to_string(b.realizations) + " realizations, not " + std::to_string(a.realizations);
  const YAML::Node sa = result_settings(a.provenance.settings_yaml), sb = result_settings(b.provenance.settings_yaml);
  const std::string setting = sa && sb ? first_difference(sa, sb, "") : std::string("settings");
  if (!setting.empty()) return "the setting " + setting + " differs";
  if (a.provenance.inputs != b.provenance.inputs) return "its inputs differ: a file it read is another or has changed";
  return "its terrain differs";
}

const char* kJournalKind = "run-journal";
// Larger hazard grids keep only the sparse per-cell table (a dense raster would be ≥ 128 MiB).
constexpr double kMaxRasterCells = 16.0 * 1024 * 1024;

}  // namespace

RunInfo make_run_info(const mc::Scene& scene, const Provenance& provenance, const mc::Shard& shard) {
  RunInfo info;
  info.provenance = provenance;
  info.realizations = scene.realizations();
  info.shard = shard.text();
  for (const auto& b : scene.blocks()) info.blocks.push_back(b.name);
  info.stop_classes = scene.stop_classes();
  for (const auto& b : scene.barriers()) {
    info.barriers.push_back(b.name);
    std::vector<std::array<double, 2>> line;
    for (const auto& p : b.line) line.push_back({p.x(), p.y()});
    info.barrier_lines.push_back(std::move(line));
  }
  info.hazard = scene.hazard_grid();
  const auto& shift = scene.terrain().origin_shift;
  info.origin_shift = {shift.x(), shift.y(), shift.z()};
  info.hazard_relative_accuracy = scene.settings().outputs.hazard_relative_accuracy;
  info.release_kind = scene.settings().release.kind;
  double total = 0.0;
  for (const auto& f : scene.release_features()) total += f.weight;
  for (const auto& f : scene.release_features()) {
    ReleaseArea& area = info.release.emplace_back();
    area.probability = total > 0.0 ? f.weight / total : 0.0;
    for (const auto& part : f.parts) {
      auto& rings = area.parts.emplace_back();
      for (const auto& ring : part) {
        auto& out = rings.emplace_back();
        for (const auto& p : ring) out.push_back({p.x(), p.y()});
      }
    }
  }
  return info;
}

std::string run_journal_path(const std::string& output) { return output + ".journal"; }

namespace {

constexpr const char* kJournalInfo = "info.h5";

std::string chunk_name(std::uint64_t k) {
  char name[32];
  std::snprintf(name, sizeof name, "chunk-%08llu.h5", static_cast<unsigned long long>(k));
  return name;
}

// Writes an HDF5 file under a temporary name in its directory and renames it: the final
// name holds a complete file or nothing, whenever the process is killed.
template <class Fill>
void write_whole(const std::filesystem::path& path, Fill fill) {
  const std::filesystem::path temp =
      path.parent_path() / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()));
  try {
    {
      h5::File file = h5::File::create(temp.string(), path.string());
      fill(file.root());
      file.close();
    }
    std::filesystem::rename(temp, path);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(temp, ec);
    throw;
  }
}

}  // namespace

RunJournal RunJournal::create(const std::string& path, const RunInfo& info) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::remove_all(path, ec);
  if (!fs::create_directory(path, ec) || ec)
    throw core::RuntimeError(path + ": cannot create the journal directory (" + ec.message() + ")");
  write_whole(fs::path(path) / kJournalInfo, [&](const h5::Group& root) {
    write_header(root, kJournalKind, kRunSchema, info.provenance);
    write_info(root, info);
  });
  return RunJournal(path, info);
}

RunJournal RunJournal::resume(const std::string& path, const RunInfo& info) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(path))
    throw InputError(path, fs::exists(path) ? "not a journal directory (a journal of an older Talus is a file: delete "
                                              "it to start afresh)"
                                            : "no journal to resume");
  const fs::path info_path = fs::path(path) / kJournalInfo;
  // Killed while creating the journal, before its metadata was complete: nothing ran yet.
  if (!fs::exists(info_path)) return create(path, info);
  RunInfo stored;
  {
    const h5::File file = h5::File::open(info_path.string());
    check_header(file.root(), kJournalKind, kRunSchema);
    stored = read_info(file.root());
  }
  if (const std::string why = run_difference(stored, info); !why.empty())
    throw InputError(path, "the journal belongs to a run with other settings or inputs (" + why +
                               "); refusing to resume (delete it to start afresh)");
  if (stored.shard != info.shard)
    throw InputError(path, "the journal is of shard " + stored.shard + ", not " + info.shard);
  RunJournal journal(path, info);
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(path)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(".", 0) == 0) {
      // The temporary of a write that was killed: its chunk never counted.
      fs::remove(entry.path());
      continue;
    }
    if (name.rfind("chunk-", 0) == 0) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  std::vector<bool> seen(info.realizations, false);
  for (const auto& name : names) {
    const std::string file_path = (fs::path(path) / name).string();
    const h5::File file = h5::File::open(file_path);
    for (const auto& r : decode_records(file.root().open_group("records"), info)) {
      if (seen[r.realization]) throw InputError(file_path, "realization " + std::to_string(r.realization) + " repeats");
      seen[r.realization] = true;
      journal.done_.push_back(r.realization);
    }
    journal.chunks_.push_back(name);
    journal.next_chunk_ = std::max<std::uint64_t>(journal.next_chunk_, std::stoull(name.substr(6)) + 1);
  }
  return journal;
}

void RunJournal::append(const std::vector<mc::RealizationResult>& chunk) {
  if (chunk.empty()) return;
  mc::RunData data;
  data.hazard = empty_hazard(info_);
  for (const auto& r : chunk) data.add(mc::RealizationResult(r));
  const std::string name = chunk_name(next_chunk_);
  write_whole(std::filesystem::path(path_) / name, [&](const h5::Group& root) {
    store(root.create_group("records"), record_table(data.records), Mode::write);
    store(root.create_group("crossings"), crossing_table(data.crossings), Mode::write);
    store(root.create_group("trajectories"), trajectory_table(data.trajectories), Mode::write);
    store(root.create_group("hazard"), hazard_table(data.hazard.table()), Mode::write);
  });
  ++next_chunk_;
  chunks_.push_back(name);
  for (const auto& r : data.records) done_.push_back(r.realization);
}

std::vector<std::uint32_t> RunJournal::finished() const {
  std::vector<std::uint32_t> out = done_;
  std::sort(out.begin(), out.end());
  return out;
}

mc::RunData RunJournal::read() const {
  mc::RunData data;
  data.hazard = empty_hazard(info_);
  for (const auto& name : chunks_) {
    const std::string file_path = (std::filesystem::path(path_) / name).string();
    const h5::File file = h5::File::open(file_path);
    const h5::Group root = file.root();
    for (auto& r : decode_records(root.open_group("records"), info_)) data.records.push_back(r);
    for (auto& c : decode_crossings(root.open_group("crossings"), info_)) data.crossings.push_back(c);
    for (auto& p : decode_trajectories(root.open_group("trajectories"), info_)) data.trajectories.push_back(p);
    data.hazard.merge(decode_hazard(load_hazard(root.open_group("hazard"))), file_path);
  }
  data.sort(path_);
  return data;
}

void RunJournal::remove() const {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

void write_run_file(const std::string& path, const RunInfo& info, const mc::RunData& data) {
  AtomicOutput out(path);
  {
    h5::File file = h5::File::create(out.temp_path(), path);
    const h5::Group root = file.root();
    write_header(root, "run", kRunSchema, info.provenance);
    write_info(root, info);
    store(root.create_group("records"), record_table(data.records), Mode::write);
    store(root.create_group("crossings"), crossing_table(data.crossings), Mode::write);
    store(root.create_group("trajectories"), trajectory_table(data.trajectories), Mode::write);
    const h5::Group hazard = root.create_group("hazard");
    store(hazard, hazard_table(data.hazard.table()), Mode::write);
    const double cells = static_cast<double>(info.hazard.nx) * static_cast<double>(info.hazard.ny);
    if (info.hazard.size > 0.0 && cells <= kMaxRasterCells) {
      // A dense reach-count raster (ny × nx) for direct viewing.
      std::vector<std::int64_t> reach(static_cast<std::size_t>(info.hazard.nx) * static_cast<std::size_t>(info.hazard.ny), 0);
      for (const auto& [id, c] : data.hazard.cells()) reach[static_cast<std::size_t>(id)] = static_cast<std::int64_t>(c.reach);
      hazard.write("reach_raster", reach.data(),
                   {static_cast<std::uint64_t>(info.hazard.ny), static_cast<std::uint64_t>(info.hazard.nx)}, {}, true);
    }
    if (!data.trajectories.empty()) {
      // XDMF Mixed topology: for each realization, polyline type 2, node count, node ids.
      std::vector<std::int64_t> topology;
      std::size_t k = 0, polylines = 0;
      while (k < data.trajectories.size()) {
        std::size_t e = k;
        while (e < data.trajectories.size() && data.trajectories[e].realization == data.trajectories[k].realization) ++e;
        topology.push_back(2);
        topology.push_back(static_cast<std::int64_t>(e - k));
        for (std::size_t j = k; j < e; ++j) topology.push_back(static_cast<std::int64_t>(j));
        ++polylines;
        k = e;
      }
      const h5::Group traj = root.open_group("trajectories");
      traj.write("xdmf_topology", topology.data(), {topology.size()});
      // The pose as a rotation matrix (row-major, body → world) per sample: ParaView's
      // Tensor Glyph draws the block's axes from it.
      std::vector<double> rotation;
      rotation.reserve(9 * data.trajectories.size());
      for (const auto& p : data.trajectories) {
        const geometry::Mat3 r = p.sample.orientation.normalized().toRotationMatrix();
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) rotation.push_back(r(i, j));
      }
      traj.write("xdmf_rotation", rotation.data(), {data.trajectories.size(), 9});
      traj.set_attr("polylines", static_cast<std::int64_t>(polylines));
    }
    file.close();
  }
  if (!data.trajectories.empty()) {
    std::size_t polylines = 1;
    for (std::size_t k = 1; k < data.trajectories.size(); ++k)
      if (data.trajectories[k].realization != data.trajectories[k - 1].realization) ++polylines;
    const std::string h5_name = std::filesystem::path(path).filename().string();
    const std::size_t n = data.trajectories.size();
    const std::size_t topo = 2 * polylines + n;
    std::ostringstream x;
    x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"trajectories\" GridType=\"Uniform\">\n"
      << "   <Topology TopologyType=\"Mixed\" NumberOfElements=\"" << polylines << "\">\n"
      << "    <DataItem Dimensions=\"" << topo << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << h5_name
      << ":/trajectories/xdmf_topology</DataItem>\n   </Topology>\n"
      << "   <Geometry GeometryType=\"XYZ\">\n    <DataItem Dimensions=\"" << n
      << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":/trajectories/position</DataItem>\n"
      << "   </Geometry>\n";
    for (const char* name : {"time", "height", "energy"})
      x << "   <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Node\">\n    <DataItem Dimensions=\"" << n
        << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":/trajectories/" << name
        << "</DataItem>\n   </Attribute>\n";
    for (const char* name : {"velocity", "angular_velocity"})
      x << "   <Attribute Name=\"" << name << "\" AttributeType=\"Vector\" Center=\"Node\">\n    <DataItem Dimensions=\""
        << n << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":/trajectories/" << name
        << "</DataItem>\n   </Attribute>\n";
    x << "   <Attribute Name=\"motion\" AttributeType=\"Scalar\" Center=\"Node\">\n    <DataItem Dimensions=\"" << n
      << "\" NumberType=\"UChar\" Precision=\"1\" Format=\"HDF\">" << h5_name << ":/trajectories/motion</DataItem>\n"
      << "   </Attribute>\n"
      << "   <Attribute Name=\"rotation\" AttributeType=\"Tensor\" Center=\"Node\">\n    <DataItem Dimensions=\"" << n
      << " 9\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name
      << ":/trajectories/xdmf_rotation</DataItem>\n   </Attribute>\n  </Grid>\n </Domain>\n</Xdmf>\n";
    write_text_file(xdmf_sidecar_path(path), x.str());
  }
  out.commit();
}

namespace {

// A realization that did not fail numerically has only finite values: a NaN or an
// infinity in one is a damaged or hand-edited file, refused here rather than in stats.
void check_record_values(const std::vector<mc::Record>& records, const std::string& path) {
  for (const auto& r : records) {
    if (dda::is_failure(r.end)) continue;
    const std::pair<const char*, double> values[] = {
        {"time", r.time},
        {"runout", r.runout},
        {"lateral", r.lateral},
        {"max_speed", r.max_speed},
        {"max_jump_height", r.max_jump_height},
        {"max_normal_jump_height", r.max_normal_jump_height},
        {"max_kinetic_energy", r.max_kinetic_energy},
        {"final_position", r.final_position.norm()},
        {"release_position", r.release_position.norm()}};
    for (const auto& [name, value] : values)
      if (!std::isfinite(value))
        throw InputError(path, "/records: realization " + std::to_string(r.realization) + ": " + name + " is " +
                                   core::format_number(value) + " (values of a realization that did not fail must "
                                   "be finite)");
    // Magnitudes, durations and energies: a negative one is a damaged or edited file.
    const std::pair<const char*, double> magnitudes[] = {{"time", r.time},
                                                         {"max_speed", r.max_speed},
                                                         {"max_kinetic_energy", r.max_kinetic_energy}};
    for (const auto& [name, value] : magnitudes)
      if (value < 0.0)
        throw InputError(path, "/records: realization " + std::to_string(r.realization) + ": " + name + " is " +
                                   core::format_number(value) + " (must be >= 0)");
  }
}

}  // namespace

RunFile read_run_file(const std::string& path) {
  const h5::File file = h5::File::open(path);
  const h5::Group root = file.root();
  check_header(root, "run", kRunSchema);
  RunFile f;
  f.info = read_info(root);
  f.data.records = decode_records(root.open_group("records"), f.info);
  if (f.data.records.size() > f.info.realizations)
    throw InputError(path, "/records holds " + std::to_string(f.data.records.size()) + " rows for a run of " +
                               std::to_string(f.info.realizations) + " realizations");
  check_record_values(f.data.records, path);
  f.data.crossings = decode_crossings(root.open_group("crossings"), f.info);
  f.data.trajectories = decode_trajectories(root.open_group("trajectories"), f.info);
  f.data.hazard = empty_hazard(f.info);
  f.data.hazard.merge(decode_hazard(load_hazard(root.open_group("hazard"))), path);
  f.data.sort(path);
  return f;
}

std::string run_identity(const RunInfo& info) {
  const YAML::Node settings = result_settings(info.provenance.settings_yaml);
  return (settings ? YAML::Dump(settings) : info.provenance.settings_yaml) + '\x1f' + info.provenance.inputs + '\x1f' +
         std::to_string(info.realizations) + '\x1f' + info.terrain_fingerprint;
}

RunFile merge_run_files(const std::vector<RunFile>& shards, const std::vector<std::string>& names) {
  if (shards.empty()) throw core::UsageError("merge needs at least one run file");
  RunFile merged;
  merged.info = shards.front().info;
  merged.data.hazard = empty_hazard(merged.info);
  std::map<std::uint32_t, std::size_t> holder;  // realization → the shard that holds it
  for (std::size_t k = 0; k < shards.size(); ++k) {
    const RunInfo& info = shards[k].info;
    if (const std::string why = run_difference(merged.info, info); !why.empty())
      throw InputError(names[k], "is not a shard of the same run as " + names.front() + " (" + why + ")");
    for (const auto& r : shards[k].data.records) {
      const auto [at, inserted] = holder.emplace(r.realization, k);
      if (!inserted)
        throw InputError(names[k], "realization " + std::to_string(r.realization) + " appears twice (also in " +
                                       names[at->second] +
                                       (names[at->second] == names[k] ? "; the same file given twice?)" : ")"));
    }
    mc::RunData copy = shards[k].data;
    merged.data.append(std::move(copy));
  }
  merged.data.sort("merge");
  merged.info.shard = merged.data.records.size() == merged.info.realizations ? "0/1" : "partial";
  return merged;
}

}  // namespace talus::io
