#include "talus/mc/realization.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/mc/clearance.hpp"

namespace talus::mc {
namespace {

using core::RandomStream;
using core::Stream;

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Index of the weight that the uniform draw `u` falls on, in proportion to the weights
// (a zero weight is never drawn).
std::size_t pick(const std::vector<double>& weights, double u) {
  double total = 0.0;
  for (double w : weights) total += w;
  const double at = u * total;
  double sum = 0.0;
  std::size_t last = 0;
  for (std::size_t k = 0; k < weights.size(); ++k) {
    if (!(weights[k] > 0.0)) continue;
    sum += weights[k];
    last = k;
    if (at < sum) return k;
  }
  return last;  // u·total rounded up to the total
}

// Plan point of the release zone from `rs`: draw 1 picks the feature when there are
// several, draw 2 the part of a multi-part point or polygon feature, draw 0 the position
// along a line (over all its parts), draws 16 onwards (pairs) the point in a polygon;
// draws 3–5 are the orientation. One feature of one part (an inline line, polygon or
// single point) uses the draws and arithmetic it always did.
Eigen::Vector2d release_point(const std::string& kind, const std::vector<ReleaseFeature>& features,
                              const RandomStream& rs) {
  std::size_t chosen = 0;
  if (features.size() > 1) {
    std::vector<double> weights;
    for (const auto& f : features) weights.push_back(f.weight);
    chosen = pick(weights, rs.uniform(1));
  }
  const ReleaseFeature& feature = features[chosen];
  const auto& parts = feature.parts;
  if (kind == "point") {
    const std::size_t k = parts.size() > 1 ? pick(feature.part_sizes, rs.uniform(2)) : 0;
    return parts[k][0][0];
  }
  if (kind == "line") {
    double length = 0.0;
    for (double s : feature.part_sizes) length += s;
    double at = rs.uniform(0) * length;
    for (std::size_t p = 0; p < parts.size(); ++p) {
      const std::vector<Eigen::Vector2d>& zone = parts[p][0];
      if (at > feature.part_sizes[p] && p + 1 < parts.size()) {
        at -= feature.part_sizes[p];
        continue;
      }
      for (std::size_t k = 1; k < zone.size(); ++k) {
        const double len = (zone[k] - zone[k - 1]).norm();
        if (at <= len || k + 1 == zone.size()) return zone[k - 1] + (zone[k] - zone[k - 1]) * std::min(at / len, 1.0);
        at -= len;
      }
    }
  }
  // Polygon: the part by area, then rejection sampling in its outer ring's bounding box
  // (any simple polygon, concave too; points in a hole are rejected).
  const std::size_t part = parts.size() > 1 ? pick(feature.part_sizes, rs.uniform(2)) : 0;
  const std::vector<std::vector<Eigen::Vector2d>>& rings = parts[part];
  const std::vector<Eigen::Vector2d>& zone = rings[0];
  Eigen::Vector2d lo = zone[0], hi = zone[0];
  for (const auto& p : zone) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  for (std::uint64_t k = 0; k < 100000; ++k) {
    const Eigen::Vector2d p(lo.x() + (hi.x() - lo.x()) * rs.uniform(16 + 2 * k),
                            lo.y() + (hi.y() - lo.y()) * rs.uniform(17 + 2 * k));
    if (point_in_rings(rings, p)) return p;
  }
  throw core::RuntimeError("release polygon: no point drawn inside it after 100000 tries");
}

// The state just before a step, for interpolating along it.
struct Before {
  double time = 0.0;
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  double rotational_energy = 0.0;
  std::uint64_t flight_steps = 0;
};

// Watches each step's path for barrier crossings and hazard cells. A hazard cell is
// looked up in the map only when the path enters it: while the centroid stays in one
// cell its maxima are kept aside, and merged when it leaves (or at the end).
class Observer {
 public:
  Observer(const Scene& scene, const terrain::Surface& ground, const dda::Model& model, std::uint32_t index,
           RealizationResult& out)
      : scene_(scene), ground_(ground), model_(model), index_(index), out_(out) {}

