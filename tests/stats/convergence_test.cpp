#include "talus/stats/convergence.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace talus::stats {
namespace {

TEST(Convergence, MeanRelativeErrorAndRealizationsNeeded) {
  // 50 × 9 and 50 × 11: mean 10, s² = 100/99, RE = s/(√100 · 10).
  std::vector<double> v;
  for (int k = 0; k < 50; ++k) {
    v.push_back(9.0);
    v.push_back(11.0);
  }
  const Statistic mean{Statistic::Kind::mean};
  const auto points = convergence(v, mean, {100});
  ASSERT_EQ(points.size(), 1u);
  EXPECT_DOUBLE_EQ(points[0].estimate, 10.0);
  EXPECT_NEAR(points[0].relative_error, std::sqrt(100.0 / 99.0) / 100.0, 1e-15);
  // n · (RE / 0.01)² = s² · 100 = 101.01 → 102.
  EXPECT_EQ(realizations_needed(v, mean, 0.01), 102.0);
}

TEST(Convergence, QuantileRelativeErrorOnUniformGrid) {
  // A uniform grid has density 1 and exact quantiles Q_p = p, so the asymptotic
  // SE is sqrt(p(1−p)/n) and RE = SE / p.
  std::vector<double> v;
  for (int k = 0; k <= 1000; ++k) v.push_back(k / 1000.0);
  const auto p50 = convergence(v, {Statistic::Kind::quantile, 0.5}, {1001});
  EXPECT_NEAR(p50[0].relative_error, std::sqrt(0.25 / 1001.0) / 0.5, 1e-12);
  const auto p95 = convergence(v, {Statistic::Kind::quantile, 0.95}, {1001});
  EXPECT_NEAR(p95[0].relative_error, std::sqrt(0.95 * 0.05 / 1001.0) / 0.95, 1e-12);
  EXPECT_EQ((Statistic{Statistic::Kind::quantile, 0.95}).name(), "P95");
}

TEST(Convergence, UsesTheFirstNInRealizationOrder) {
  const std::vector<double> v = {1, 1, 1, 1, 100, 100};
  const auto points = convergence(v, {Statistic::Kind::mean}, {4, 6});
  EXPECT_EQ(points[0].estimate, 1.0);
  EXPECT_EQ(points[0].relative_error, 0.0);
  EXPECT_EQ(points[1].estimate, 34.0);
  EXPECT_THROW(convergence(v, {Statistic::Kind::mean}, {7}), std::exception);
}

TEST(Convergence, CountsAreGeometricAndEndAtN) {
  const auto c = convergence_counts(250, 8);
  EXPECT_EQ(c.front(), 10u);
  EXPECT_EQ(c.back(), 250u);
  for (std::size_t i = 1; i < c.size(); ++i) EXPECT_GT(c[i], c[i - 1]);
  EXPECT_EQ(convergence_counts(5, 8).front(), 5u);
}

}  // namespace
}  // namespace talus::stats

namespace talus::stats {
namespace {

// Values computed independently with NumPy (std(ddof=1), numpy.quantile) for a fixed sample
// in realization order: RE(mean) = s/(√n·x̄); RE(P50) = √(0.25/n)·(Q.55 − Q.45)/0.1 / Q.50.
TEST(Convergence, AgreesWithNumpyOnAFixedSample) {
  const std::vector<double> v = {2.3, 0.7, 5.1, 3.3, 1.9, 4.4, 2.8, 0.2, 3.9, 6.0};
  const Statistic mean{Statistic::Kind::mean};
  const auto points = convergence(v, mean, {6, 10});
  // A handful of roundings: 1e-13 relative.
  EXPECT_NEAR(points[0].estimate, 2.95, 1e-13);
  EXPECT_NEAR(points[0].relative_error, 0.2268486463272708, 1e-13);
  EXPECT_NEAR(points[1].relative_error, 0.19211684257122963, 1e-13);
  EXPECT_EQ(realizations_needed(v, mean, 0.01), 3691.0);
  const auto p50 = convergence(v, {Statistic::Kind::quantile, 0.5}, {10});
  EXPECT_NEAR(p50[0].estimate, 3.05, 1e-14);
  EXPECT_NEAR(p50[0].relative_error, 0.23328277820914284, 1e-13);
}

}  // namespace
}  // namespace talus::stats
