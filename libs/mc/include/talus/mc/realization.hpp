// SPDX-License-Identifier: MIT
#pragma once
#include <atomic>
#include <cstdint>
#include <map>
#include <vector>

#include "talus/dda/engine.hpp"
#include "talus/mc/scene.hpp"
#include "talus/stats/quantile_sketch.hpp"

namespace talus::mc {

using geometry::Vec3;

/// One record per realization: the SPEC §4 summary values and where the block stopped.
struct Record {
  std::uint32_t realization = 0;
  std::int32_t block = 0;               ///< index into the scene's blocks
  dda::EndReason end = dda::EndReason::running;
  std::int32_t stop_class = 0;          ///< index into Scene::stop_classes()
  std::uint64_t impacts = 0;
  std::uint64_t steps = 0;
  double time = 0.0;                    ///< simulated duration (s)
  Vec3 release_position = Vec3::Zero(); ///< centroid (m)
  Vec3 final_position = Vec3::Zero();   ///< centroid (m)
  double runout = 0.0;                  ///< m, along the main direction
  double lateral = 0.0;                 ///< m, left of the main direction positive
  double max_speed = 0.0;               ///< m/s, centroid
  double max_jump_height = 0.0;         ///< m, centroid above the terrain (vertical), after the first touch
  double max_normal_jump_height = 0.0;  ///< m, centroid above the ground along its normal, after the first touch
  double max_kinetic_energy = 0.0;      ///< J, translational + rotational
  /// Invariant checks (engine.check_invariants; zero when off): steps that broke one,
  /// the largest one-step rise of the total energy (J), the deepest overlap of terrain
  /// and block (m).
  std::uint64_t invariant_violations = 0;
  double max_energy_gain = 0.0;
  double max_overlap = 0.0;
  /// Kinetic energy the engine's energy limiter took back from contact steps that gained
  /// energy without a source (J; docs/dda.md).
  double energy_removed = 0.0;
  bool operator==(const Record&) const = default;
};

/// A crossing of a barrier line by the centroid's plan path.
struct Crossing {
  std::uint32_t realization = 0;
  std::int32_t barrier = 0;         ///< index into the scene's barriers
  double position = 0.0;            ///< distance along the line from its first vertex (m)
  double time = 0.0;                ///< s
  double height = 0.0;              ///< passing height: centroid above the ground (m), NaN off terrain
  Vec3 velocity = Vec3::Zero();     ///< centroid (m/s)
  double kinetic_energy = 0.0;      ///< translational + rotational (J)
  /// +1 when crossing from the line's right to its left (walking along it), −1 otherwise.
  std::int32_t direction = 1;
  bool operator==(const Crossing&) const = default;
};

/// A sampled trajectory point (dda::TrajectorySample) tagged with its realization.
struct TrajectoryPoint {
  std::uint32_t realization = 0;
  dda::TrajectorySample sample;
};

/// What one realization contributed to a hazard cell: the largest kinetic energy (J),
/// passing height (m) and centroid speed (m/s) its path had there.
struct CellVisit {
  std::int64_t cell = 0;
  double energy = 0.0;
  double height = 0.0;
  double speed = 0.0;
};

/// Everything one realization produced.
struct RealizationResult {
  Record record;
  std::vector<Crossing> crossings;        ///< in time order
  std::vector<dda::TrajectorySample> trajectory;
  std::vector<CellVisit> cells;           ///< each cell once, ascending id
};

/// Runs realization `index` of `scene`: a pure function of (scene, index) — the terrain
/// realization `index`, the release draws of Stream::release, the block of
/// Stream::block_shape (weighted selection) and the impact draws of Stream::impact, all
/// keyed by the scene seed (the terrain's own seed for roughness). Throws
/// core::InputError as draw_release does. When `abandon` is given and becomes true, the
/// realization stops within a few hundred steps by throwing Abandoned (a run stopped by a
/// signal redoes it on --resume).
struct Abandoned {};
RealizationResult run_realization(const Scene& scene, std::uint32_t index,
                                  const std::atomic<bool>* abandon = nullptr);

/// The release of realization `index` and its block on its realized `ground`: plan point
/// and orientation drawn, then the height set by release.height_reference, and a
/// centroid-placed block within release.clearance_gap of the ground (or in it) lifted or
/// refused by release.clearance. Throws core::InputError (the scene's source) naming the
/// realization when the release point is off the realized terrain or the block is refused.
struct ReleaseDraw {
  std::int32_t block = 0;
  dda::Release release;
};
ReleaseDraw draw_release(const Scene& scene, const terrain::Surface& ground, std::uint32_t index);

/// The uniformly random rotation (Shoemake 1992) of three uniforms in [0, 1), with the
/// platform-independent sine and cosine of the random streams: the release's random
/// orientation.
Eigen::Quaterniond uniform_rotation(double u1, double u2, double u3);

/// A per-cell hazard variable: each realization's largest value in the cell of its
/// kinetic energy (J), passing height (m) or centroid speed (m/s).
enum class HazardVariable { energy, height, speed };

/// Per-cell hazard accumulators: how many realizations reached each cell, sketches of
/// their energies, passing heights and speeds there (quantiles without storing
/// trajectories), their exact values while a cell has at most kExactLimit passages (exact
/// low-count quantiles), and the largest energy, speed and passing height of any of them.
/// Counts are integers, sketches merge exactly and exact values are kept sorted, so the
/// result does not depend on the order realizations are added or shards merged.
class HazardAccumulator {
 public:
  HazardAccumulator() = default;
  HazardAccumulator(const HazardGridSpec& spec, double relative_accuracy);

