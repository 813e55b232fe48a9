// SPDX-License-Identifier: MIT
#pragma once
#include <vector>

#include "talus/stats/sample.hpp"

namespace talus::stats {

/// A published summary of a sample: the share of values above a threshold, a quantile, or
/// the largest or smallest of n values; with the observed value and its stated standard
/// uncertainty (docs/calibration.md, "Summary statistics").
struct SummaryTarget {
  enum class Kind { share_above, quantile, max, min };
  Kind kind = Kind::quantile;
  double threshold = 0.0;  ///< share_above: values above it count (the variable's unit)
  double p = 0.5;          ///< quantile: its probability (-)
  double n = 0.0;          ///< max, min: the number of values the extreme is over (-)
  double value = 0.0;      ///< the observed value (the variable's unit; a share: -)
  double sd = 0.0;         ///< its standard uncertainty, > 0 (same unit)
};

/// A simulated sample compared with a summary target.
struct SummaryComparison {
  double simulated = 0.0;  ///< the simulated counterpart of the observed value
  double sd = 0.0;         ///< the combined standard uncertainty of their difference
  double z = 0.0;          ///< (simulated − observed) / sd
};

/// The simulated statistic of `sample` (m values) and its difference from the target in
/// units of the combined uncertainty:
/// - share_above: the share of m, sd² = target sd² + p̃(1 − p̃)/m, p̃ = (k + 1)/(m + 2);
/// - quantile: Q(p), sd² = target sd² + ((Q(p + s) − Q(p − s))/2)², s = √(p(1 − p)/m)
///   (the order statistics one binomial sd either side);
/// - max of n: the median of the maximum of n values drawn from the sample's distribution,
///   Q(0.5^(1/n)), and its spread w = (Q(0.8413^(1/n)) − Q(0.1587^(1/n)))/2, when at least
///   5 values lie beyond Q(0.8413^(1/n)) (m >= 29 n); otherwise from an exponential tail
///   fitted to the top k = max(10, m/10) values (mean excess a over the next one, u): the
///   maximum is then Gumbel, median u + a(ln(nk/m) − ln ln 2), w = aπ/√6. w is the observed
///   maximum's own scatter, w·√(n/m) the simulation's error in estimating it:
///   sd² = target sd² + w²(1 + n/m). min mirrors max.
/// Needs a sample of at least 2 values (and m >= n for max and min, checked by callers).
SummaryComparison compare_summary(const Sample& sample, const SummaryTarget& target);

/// The statistic as an observer computes it from `values` (in the order they were drawn):
/// the share above the threshold, the p-quantile, the largest or smallest of the first n
/// (all of them when fewer). A posterior-predictive draw of the observed value.
double summary_statistic(const std::vector<double>& values, const SummaryTarget& target);

/// The discrepancy of several comparisons: √(mean of z²).
double summary_distance(const std::vector<SummaryComparison>& comparisons);

}  // namespace talus::stats
