#include "talus/stats/sample.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"

namespace talus::stats {

Sample::Sample(std::vector<double> values, const char* source) : sorted_(std::move(values)) {
  for (std::size_t i = 0; i < sorted_.size(); ++i)
    if (!std::isfinite(sorted_[i]))
      throw core::InputError(source, "value " + std::to_string(i) + " is not finite");
  std::sort(sorted_.begin(), sorted_.end());
}

double Sample::cdf(double x) const {
  if (sorted_.empty()) return 0.0;
  const auto it = std::upper_bound(sorted_.begin(), sorted_.end(), x);
  return static_cast<double>(it - sorted_.begin()) / static_cast<double>(sorted_.size());
}

double Sample::quantile(double p) const {
  if (sorted_.empty()) throw core::InputError("sample", "quantile of an empty sample");
  p = std::clamp(p, 0.0, 1.0);
  const double h = static_cast<double>(sorted_.size() - 1) * p;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  if (lo + 1 >= sorted_.size()) return sorted_.back();
  return sorted_[lo] + (h - static_cast<double>(lo)) * (sorted_[lo + 1] - sorted_[lo]);
}

double Sample::mean() const {
  if (sorted_.empty()) return 0.0;
  // Summed in sorted order: the result does not depend on the realization order.
  return std::accumulate(sorted_.begin(), sorted_.end(), 0.0) / static_cast<double>(sorted_.size());
}

double Sample::sd() const {
  if (sorted_.size() < 2) return 0.0;
  const double m = mean();
  double ss = 0.0;
  for (double v : sorted_) ss += (v - m) * (v - m);
  return std::sqrt(ss / static_cast<double>(sorted_.size() - 1));
}

double dkw_epsilon(std::size_t n, double alpha) {
  if (n == 0) return 1.0;
  return std::sqrt(std::log(2.0 / alpha) / (2.0 * static_cast<double>(n)));
}

double ks_distance(const Sample& a, const Sample& b) {
  const auto& x = a.sorted();
  const auto& y = b.sorted();
  if (x.empty() || y.empty()) return 1.0;
  const double na = static_cast<double>(x.size());
  const double nb = static_cast<double>(y.size());
  std::size_t i = 0, j = 0;
  double d = 0.0;
  // Walk both sorted samples; evaluate after consuming every copy of the smaller value.
  while (i < x.size() && j < y.size()) {
    const double v = std::min(x[i], y[j]);
    while (i < x.size() && x[i] == v) ++i;
    while (j < y.size() && y[j] == v) ++j;
    d = std::max(d, std::abs(static_cast<double>(i) / na - static_cast<double>(j) / nb));
  }
  return d;
}

double ks_p_value(double d, std::size_t n_a, std::size_t n_b) {
  if (n_a == 0 || n_b == 0) return 1.0;
  const double ne = static_cast<double>(n_a) * static_cast<double>(n_b) / static_cast<double>(n_a + n_b);
  const double sq = std::sqrt(ne);
  const double lambda = (sq + 0.12 + 0.11 / sq) * d;
  if (lambda < 1e-3) return 1.0;
  double sum = 0.0;
  double sign = 1.0;
  for (int k = 1; k <= 100; ++k) {
    const double term = sign * std::exp(-2.0 * k * k * lambda * lambda);
    sum += term;
    if (std::abs(term) < 1e-12 * std::abs(sum)) break;
    sign = -sign;
  }
  return std::clamp(2.0 * sum, 0.0, 1.0);
}

namespace {

// Quantile estimates of every resample: estimates[k][b] is the ps[k]-quantile of resample b,
// drawn with replacement from stream (seed, bootstrap, b).
std::vector<std::vector<double>> bootstrap_estimates(const Sample& sample, const std::vector<double>& ps,
                                                     std::size_t resamples, std::uint64_t seed) {
  const auto& x = sample.sorted();
  if (x.empty()) throw core::InputError("sample", "bootstrap of an empty sample");
  const std::size_t n = x.size();
  std::vector<std::vector<double>> estimates(ps.size(), std::vector<double>(resamples));
  std::vector<double> draw(n);
  for (std::size_t b = 0; b < resamples; ++b) {
    const core::RandomStream stream(seed, core::Stream::bootstrap, static_cast<std::uint32_t>(b));
    for (std::size_t k = 0; k < n; ++k) {
      const auto idx = static_cast<std::size_t>(stream.uniform(k) * static_cast<double>(n));
      draw[k] = x[std::min(idx, n - 1)];
    }
    const Sample resample(draw);
    for (std::size_t k = 0; k < ps.size(); ++k) estimates[k][b] = resample.quantile(ps[k]);
  }
  return estimates;
}

}  // namespace

Interval bootstrap_quantile_interval(const Sample& sample, double p, double alpha, std::size_t resamples,
                                     std::uint64_t seed, double* se) {
  const Sample dist(std::move(bootstrap_estimates(sample, {p}, resamples, seed).front()));
  if (se) *se = dist.sd();
  return {dist.quantile(alpha / 2.0), dist.quantile(1.0 - alpha / 2.0)};
}

std::vector<Interval> bootstrap_quantile_intervals(const Sample& sample, const std::vector<double>& ps,
                                                   double alpha, std::size_t resamples, std::uint64_t seed) {
  std::vector<Interval> out;
  for (auto& estimates : bootstrap_estimates(sample, ps, resamples, seed)) {
    const Sample dist(std::move(estimates));
    out.push_back({dist.quantile(alpha / 2.0), dist.quantile(1.0 - alpha / 2.0)});
  }
  return out;
}

}  // namespace talus::stats
