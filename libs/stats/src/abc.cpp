#include "talus/stats/abc.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "talus/core/random.hpp"

namespace talus::stats {

namespace {

// Draws of one candidate: stream (seed, calibration, generation), draws numbered from
// candidate · 2^20, so candidates never share a draw and a candidate's draws do not depend
// on how many its predecessors used.
class CandidateDraws {
 public:
  CandidateDraws(std::uint64_t seed, std::int64_t generation, std::int64_t candidate)
      : stream_(seed, core::Stream::calibration, static_cast<std::uint32_t>(generation)),
        next_(static_cast<std::uint64_t>(candidate) << 20) {}
  double uniform() { return stream_.uniform(next_++); }
  double normal() { return stream_.normal(next_++); }

 private:
  core::RandomStream stream_;
  std::uint64_t next_;
};

constexpr int kMaxTries = 10000;  // proposals refused outside the support before giving up

double draw_prior(const Prior& p, CandidateDraws& d) {
  if (p.kind == "uniform") return p.min + (p.max - p.min) * d.uniform();
  for (int t = 0; t < kMaxTries; ++t) {
    const double x = p.mean + p.sd * d.normal();
    if (x >= p.min && x <= p.max) return x;
  }
  throw std::runtime_error("a normal prior has almost no mass inside [min, max]");
}

bool inside(const std::vector<Prior>& priors, const Eigen::VectorXd& x) {
  for (std::size_t k = 0; k < priors.size(); ++k)
    if (!(x[static_cast<Eigen::Index>(k)] >= priors[k].min && x[static_cast<Eigen::Index>(k)] <= priors[k].max))
      return false;
  return true;
}

double prior_density(const std::vector<Prior>& priors, const std::vector<double>& x) {
  double d = 1.0;
  for (std::size_t k = 0; k < priors.size(); ++k) d *= priors[k].density(x[k]);
  return d;
}

}  // namespace

double Prior::density(double x) const {
  if (!(x >= min && x <= max)) return 0.0;
  if (kind == "uniform") return 1.0;
  const double z = (x - mean) / sd;
  return std::exp(-0.5 * z * z);
}

AbcSmc::AbcSmc(std::vector<Prior> priors, AbcSettings settings)
    : priors_(std::move(priors)), settings_(settings) {
  if (priors_.empty()) throw std::invalid_argument("no parameter to fit");
  for (const Prior& p : priors_) {
    if (!(p.min < p.max) || !std::isfinite(p.min) || !std::isfinite(p.max))
      throw std::invalid_argument("a prior needs finite min < max");
    if (p.kind != "uniform" && p.kind != "normal") throw std::invalid_argument("prior kind must be uniform or normal");
    if (p.kind == "normal" && !(p.sd > 0.0 && std::isfinite(p.mean))) throw std::invalid_argument("a normal prior needs sd > 0");
  }
  if (settings_.particles < 2) throw std::invalid_argument("at least 2 particles are needed");
  if (!(settings_.quantile > 0.0 && settings_.quantile < 1.0)) throw std::invalid_argument("quantile must be in (0, 1)");
}

AbcGeneration AbcSmc::first(const AbcSimulator& simulate) const {
  AbcGeneration g;
  g.index = 0;
  g.tolerance = std::numeric_limits<double>::infinity();
  const auto n = static_cast<std::size_t>(settings_.particles);
  g.theta.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    CandidateDraws d(settings_.seed, 0, static_cast<std::int64_t>(i));
    for (const Prior& p : priors_) g.theta[i].push_back(draw_prior(p, d));
  }
  g.distance = simulate(g.theta);
  if (g.distance.size() != n) throw std::logic_error("the simulator returned a wrong number of distances");
  g.weight.assign(n, 1.0 / static_cast<double>(n));
  g.proposed = static_cast<std::int64_t>(n);
  return g;
}

