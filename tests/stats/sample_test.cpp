#include "talus/stats/sample.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"

namespace talus::stats {
namespace {

TEST(Sample, EcdfCountsValuesAtOrBelow) {
  const Sample s({3, 1, 2, 2, 5});
  EXPECT_EQ(s.cdf(0.5), 0.0);
  EXPECT_EQ(s.cdf(1.0), 0.2);
  EXPECT_EQ(s.cdf(2.0), 0.6);  // ties counted together
  EXPECT_EQ(s.cdf(4.9), 0.8);
  EXPECT_EQ(s.cdf(5.0), 1.0);
  EXPECT_EQ(s.min(), 1.0);
  EXPECT_EQ(s.max(), 5.0);
}

// Values from numpy.quantile(x, p) (its default method is Hyndman–Fan type 7).
TEST(Sample, QuantilesAreTypeSeven) {
  const Sample a({1, 2, 3, 4, 5});
  EXPECT_DOUBLE_EQ(a.quantile(0.25), 2.0);
  EXPECT_DOUBLE_EQ(a.quantile(0.10), 1.4);
  EXPECT_DOUBLE_EQ(a.quantile(0.0), 1.0);
  EXPECT_DOUBLE_EQ(a.quantile(1.0), 5.0);
  const Sample b({40, 10, 20});
  EXPECT_DOUBLE_EQ(b.quantile(0.75), 30.0);
  EXPECT_DOUBLE_EQ(b.quantile(0.95), 38.0);  // h = 1.9: 20 + 0.9·20
  EXPECT_THROW(Sample({}).quantile(0.5), core::InputError);
}

TEST(Sample, MeanAndSd) {
  const Sample s({2, 4, 4, 4, 5, 5, 7, 9});
  EXPECT_DOUBLE_EQ(s.mean(), 5.0);
  EXPECT_NEAR(s.sd(), std::sqrt(32.0 / 7.0), 1e-15);  // Σ(x−5)² = 32, n−1 = 7
}

// The sample standard deviation of one value is undefined (n − 1 = 0): NaN, not 0, which
// would read as a sample without scatter; two values have one.
TEST(Sample, SdOfOneValueIsUndefined) {
  EXPECT_TRUE(std::isnan(Sample({3.5}).sd()));
  EXPECT_TRUE(std::isnan(Sample({}).sd()));
  EXPECT_DOUBLE_EQ(Sample({1.0, 3.0}).sd(), std::sqrt(2.0));
}

// Every resample of one value is that value: no interval, rather than one of zero width.
TEST(Bootstrap, OneValueHasNoInterval) {
  double se = 0.0;
  const Interval i = bootstrap_quantile_interval(Sample({7.0}), 0.5, 0.05, 100, 3, &se);
  EXPECT_TRUE(std::isnan(i.lo));
  EXPECT_TRUE(std::isnan(i.hi));
  EXPECT_TRUE(std::isnan(se));
  for (const Interval& k : bootstrap_quantile_intervals(Sample({7.0}), {0.05, 0.95}, 0.05, 100, 3)) {
    EXPECT_TRUE(std::isnan(k.lo));
    EXPECT_TRUE(std::isnan(k.hi));
  }
  // Two values already spread: a proper interval around the median.
  const Interval two = bootstrap_quantile_interval(Sample({1.0, 3.0}), 0.5, 0.05, 100, 3);
  EXPECT_LE(two.lo, 2.0);
  EXPECT_GE(two.hi, 2.0);
}

TEST(Sample, RejectsNonFinite) {
  EXPECT_THROW(Sample({1.0, std::nan("")}, "run.h5"), core::InputError);
}

TEST(Dkw, MassartBand) {
  // sqrt(ln(2/0.05) / 200) for n = 100.
  EXPECT_NEAR(dkw_epsilon(100, 0.05), 0.1358102, 1e-7);
  EXPECT_NEAR(dkw_epsilon(250, 0.05), 0.0858938, 1e-7);
}

TEST(KolmogorovSmirnov, DistanceByHand) {
  // F_a − F_b is largest at x = 3: 0.6 − 0 (worked out by hand over the merged sample).
  EXPECT_DOUBLE_EQ(ks_distance(Sample({1, 2, 3, 4, 5}), Sample({3.5, 4.5, 6, 7})), 0.6);
  EXPECT_DOUBLE_EQ(ks_distance(Sample({1, 2, 3}), Sample({1, 2, 3})), 0.0);
  EXPECT_DOUBLE_EQ(ks_distance(Sample({1, 2}), Sample({3, 4})), 1.0);
  // Ties across samples: at x = 2 both CDFs jump together.
  EXPECT_DOUBLE_EQ(ks_distance(Sample({1, 2, 2, 3}), Sample({2, 2, 2, 4})), 0.25);
}

TEST(KolmogorovSmirnov, AsymptoticPValueMatchesTables) {
  // Critical values of the Kolmogorov distribution: λ = 1.3581 at 5 %, 1.6276 at 1 %.
  // With n_a = n_b = 2e6 the Stephens correction is negligible (nₑ = 1e6).
  const double scale = 1000.0 + 0.12 + 0.11 / 1000.0;
  EXPECT_NEAR(ks_p_value(1.3581 / scale, 2000000, 2000000), 0.05, 1e-4);
  EXPECT_NEAR(ks_p_value(1.6276 / scale, 2000000, 2000000), 0.01, 1e-4);
  EXPECT_EQ(ks_p_value(0.0, 10, 10), 1.0);
}

TEST(Bootstrap, ReproducibleAndCalibrated) {
  std::vector<double> grid;
  for (int k = 0; k <= 1000; ++k) grid.push_back(k / 1000.0);
  const Sample s(grid);
  double se = 0.0, se2 = 0.0;
  const Interval a = bootstrap_quantile_interval(s, 0.5, 0.05, 2000, 7, &se);
  const Interval b = bootstrap_quantile_interval(s, 0.5, 0.05, 2000, 7, &se2);
  EXPECT_EQ(a.lo, b.lo);
  EXPECT_EQ(a.hi, b.hi);
  EXPECT_LT(a.lo, 0.5);
  EXPECT_GT(a.hi, 0.5);
  // Asymptotic SE of the median of U(0,1): sqrt(0.25 / 1001) = 0.0158; the bootstrap
  // estimate of it is noisy (median discreteness), so 20 %.
  EXPECT_NEAR(se, 0.0158, 0.2 * 0.0158);
}

}  // namespace
}  // namespace talus::stats

