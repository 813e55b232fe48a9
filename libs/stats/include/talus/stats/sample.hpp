// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <span>
#include <vector>

namespace talus::stats {

/// A sorted sample of one variable (e.g. runout of every realization), for empirical
/// distribution statistics. Non-finite values are rejected at construction.
class Sample {
 public:
  /// Sorts a copy of `values`. Throws core::InputError(source, …) if a value is not finite.
  explicit Sample(std::vector<double> values, const char* source = "sample");

  std::size_t size() const { return sorted_.size(); }
  bool empty() const { return sorted_.empty(); }
  const std::vector<double>& sorted() const { return sorted_; }
  double min() const { return sorted_.front(); }
  double max() const { return sorted_.back(); }

  /// Empirical CDF F(x) = #{values <= x} / n.
  double cdf(double x) const;
  /// Quantile of probability p in [0, 1], by linear interpolation between order
  /// statistics (Hyndman & Fan type 7, the default of R and NumPy):
  /// h = (n−1)p, Q = x[⌊h⌋] + (h − ⌊h⌋)(x[⌊h⌋+1] − x[⌊h⌋]).
  double quantile(double p) const;
  double mean() const;
  /// Sample standard deviation (n − 1 in the denominator); NaN for n < 2 (undefined).
  double sd() const;

 private:
  std::vector<double> sorted_;
};

/// Half-width ε of the Dvoretzky–Kiefer–Wolfowitz confidence band of an empirical CDF of
/// n values: P(sup|F_n − F| > ε) <= α with ε = sqrt(ln(2/α) / (2n)) (Massart's constant).
double dkw_epsilon(std::size_t n, double alpha);

/// Two-sample Kolmogorov–Smirnov statistic D = sup_x |F_a(x) − F_b(x)|.
double ks_distance(const Sample& a, const Sample& b);
/// Asymptotic p-value of D for sample sizes n_a, n_b: Q_KS(λ) = 2 Σ (−1)^(k−1) e^(−2k²λ²),
/// λ = (√nₑ + 0.12 + 0.11/√nₑ) D, nₑ = n_a n_b / (n_a + n_b) (Stephens' correction).
double ks_p_value(double d, std::size_t n_a, std::size_t n_b);

/// A confidence interval.
struct Interval {
  double lo = 0.0;
  double hi = 0.0;
};

/// The resamples of a bootstrap of n values, reduced to what the quantile estimates need.
/// Resample b draws index ⌊u·n⌋ (u = draw k of stream (seed, bootstrap, b)) for k < n; since
/// the sample is sorted, the sorted resample is the sample at the sorted drawn indices, so
/// the p-quantile of the resample is fixed by the drawn indices at two ranks. The plan keeps
/// those indices: it depends on n, ps, resamples and seed, not on the values, so one plan
/// serves every sample of n values (counting the draws, not sorting them: O(n) a resample).
class BootstrapPlan {
 public:
  /// Throws core::InputError if n is 0. The resamples are drawn by up to `threads`
  /// threads when there are enough of them; the plan is the same whatever the count.
  BootstrapPlan(std::size_t n, const std::vector<double>& ps, std::size_t resamples, std::uint64_t seed,
                unsigned threads = 1);

  std::size_t n() const { return n_; }
  /// Percentile-bootstrap intervals (level 1 − α) of the quantiles at ps of `sample`, which
  /// must hold n values: bit for bit those of sorting every resample. NaN bounds (and
  /// standard error) for n = 1: every resample of one value is that value, and the
  /// interval of zero width it would give says nothing about the sampling error.
  std::vector<Interval> intervals(const Sample& sample, double alpha, double* se_first = nullptr) const;

 private:
  struct Slot {
    std::uint32_t lo = 0, hi = 0;  ///< indices into the sorted sample of ranks ⌊h⌋ and ⌊h⌋ + 1
    bool last = false;             ///< ⌊h⌋ + 1 ≥ n: the quantile is the largest value (index lo)
  };
  std::size_t n_;
  std::vector<double> ps_;
  std::size_t resamples_;
  std::vector<Slot> slots_;  ///< slots_[b · ps.size() + k]
};

/// Percentile-bootstrap confidence interval (level 1 − α) of the p-quantile: `resamples`
/// resamples with replacement, resample b drawn from stream (seed, bootstrap, b), so the
/// interval is reproducible. Also returns the bootstrap standard error in `se` if given.
/// NaN for a sample of one value (BootstrapPlan::intervals).
Interval bootstrap_quantile_interval(const Sample& sample, double p, double alpha,
                                     std::size_t resamples, std::uint64_t seed,
                                     double* se = nullptr);

/// The same for several probabilities at once, from one set of resamples (each resample
/// sorted once): element k is the interval of ps[k], identical to what
/// bootstrap_quantile_interval gives for ps[k] alone with the same seed.
std::vector<Interval> bootstrap_quantile_intervals(const Sample& sample, const std::vector<double>& ps,
                                                   double alpha, std::size_t resamples, std::uint64_t seed);

}  // namespace talus::stats
