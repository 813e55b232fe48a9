#include "talus/stats/quantile_sketch.hpp"

#include <algorithm>
#include <cmath>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"

namespace talus::stats {

QuantileSketch::QuantileSketch(double relative_accuracy, double min_value)
    : alpha_(relative_accuracy), min_value_(min_value) {
  if (!(relative_accuracy > 0.0 && relative_accuracy < 1.0))
    throw core::InputError("quantile sketch", "relative accuracy must be in (0, 1)");
  if (!(min_value > 0.0) || !std::isfinite(min_value))
    throw core::InputError("quantile sketch", "min_value must be positive and finite");
  gamma_ = (1.0 + alpha_) / (1.0 - alpha_);
  log_gamma_ = core::detmath::log(gamma_);
}

void QuantileSketch::add(double x, std::uint64_t weight) {
  if (!(x >= 0.0) || !std::isfinite(x))
    throw core::InputError("quantile sketch", "value must be non-negative and finite");
  count_ += weight;
  if (x <= min_value_) {
    zero_count_ += weight;
    return;
  }
  const auto index = static_cast<std::int32_t>(std::ceil(core::detmath::log(x) / log_gamma_));
  buckets_[index] += weight;
}

void QuantileSketch::merge(const QuantileSketch& other) {
  if (other.alpha_ != alpha_ || other.min_value_ != min_value_)
    throw core::InputError("quantile sketch", "cannot merge sketches of different accuracy");
  count_ += other.count_;
  zero_count_ += other.zero_count_;
  for (const auto& [index, n] : other.buckets_) buckets_[index] += n;
}

double QuantileSketch::value_at_rank(std::uint64_t rank) const {
  if (count_ == 0) throw core::InputError("quantile sketch", "quantile of an empty sketch");
  if (rank < zero_count_) return 0.0;
  std::uint64_t seen = zero_count_;
  for (const auto& [index, n] : buckets_) {
    seen += n;
    if (rank < seen) return 2.0 * std::pow(gamma_, index) / (gamma_ + 1.0);
  }
  return 2.0 * std::pow(gamma_, buckets_.rbegin()->first) / (gamma_ + 1.0);
}

double QuantileSketch::quantile(double p) const {
  if (count_ == 0) throw core::InputError("quantile sketch", "quantile of an empty sketch");
  p = std::min(std::max(p, 0.0), 1.0);
  return value_at_rank(static_cast<std::uint64_t>(std::floor(p * static_cast<double>(count_ - 1))));
}

double QuantileSketch::interpolated_quantile(double p) const {
  if (count_ == 0) throw core::InputError("quantile sketch", "quantile of an empty sketch");
  p = std::min(std::max(p, 0.0), 1.0);
  const double h = p * static_cast<double>(count_ - 1);
  const auto lo = static_cast<std::uint64_t>(std::floor(h));
  const double below = value_at_rank(lo);
  if (lo + 1 >= count_) return below;
  return below + (h - static_cast<double>(lo)) * (value_at_rank(lo + 1) - below);
}

double QuantileSketch::mean() const {
  if (count_ == 0) throw core::InputError("quantile sketch", "mean of an empty sketch");
  double sum = 0.0;
  for (const auto& [index, n] : buckets_) sum += static_cast<double>(n) * (2.0 * std::pow(gamma_, index) / (gamma_ + 1.0));
  return sum / static_cast<double>(count_);
}

QuantileSketch QuantileSketch::from_buckets(double relative_accuracy, double min_value, std::uint64_t zero_count,
                                            const std::vector<std::int32_t>& indices,
                                            const std::vector<std::uint64_t>& counts) {
  if (indices.size() != counts.size())
    throw core::InputError("quantile sketch", "bucket index and count lists differ in length");
  QuantileSketch s(relative_accuracy, min_value);
  s.zero_count_ = zero_count;
  s.count_ = zero_count;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    s.buckets_[indices[k]] += counts[k];
    s.count_ += counts[k];
  }
  return s;
}

}  // namespace talus::stats
