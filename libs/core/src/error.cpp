#include "talus/core/error.hpp"

#include <cstdio>

namespace talus::core {

std::string format_number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

}  // namespace talus::core
