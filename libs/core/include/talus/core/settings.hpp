// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace talus::core {

/// The allowed values of a number setting: an interval whose ends may be open or absent.
/// Settings declared with a range are refused outside it where they are read, naming the
/// file and line (or the --set key) and the interval.
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< min itself is excluded
  bool max_open = false;  ///< max itself is excluded

  bool contains(double value) const;
  /// "[0, 90)", "(0, inf)"; `unit` is appended when not empty ("[0, 90) deg").
  std::string text(std::string_view unit = {}) const;

  static Range closed(double lo, double hi) { return {lo, hi, false, false}; }
  /// [lo, hi)
  static Range right_open(double lo, double hi) { return {lo, hi, false, true}; }
  /// (lo, hi]
  static Range left_open(double lo, double hi) { return {lo, hi, true, false}; }
  /// (0, hi]
  static Range positive(double hi) { return {0.0, hi, true, false}; }
  /// [-limit, limit]
  static Range symmetric(double limit) { return {-limit, limit, false, false}; }
};

/// A settings struct declares each of its fields once, with its unit and meaning, by
/// accepting a SettingsVisitor:
///
///     void visit(SettingsVisitor& v) {
///       v.field("sigma", sigma_m, "m", "standard deviation of the elevation shifts");
///     }
///
/// The same declaration then reads YAML (unknown keys are errors), applies --set
/// overrides, prints the effective settings with units and descriptions, and records
/// provenance. Units are SI; angles given in degrees say "deg" in the unit and the key.
class SettingsVisitor {
 public:
  virtual ~SettingsVisitor() = default;

  virtual void field(std::string_view key, double& value, std::string_view unit,
                     std::string_view doc) = 0;
  /// An optional number: absent (null) unless given.
  virtual void field(std::string_view key, std::optional<double>& value, std::string_view unit,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::int64_t& value, std::string_view unit,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::uint64_t& value, std::string_view unit,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, bool& value, std::string_view doc) = 0;
  virtual void field(std::string_view key, std::string& value, std::string_view doc) = 0;
  virtual void field(std::string_view key, std::array<double, 3>& value, std::string_view unit,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::vector<double>& value, std::string_view unit,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::vector<std::string>& value,
                     std::string_view doc) = 0;
  /// A polygon or polyline: a list of [x, y] pairs.
  virtual void field(std::string_view key, std::vector<std::array<double, 2>>& value,
                     std::string_view unit, std::string_view doc) = 0;
  /// A number restricted to `range` (read as a number, then checked). The default only
  /// forwards to the plain field, for visitors that do not read values.
  virtual void bounded(std::string_view key, double& value, std::string_view unit, std::string_view doc,
                       const Range& range) {
    (void)range;
    field(key, value, unit, doc);
  }
  virtual void bounded(std::string_view key, std::optional<double>& value, std::string_view unit,
                       std::string_view doc, const Range& range) {
    (void)range;
    field(key, value, unit, doc);
  }
  /// Each component restricted to `range`.
  virtual void bounded(std::string_view key, std::array<double, 3>& value, std::string_view unit,
                       std::string_view doc, const Range& range) {
    (void)range;
    field(key, value, unit, doc);
  }
  /// An integer restricted to `range`.
  virtual void bounded(std::string_view key, std::int64_t& value, std::string_view unit, std::string_view doc,
                       const Range& range) {
    (void)range;
    field(key, value, unit, doc);
  }
  /// A string restricted to `allowed` (the first allowed value is not implied as default).
  virtual void choice(std::string_view key, std::string& value,
                      std::initializer_list<std::string_view> allowed, std::string_view doc) = 0;
  /// A nested group of settings.
  virtual void section(std::string_view key, std::string_view doc,
                       const std::function<void(SettingsVisitor&)>& body) = 0;

  /// A list of settings structs (materials, zones, barrier lines …).
  struct ListAccess {
    std::function<std::size_t()> size;
    std::function<void(std::size_t)> resize;
    std::function<void(std::size_t, SettingsVisitor&)> visit_item;
  };
  virtual void list(std::string_view key, std::string_view doc, const ListAccess& items) = 0;

  /// Convenience for std::vector<T> where T has `void visit(SettingsVisitor&)`.
  template <class T>
  void list_of(std::string_view key, std::string_view doc, std::vector<T>& items) {
    list(key, doc,
         ListAccess{[&items] { return items.size(); }, [&items](std::size_t n) { items.resize(n); },
                    [&items](std::size_t i, SettingsVisitor& v) { items[i].visit(v); }});
  }
};

/// Where the value of each setting came from, for messages about values checked after
/// reading (a release point off the terrain, a cell size that does not divide a slope):
/// "--set KEY" when the command line gave it, "FILE:LINE" when a line of the settings file
/// did, else the source alone (a default). The settings reader records it
/// (io::read_settings); a message about a value names `of(its key path)`.
class SettingsOrigins {
 public:
  /// `source` names values nobody gave: the settings file, or "settings" without one.
  SettingsOrigins(std::string source = "settings") : source_(std::move(source)) {}  // NOLINT: a name converts
  SettingsOrigins(const char* source) : source_(source) {}                           // NOLINT: a name converts

  /// The value at `path` ("release.points", "stop_zones[1].polygon") came from `where`.
  void record(const std::string& path, const std::string& where);
  /// Where the value at `path` came from. A path nobody gave takes the place of the list
  /// item it belongs to (its default was filled into an item given there), else the source.
  std::string of(std::string_view path) const;
  /// A message about several values (a cell size and the width it must divide) names the
  /// first of `paths` that an override (--set) gave, else where the first one came from.
  std::string of(std::initializer_list<std::string_view> paths) const;
  std::string of(const std::vector<std::string>& paths) const;
  /// The origins of the settings under `prefix` ("synthetic", a list "zones"), for code
  /// that knows only their keys: within("synthetic").of("cell_size") is
  /// of("synthetic.cell_size"), within("zones").of("[2].material") of("zones[2].material").
  SettingsOrigins within(std::string_view prefix) const;
  const std::string& source() const { return source_; }

 private:
  std::string full(std::string_view path) const;

  std::string source_;
  std::string prefix_;  ///< "synthetic" for a view of that section; "" for the whole
  std::map<std::string, std::string, std::less<>> where_;
};

/// Checks each number a settings struct declares as bounded (`visit` lets it declare its
/// fields) against the declared range, and that it is finite, and each choice against its
/// values: the check of settings made in code, which no reader has seen (the reader checks
/// what it reads). Throws InputError(origins.of(KEY), "KEY = VALUE: must be in RANGE") or
/// (…, "KEY = 'VALUE': must be one of A, B"), KEY with its sections' prefix.
void check_ranges(const std::function<void(SettingsVisitor&)>& visit, const SettingsOrigins& origins);

/// Levenshtein distance between two words: the suggestion for a misspelt key or option.
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace talus::core
