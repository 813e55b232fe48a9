#include "talus/core/settings.hpp"

#include "talus/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

namespace talus::core {

bool Range::contains(double value) const {
  if (!(value == value)) return false;  // NaN
  if (min_open ? !(value > min) : !(value >= min)) return false;
  if (max_open ? !(value < max) : !(value <= max)) return false;
  return true;
}

std::string Range::text(std::string_view unit) const {
  const auto end = [](double v) {
    if (v == std::numeric_limits<double>::infinity()) return std::string("inf");
    if (v == -std::numeric_limits<double>::infinity()) return std::string("-inf");
    // Short (%g), unless that rounds the bound (2^32 - 1 would read 4.29497e+09).
    char text[32];
    std::snprintf(text, sizeof text, "%g", v);
    return std::strtod(text, nullptr) == v ? std::string(text) : format_number(v);
  };
  std::string out = std::string(min_open || min == -std::numeric_limits<double>::infinity() ? "(" : "[") + end(min) +
                    ", " + end(max) + (max_open || max == std::numeric_limits<double>::infinity() ? ")" : "]");
  if (!unit.empty() && unit != "-") out += " " + std::string(unit);
  return out;
}

namespace {

// The visitor of check_ranges: reads nothing, changes nothing; each bounded number is
// checked (the values of bounded lists and triples by component).
class RangeCheck final : public SettingsVisitor {
 public:
  RangeCheck(const SettingsOrigins& origins, std::string prefix) : origins_(origins), prefix_(std::move(prefix)) {}

  void field(std::string_view, double&, std::string_view, std::string_view) override {}
  void field(std::string_view, std::optional<double>&, std::string_view, std::string_view) override {}
  void field(std::string_view, std::int64_t&, std::string_view, std::string_view) override {}
  void field(std::string_view, std::uint64_t&, std::string_view, std::string_view) override {}
  void field(std::string_view, bool&, std::string_view) override {}
  void field(std::string_view, std::string&, std::string_view) override {}
  void field(std::string_view, std::array<double, 3>&, std::string_view, std::string_view) override {}
  void field(std::string_view, std::vector<double>&, std::string_view, std::string_view) override {}
  void field(std::string_view, std::vector<std::string>&, std::string_view) override {}
  void field(std::string_view, std::vector<std::array<double, 2>>&, std::string_view, std::string_view) override {}
  void bounded(std::string_view key, double& value, std::string_view unit, std::string_view,
               const Range& range) override {
    check(key, value, unit, range);
  }
  void bounded(std::string_view key, std::optional<double>& value, std::string_view unit, std::string_view,
               const Range& range) override {
    if (value) check(key, *value, unit, range);
  }
  void bounded(std::string_view key, std::array<double, 3>& value, std::string_view unit, std::string_view,
               const Range& range) override {
    for (const double v : value) check(key, v, unit, range);
  }
  void bounded(std::string_view key, std::int64_t& value, std::string_view unit, std::string_view,
               const Range& range) override {
    check(key, static_cast<double>(value), unit, range);
  }
  void choice(std::string_view key, std::string& value, std::initializer_list<std::string_view> allowed,
              std::string_view) override {
    if (std::find(allowed.begin(), allowed.end(), value) != allowed.end()) return;
    std::string list;
    for (const std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    throw InputError(origins_.of(path(key)), path(key) + " = '" + value + "': must be one of " + list);
  }
  void section(std::string_view key, std::string_view, const std::function<void(SettingsVisitor&)>& body) override {
    RangeCheck inner(origins_, path(key) + ".");
    body(inner);
  }
  void list(std::string_view key, std::string_view, const ListAccess& items) override {
    for (std::size_t i = 0; i < items.size(); ++i) {
      RangeCheck inner(origins_, path(key) + "[" + std::to_string(i) + "].");
      items.visit_item(i, inner);
    }
  }

 private:
  std::string path(std::string_view key) const { return prefix_ + std::string(key); }
  void check(std::string_view key, double value, std::string_view unit, const Range& range) const {
    if (range.contains(value) && std::isfinite(value)) return;
    throw InputError(origins_.of(path(key)),
                     path(key) + " = " + format_number(value) + ": must be in " + range.text(unit));
  }
  const SettingsOrigins& origins_;
  std::string prefix_;
};

}  // namespace

std::string SettingsOrigins::full(std::string_view path) const {
  if (prefix_.empty()) return std::string(path);
  return prefix_ + (path.empty() || path.front() == '[' ? "" : ".") + std::string(path);
}

void SettingsOrigins::record(const std::string& path, const std::string& where) { where_[full(path)] = where; }

std::string SettingsOrigins::of(std::string_view path) const {
  const std::string full = this->full(path);
  if (const auto it = where_.find(full); it != where_.end()) return it->second;
  // A key an item of a list does not give keeps its default, in the item given there.
  for (std::size_t end = full.rfind(']'); end != std::string::npos && end > 0; end = full.rfind(']', end - 1))
    if (const auto it = where_.find(std::string_view(full).substr(0, end + 1)); it != where_.end()) return it->second;
  return source_;
}

std::string SettingsOrigins::of(std::initializer_list<std::string_view> paths) const {
  return of(std::vector<std::string>(paths.begin(), paths.end()));
}

std::string SettingsOrigins::of(const std::vector<std::string>& paths) const {
  // An override (--set, or another file's list of them) is named before the source.
  for (const std::string& path : paths)
    if (const std::string where = of(path); where != source_ && where.rfind(source_ + ":", 0) != 0) return where;
  return paths.empty() ? source_ : of(paths.front());
}

SettingsOrigins SettingsOrigins::within(std::string_view prefix) const {
  SettingsOrigins view = *this;
  view.prefix_ = full(prefix);
  return view;
}

void check_ranges(const std::function<void(SettingsVisitor&)>& visit, const SettingsOrigins& origins) {
  RangeCheck check(origins, "");
  visit(check);
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

}  // namespace talus::core
