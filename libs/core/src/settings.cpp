#include "talus/core/settings.hpp"

#include <cstdio>

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

}  // namespace talus::core