  bool active() const { return !scene_.barriers().empty() || scene_.hazard_grid().size > 0.0; }

  void start(const Vec3& p, const Vec3& v, double rotational) {
    visit(p, 0.5 * model_.mass * v.squaredNorm() + rotational, height_above_ground(p), v.norm());
  }

  // The step from `b` to `s`; `s.kinetic` and `s.height` are the engine's values at its end.
  void segment(const Before& b, const dda::State& s, double rotational_after) {
    const double dt = s.time - b.time;
    if (!(dt > 0.0)) return;
    // In flight the engine advances on the exact parabola; horizontal motion is uniform,
    // so plan fractions are time fractions in both cases.
    const bool flight = s.counters.flight_steps > b.flight_steps;
    const Vec3 p1 = s.position;
    const Vec3 v1 = s.velocity.head<3>();
    const double g = model_.settings.gravity;
    auto at = [&](double f, Vec3& p, Vec3& v, double& rotational) {
      if (f == 1.0) {
        // The step's end: the state itself.
        p = p1;
        v = v1;
        rotational = rotational_after;
      } else if (flight) {
        const double tau = f * dt;
        p = b.position + b.velocity * tau - Vec3(0.0, 0.0, 0.5 * g * tau * tau);
        v = b.velocity - Vec3(0.0, 0.0, g * tau);
        rotational = b.rotational_energy;
      } else {
        p = b.position + f * (p1 - b.position);
        v = b.velocity + f * (v1 - b.velocity);
        rotational = b.rotational_energy + f * (rotational_after - b.rotational_energy);
      }
    };
    const Eigen::Vector2d q0 = b.position.head<2>();
    const Eigen::Vector2d q1 = p1.head<2>();
    const Eigen::Vector2d d = q1 - q0;

    for (std::size_t k = 0; k < scene_.barriers().size(); ++k) {
      const Barrier& barrier = scene_.barriers()[k];
      for (std::size_t j = 1; j < barrier.line.size(); ++j) {
        const Eigen::Vector2d a = barrier.line[j - 1];
        const Eigen::Vector2d e = barrier.line[j] - a;
        const double denom = cross(d, e);
        if (denom == 0.0) continue;  // parallel (or no plan motion)
        const double f = cross(a - q0, e) / denom;
        const double u = cross(a - q0, d) / denom;
        const bool last = j + 1 == barrier.line.size();
        // Half-open on both sides, so a crossing exactly at a step end or a vertex counts once.
        if (!(f > 0.0 && f <= 1.0 && u >= 0.0 && (u < 1.0 || (last && u <= 1.0)))) continue;
        Crossing c;
        c.realization = index_;
        c.barrier = static_cast<std::int32_t>(k);
        c.position = barrier.offsets[j - 1] + u * e.norm();
        c.time = b.time + f * dt;
        Vec3 p, v;
        double rotational = 0.0;
        at(f, p, v, rotational);
        c.height = height_above_ground(p);
        c.velocity = v;
        c.kinetic_energy = 0.5 * model_.mass * v.squaredNorm() + rotational;
        c.direction = cross(e, d) > 0.0 ? 1 : -1;
        out_.crossings.push_back(c);
      }
    }

    const HazardGridSpec& grid = scene_.hazard_grid();
    if (grid.size > 0.0) {
      // Sample the path at least every quarter cell so no cell it crosses is skipped
      // except by a corner clip shorter than that.
      const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / (0.25 * grid.size))));
      for (int k = 1; k < n; ++k) {
        Vec3 p, v;
        double rotational = 0.0;
        at(static_cast<double>(k) / n, p, v, rotational);
        visit(p, 0.5 * model_.mass * v.squaredNorm() + rotational, height_above_ground(p), v.norm());
      }
      // The end of the step: the engine has its kinetic energy and height already.
      visit(p1, s.kinetic, s.height, v1.norm());
    }
  }

  // Per-cell maxima, sorted by cell.
  std::vector<CellVisit> cells() {
    merge_current();
    std::vector<CellVisit> out;
    out.reserve(cells_.size());
    for (const auto& [id, m] : cells_) out.push_back({id, m.energy, m.height, m.speed});
    std::sort(out.begin(), out.end(), [](const CellVisit& a, const CellVisit& b) { return a.cell < b.cell; });
    return out;
  }

 private:
  double height_above_ground(const Vec3& p) const {
    const auto hit = ground_.height_at(p.x(), p.y());
    return hit ? p.z() - hit->z : std::numeric_limits<double>::quiet_NaN();
  }

  // A sample of the path: kinetic energy (J), height above the ground (m, NaN off it) and
  // centroid speed (m/s).
  void visit(const Vec3& p, double energy, double h, double speed) {
    const std::int64_t id = scene_.hazard_grid().cell(p.x(), p.y());
    if (id < 0) return;
    if (id != current_.cell) {
      merge_current();
      current_ = Current{id, energy, speed, h, -std::numeric_limits<double>::infinity()};
      return;
    }
    current_.energy = std::max(current_.energy, energy);
    current_.speed = std::max(current_.speed, speed);
    if (std::isfinite(h)) current_.later_height = std::max(current_.later_height, h);
  }

  // Merges the samples of the cell the path is in into the map, as if each had been
  // merged on its own: the first sample's height counts as 0 when it is off the ground
  // and the cell is new, later ones only when on the ground.
  void merge_current() {
    if (current_.cell < 0) return;
    const Current& c = current_;
    auto [it, fresh] =
        cells_.try_emplace(c.cell, Maxima{c.energy, std::isfinite(c.first_height) ? c.first_height : 0.0, c.speed});
    Maxima& m = it->second;
    if (!fresh) {
      m.energy = std::max(m.energy, c.energy);
      m.speed = std::max(m.speed, c.speed);
      if (std::isfinite(c.first_height)) m.height = std::max(m.height, c.first_height);
    }
    m.height = std::max(m.height, c.later_height);
    current_.cell = -1;
  }

  // The cell the path is in and its maxima so far.
  struct Current {
    std::int64_t cell = -1;
    double energy = 0.0;
    double speed = 0.0;
    double first_height = 0.0;  // of the first sample in the cell (m, NaN off the ground)
    double later_height = 0.0;  // largest of the later samples on the ground (m, −∞ if none)
  };

  const Scene& scene_;
  const terrain::Surface& ground_;
  const dda::Model& model_;
  std::uint32_t index_;
  RealizationResult& out_;
  // A cell's maxima over the samples merged so far: kinetic energy (J), height (m), speed (m/s).
  struct Maxima {
    double energy = 0.0, height = 0.0, speed = 0.0;
  };
  std::unordered_map<std::int64_t, Maxima> cells_;
  Current current_;
};

