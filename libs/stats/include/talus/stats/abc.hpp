// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace talus::stats {

/// The prior of one fitted parameter: uniform on [min, max], or a normal (mean, sd)
/// truncated to [min, max]. Every proposal outside [min, max] is refused.
struct Prior {
  std::string kind = "uniform";  ///< "uniform" or "normal"
  double min = 0.0;
  double max = 1.0;
  double mean = 0.5;  ///< normal only
  double sd = 0.1;    ///< normal only, > 0
  /// Density up to a constant factor (the same for every value): 0 outside [min, max].
  double density(double x) const;
};

/// Settings of the sequential Monte Carlo approximate Bayesian computation (ABC-SMC,
/// Beaumont et al. 2009 with the adaptive tolerance of Del Moral et al. 2012).
struct AbcSettings {
  std::int64_t particles = 100;        ///< population size N
  std::int64_t generations = 8;        ///< largest number of generations after the prior's (≥ 1)
  double quantile = 0.5;               ///< α: tolerance ε_t = α-quantile of generation t−1's distances
  double min_acceptance = 0.05;        ///< stop once a generation accepts fewer of its proposals
  std::int64_t max_simulations = 0;    ///< stop before a generation would exceed this total; 0 = no limit
  std::uint64_t seed = 1;              ///< the proposal draws (stream `calibration`)
};

/// One generation: N particles θ (each a vector of the fitted parameters), their
/// normalised importance weights and distances, and what it cost.
struct AbcGeneration {
  std::int64_t index = 0;                    ///< 0 = drawn from the prior
  double tolerance = 0.0;                    ///< ε (infinity for the prior's generation)
  std::vector<std::vector<double>> theta;    ///< [N][d]
  std::vector<double> weight;                ///< [N], sum 1
  std::vector<double> distance;              ///< [N]
  std::int64_t proposed = 0;                 ///< simulations run for this generation
  double acceptance() const { return proposed > 0 ? static_cast<double>(theta.size()) / static_cast<double>(proposed) : 0.0; }
};

/// Distances of a batch of parameter vectors, in the batch's order. Must be a pure
/// function of each θ, so the result does not depend on how the batch is split or on
/// thread counts: seed the simulation from θ itself. Do not give every θ the same random
/// numbers: the simulator's own scatter is what gives the posterior its width (with
/// common random numbers the population collapses onto a point estimate).
using AbcSimulator = std::function<std::vector<double>(const std::vector<std::vector<double>>& batch)>;

/// ABC-SMC over parameters with the given priors. Proposals of generation t are a pure
/// function of (seed, t, candidate index) and generation t−1, and candidates are accepted
/// in index order, so a run is reproducible whatever the simulator's threading, and a run
/// resumed from any completed generation continues exactly as it would have.
class AbcSmc {
 public:
  AbcSmc(std::vector<Prior> priors, AbcSettings settings);

  /// Generation 0: N draws from the prior, all kept (ε = ∞).
  AbcGeneration first(const AbcSimulator& simulate) const;
  /// The tolerance of the generation after `prev`: the α-quantile (type 7) of its
  /// distances; not finite when more than about α of them are infinite (simulations that
  /// could not be compared), and then no next generation can be drawn.
  double tolerance(const AbcGeneration& prev) const;
  /// Generation prev.index + 1: tolerance the α-quantile of prev's distances; candidates
  /// drawn from prev by weight and moved by a normal kernel of twice prev's weighted
  /// covariance, refused outside the priors' supports; simulated in batches until N are
  /// within the tolerance. With `max_proposals` > 0 the generation stops after that many
  /// simulations: it then holds fewer than N particles and must not be used. Throws
  /// std::domain_error when the tolerance is not finite (it would accept nothing, or
  /// everything).
  AbcGeneration next(const AbcGeneration& prev, const AbcSimulator& simulate, std::int64_t max_proposals = 0) const;

  /// Whether the run should stop after `g` (acceptance below min_acceptance, or the last
  /// generation reached).
  bool finished(const AbcGeneration& g) const;

  const std::vector<Prior>& priors() const { return priors_; }
  const AbcSettings& settings() const { return settings_; }

 private:
  std::vector<Prior> priors_;
  AbcSettings settings_;
};

/// Weighted quantile (p in [0, 1]) of values with non-negative weights: the smallest value
/// whose cumulative weight reaches p of the total (p = 0.5: the weighted median).
double weighted_quantile(const std::vector<double>& values, const std::vector<double>& weights, double p);

/// Energy distance (Székely & Rizzo 2013) between two samples of points in R^d, each
/// coordinate divided by scale[k]:
///   D = 2 E|X − Y| − E|X − X'| − E|Y − Y'|  (≥ 0; 0 iff the distributions agree),
/// with the V-statistic means over all pairs. Throws std::invalid_argument on an empty
/// sample or a dimension mismatch.
double energy_distance(const std::vector<std::vector<double>>& x, const std::vector<std::vector<double>>& y,
                       const std::vector<double>& scale);

}  // namespace talus::stats