  /// The flat form stored in files: cells with reach > 0 ascending, with their maxima
  /// (empty in files written before they were kept: the maxima are then unknown, NaN); for
  /// each sketch the (cell, bucket index, count) triplets in ascending (cell, index) order
  /// (no speed sketch in files written before it was kept); the exact values of the cells
  /// that keep them, (cell, energy, height, speed) rows by cell, each cell's values in
  /// ascending order per column (none in files written before they were kept).
  struct Table {
    std::vector<std::int64_t> cell, reach, energy_zero, height_zero, speed_zero;
    std::vector<double> speed_max, height_max, energy_max;
    std::vector<std::int64_t> energy_cell, energy_count;
    std::vector<std::int32_t> energy_index;
    std::vector<std::int64_t> height_cell, height_count;
    std::vector<std::int32_t> height_index;
    std::vector<std::int64_t> speed_cell, speed_count;
    std::vector<std::int32_t> speed_index;
    std::vector<std::int64_t> exact_cell;
    std::vector<double> exact_energy, exact_height, exact_speed;
  };

  void add(const std::vector<CellVisit>& visits);
  void merge(const HazardAccumulator& other);
  /// Adds a stored table (throws core::InputError on cells outside the grid or
  /// inconsistent arrays).
  void merge(const Table& table, const std::string& source);
  Table table() const;

  const HazardGridSpec& spec() const { return spec_; }
  double relative_accuracy() const { return alpha_; }
  /// Values at or below these count as zero in the sketches (J, m, m/s).
  static constexpr double kMinEnergy = 1e-6;
  static constexpr double kMinHeight = 1e-6;
  static constexpr double kMinSpeed = 1e-6;
  /// A cell keeps the exact values of its passages up to this many passages: below it
  /// quantiles are exact order statistics; above it they come from the sketches.
  static constexpr std::uint64_t kExactLimit = 100;

  struct Cell {
    std::uint64_t reach = 0;
    stats::QuantileSketch energy;
    stats::QuantileSketch height;
    stats::QuantileSketch speed;
    double max_speed = 0.0;   ///< m/s; NaN when a merged file did not keep it
    double max_height = 0.0;  ///< m; NaN likewise
    double max_energy = 0.0;  ///< J; NaN likewise
    /// Each passage's value, ascending, while every part kept them and reach ≤ kExactLimit
    /// (else empty).
    std::vector<double> exact_energy, exact_height, exact_speed;

    /// True when the cell holds every passage's exact values.
    bool exact() const { return reach > 0 && exact_energy.size() == reach; }
    /// The p-quantile of the variable over the passages (Hyndman–Fan type 7): exact order
    /// statistics when exact(), else interpolated between sketch representatives (within
    /// the sketch's relative accuracy). NaN when unknown (no passage, or a speed sketch
    /// missing from an earlier file).
    double quantile(HazardVariable v, double p) const;
    /// The mean over the passages: exact when exact(), else of the sketch's bucket
    /// representatives. NaN when unknown.
    double mean(HazardVariable v) const;
    /// The largest value of any passage (exact); NaN when unknown.
    double max(HazardVariable v) const;
    /// How many passages had a value ≥ x: exact when exact(), else counted by bucket
    /// representative (a threshold within the sketch's relative accuracy of a value may
    /// count it either way). NaN when unknown.
    double count_at_least(HazardVariable v, double x) const;
    /// The k-th largest value over the passages (k ≥ 1; 0 when k > reach): exact when
    /// exact(), else its bucket's representative. NaN when unknown.
    double kth_largest(HazardVariable v, std::uint64_t k) const;
    /// The exact values of the variable (empty unless exact()).
    const std::vector<double>& values(HazardVariable v) const;
    /// The sketch of the variable.
    const stats::QuantileSketch& sketch(HazardVariable v) const;
  };
  const std::map<std::int64_t, Cell>& cells() const { return cells_; }

 private:
  Cell& cell(std::int64_t id);
  HazardGridSpec spec_;
  double alpha_ = 0.01;
  std::map<std::int64_t, Cell> cells_;
};

/// The results of a run or of a shard in canonical order (by realization), whatever
/// order they finished in: the content of a run file.
struct RunData {
  std::vector<Record> records;             ///< ascending realization
  std::vector<Crossing> crossings;         ///< by realization, then time
  std::vector<TrajectoryPoint> trajectories;  ///< by realization, then time
  HazardAccumulator hazard;

  /// Adds one realization's results (any order; call sort() when done).
  void add(RealizationResult&& result);
  /// Puts records, crossings and trajectory points in canonical order (stable within a
  /// realization) and throws core::InputError if a realization appears twice.
  void sort(const std::string& source);
  /// Appends another shard's data (then sort()).
  void append(RunData&& other);
};

}  // namespace talus::mc
