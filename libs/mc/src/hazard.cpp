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

namespace {

constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

// Inserts x keeping v ascending, so the stored values do not depend on the order.
void insert_sorted(std::vector<double>& v, double x) { v.insert(std::upper_bound(v.begin(), v.end(), x), x); }

void clear_exact(HazardAccumulator::Cell& c) {
  std::vector<double>().swap(c.exact_energy);
  std::vector<double>().swap(c.exact_height);
  std::vector<double>().swap(c.exact_speed);
}

// Adds n exact passages (ascending per column) to a cell whose reach was `before`: kept
// while both sides held all their values and the total stays within the limit.
void merge_exact(HazardAccumulator::Cell& c, std::uint64_t before, const double* energy, const double* height,
                 const double* speed, std::size_t n, std::uint64_t other_reach) {
  const bool keep = c.exact_energy.size() == before && n == other_reach && c.reach <= HazardAccumulator::kExactLimit;
  if (!keep) {
    clear_exact(c);
    return;
  }
  for (std::size_t k = 0; k < n; ++k) {
    insert_sorted(c.exact_energy, energy[k]);
    insert_sorted(c.exact_height, height[k]);
    insert_sorted(c.exact_speed, speed[k]);
  }
}

}  // namespace

HazardAccumulator::HazardAccumulator(const HazardGridSpec& spec, double relative_accuracy)
    : spec_(spec), alpha_(relative_accuracy) {}

HazardAccumulator::Cell& HazardAccumulator::cell(std::int64_t id) {
  auto it = cells_.find(id);
  if (it == cells_.end()) {
    Cell c;
    c.energy = stats::QuantileSketch(alpha_, kMinEnergy);
    c.height = stats::QuantileSketch(alpha_, kMinHeight);
    c.speed = stats::QuantileSketch(alpha_, kMinSpeed);
    it = cells_.emplace(id, std::move(c)).first;
  }
  return it->second;
}

void HazardAccumulator::add(const std::vector<CellVisit>& visits) {
  for (const CellVisit& v : visits) {
    Cell& c = cell(v.cell);
    const std::uint64_t before = c.reach;
    ++c.reach;
    const double height = std::max(v.height, 0.0);
    const double energy = std::max(v.energy, 0.0);
    const double speed = std::max(v.speed, 0.0);
    c.energy.add(energy);
    c.height.add(height);
    c.speed.add(speed);
    c.max_speed = max_or_unknown(c.max_speed, v.speed);
    c.max_height = max_or_unknown(c.max_height, height);
    c.max_energy = max_or_unknown(c.max_energy, energy);
    merge_exact(c, before, &energy, &height, &speed, 1, 1);
  }
}

void HazardAccumulator::merge(const HazardAccumulator& other) {
  if (other.cells_.empty()) return;
  if (other.spec_.nx != spec_.nx || other.spec_.ny != spec_.ny || other.spec_.size != spec_.size ||
      other.spec_.x0 != spec_.x0 || other.spec_.y0 != spec_.y0 || other.alpha_ != alpha_)
    throw core::InputError("hazard", "hazard grids or accuracies differ: the runs are not shards of one run");
  for (const auto& [id, c] : other.cells_) {
    Cell& mine = cell(id);
    const std::uint64_t before = mine.reach;
    mine.reach += c.reach;
    mine.energy.merge(c.energy);
    mine.height.merge(c.height);
    mine.speed.merge(c.speed);
    mine.max_speed = max_or_unknown(mine.max_speed, c.max_speed);
    mine.max_height = max_or_unknown(mine.max_height, c.max_height);
    mine.max_energy = max_or_unknown(mine.max_energy, c.max_energy);
    merge_exact(mine, before, c.exact_energy.data(), c.exact_height.data(), c.exact_speed.data(),
                c.exact_energy.size(), c.reach);
  }
}

const std::vector<double>& HazardAccumulator::Cell::values(HazardVariable v) const {
  return v == HazardVariable::energy ? exact_energy : v == HazardVariable::height ? exact_height : exact_speed;
}

const stats::QuantileSketch& HazardAccumulator::Cell::sketch(HazardVariable v) const {
  return v == HazardVariable::energy ? energy : v == HazardVariable::height ? height : speed;
}