// Where the release points were given: the vector file that holds them, or the scene's
// release.points (the file and line, or the --set key).
std::string release_origin(const Scene& scene) {
  const std::string& file = scene.settings().release.file;
  return file.empty() ? scene.origins().of("release.points") : file;
}

// "(x, y)" of a local plan point in the scene's frame, as the user wrote it.
std::string plan_text(const Scene& scene, const Eigen::Vector2d& xy) {
  const Vec3 shift = scene.frame_shift();
  return "(" + core::format_number(xy.x() + shift.x()) + ", " + core::format_number(xy.y() + shift.y()) + ")";
}

// Sets the release height of `block` (orientation already drawn) at plan point `xy`,
// where the realized ground is at `ground_z` (docs/dda-run.md, "Release clearance").
// Positions in its messages are in the scene's frame, not the engine's local one.
void place_block(const Scene& scene, const SceneBlock& block, const terrain::Surface& ground, std::uint32_t index,
                 const Eigen::Vector2d& xy, double ground_z, dda::Release& rel) {
  const ReleaseSettings& r = scene.settings().release;
  using core::format_number;
  const Vec3 shift = scene.frame_shift();
  const std::string where = "release of realization " + std::to_string(index) + " at " + plan_text(scene, xy) +
                            ": block '" + block.name + "'";
  if (r.height_reference == "lowest_point") {
    // Lowered from any height onto the ground, then raised by `height`: the clearance
    // changes by exactly the vertical shift, so one evaluation suffices.
    rel.position = Vec3(xy.x(), xy.y(), ground_z + block.model.radius);
    const Clearance c = vertical_clearance(block.model, rel.position, rel.orientation, ground);
    if (!std::isfinite(c.gap))
      throw core::InputError(release_origin(scene), where + " has no ground under it");
    rel.position.z() += r.height - c.gap;
    return;
  }
  // An elevation is in the scene's frame: the terrain's input coordinates (frame: input)
  // less the origin shift the engine works in.
  rel.position = Vec3(xy.x(), xy.y(), r.height_reference == "elevation" ? r.height - shift.z() : ground_z + r.height);
  // Most releases float well clear of the ground: the bound settles them without the
  // block's geometry (a 5 120-face block's exact clearance costs some 2 M instructions).
  if (clearance_lower_bound(block.model, rel.position, ground) >= r.clearance_gap) return;
  const Clearance c = vertical_clearance(block.model, rel.position, rel.orientation, ground);
  if (!(c.gap < r.clearance_gap)) return;
  const double raise = r.clearance_gap - c.gap;
  if (r.clearance == "lift") {
    rel.position.z() += raise;
    return;
  }
  const Vec3 at = c.point + shift;
  const std::string point =
      " (at x " + format_number(at.x()) + ", y " + format_number(at.y()) + ", z " + format_number(at.z()) + ")";
  const std::string state = c.gap < 0.0 ? " reaches " + format_number(-c.gap) + " m into the ground" + point
                                        : " is only " + format_number(c.gap) + " m above the ground" + point +
                                              ", less than release.clearance_gap " +
                                              format_number(r.clearance_gap) + " m";
  throw core::InputError(scene.origins().of({"release.height", "release.clearance_gap"}),
                         where + state + ": raise release.height by at least " +
                                             format_number(raise) + " m, or set release.clearance to lift");
}

}  // namespace

