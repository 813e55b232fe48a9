#include "talus/stats/sample.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "talus/core/error.hpp"

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