double HazardAccumulator::Cell::quantile(HazardVariable v, double p) const {
  if (exact()) {
    // Hyndman–Fan type 7 on the sorted exact values (as stats::Sample::quantile).
    const std::vector<double>& x = values(v);
    const double h = std::min(std::max(p, 0.0), 1.0) * static_cast<double>(x.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(h));
    if (lo + 1 >= x.size()) return x.back();
    return x[lo] + (h - static_cast<double>(lo)) * (x[lo + 1] - x[lo]);
  }
  const stats::QuantileSketch& s = sketch(v);
  return reach > 0 && s.count() == reach ? s.interpolated_quantile(p) : kUnknown;
}

double HazardAccumulator::Cell::mean(HazardVariable v) const {
  if (exact()) {
    double sum = 0.0;
    for (double x : values(v)) sum += x;
    return sum / static_cast<double>(reach);
  }
  const stats::QuantileSketch& s = sketch(v);
  return reach > 0 && s.count() == reach ? s.mean() : kUnknown;
}

double HazardAccumulator::Cell::count_at_least(HazardVariable v, double x) const {
  if (exact()) {
    const std::vector<double>& values = this->values(v);
    return static_cast<double>(values.end() - std::lower_bound(values.begin(), values.end(), x));
  }
  const stats::QuantileSketch& s = sketch(v);
  if (reach == 0 || s.count() != reach) return kUnknown;
  // The sorted representatives: count those ≥ x from the top.
  std::uint64_t above = 0;
  for (auto it = s.buckets().rbegin(); it != s.buckets().rend(); ++it) {
    if (s.value_at_rank(s.count() - 1 - above) < x) break;
    above += it->second;
  }
  if (above == s.count() - s.zero_count() && x <= 0.0) above += s.zero_count();
  return static_cast<double>(above);
}

double HazardAccumulator::Cell::kth_largest(HazardVariable v, std::uint64_t k) const {
  if (k == 0 || k > reach) return k == 0 ? kUnknown : 0.0;
  if (exact()) return values(v)[reach - k];
  const stats::QuantileSketch& s = sketch(v);
  return s.count() == reach ? s.value_at_rank(reach - k) : kUnknown;
}

