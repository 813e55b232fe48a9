// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace talus::stats {

/// Which statistic a convergence study follows.
struct Statistic {
  enum class Kind { mean, quantile } kind = Kind::mean;
  double p = 0.5;  ///< probability, for Kind::quantile
  std::string name() const;  ///< "mean", "P50", "P95" …
};

/// The Monte-Carlo relative error of a statistic estimated from the first n realizations.
///
/// Relative error = standard error / |estimate|:
/// - mean: SE = s / √n (s: sample standard deviation);
/// - p-quantile: SE = √(p(1−p)/n) / f(Q_p), the asymptotic standard error of a sample
///   quantile, with the density f at the quantile estimated by the difference quotient
///   f ≈ 2h / (Q_{p+h} − Q_{p−h}), h = min(0.05, p/2, (1−p)/2) (a robust, bandwidth-free
///   estimate; documented in docs/stats.md).
/// Because SE scales as 1/√n, the realizations needed for a target relative error r are
/// n·(RE_n / r)².
struct ConvergencePoint {
  std::size_t n = 0;               ///< realizations used (the first n, in realization order)
  double estimate = 0.0;
  double relative_error = 0.0;     ///< SE / |estimate| (infinity when the estimate is 0)
};

/// The statistic and its relative error from the first n values of `values` (realization
/// order) for each n in `counts` (each in [2, values.size()]).
std::vector<ConvergencePoint> convergence(std::span<const double> values, const Statistic& statistic,
                                          const std::vector<std::size_t>& counts);

/// Realizations needed to bring the relative error under `target` (e.g. 0.01), estimated
/// from all of `values`; at least values.size() is never assumed — it may be smaller
/// when the target is already met. Infinity if the estimate is 0.
double realizations_needed(std::span<const double> values, const Statistic& statistic, double target);

/// Counts for a convergence curve: about `points` values spaced geometrically from 10
/// (or n) to n, always ending at n.
std::vector<std::size_t> convergence_counts(std::size_t n, std::size_t points);

}  // namespace talus::stats
