#include "talus/stats/summary.hpp"

#include <algorithm>
#include <cmath>

namespace talus::stats {

namespace {

// One standard normal deviation either side of the median, as probabilities.
constexpr double kBelowOneSd = 0.15865525393145707;
constexpr double kAboveOneSd = 0.8413447460685429;
// The maximum's quantiles are read off the sample when this many values lie beyond the
// highest of them; otherwise from an exponential tail fitted to the top values (at least
// kTailMin of them, a tenth of the sample when more).
constexpr double kResolvedBeyond = 5.0;
constexpr std::size_t kTailMin = 10;

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
      const bool max = t.kind == SummaryTarget::Kind::max;
      double w = 0.0;
      if (m * (1.0 - std::pow(kAboveOneSd, 1.0 / t.n)) >= kResolvedBeyond) {
        // The maximum of n values of CDF F has CDF F^n: its quantile u is F's u^(1/n).
        const auto q = [&](double u) {
          const double p = std::pow(u, 1.0 / t.n);
          return sample.quantile(max ? p : 1.0 - p);
        };
        c.simulated = q(0.5);
        w = 0.5 * std::abs(q(kAboveOneSd) - q(kBelowOneSd));
      } else {
        // Too few values reach the maximum's quantiles: the top k exceed the next one by
        // an exponential of mean a, so the maximum of n is Gumbel, of location
        // u + a ln(n k / m), median that + a(−ln ln 2) and sd aπ/√6.
        std::vector<double> x = sample.sorted();
        if (!max) {
          for (double& v : x) v = -v;
          std::reverse(x.begin(), x.end());
        }
        const std::size_t size = x.size();
        const std::size_t k = std::min(size - 1, std::max<std::size_t>(kTailMin, (size + 9) / 10));
        const double u = x[size - 1 - k];
        double a = 0.0;
        for (std::size_t i = size - k; i < size; ++i) a += x[i] - u;
        a /= static_cast<double>(k);
        const double median = u + a * (std::log(t.n * static_cast<double>(k) / m) - std::log(std::log(2.0)));
        c.simulated = max ? median : -median;
        w = a * M_PI / std::sqrt(6.0);
      }
      // w is the observed extreme's own scatter; w·√(n/m) the simulation's error in
      // estimating where it lies.
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