Eigen::Quaterniond uniform_rotation(double u1, double u2, double u3) {
  double s2 = 0.0, c2 = 0.0, s3 = 0.0, c3 = 0.0;
  core::detmath::sincos_2pi(u2, s2, c2);
  core::detmath::sincos_2pi(u3, s3, c3);
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  return Eigen::Quaterniond(b * c3, a * s2, a * c2, b * s3).normalized();
}

ReleaseDraw draw_release(const Scene& scene, const terrain::Surface& ground, std::uint32_t index) {
  const SceneSettings& s = scene.settings();
  const ReleaseSettings& r = s.release;
  ReleaseDraw draw;
  const auto blocks = static_cast<std::uint32_t>(scene.blocks().size());
  if (s.block_selection == "weighted" && blocks > 1) {
    std::vector<double> weights;
    for (const auto& b : scene.blocks()) weights.push_back(b.weight);
    draw.block = static_cast<std::int32_t>(pick(weights, RandomStream(s.seed, Stream::block_shape, index).uniform(0)));
  } else {
    draw.block = static_cast<std::int32_t>(index % blocks);
  }

  const RandomStream rs(s.seed, Stream::release, index);
  const Eigen::Vector2d xy = release_point(r.kind, scene.release_features(), rs);
  const auto hit = ground.height_at(xy.x(), xy.y());
  if (!hit)
    throw core::InputError(release_origin(scene), "release point " + plan_text(scene, xy) + " of realization " +
                                               std::to_string(index) + " is outside the realized terrain");
  dda::Release& rel = draw.release;
  if (r.orientation == "random") {
    rel.orientation = uniform_rotation(rs.uniform(3), rs.uniform(4), rs.uniform(5));
  } else if (r.orientation == "list") {
    // With blocks cycled, B consecutive realizations share a row: every block meets every row.
    const std::vector<Eigen::Quaterniond>& rows = scene.release_orientations();
    const std::uint32_t step = s.block_selection == "cycle" ? index / blocks : index;
    rel.orientation = rows[step % rows.size()];
  } else {
    rel.orientation = zyx_rotation(r.orientation_deg);
  }
  place_block(scene, scene.blocks()[static_cast<std::size_t>(draw.block)], ground, index, xy, hit->z, rel);
  rel.velocity = Vec3(r.velocity[0], r.velocity[1], r.velocity[2]);
  rel.angular_velocity = Vec3(r.angular_velocity[0], r.angular_velocity[1], r.angular_velocity[2]);
  rel.main_direction = scene.main_direction();
  return draw;
}

