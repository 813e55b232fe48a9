#include "talus/terrain/roughness.hpp"

#include <cmath>

#include "talus/core/error.hpp"

namespace talus::terrain {

double sigma_from_roughness_index(double roughness_index) {
  if (!(std::isfinite(roughness_index) && roughness_index >= 0.0)) {
    throw core::InputError("roughness_index",
                           "must be finite and >= 0, got " + core::format_number(roughness_index));
  }
  // σ = 2A mm with A = R / F, F = 1/400: σ = 800 R mm.
  constexpr double peak_frequency = 1.0 / 400.0;
  const double area_index = roughness_index / peak_frequency;
  return 2.0 * area_index * 1e-3;
}

}  // namespace talus::terrain
