#include "talus/stats/quantile_sketch.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/stats/sample.hpp"

namespace talus::stats {
namespace {

std::vector<double> lognormal_values(std::size_t n, std::uint64_t seed) {
  const core::RandomStream s(seed, core::Stream::bootstrap, 0);
  std::vector<double> v(n);
  for (std::size_t k = 0; k < n; ++k) v[k] = std::exp(10.0 + 1.5 * s.normal(k));  // J-like energies
  return v;
}

// The sketch answers the value of rank ⌊p(n−1)⌋ within relative error α.
TEST(QuantileSketch, RelativeErrorBoundHoldsAgainstExactOrderStatistics) {
  const auto values = lognormal_values(20000, 3);
  QuantileSketch sketch(0.01);
  for (double v : values) sketch.add(v);
  const Sample exact(values);
  for (double p : {0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99, 1.0}) {
    const auto rank = static_cast<std::size_t>(std::floor(p * static_cast<double>(values.size() - 1)));
    const double truth = exact.sorted()[rank];
    EXPECT_LE(std::abs(sketch.quantile(p) - truth), 0.01 * truth * (1 + 1e-12)) << p;
  }
  EXPECT_EQ(sketch.count(), values.size());
}

// The interpolated quantile is within α of the type-7 quantile (a convex combination of
// two representatives, each within α of its order statistic), at low counts too: with two
// values P95 lies between them, near the larger.
TEST(QuantileSketch, InterpolatedQuantileWithinAlphaOfTypeSeven) {
  for (std::size_t n : {2u, 3u, 7u, 40u, 20000u}) {
    const auto values = lognormal_values(n, 11 + n);
    QuantileSketch sketch(0.01);
    for (double v : values) sketch.add(v);
    const Sample exact(values);
    for (double p : {0.0, 0.1, 0.5, 0.9, 0.95, 0.99, 1.0}) {
      const double truth = exact.quantile(p);
      EXPECT_LE(std::abs(sketch.interpolated_quantile(p) - truth), 0.01 * truth * (1 + 1e-12)) << n << " " << p;
    }
  }
  QuantileSketch two(0.01);
  two.add(100.0);
  two.add(200.0);
  EXPECT_NEAR(two.interpolated_quantile(0.95), 195.0, 1.95);
  EXPECT_NEAR(two.quantile(0.95), 100.0, 1.0);  // the rank-⌊p(n−1)⌋ value: the smaller one
}

// The mean of the bucket representatives is within α of the exact mean (every value is
// within α of its representative); zeros count as 0.
TEST(QuantileSketch, MeanWithinRelativeAccuracy) {
  const auto values = lognormal_values(20000, 5);
  QuantileSketch sketch(0.01);
  double sum = 0.0;
  for (double v : values) {
    sketch.add(v);
    sum += v;
  }
  sketch.add(0.0, 20000);  // as many zeros: the mean halves
  const double truth = sum / 40000.0;
  EXPECT_LE(std::abs(sketch.mean() - truth), 0.01 * truth);
  EXPECT_THROW(QuantileSketch().mean(), core::InputError);
}

// Integer counts: the merge of shards is exactly the sketch of the whole, in any order.
TEST(QuantileSketch, MergeOfShardsEqualsWhole) {
  const auto values = lognormal_values(3000, 5);
  QuantileSketch whole(0.02), a(0.02), b(0.02), c(0.02);
  for (std::size_t k = 0; k < values.size(); ++k) {
    whole.add(values[k]);
    (k % 3 == 0 ? a : k % 3 == 1 ? b : c).add(values[k]);
  }
  QuantileSketch merged(0.02);
  merged.merge(c);
  merged.merge(a);
  merged.merge(b);
  EXPECT_EQ(merged.buckets(), whole.buckets());
  EXPECT_EQ(merged.count(), whole.count());
  EXPECT_THROW(merged.merge(QuantileSketch(0.01)), core::InputError);
}

TEST(QuantileSketch, ZerosAndRoundTripThroughBuckets) {
  QuantileSketch s(0.01, 1e-6);
  for (int k = 0; k < 10; ++k) s.add(0.0);
  for (int k = 1; k <= 10; ++k) s.add(k);
  EXPECT_EQ(s.zero_count(), 10u);
  EXPECT_EQ(s.quantile(0.4), 0.0);
  EXPECT_NEAR(s.quantile(1.0), 10.0, 0.1);
  std::vector<std::int32_t> idx;
  std::vector<std::uint64_t> cnt;
  for (const auto& [i, n] : s.buckets()) {
    idx.push_back(i);
    cnt.push_back(n);
  }
  const QuantileSketch back = QuantileSketch::from_buckets(0.01, 1e-6, s.zero_count(), idx, cnt);
  EXPECT_EQ(back.quantile(0.9), s.quantile(0.9));
  EXPECT_EQ(back.count(), s.count());
  EXPECT_THROW(s.add(-1.0), core::InputError);
  EXPECT_THROW(QuantileSketch(0.01).quantile(0.5), core::InputError);
}

}  // namespace
}  // namespace talus::stats