AbcGeneration AbcSmc::next(const AbcGeneration& prev, const AbcSimulator& simulate, std::int64_t max_proposals) const {
  const auto dim = static_cast<Eigen::Index>(priors_.size());
  const std::size_t n_prev = prev.theta.size();
  const auto n = static_cast<std::size_t>(settings_.particles);
  AbcGeneration g;
  g.index = prev.index + 1;
  g.tolerance = tolerance(prev);
  // A NaN tolerance (∞ − ∞ between two infinite distances) accepted no candidate, and the
  // generation never ended; an infinite one would accept every candidate.
  if (!std::isfinite(g.tolerance))
    throw std::domain_error("the tolerance of generation " + std::to_string(g.index) +
                            " is not finite: too many distances of the previous generation are infinite");

  // The kernel: twice the weighted covariance of the previous generation (Beaumont et al.
  // 2009), with a floor so a parameter the data pin down still moves a little.
  Eigen::MatrixXd points(static_cast<Eigen::Index>(n_prev), dim);
  for (std::size_t i = 0; i < n_prev; ++i)
    for (Eigen::Index k = 0; k < dim; ++k) points(static_cast<Eigen::Index>(i), k) = prev.theta[i][static_cast<std::size_t>(k)];
  const Eigen::VectorXd w = Eigen::Map<const Eigen::VectorXd>(prev.weight.data(), static_cast<Eigen::Index>(n_prev));
  const Eigen::RowVectorXd mean = w.transpose() * points;
  const Eigen::MatrixXd centred = points.rowwise() - mean;
  Eigen::MatrixXd cov = 2.0 * centred.transpose() * w.asDiagonal() * centred;
  for (Eigen::Index k = 0; k < dim; ++k) {
    const double range = priors_[static_cast<std::size_t>(k)].max - priors_[static_cast<std::size_t>(k)].min;
    cov(k, k) += 1e-8 * range * range;
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  if (llt.info() != Eigen::Success) throw std::runtime_error("the kernel covariance is not positive definite");
  const Eigen::MatrixXd lower = llt.matrixL();
  std::vector<double> cumulative(n_prev);
  std::partial_sum(prev.weight.begin(), prev.weight.end(), cumulative.begin());

  auto propose = [&](std::int64_t candidate) {
    CandidateDraws d(settings_.seed, g.index, candidate);
    for (int t = 0; t < kMaxTries; ++t) {
      const double u = d.uniform() * cumulative.back();
      const auto j = static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin());
      Eigen::VectorXd z(dim);
      for (Eigen::Index k = 0; k < dim; ++k) z[k] = d.normal();
      const Eigen::VectorXd x = points.row(static_cast<Eigen::Index>(std::min(j, n_prev - 1))).transpose() + lower * z;
      if (inside(priors_, x) && prior_density(priors_, std::vector<double>(x.data(), x.data() + dim)) > 0.0)
        return std::vector<double>(x.data(), x.data() + dim);
    }
    throw std::runtime_error("no proposal inside the priors' supports after 10000 tries");
  };

  std::int64_t candidate = 0;
  while (g.theta.size() < n) {
    // Batch size from the acceptance so far (deterministic: it depends on results only).
    const std::size_t missing = n - g.theta.size();
    const double rate = candidate == 0 ? 1.0
                                       : std::max(0.01, static_cast<double>(g.theta.size()) / static_cast<double>(candidate));
    auto batch_size = static_cast<std::int64_t>(std::ceil(1.2 * static_cast<double>(missing) / rate));
    batch_size = std::clamp<std::int64_t>(batch_size, static_cast<std::int64_t>(missing), 20 * settings_.particles);
    if (max_proposals > 0) batch_size = std::min(batch_size, max_proposals - candidate);
    if (batch_size <= 0) break;
    std::vector<std::vector<double>> batch;
    for (std::int64_t c = 0; c < batch_size; ++c) batch.push_back(propose(candidate + c));
    const std::vector<double> distances = simulate(batch);
    if (distances.size() != batch.size()) throw std::logic_error("the simulator returned a wrong number of distances");
    for (std::size_t c = 0; c < batch.size(); ++c) {
      ++g.proposed;
      if (distances[c] <= g.tolerance) {
        g.theta.push_back(batch[c]);
        g.distance.push_back(distances[c]);
        if (g.theta.size() == n) break;
      }
    }
    candidate += batch_size;
  }
  if (g.theta.size() < n) return g;

  // Importance weights π(θ) / Σ_j w_j K(θ | θ_j); the kernel's constant cancels.
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(dim, dim));
  g.weight.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Map<const Eigen::VectorXd> x(g.theta[i].data(), dim);
    double mixture = 0.0;
    for (std::size_t j = 0; j < n_prev; ++j) {
      const Eigen::VectorXd delta = x - points.row(static_cast<Eigen::Index>(j)).transpose();
      mixture += prev.weight[j] * std::exp(-0.5 * delta.dot(inverse * delta));
    }
    g.weight[i] = mixture > 0.0 ? prior_density(priors_, g.theta[i]) / mixture : 0.0;
  }
  const double total = std::accumulate(g.weight.begin(), g.weight.end(), 0.0);
  if (!(total > 0.0)) throw std::runtime_error("every importance weight is zero");
  for (double& x : g.weight) x /= total;
  return g;
}

double AbcSmc::tolerance(const AbcGeneration& prev) const {
  std::vector<double> d = prev.distance;
  if (d.empty()) throw std::invalid_argument("a generation without distances");
  std::sort(d.begin(), d.end());
  // Type-7 quantile of the previous distances.
  const double h = settings_.quantile * static_cast<double>(d.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, d.size() - 1);
  const double fraction = h - static_cast<double>(lo);
  // Written so that an infinite distance beyond the quantile gives no ∞ − ∞ (NaN); the
  // same value as the interpolation wherever that is finite.
  if (fraction == 0.0 || d[hi] == d[lo]) return d[lo];
  if (!std::isfinite(d[hi])) return std::numeric_limits<double>::infinity();
  return d[lo] + fraction * (d[hi] - d[lo]);
}

bool AbcSmc::finished(const AbcGeneration& g) const {
  if (g.index >= settings_.generations) return true;
  return g.index > 0 && g.acceptance() < settings_.min_acceptance;
}

double weighted_quantile(const std::vector<double>& values, const std::vector<double>& weights, double p) {
  if (values.empty() || values.size() != weights.size()) throw std::invalid_argument("weighted_quantile: bad sizes");
  std::vector<std::size_t> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  double cumulative = 0.0;
  for (std::size_t k : order) {
    cumulative += weights[k];
    if (cumulative >= p * total) return values[k];
  }
  return values[order.back()];
}

double energy_distance(const std::vector<std::vector<double>>& x, const std::vector<std::vector<double>>& y,
                       const std::vector<double>& scale) {
  if (x.empty() || y.empty()) throw std::invalid_argument("energy_distance: an empty sample");
  const std::size_t dim = scale.size();
  auto dist = [&](const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != dim || b.size() != dim) throw std::invalid_argument("energy_distance: dimension mismatch");
    double s = 0.0;
    for (std::size_t k = 0; k < dim; ++k) {
      const double e = (a[k] - b[k]) / scale[k];
      s += e * e;
    }
    return std::sqrt(s);
  };
  auto mean_pairs = [&](const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
    double s = 0.0;
    for (const auto& p : a)
      for (const auto& q : b) s += dist(p, q);
    return s / (static_cast<double>(a.size()) * static_cast<double>(b.size()));
  };
  return std::max(0.0, 2.0 * mean_pairs(x, y) - mean_pairs(x, x) - mean_pairs(y, y));
}

}  // namespace talus::stats
