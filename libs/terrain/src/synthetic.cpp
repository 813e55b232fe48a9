#include "talus/terrain/synthetic.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "talus/core/error.hpp"

namespace talus::terrain {
namespace {

using core::format_number;

// Points of a lattice of step `cell` over `extent`, allowing 1e-9 of a cell of rounding.
// `origins` are those of the slope's settings; `extent_key` the one that gave the extent.
std::int32_t lattice_points(double extent, double cell, const std::string& what, const std::string& extent_key,
                            const core::SettingsOrigins& origins) {
  const std::string source = origins.of({"cell_size", extent_key});
  const double n = std::floor(extent / cell + 1e-9) + 1.0;
  if (n < 2.0) {
    throw core::InputError(source, "synthetic slope: " + what + " " + format_number(extent) +
                                       " m is shorter than one cell (" + format_number(cell) + " m)");
  }
  if (n > 1e6) throw core::InputError(source, "synthetic slope: " + what + " needs more than 10^6 points");
  // A remainder would be cut off silently: the slope would be smaller than asked for.
  if (std::abs(extent - (n - 1.0) * cell) > 1e-6 * cell)
    throw core::InputError(source, "synthetic slope: " + what + " " + format_number(extent) +
                                       " m is not a whole number of cells of cell_size " + format_number(cell) +
                                       " m (choose a cell_size that divides it)");
  return static_cast<std::int32_t>(n);
}

void require_positive(double value, const std::string& key, const core::SettingsOrigins& origins) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw core::InputError(origins.of(key),
                           "synthetic slope: " + key + " must be finite and > 0, got " + format_number(value));
  }
}

// z at x on the piecewise-linear profile (constant beyond its ends).
double profile_z(const std::vector<std::array<double, 2>>& p, double x) {
  if (x <= p.front()[0]) return p.front()[1];
  for (std::size_t k = 1; k < p.size(); ++k) {
    if (x <= p[k][0]) {
      // Exact at breakpoints: t = 1 gives p[k] bit for bit.
      const double t = (x - p[k - 1][0]) / (p[k][0] - p[k - 1][0]);
      return t == 1.0 ? p[k][1] : p[k - 1][1] + t * (p[k][1] - p[k - 1][1]);
    }
  }
  return p.back()[1];
}

}  // namespace

void SyntheticSlope::visit(core::SettingsVisitor& v) {
  v.choice("kind", kind, {"bench", "plane", "profile"},
           "bench: the reference bench slope; plane: a uniform slope; profile: z piecewise linear in x");
  v.bounded("cell_size", cell_size, "m", "grid spacing in x and y", core::Range::positive(1e4));
  v.bounded("width", width, "m", "extent across the slope (y)", core::Range::positive(1e6));
  v.bounded("length", length, "m", "plane: extent downslope (x)", core::Range::positive(1e6));
  v.bounded("slope_angle_deg", slope_angle_deg, "deg", "plane: inclination of the slope",
            core::Range::right_open(0.0, 90.0));
  v.field("profile", profile, "m", "profile: [x, z] breakpoints, x increasing downslope");
}

std::vector<std::array<double, 2>> bench_profile() {
  return {{0, 30}, {6, 24}, {8, 24}, {14, 18}, {16, 18}, {22, 12}, {24, 12}, {36, 0}, {60, 0}};
}

DemGrid make_synthetic(const SyntheticSlope& slope, const core::SettingsOrigins& origins) {
  require_positive(slope.cell_size, "cell_size", origins);
  require_positive(slope.width, "width", origins);
  // The key whose value sets the slope's length: the bench's is fixed.
  const std::string length_key = slope.kind == "plane" ? "length" : slope.kind == "profile" ? "profile" : "cell_size";
  std::vector<std::array<double, 2>> profile;
  if (slope.kind == "bench") {
    profile = bench_profile();
  } else if (slope.kind == "plane") {
    require_positive(slope.length, "length", origins);
    if (!(slope.slope_angle_deg >= 0.0 && slope.slope_angle_deg < 90.0)) {
      throw core::InputError(
          origins.of("slope_angle_deg"),
          "synthetic slope: slope_angle_deg must be in [0, 90), got " + format_number(slope.slope_angle_deg));
    }
    const double drop = slope.length * std::tan(slope.slope_angle_deg * std::numbers::pi / 180.0);
    profile = {{0.0, drop}, {slope.length, 0.0}};
  } else if (slope.kind == "profile") {
    profile = slope.profile;
    if (profile.size() < 2) {
      throw core::InputError(origins.of("profile"), "synthetic slope: profile needs at least 2 [x, z] points, got " +
                                         std::to_string(profile.size()));
    }
    for (std::size_t k = 0; k < profile.size(); ++k) {
      if (!std::isfinite(profile[k][0]) || !std::isfinite(profile[k][1])) {
        throw core::InputError(origins.of("profile"),
                               "synthetic slope: profile point " + std::to_string(k) + " is not finite");
      }
      if (k > 0 && !(profile[k][0] > profile[k - 1][0])) {
        throw core::InputError(origins.of("profile"), "synthetic slope: profile x must increase, but point " +
                                                          std::to_string(k) +
                                                          " has x = " + format_number(profile[k][0]) + " after " +
                                                          format_number(profile[k - 1][0]));
      }
    }
  } else {
    throw core::InputError(origins.of("kind"),
                           "synthetic slope: unknown kind '" + slope.kind + "' (bench, plane, profile)");
  }

  DemGrid dem;
  const double x_first = profile.front()[0];
  dem.spec.x0 = x_first;
  dem.spec.y0 = 0.0;
  dem.spec.dx = slope.cell_size;
  dem.spec.dy = slope.cell_size;
  dem.spec.nx = lattice_points(profile.back()[0] - x_first, slope.cell_size, "length", length_key, origins);
  dem.spec.ny = lattice_points(slope.width, slope.cell_size, "width", "width", origins);
  dem.z.resize(dem.spec.point_count());
  for (std::int32_t i = 0; i < dem.spec.nx; ++i) {
    const double z = profile_z(profile, x_first + i * slope.cell_size);
    for (std::int32_t j = 0; j < dem.spec.ny; ++j) dem.z[dem.spec.index(i, j)] = z;
  }
  return dem;
}

}  // namespace talus::terrain
