#include "talus/stats/convergence.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "talus/core/error.hpp"
#include "talus/stats/sample.hpp"

namespace talus::stats {

std::string Statistic::name() const {
  if (kind == Kind::mean) return "mean";
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "P%g", p * 100.0);
  return buffer;
}

namespace {

ConvergencePoint evaluate(const Sample& s, const Statistic& statistic) {
  ConvergencePoint point;
  point.n = s.size();
  const double n = static_cast<double>(s.size());
  double se = 0.0;
  if (statistic.kind == Statistic::Kind::mean) {
    point.estimate = s.mean();
    se = s.sd() / std::sqrt(n);
  } else {
    const double p = statistic.p;
    point.estimate = s.quantile(p);
    const double h = std::min({0.05, p / 2.0, (1.0 - p) / 2.0});
    const double spread = s.quantile(p + h) - s.quantile(p - h);
    // A sample with a flat stretch at the quantile has an unresolved density: its
    // quantile is exact to the data, so the standard error is zero there.
    se = spread > 0.0 && h > 0.0 ? std::sqrt(p * (1.0 - p) / n) * spread / (2.0 * h) : 0.0;
  }
  point.relative_error = point.estimate != 0.0 ? se / std::abs(point.estimate)
                                               : (se == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
  return point;
}

}  // namespace

std::vector<ConvergencePoint> convergence(std::span<const double> values, const Statistic& statistic,
                                          const std::vector<std::size_t>& counts) {
  std::vector<ConvergencePoint> out;
  for (std::size_t n : counts) {
    if (n < 2 || n > values.size())
      throw core::InputError("convergence", "count " + std::to_string(n) + " outside [2, " +
                                                std::to_string(values.size()) + "]");
    out.push_back(evaluate(Sample(std::vector<double>(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(n))),
                           statistic));
  }
  return out;
}

double realizations_needed(std::span<const double> values, const Statistic& statistic, double target) {
  if (values.size() < 2) return std::numeric_limits<double>::infinity();
  const ConvergencePoint now = evaluate(Sample(std::vector<double>(values.begin(), values.end())), statistic);
  if (!std::isfinite(now.relative_error)) return std::numeric_limits<double>::infinity();
  const double ratio = now.relative_error / target;
  return std::ceil(static_cast<double>(now.n) * ratio * ratio);
}

std::vector<std::size_t> convergence_counts(std::size_t n, std::size_t points) {
  std::vector<std::size_t> counts;
  if (n < 2) return counts;
  const double first = static_cast<double>(std::min<std::size_t>(10, n));
  const double last = static_cast<double>(n);
  points = std::max<std::size_t>(points, 2);
  for (std::size_t k = 0; k < points; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(points - 1);
    const auto c = static_cast<std::size_t>(std::llround(first * std::pow(last / first, t)));
    if (counts.empty() || c > counts.back()) counts.push_back(std::max<std::size_t>(c, 2));
  }
  if (counts.back() != n) counts.push_back(n);
  return counts;
}

}  // namespace talus::stats
