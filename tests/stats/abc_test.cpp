// ABC-SMC (libs/stats/src/abc.cpp) on models whose posterior is known: the location and
// the scale of a normal sample.
#include "talus/stats/abc.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "talus/core/random.hpp"

namespace talus::stats {
namespace {

// n standard normals of stream `seed`.
std::vector<double> normals(std::uint64_t seed, std::size_t n) {
  const core::RandomStream s(seed, core::Stream::bootstrap, 0);
  std::vector<double> z(n);
  for (std::size_t k = 0; k < n; ++k) z[k] = s.normal(k);
  return z;
}

std::vector<std::vector<double>> points(const std::vector<double>& v) {
  std::vector<std::vector<double>> p;
  for (double x : v) p.push_back({x});
  return p;
}

// Observed: 40 values of N(1.3, 0.7). Simulated for θ = (μ, σ): μ + σ z with 200 normals
// z seeded from θ's bits, so each candidate has draws of its own (fixed draws for every
// candidate would remove the noise the posterior's width comes from) and the distance is
// still a pure function of θ.
struct NormalModel {
  std::vector<double> observed;
  int calls = 0;
  NormalModel() {
    for (double e : normals(5, 40)) observed.push_back(1.3 + 0.7 * e);
  }
  std::vector<double> operator()(const std::vector<std::vector<double>>& batch) {
    ++calls;
    std::vector<double> d;
    for (const auto& theta : batch) {
      std::uint64_t seed = 1469598103934665603ull;
      for (double t : theta) seed = (seed ^ std::hash<double>{}(t)) * 1099511628211ull;
      const std::vector<double> z = normals(seed, 200);
      std::vector<double> sim;
      for (double e : z) sim.push_back(theta[0] + (theta.size() > 1 ? theta[1] : 0.7) * e);
      d.push_back(energy_distance(points(sim), points(observed), {1.0}));
    }
    return d;
  }
};

std::vector<double> column(const AbcGeneration& g, std::size_t k) {
  std::vector<double> c;
  for (const auto& t : g.theta) c.push_back(t[k]);
  return c;
}

AbcGeneration run(const AbcSmc& abc, const AbcSimulator& sim) {
  AbcGeneration g = abc.first(sim);
  while (!abc.finished(g)) g = abc.next(g, sim);
  return g;
}

TEST(Abc, RecoversTheLocationOfANormalSample) {
  NormalModel model;
  AbcSettings s;
  s.particles = 200;
  s.generations = 6;
  const AbcSmc abc({Prior{"uniform", -5.0, 5.0}}, s);
  const AbcGeneration g = run(abc, [&](const auto& b) { return model(b); });
  ASSERT_EQ(g.theta.size(), 200u);
  const double sample_mean = std::accumulate(model.observed.begin(), model.observed.end(), 0.0) / 40.0;
  const double median = weighted_quantile(column(g, 0), g.weight, 0.5);
  const double p5 = weighted_quantile(column(g, 0), g.weight, 0.05), p95 = weighted_quantile(column(g, 0), g.weight, 0.95);
  // The posterior of μ with σ known is N(sample mean, 0.7²/40): sd 0.11, a 90 % band
  // 0.36 wide. ABC at a finite tolerance is a little wider.
  EXPECT_NEAR(median, sample_mean, 0.1);
  EXPECT_LT(p5, sample_mean);
  EXPECT_GT(p95, sample_mean);
  EXPECT_GT(p95 - p5, 0.25);
  EXPECT_LT(p95 - p5, 0.8);  // from a prior 10 wide
  EXPECT_NEAR(std::accumulate(g.weight.begin(), g.weight.end(), 0.0), 1.0, 1e-12);
  EXPECT_LT(g.tolerance, 0.05);
}

TEST(Abc, RecoversLocationAndScaleTogether) {
  NormalModel model;
  AbcSettings s;
  s.particles = 300;
  s.generations = 8;
  const AbcSmc abc({Prior{"uniform", -5.0, 5.0}, Prior{"uniform", 0.05, 3.0}}, s);
  const AbcGeneration g = run(abc, [&](const auto& b) { return model(b); });
  for (std::size_t k = 0; k < 2; ++k) {
    const double truth = k == 0 ? 1.3 : 0.7;
    EXPECT_LT(weighted_quantile(column(g, k), g.weight, 0.05), truth) << k;
    EXPECT_GT(weighted_quantile(column(g, k), g.weight, 0.95), truth) << k;
  }
  EXPECT_NEAR(weighted_quantile(column(g, 1), g.weight, 0.5), 0.7, 0.2);
}

// The result is a function of the seed and the simulator's values: simulating one
// candidate at a time instead of in batches changes nothing, and continuing from a
// stored generation gives the generations an uninterrupted run gives.
TEST(Abc, SameSeedSameResultWhateverTheBatchingOrResume) {
  NormalModel model;
  AbcSettings s;
  s.particles = 50;
  s.generations = 3;
  s.seed = 9;
  const AbcSmc abc({Prior{"normal", -5.0, 5.0, 0.0, 2.0}}, s);
  const AbcSimulator batched = [&](const auto& b) { return model(b); };
  const AbcSimulator single = [&](const std::vector<std::vector<double>>& b) {
    std::vector<double> d;
    for (const auto& t : b) d.push_back(model({t})[0]);
    return d;
  };
  const AbcGeneration a = run(abc, batched);
  const AbcGeneration b = run(abc, single);
  EXPECT_EQ(a.theta, b.theta);
  EXPECT_EQ(a.weight, b.weight);
  EXPECT_EQ(a.proposed, b.proposed);
  AbcGeneration g1 = abc.next(abc.first(batched), batched);
  const AbcGeneration stored = g1;  // as read back from a checkpoint
  const AbcGeneration resumed = abc.next(abc.next(stored, single), single);
  EXPECT_EQ(resumed.theta, a.theta);
  AbcSettings other = s;
  other.seed = 10;
  EXPECT_NE(run(AbcSmc({Prior{"normal", -5.0, 5.0, 0.0, 2.0}}, other), batched).theta, a.theta);
}

TEST(Abc, StopsAtTheProposalBudgetAndOnLowAcceptance) {
  NormalModel model;
  AbcSettings s;
  s.particles = 40;
  s.generations = 50;
  s.min_acceptance = 0.2;
  const AbcSmc abc({Prior{"uniform", -5.0, 5.0}}, s);
  const AbcSimulator sim = [&](const auto& b) { return model(b); };
  const AbcGeneration g0 = abc.first(sim);
  const AbcGeneration cut = abc.next(g0, sim, 10);
  EXPECT_LT(cut.theta.size(), 40u);
  EXPECT_EQ(cut.proposed, 10);
  const AbcGeneration last = run(abc, sim);
  EXPECT_LT(last.index, 50);  // the acceptance fell below 0.2 first
  EXPECT_LT(last.acceptance(), 0.2);
}

// Simulations that cannot be compared have infinite distances. With more than the quantile
// of a generation so, the next tolerance is not finite: next() refuses at once (it looped
// forever on a NaN tolerance). Fewer: the tolerance is the quantile of the distances, and
// an infinite distance past it changes nothing.
TEST(Abc, InfiniteDistancesBeyondTheQuantileGiveNoTolerance) {
  AbcSettings s;
  s.particles = 4;
  s.quantile = 0.5;
  const AbcSmc abc({Prior{"uniform", -5.0, 5.0}}, s);
  int batches = 0;
  const AbcSimulator never = [&](const std::vector<std::vector<double>>& b) {
    if (++batches > 100) throw std::runtime_error("looping");
    return std::vector<double>(b.size(), std::numeric_limits<double>::infinity());
  };
  const AbcGeneration g0 = abc.first(never);
  EXPECT_TRUE(std::isinf(abc.tolerance(g0)));
  EXPECT_THROW(abc.next(g0, never), std::domain_error);
  EXPECT_EQ(batches, 1);  // generation 0's only
  constexpr double inf = std::numeric_limits<double>::infinity();
  AbcGeneration some = g0;
  some.distance = {0.1, inf, inf, 0.2};
  EXPECT_TRUE(std::isinf(abc.tolerance(some)));  // h = 1.5: between 0.2 and ∞
  some.distance = {0.3, inf, 0.1, 0.2};
  EXPECT_DOUBLE_EQ(abc.tolerance(some), 0.25);  // h = 1.5: between 0.2 and 0.3
  some.distance = {0.3, inf, 0.1, 0.2, inf};
  EXPECT_EQ(abc.tolerance(some), 0.3);  // h = 2 exactly: 0.3 itself (0.3 + 0 · ∞ gave NaN)
  some.distance = {0.3, inf, inf, 0.2, inf};
  EXPECT_TRUE(std::isinf(abc.tolerance(some)));  // h = 2 exactly, on an infinite distance
}

TEST(Abc, EnergyDistanceIsZeroForEqualSamplesAndGrowsWithShift) {
  const auto x = points(normals(3, 100));
  EXPECT_DOUBLE_EQ(energy_distance(x, x, {1.0}), 0.0);
  std::vector<double> shifted;
  for (const auto& p : x) shifted.push_back(p[0] + 2.0);
  const double d2 = energy_distance(x, points(shifted), {1.0});
  std::vector<double> shifted1;
  for (const auto& p : x) shifted1.push_back(p[0] + 1.0);
  const double d1 = energy_distance(x, points(shifted1), {1.0});
  EXPECT_GT(d2, d1);
  EXPECT_GT(d1, 0.0);
  // The distance is homogeneous of degree 1: the scale divides it.
  EXPECT_NEAR(energy_distance(x, points(shifted), {2.0}), 0.5 * d2, 1e-12);
  EXPECT_THROW(energy_distance({}, x, {1.0}), std::invalid_argument);
}

TEST(Abc, WeightedQuantileOfWeights) {
  EXPECT_EQ(weighted_quantile({3.0, 1.0, 2.0}, {0.2, 0.5, 0.3}, 0.5), 1.0);
  EXPECT_EQ(weighted_quantile({3.0, 1.0, 2.0}, {0.2, 0.5, 0.3}, 0.6), 2.0);
  EXPECT_EQ(weighted_quantile({3.0, 1.0, 2.0}, {0.2, 0.5, 0.3}, 1.0), 3.0);
}

TEST(Abc, BadPriorsAreRefused) {
  EXPECT_THROW(AbcSmc({}, {}), std::invalid_argument);
  EXPECT_THROW(AbcSmc({Prior{"uniform", 1.0, 1.0}}, {}), std::invalid_argument);
  EXPECT_THROW(AbcSmc({Prior{"beta", 0.0, 1.0}}, {}), std::invalid_argument);
  EXPECT_THROW(AbcSmc({Prior{"normal", 0.0, 1.0, 0.5, 0.0}}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace talus::stats
