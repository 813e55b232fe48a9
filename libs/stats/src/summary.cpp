#include "talus/stats/summary.hpp"

#include <algorithm>
#include <cmath>

namespace talus::stats {

namespace {

// One standard normal deviation either side of the median, as probabilities.
constexpr double kBelowOneSd = 0.15865525393145707;
constexpr double kAboveOneSd = 0.8413447460685429;

double share_above(const std::vector<double>& sorted, double threshold) {
  const auto above = sorted.end() - std::upper_bound(sorted.begin(), sorted.end(), threshold);
  return static_cast<double>(above) / static_cast<double>(sorted.size());
}

}  // namespace

SummaryComparison compare_summary(const Sample& sample, const SummaryTarget& t) {
  const double m = static_cast<double>(sample.size());
  SummaryComparison c;
  double sim_var = 0.0;
  switch (t.kind) {
    case SummaryTarget::Kind::share_above: {
      c.simulated = share_above(sample.sorted(), t.threshold);
      // (k + 1)/(m + 2): a share of 0 or 1 in m draws is not known exactly.
      const double shrunk = (c.simulated * m + 1.0) / (m + 2.0);
      sim_var = shrunk * (1.0 - shrunk) / m;
      break;
    }
    case SummaryTarget::Kind::quantile: {
      c.simulated = sample.quantile(t.p);
      const double s = std::sqrt(t.p * (1.0 - t.p) / m);
      const double w = 0.5 * (sample.quantile(t.p + s) - sample.quantile(t.p - s));
      sim_var = w * w;
      break;
    }
    case SummaryTarget::Kind::max:
    case SummaryTarget::Kind::min: {
      // The maximum of n values of CDF F has CDF F^n: its quantile u is F's u^(1/n).
      const bool max = t.kind == SummaryTarget::Kind::max;
      const auto q = [&](double u) {
        const double p = std::pow(u, 1.0 / t.n);
        return sample.quantile(max ? p : 1.0 - p);
      };
      c.simulated = q(0.5);
      const double w = 0.5 * std::abs(q(kAboveOneSd) - q(kBelowOneSd));
      sim_var = w * w * (1.0 + t.n / m);
      break;
    }
  }
  c.sd = std::sqrt(t.sd * t.sd + sim_var);
  c.z = (c.simulated - t.value) / c.sd;
  return c;
}

double summary_statistic(const std::vector<double>& values, const SummaryTarget& t) {
  switch (t.kind) {
    case SummaryTarget::Kind::share_above: {
      const auto above = std::count_if(values.begin(), values.end(), [&](double v) { return v > t.threshold; });
      return static_cast<double>(above) / static_cast<double>(values.size());
    }
    case SummaryTarget::Kind::quantile:
      return Sample(values).quantile(t.p);
    case SummaryTarget::Kind::max:
    case SummaryTarget::Kind::min: {
      const auto end = values.begin() + static_cast<std::ptrdiff_t>(
                                            std::min(values.size(), static_cast<std::size_t>(t.n)));
      return t.kind == SummaryTarget::Kind::max ? *std::max_element(values.begin(), end)
                                                : *std::min_element(values.begin(), end);
    }
  }
  return 0.0;
}

double summary_distance(const std::vector<SummaryComparison>& comparisons) {
  double sum = 0.0;
  for (const auto& c : comparisons) sum += c.z * c.z;
  return std::sqrt(sum / static_cast<double>(comparisons.size()));
}

}  // namespace talus::stats
