// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <map>
#include <vector>

namespace talus::stats {

/// A mergeable summary of a distribution of non-negative values (kinetic energies,
/// passing heights) that answers quantiles with a bounded relative error, without storing
/// the values: the log-bucket sketch of Masson, Rim & Lee (DDSketch, VLDB 2019).
///
/// A value x > `min_value` goes to bucket i = ⌈log_γ x⌉, γ = (1 + α)/(1 − α); a quantile is
/// answered by the bucket's representative 2γ^i/(γ + 1), which is within relative error α of
/// every value in the bucket. Values ≤ min_value are counted in a zero bucket (answered as
/// 0). Counts are integers and bucket indices use the platform-independent logarithm, so
/// merging sketches of shards gives exactly the sketch of the whole run.
class QuantileSketch {
 public:
  /// α: relative accuracy (−), e.g. 0.01; min_value: values at or below it count as zero
  /// (same unit as the values).
  explicit QuantileSketch(double relative_accuracy = 0.01, double min_value = 1e-9);

  /// Adds a value (negative or non-finite values throw core::InputError).
  void add(double x, std::uint64_t weight = 1);
  /// Adds every count of `other`; both must have the same accuracy and min_value.
  void merge(const QuantileSketch& other);

  std::uint64_t count() const { return count_; }
  bool empty() const { return count_ == 0; }
  /// The p-quantile (p in [0, 1]) of the values added, within relative error α (the value
  /// of rank ⌊p·(n − 1)⌋ among the sorted values, 0-based). Throws if empty.
  double quantile(double p) const;
  /// The p-quantile by linear interpolation between the order statistics of ranks ⌊h⌋ and
  /// ⌊h⌋ + 1, h = p·(n − 1) (Hyndman–Fan type 7, as stats::Sample::quantile), each taken as
  /// its bucket's representative: within relative error α of the type-7 quantile of the
  /// values added. Throws if empty.
  double interpolated_quantile(double p) const;
  /// The representative of the value of 0-based rank `rank` (< count()) among the sorted
  /// values: 0 in the zero bucket, else its bucket's representative.
  double value_at_rank(std::uint64_t rank) const;
  /// The mean of the values added, each taken as its bucket's representative (so within
  /// relative error α of the true mean; values ≤ min_value as 0). Throws if empty.
  double mean() const;

  double relative_accuracy() const { return alpha_; }
  double min_value() const { return min_value_; }
  std::uint64_t zero_count() const { return zero_count_; }
  /// Non-empty buckets, by index.
  const std::map<std::int32_t, std::uint64_t>& buckets() const { return buckets_; }
  /// Restores a sketch from stored buckets (for file readers).
  static QuantileSketch from_buckets(double relative_accuracy, double min_value, std::uint64_t zero_count,
                                     const std::vector<std::int32_t>& indices,
                                     const std::vector<std::uint64_t>& counts);

 private:
  double alpha_;
  double min_value_;
  double gamma_;
  double log_gamma_;
  std::uint64_t zero_count_ = 0;
  std::uint64_t count_ = 0;
  std::map<std::int32_t, std::uint64_t> buckets_;
};

}  // namespace talus::stats