namespace talus::stats {
namespace {

// Independent values from NumPy 1.24 / SciPy 1.10 for a fixed pair of samples:
// numpy.quantile (type 7), scipy.stats.ks_2samp(a, b).statistic, and
// scipy.stats.kstwobign.sf(λ) with Stephens' λ = (√nₑ + 0.12 + 0.11/√nₑ)·D.
TEST(Sample, AgreesWithNumpyAndScipyOnAFixedSample) {
  const Sample a({2.3, 0.7, 5.1, 3.3, 1.9, 4.4, 2.8, 0.2, 3.9, 6.0});
  const Sample b({1.1, 3.0, 4.8, 6.5, 7.2, 2.2, 5.9, 8.1});
  // Interpolation adds one rounding: 1e-14 relative.
  EXPECT_NEAR(a.quantile(0.05), 0.425, 1e-14);
  EXPECT_NEAR(a.quantile(0.25), 2.0, 1e-14);
  EXPECT_NEAR(a.quantile(0.50), 3.05, 1e-14);
  EXPECT_NEAR(a.quantile(0.90), 5.19, 1e-14);
  EXPECT_NEAR(a.quantile(0.99), 5.919, 1e-14);
  EXPECT_NEAR(a.mean(), 3.06, 1e-14);
  EXPECT_NEAR(a.sd(), 1.85903200617956, 1e-13);
  EXPECT_DOUBLE_EQ(ks_distance(a, b), 0.425);
  EXPECT_DOUBLE_EQ(ks_distance(b, a), 0.425);
  // The series is summed to 1e-12 of its value.
  EXPECT_NEAR(ks_p_value(0.425, 10, 8), 0.3045417500107567, 1e-10);
  // DKW at 90 %: sqrt(ln 20 / 20).
  EXPECT_NEAR(dkw_epsilon(10, 0.10), 0.38702275602049496, 1e-15);
  // The ECDF band of the summary: F(3.0) = 5/10 (0.2 0.7 1.9 2.3 2.8 ≤ 3.0).
  EXPECT_EQ(a.cdf(3.0), 0.5);
}

// Several probabilities from one set of resamples give exactly the single-probability intervals.
TEST(Bootstrap, SeveralQuantilesAtOnceEqualOneByOne) {
  std::vector<double> v;
  for (int k = 0; k < 60; ++k) v.push_back(std::sin(k * 1.7) * 10.0 + k * 0.1);
  const Sample s(v);
  const std::vector<double> ps = {0.05, 0.5, 0.95};
  const auto together = bootstrap_quantile_intervals(s, ps, 0.1, 300, 9);
  ASSERT_EQ(together.size(), ps.size());
  for (std::size_t k = 0; k < ps.size(); ++k) {
    const Interval alone = bootstrap_quantile_interval(s, ps[k], 0.1, 300, 9);
    EXPECT_EQ(together[k].lo, alone.lo);
    EXPECT_EQ(together[k].hi, alone.hi);
    EXPECT_LE(together[k].lo, s.quantile(ps[k]));
    EXPECT_GE(together[k].hi, s.quantile(ps[k]));
  }
  EXPECT_THROW(bootstrap_quantile_intervals(Sample({}), ps, 0.1, 10, 1), core::InputError);
}

// The slow reference: every resample drawn, sorted and its quantiles taken (what the
// bootstrap did before it counted the draws).
std::vector<Interval> sorted_resample_intervals(const Sample& s, const std::vector<double>& ps, double alpha,
                                                std::size_t resamples, std::uint64_t seed) {
  const auto& x = s.sorted();
  const std::size_t n = x.size();
  std::vector<std::vector<double>> estimates(ps.size(), std::vector<double>(resamples));
  std::vector<double> draw(n);
  for (std::size_t b = 0; b < resamples; ++b) {
    const core::RandomStream stream(seed, core::Stream::bootstrap, static_cast<std::uint32_t>(b));
    for (std::size_t k = 0; k < n; ++k)
      draw[k] = x[std::min(static_cast<std::size_t>(stream.uniform(k) * static_cast<double>(n)), n - 1)];
    const Sample resample(draw);
    for (std::size_t k = 0; k < ps.size(); ++k) estimates[k][b] = resample.quantile(ps[k]);
  }
  std::vector<Interval> out;
  for (auto& e : estimates) {
    const Sample dist(e);
    out.push_back({dist.quantile(alpha / 2.0), dist.quantile(1.0 - alpha / 2.0)});
  }
  return out;
}

// Counting the drawn indices gives the intervals of sorting every resample, bit for bit:
// sizes 2 to 700, ties, unsorted and extreme probabilities, one plan for several samples.
// A sample of one value has no interval (NaN; OneValueHasNoInterval).
TEST(Bootstrap, PlanEqualsSortingEveryResample) {
  const std::vector<double> ps = {0.99, 0.0, 0.05, 0.5, 0.25, 1.0, 0.95, 0.1, 0.75, 0.9};
  for (std::size_t n : {1u, 2u, 3u, 7u, 10u, 64u, 250u, 701u}) {
    const BootstrapPlan plan(n, ps, 120, 3 + n);
    for (int variant = 0; variant < 3; ++variant) {
      const core::RandomStream values(11 + static_cast<std::uint64_t>(variant), core::Stream::bootstrap, 99);
      std::vector<double> v(n);
      for (std::size_t k = 0; k < n; ++k) {
        const double u = values.uniform(k);
        // variant 1: heavy ties; variant 2: a wide range of magnitudes.
        v[k] = variant == 0 ? u * 40.0 - 3.0 : variant == 1 ? std::floor(u * 4.0) : std::exp(u * 30.0) * 1e-6;
      }
      const Sample s(v);
      const auto fast = plan.intervals(s, 0.05);
      if (n == 1) {
        for (const Interval& i : fast) EXPECT_TRUE(std::isnan(i.lo) && std::isnan(i.hi)) << "variant " << variant;
        continue;
      }
      const auto slow = sorted_resample_intervals(s, ps, 0.05, 120, 3 + n);
      ASSERT_EQ(fast.size(), slow.size());
      for (std::size_t k = 0; k < ps.size(); ++k) {
        EXPECT_EQ(fast[k].lo, slow[k].lo) << "n " << n << " variant " << variant << " p " << ps[k];
        EXPECT_EQ(fast[k].hi, slow[k].hi) << "n " << n << " variant " << variant << " p " << ps[k];
      }
      const auto direct = bootstrap_quantile_intervals(s, ps, 0.05, 120, 3 + n);
      for (std::size_t k = 0; k < ps.size(); ++k) EXPECT_EQ(direct[k].lo, fast[k].lo);
    }
  }
  // Drawn by several threads (1 200 values × 500 resamples: four parts), the plan is the same.
  const core::RandomStream values(5, core::Stream::bootstrap, 7);
  std::vector<double> v(1200);
  for (std::size_t k = 0; k < v.size(); ++k) v[k] = values.uniform(k) * 10.0;
  const Sample big(v);
  const auto one = BootstrapPlan(v.size(), ps, 500, 9).intervals(big, 0.05);
  const auto four = BootstrapPlan(v.size(), ps, 500, 9, 4).intervals(big, 0.05);
  for (std::size_t k = 0; k < ps.size(); ++k) {
    EXPECT_EQ(one[k].lo, four[k].lo) << ps[k];
    EXPECT_EQ(one[k].hi, four[k].hi) << ps[k];
  }
  EXPECT_THROW(BootstrapPlan(0, ps, 10, 1), core::InputError);
  EXPECT_THROW(BootstrapPlan(5, ps, 10, 1).intervals(Sample({1.0, 2.0}), 0.05), core::InputError);
}

}  // namespace
}  // namespace talus::stats
