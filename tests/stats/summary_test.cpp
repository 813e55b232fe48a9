#include "talus/stats/summary.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "talus/core/random.hpp"

namespace talus::stats {
namespace {

using Kind = SummaryTarget::Kind;

std::vector<double> uniforms(std::uint64_t seed, std::uint32_t index, std::size_t n) {
  const core::RandomStream s(seed, core::Stream::bootstrap, index);
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) x[k] = s.uniform(k);
  return x;
}

TEST(Summary, StatisticsOfAKnownSample) {
  const std::vector<double> x = {5, 1, 4, 2, 3};
  EXPECT_DOUBLE_EQ(summary_statistic(x, {Kind::share_above, 2.0}), 0.6);  // 3, 4, 5: a value at the threshold is not above
  EXPECT_DOUBLE_EQ(summary_statistic(x, {Kind::quantile, 0.0, 0.25}), 2.0);
  // The extreme of the first n values, in the order drawn.
  EXPECT_DOUBLE_EQ(summary_statistic(x, {Kind::max, 0.0, 0.5, 3.0}), 5.0);
  EXPECT_DOUBLE_EQ(summary_statistic(x, {Kind::min, 0.0, 0.5, 2.0}), 1.0);
  EXPECT_DOUBLE_EQ(summary_statistic(x, {Kind::min, 0.0, 0.5, 1.0}), 5.0);
  EXPECT_DOUBLE_EQ(summary_distance({{0, 1, 3}, {0, 1, -1}, {0, 1, 0}, {0, 1, 1}}), std::sqrt(11.0 / 4.0));
}

// Uniform [0, 1]: the share above 0.3 is 0.7, the 0.25-quantile 0.25, the median of the
// maximum of 20 values 0.5^(1/20) = 0.966, of their minimum 1 − 0.966. A large sample
// gives them within its sampling error (the sd it reports).
TEST(Summary, SimulatedCounterpartsOfUniformValues) {
  const Sample big(uniforms(3, 0, 20000));
  const double med_max = std::pow(0.5, 1.0 / 20.0);
  const std::vector<std::pair<SummaryTarget, double>> cases = {
      {{Kind::share_above, 0.3, 0.5, 0.0, 0.7, 0.01}, 0.7},
      {{Kind::quantile, 0.0, 0.25, 0.0, 0.25, 0.01}, 0.25},
      {{Kind::max, 0.0, 0.5, 20.0, med_max, 0.01}, med_max},
      {{Kind::min, 0.0, 0.5, 20.0, 1.0 - med_max, 0.01}, 1.0 - med_max}};
  for (const auto& [target, truth] : cases) {
    const SummaryComparison c = compare_summary(big, target);
    EXPECT_NEAR(c.simulated, truth, 0.01);  // sampling error of 20 000 values, about 0.003
    EXPECT_GT(c.sd, target.sd);             // the simulation's own error is added
    EXPECT_LT(std::abs(c.z), 3.0);
  }
}

// The maximum of n is compared with its own scatter: observed maxima of 50 exponential
// values, each against a simulation of 500 (too few to read the maximum's quantiles off,
// so the tail fit), give z of mean about 0 and mean square about 1, not the z of hundreds
// a comparison with no scatter (the stated sd of 1e-6 alone) would give.
TEST(Summary, MaximumOfNIsComparedWithItsScatter) {
  const auto exponentials = [](std::uint64_t seed, std::uint32_t index, std::size_t n) {
    std::vector<double> x = uniforms(seed, index, n);
    for (double& v : x) v = -std::log1p(-v);
    return x;
  };
  double sum = 0.0, sum_sq = 0.0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    const std::vector<double> observed = exponentials(7, static_cast<std::uint32_t>(t), 50);
    const Sample simulated(exponentials(8, static_cast<std::uint32_t>(t), 500));
    const SummaryTarget target{Kind::max, 0.0, 0.5, 50.0, summary_statistic(observed, {Kind::max, 0, 0.5, 50.0}), 1e-6};
    const double z = compare_summary(simulated, target).z;
    sum += z;
    sum_sq += z * z;
  }
  // The Gumbel's mean lies 0.21 sd above its median (z about −0.2); its mean square is
  // about 1/(1 + n/m) plus the tail fit's own error. Bounds for 400 trials.
  EXPECT_NEAR(sum / trials, -0.2, 0.2);
  EXPECT_GT(sum_sq / trials, 0.7);
  EXPECT_LT(sum_sq / trials, 1.5);
}

// With enough values (m >= 29 n) the maximum's quantiles are the sample's: uniform values,
// the maximum of 10 has median 0.5^(1/10) and, between its quantiles of ±1 normal sd, a
// half-width of (0.8413^(1/10) − 0.1587^(1/10))/2.
TEST(Summary, MaximumOfFewIsReadOffALargeSample) {
  const Sample big(uniforms(4, 0, 20000));
  const SummaryComparison c = compare_summary(big, {Kind::max, 0.0, 0.5, 10.0, 0.9, 1e-9});
  EXPECT_NEAR(c.simulated, std::pow(0.5, 0.1), 0.003);  // sampling error of 20 000 values
  const double w = 0.5 * (std::pow(0.8413447460685429, 0.1) - std::pow(0.15865525393145707, 0.1));
  EXPECT_NEAR(c.sd, w * std::sqrt(1.0 + 10.0 / 20000.0), 0.003);
}

// A share observed as 0.581 of 250 (sd 0.031) against simulations of 250 at true shares
// 0.58 and 0.95: near 0 and far off, by the combined binomial sd.
TEST(Summary, ShareDiscrepancyScalesWithBinomialError) {
  std::vector<double> near(250, 0.0), far(250, 0.0);
  for (std::size_t k = 0; k < 145; ++k) near[k] = 1.0;
  for (std::size_t k = 0; k < 238; ++k) far[k] = 1.0;
  const SummaryTarget target{Kind::share_above, 0.5, 0.5, 0.0, 0.581, 0.0312};
  EXPECT_LT(std::abs(compare_summary(Sample(near), target).z), 0.1);
  const SummaryComparison c = compare_summary(Sample(far), target);
  EXPECT_NEAR(c.simulated, 238.0 / 250.0, 1e-12);
  EXPECT_NEAR(c.z, (238.0 / 250.0 - 0.581) / std::hypot(0.0312, std::sqrt(0.9484 * 0.0516 / 250.0)), 0.05);
}

}  // namespace
}  // namespace talus::stats