double HazardAccumulator::Cell::max(HazardVariable v) const {
  if (reach == 0) return kUnknown;
  return v == HazardVariable::energy ? max_energy : v == HazardVariable::height ? max_height : max_speed;
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
  const bool speeds = !t.speed_zero.empty();
  const std::size_t x = t.exact_cell.size();
  if (t.reach.size() != n || t.energy_zero.size() != n || t.height_zero.size() != n ||
      (maxima && (t.speed_max.size() != n || t.height_max.size() != n)) ||
      (!t.energy_max.empty() && t.energy_max.size() != n) || (speeds && t.speed_zero.size() != n) ||
      t.energy_index.size() != t.energy_cell.size() || t.energy_count.size() != t.energy_cell.size() ||
      t.height_index.size() != t.height_cell.size() || t.height_count.size() != t.height_cell.size() ||
      t.speed_index.size() != t.speed_cell.size() || t.speed_count.size() != t.speed_cell.size() ||
      t.exact_energy.size() != x || t.exact_height.size() != x || t.exact_speed.size() != x)
    throw core::InputError(source, "hazard table arrays differ in length");
  const std::int64_t cells = static_cast<std::int64_t>(spec_.nx) * spec_.ny;
  auto sorted = [](const std::vector<std::int64_t>& v) { return std::is_sorted(v.begin(), v.end()); };
  if (!sorted(t.cell) || !sorted(t.energy_cell) || !sorted(t.height_cell) || !sorted(t.speed_cell) ||
      !sorted(t.exact_cell))
    throw core::InputError(source, "hazard table cells are not in ascending order");
  Triplets energy{t.energy_cell, t.energy_index, t.energy_count};
  Triplets height{t.height_cell, t.height_index, t.height_count};
  Triplets speed{t.speed_cell, t.speed_index, t.speed_count};
  std::size_t exact_at = 0;
  std::vector<std::int32_t> indices;
  std::vector<std::uint64_t> counts;
  for (std::size_t k = 0; k < n; ++k) {
    const std::int64_t id = t.cell[k];
    if (id < 0 || id >= cells || t.reach[k] < 0 || t.energy_zero[k] < 0 || t.height_zero[k] < 0 ||
        (speeds && t.speed_zero[k] < 0))
      throw core::InputError(source, "hazard cell " + std::to_string(id) + " is outside the grid or has negative counts");
    Cell& c = cell(id);
    const std::uint64_t before = c.reach;
    const auto reach = static_cast<std::uint64_t>(t.reach[k]);
    c.reach += reach;
    c.max_speed = max_or_unknown(c.max_speed, maxima ? t.speed_max[k] : kUnknown);
    c.max_height = max_or_unknown(c.max_height, maxima ? t.height_max[k] : kUnknown);
    c.max_energy = max_or_unknown(c.max_energy, t.energy_max.empty() ? kUnknown : t.energy_max[k]);
    energy.take(id, indices, counts);
    c.energy.merge(stats::QuantileSketch::from_buckets(alpha_, kMinEnergy, static_cast<std::uint64_t>(t.energy_zero[k]),
                                                       indices, counts));
    height.take(id, indices, counts);
    c.height.merge(stats::QuantileSketch::from_buckets(alpha_, kMinHeight, static_cast<std::uint64_t>(t.height_zero[k]),
                                                       indices, counts));
    speed.take(id, indices, counts);
    if (speeds)
      c.speed.merge(stats::QuantileSketch::from_buckets(alpha_, kMinSpeed, static_cast<std::uint64_t>(t.speed_zero[k]),
                                                        indices, counts));
    const std::size_t first = exact_at;
    while (exact_at < x && t.exact_cell[exact_at] == id) ++exact_at;
    const std::size_t m = exact_at - first;
    for (std::size_t j = first; j < exact_at; ++j)
      if (!(t.exact_energy[j] >= 0.0) || !(t.exact_height[j] >= 0.0) || !(t.exact_speed[j] >= 0.0) ||
          !std::isfinite(t.exact_energy[j] + t.exact_height[j] + t.exact_speed[j]))
        throw core::InputError(source, "hazard cell " + std::to_string(id) + " has a negative or non-finite exact value");
    merge_exact(c, before, t.exact_energy.data() + first, t.exact_height.data() + first, t.exact_speed.data() + first,
                m, reach);
  }
  if (energy.at != t.energy_cell.size() || height.at != t.height_cell.size() || speed.at != t.speed_cell.size() ||
      exact_at != x)
    throw core::InputError(source, "hazard buckets name cells missing from the cell list");
}

HazardAccumulator::Table HazardAccumulator::table() const {
  Table t;
  for (const auto& [id, c] : cells_) {
    t.cell.push_back(id);
    t.reach.push_back(static_cast<std::int64_t>(c.reach));
    t.energy_zero.push_back(static_cast<std::int64_t>(c.energy.zero_count()));
    t.height_zero.push_back(static_cast<std::int64_t>(c.height.zero_count()));
    t.speed_zero.push_back(static_cast<std::int64_t>(c.speed.zero_count()));
    t.speed_max.push_back(c.max_speed);
    t.height_max.push_back(c.max_height);
    t.energy_max.push_back(c.max_energy);
    const auto put = [id](const stats::QuantileSketch& s, std::vector<std::int64_t>& cell,
                          std::vector<std::int32_t>& index, std::vector<std::int64_t>& count) {
      for (const auto& [i, n] : s.buckets()) {
        cell.push_back(id);
        index.push_back(i);
        count.push_back(static_cast<std::int64_t>(n));
      }
    };
    put(c.energy, t.energy_cell, t.energy_index, t.energy_count);
    put(c.height, t.height_cell, t.height_index, t.height_count);
    put(c.speed, t.speed_cell, t.speed_index, t.speed_count);
    if (c.exact())
      for (std::size_t k = 0; k < c.exact_energy.size(); ++k) {
        t.exact_cell.push_back(id);
        t.exact_energy.push_back(c.exact_energy[k]);
        t.exact_height.push_back(c.exact_height[k]);
        t.exact_speed.push_back(c.exact_speed[k]);
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
