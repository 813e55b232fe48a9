#include "talus/stats/sample.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <thread>

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
  // One value has no spread to measure: 0 would read as a sample without scatter.
  if (sorted_.size() < 2) return std::numeric_limits<double>::quiet_NaN();
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

BootstrapPlan::BootstrapPlan(std::size_t n, const std::vector<double>& ps, std::size_t resamples,
                             std::uint64_t seed, unsigned threads)
    : n_(n), ps_(ps), resamples_(resamples), slots_(resamples * ps.size()) {
  if (n == 0) throw core::InputError("sample", "bootstrap of an empty sample");
  // The ranks each quantile needs (Sample::quantile: h = (n − 1)p, ranks ⌊h⌋ and ⌊h⌋ + 1),
  // in increasing order, so that one pass over the counts finds them all.
  struct Need {
    std::size_t rank;
    std::size_t slot;
    bool hi;
  };
  std::vector<Need> needs;
  std::vector<bool> last(ps.size(), false);
  for (std::size_t k = 0; k < ps.size(); ++k) {
    const double h = static_cast<double>(n - 1) * std::clamp(ps[k], 0.0, 1.0);
    const auto lo = static_cast<std::size_t>(std::floor(h));
    if (lo + 1 >= n) {
      last[k] = true;
      needs.push_back({n - 1, k, false});
    } else {
      needs.push_back({lo, k, false});
      needs.push_back({lo + 1, k, true});
    }
  }
  std::sort(needs.begin(), needs.end(), [](const Need& a, const Need& b) { return a.rank < b.rank; });
  // Resamples [b0, b1): each has its own stream, so any split gives the same slots.
  const auto plan = [&](std::size_t b0, std::size_t b1) {
    std::vector<std::uint32_t> counts(n);
    for (std::size_t b = b0; b < b1; ++b) {
      const core::RandomStream stream(seed, core::Stream::bootstrap, static_cast<std::uint32_t>(b));
      std::fill(counts.begin(), counts.end(), 0u);
      for (std::size_t k = 0; k < n; ++k) {
        const auto idx = static_cast<std::size_t>(stream.uniform(k) * static_cast<double>(n));
        ++counts[std::min(idx, n - 1)];
      }
      Slot* row = &slots_[b * ps.size()];
      std::size_t index = 0, below = counts[0];  // draws of indices <= index
      for (const Need& need : needs) {
        while (below <= need.rank) below += counts[++index];
        Slot& slot = row[need.slot];
        (need.hi ? slot.hi : slot.lo) = static_cast<std::uint32_t>(index);
        slot.last = last[need.slot];
      }
    }
  };
  // Threads only where they pay: about 10^5 draws or more each.
  const std::size_t parts = std::clamp<std::size_t>(std::min<std::size_t>(threads, n * resamples / 100000), 1, resamples);
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < parts; ++t) pool.emplace_back(plan, resamples * t / parts, resamples * (t + 1) / parts);
  plan(0, resamples / parts);
  for (auto& t : pool) t.join();
}

std::vector<Interval> BootstrapPlan::intervals(const Sample& sample, double alpha, double* se_first) const {
  const auto& x = sample.sorted();
  if (x.size() != n_)
    throw core::InputError("sample", "bootstrap plan of " + std::to_string(n_) + " values used for " +
                                         std::to_string(x.size()));
  // Every resample of one value is that value: a zero-width interval would claim a
  // certainty the sample cannot give.
  if (n_ < 2) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    if (se_first) *se_first = nan;
    return std::vector<Interval>(ps_.size(), Interval{nan, nan});
  }
  std::vector<Interval> out;
  std::vector<double> estimates(resamples_);
  for (std::size_t k = 0; k < ps_.size(); ++k) {
    // As Sample::quantile of the sorted resample r: r[lo] + (h − lo)(r[lo + 1] − r[lo]).
    const double h = static_cast<double>(n_ - 1) * std::clamp(ps_[k], 0.0, 1.0);
    const double frac = h - std::floor(h);
    for (std::size_t b = 0; b < resamples_; ++b) {
      const Slot& s = slots_[b * ps_.size() + k];
      estimates[b] = s.last ? x[s.lo] : x[s.lo] + frac * (x[s.hi] - x[s.lo]);
    }
    const Sample dist(estimates);
    if (k == 0 && se_first) *se_first = dist.sd();
    out.push_back({dist.quantile(alpha / 2.0), dist.quantile(1.0 - alpha / 2.0)});
  }
  return out;
}

Interval bootstrap_quantile_interval(const Sample& sample, double p, double alpha, std::size_t resamples,
                                     std::uint64_t seed, double* se) {
  if (sample.empty()) throw core::InputError("sample", "bootstrap of an empty sample");
  return BootstrapPlan(sample.size(), {p}, resamples, seed).intervals(sample, alpha, se).front();
}

std::vector<Interval> bootstrap_quantile_intervals(const Sample& sample, const std::vector<double>& ps,
                                                   double alpha, std::size_t resamples, std::uint64_t seed) {
  if (sample.empty()) throw core::InputError("sample", "bootstrap of an empty sample");
  return BootstrapPlan(sample.size(), ps, resamples, seed).intervals(sample, alpha);
}

}  // namespace talus::stats