RealizationResult run_realization(const Scene& scene, std::uint32_t index, const std::atomic<bool>* abandon) {
  const SceneSettings& s = scene.settings();
  const terrain::Surface surface =
      scene.base_surface().realization(s.stochastic.roughness ? std::optional<std::uint32_t>(index) : std::nullopt);
  const ReleaseDraw draw = draw_release(scene, surface, index);
  const dda::Model& model = scene.blocks()[static_cast<std::size_t>(draw.block)].model;
  const dda::Ground ground{&surface, scene.materials()};

  RealizationResult result;
  dda::State state = dda::start(model, draw.release, RandomStream(s.seed, Stream::impact, index));
  dda::Workspace workspace;
  Observer observer(scene, surface, model, index, result);
  const bool observe = observer.active();
  auto rotational = [&model](const dda::State& st, double kinetic) {
    return kinetic - 0.5 * model.mass * st.velocity.head<3>().squaredNorm();
  };
  double kinetic = state.kinetic;
  double max_kinetic = kinetic;
  if (observe) observer.start(state.position, state.velocity.head<3>(), rotational(state, kinetic));
  while (state.end == dda::EndReason::running) {
    const Before before{state.time, state.position, state.velocity.head<3>(), rotational(state, kinetic),
                        state.counters.flight_steps};
    dda::step(model, ground, state, workspace);
    if (abandon != nullptr && (state.counters.steps & 255u) == 0 && abandon->load(std::memory_order_relaxed))
      throw Abandoned{};
    kinetic = state.kinetic;
    if (std::isfinite(kinetic)) max_kinetic = std::max(max_kinetic, kinetic);
    if (observe && state.position.allFinite()) observer.segment(before, state, rotational(state, kinetic));
  }
  dda::Summary summary = dda::summarize(state);

  Record& rec = result.record;
  rec.realization = index;
  rec.block = draw.block;
  rec.end = summary.end;
  rec.stop_class = scene.classify(summary.final_position.head<2>(), summary.end == dda::EndReason::left_terrain);
  rec.impacts = summary.impacts;
  rec.steps = summary.steps;
  rec.time = summary.time;
  rec.release_position = draw.release.position;
  rec.final_position = summary.final_position;
  rec.runout = summary.runout;
  rec.lateral = summary.lateral;
  rec.max_speed = summary.max_speed;
  rec.max_jump_height = summary.max_jump_height;
  rec.max_normal_jump_height = summary.max_normal_jump_height;
  rec.max_kinetic_energy = max_kinetic;
  rec.invariant_violations = summary.counters.energy_violations + summary.counters.depth_violations;
  rec.max_energy_gain = summary.max_energy_gain;
  rec.max_overlap = summary.max_depth;
  rec.energy_removed = summary.energy_removed;
  result.trajectory = std::move(summary.trajectory);
  if (observe) result.cells = observer.cells();
  return result;
}

}  // namespace talus::mc
