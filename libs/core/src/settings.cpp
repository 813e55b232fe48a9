#include "talus/core/settings.hpp"

#include <algorithm>
#include <cstdio>
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
    char text[32];
    std::snprintf(text, sizeof text, "%g", v);
    return std::string(text);
  };
  std::string out = std::string(min_open || min == -std::numeric_limits<double>::infinity() ? "(" : "[") + end(min) +
                    ", " + end(max) + (max_open || max == std::numeric_limits<double>::infinity() ? ")" : "]");
  if (!unit.empty() && unit != "-") out += " " + std::string(unit);
  return out;
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
