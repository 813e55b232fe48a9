#include <algorithm>
#include <cmath>
#include <limits>

#include "talus/core/error.hpp"
#include "talus/mc/realization.hpp"

namespace talus::mc {

namespace {
// The larger of two maxima, unknown (NaN) when either is.
double max_or_unknown(double a, double b) {
  return std::isnan(a) || std::isnan(b) ? std::numeric_limits<double>::quiet_NaN() : std::max(a, b);
}
}  // namespace

HazardAccumulator::HazardAccumulator(const HazardGridSpec& spec, double relative_accuracy)
    : spec_(spec), alpha_(relative_accuracy) {}

HazardAccumulator::Cell& HazardAccumulator::cell(std::int64_t id) {
  auto it = cells_.find(id);
  if (it == cells_.end())
    it = cells_
             .emplace(id, Cell{0, stats::QuantileSketch(alpha_, kMinEnergy), stats::QuantileSketch(alpha_, kMinHeight)})
             .first;
  return it->second;
}

void HazardAccumulator::add(const std::vector<CellVisit>& visits) {
  for (const CellVisit& v : visits) {
    Cell& c = cell(v.cell);
    ++c.reach;
    const double height = std::max(v.height, 0.0);
    c.energy.add(std::max(v.energy, 0.0));
    c.height.add(height);
    c.max_speed = max_or_unknown(c.max_speed, v.speed);
    c.max_height = max_or_unknown(c.max_height, height);
  }
}

void HazardAccumulator::merge(const HazardAccumulator& other) {
  if (other.cells_.empty()) return;
  if (other.spec_.nx != spec_.nx || other.spec_.ny != spec_.ny || other.spec_.size != spec_.size ||
      other.spec_.x0 != spec_.x0 || other.spec_.y0 != spec_.y0 || other.alpha_ != alpha_)
    throw core::InputError("hazard", "hazard grids or accuracies differ: the runs are not shards of one run");
  for (const auto& [id, c] : other.cells_) {
    Cell& mine = cell(id);
    mine.reach += c.reach;
    mine.energy.merge(c.energy);
    mine.height.merge(c.height);
    mine.max_speed = max_or_unknown(mine.max_speed, c.max_speed);
    mine.max_height = max_or_unknown(mine.max_height, c.max_height);
  }
}

namespace {

using Table = HazardAccumulator::Table;

// Splits (cell, index, count) triplets sorted by cell into per-cell bucket lists.
struct Triplets {
  const std::vector<std::int64_t>& cell;
  const std::vector<std::int32_t>& index;
  const std::vector<std::int64_t>& count;
  std::size_t at = 0;
  void take(std::int64_t id, std::vector<std::int32_t>& indices, std::vector<std::uint64_t>& counts) {
    indices.clear();
    counts.clear();
    while (at < cell.size() && cell[at] == id) {
      indices.push_back(index[at]);
      counts.push_back(static_cast<std::uint64_t>(count[at]));
      ++at;
    }
  }
};

}  // namespace

void HazardAccumulator::merge(const Table& t, const std::string& source) {
  const std::size_t n = t.cell.size();
  const bool maxima = !t.speed_max.empty() || !t.height_max.empty();
  if (t.reach.size() != n || t.energy_zero.size() != n || t.height_zero.size() != n ||
      (maxima && (t.speed_max.size() != n || t.height_max.size() != n)) ||
      t.energy_index.size() != t.energy_cell.size() || t.energy_count.size() != t.energy_cell.size() ||
      t.height_index.size() != t.height_cell.size() || t.height_count.size() != t.height_cell.size())
    throw core::InputError(source, "hazard table arrays differ in length");
  const std::int64_t cells = static_cast<std::int64_t>(spec_.nx) * spec_.ny;
  auto sorted = [](const std::vector<std::int64_t>& v) { return std::is_sorted(v.begin(), v.end()); };
  if (!sorted(t.cell) || !sorted(t.energy_cell) || !sorted(t.height_cell))
    throw core::InputError(source, "hazard table cells are not in ascending order");
  Triplets energy{t.energy_cell, t.energy_index, t.energy_count};
  Triplets height{t.height_cell, t.height_index, t.height_count};
  std::vector<std::int32_t> indices;
  std::vector<std::uint64_t> counts;
  for (std::size_t k = 0; k < n; ++k) {
    const std::int64_t id = t.cell[k];
    if (id < 0 || id >= cells || t.reach[k] < 0 || t.energy_zero[k] < 0 || t.height_zero[k] < 0)
      throw core::InputError(source, "hazard cell " + std::to_string(id) + " is outside the grid or has negative counts");
    Cell& c = cell(id);
    c.reach += static_cast<std::uint64_t>(t.reach[k]);
    const double unknown = std::numeric_limits<double>::quiet_NaN();
    c.max_speed = max_or_unknown(c.max_speed, maxima ? t.speed_max[k] : unknown);
    c.max_height = max_or_unknown(c.max_height, maxima ? t.height_max[k] : unknown);
    energy.take(id, indices, counts);
    c.energy.merge(stats::QuantileSketch::from_buckets(alpha_, kMinEnergy, static_cast<std::uint64_t>(t.energy_zero[k]),
                                                       indices, counts));
    height.take(id, indices, counts);
    c.height.merge(stats::QuantileSketch::from_buckets(alpha_, kMinHeight, static_cast<std::uint64_t>(t.height_zero[k]),
                                                       indices, counts));
  }
  if (energy.at != t.energy_cell.size() || height.at != t.height_cell.size())
    throw core::InputError(source, "hazard buckets name cells missing from the cell list");
}

HazardAccumulator::Table HazardAccumulator::table() const {
  Table t;
  for (const auto& [id, c] : cells_) {
    t.cell.push_back(id);
    t.reach.push_back(static_cast<std::int64_t>(c.reach));
    t.energy_zero.push_back(static_cast<std::int64_t>(c.energy.zero_count()));
    t.height_zero.push_back(static_cast<std::int64_t>(c.height.zero_count()));
    t.speed_max.push_back(c.max_speed);
    t.height_max.push_back(c.max_height);
    for (const auto& [index, count] : c.energy.buckets()) {
      t.energy_cell.push_back(id);
      t.energy_index.push_back(index);
      t.energy_count.push_back(static_cast<std::int64_t>(count));
    }
    for (const auto& [index, count] : c.height.buckets()) {
      t.height_cell.push_back(id);
      t.height_index.push_back(index);
      t.height_count.push_back(static_cast<std::int64_t>(count));
    }
  }
  return t;
}

void RunData::add(RealizationResult&& r) {
  const std::uint32_t index = r.record.realization;
  records.push_back(r.record);
  crossings.insert(crossings.end(), r.crossings.begin(), r.crossings.end());
  for (const auto& sample : r.trajectory) trajectories.push_back({index, sample});
  hazard.add(r.cells);
}

void RunData::sort(const std::string& source) {
  auto by_realization = [](const auto& a, const auto& b) { return a.realization < b.realization; };
  std::stable_sort(records.begin(), records.end(), by_realization);
  for (std::size_t k = 1; k < records.size(); ++k)
    if (records[k].realization == records[k - 1].realization)
      throw core::InputError(source, "realization " + std::to_string(records[k].realization) + " appears twice");
  std::stable_sort(crossings.begin(), crossings.end(), by_realization);
  std::stable_sort(trajectories.begin(), trajectories.end(), by_realization);
}

void RunData::append(RunData&& other) {
  records.insert(records.end(), other.records.begin(), other.records.end());
  crossings.insert(crossings.end(), other.crossings.begin(), other.crossings.end());
  trajectories.insert(trajectories.end(), other.trajectories.begin(), other.trajectories.end());
  if (hazard.cells().empty() && hazard.spec().size == 0.0) hazard = std::move(other.hazard);
  else hazard.merge(other.hazard);
}

}  // namespace talus::mc
