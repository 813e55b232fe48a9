#include "calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>

#include "talus/core/error.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/observed.hpp"
#include "talus/io/settings_yaml.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/vector.hpp"
#include "talus/mc/runner.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::calibrate {

namespace {

using core::InputError;

// FNV-1a over the bytes of the values given: a simulation's seed from its identity.
struct Fnv1a {
  std::uint64_t h = 14695981039346656037ull;
  template <class T>
  void value(const T& v) {
    const auto* p = reinterpret_cast<const unsigned char*>(&v);
    for (std::size_t k = 0; k < sizeof v; ++k) h = (h ^ p[k]) * 1099511628211ull;
  }
};

// The scene file with the overrides of the settings' `set` list and, for a group, of its
// own (`group` its index; none for the base scene). Its messages and `origins` name an
// override by the line of its list: "calibrate.yaml:7: set release.height".
mc::SceneSettings read_scene(const Settings& settings, const core::SettingsOrigins& origins,
                             std::optional<std::size_t> group, core::SettingsOrigins* scene_origins = nullptr) {
  const auto given_by = [&](const std::string& key) {
    const std::string where = origins.of(key);
    return where.rfind("--set ", 0) == 0 ? where + ":" : where + ": " + key;
  };
  std::vector<std::string> overrides = settings.set;
  std::vector<std::string> names(overrides.size(), given_by("set"));
  if (group) {
    const std::vector<std::string>& own = settings.groups[*group].set;
    overrides.insert(overrides.end(), own.begin(), own.end());
    names.resize(overrides.size(), given_by("groups[" + std::to_string(*group) + "].set"));
  }
  mc::SceneSettings s;
  core::SettingsOrigins recorded(settings.scene);
  io::read_settings_file(settings.scene, overrides, [&s](core::SettingsVisitor& v) { s.visit(v); }, &recorded, names);
  if (scene_origins != nullptr) *scene_origins = std::move(recorded);
  return s;
}

void set_property(mc::MaterialOverride& o, const std::string& parameter, double value) {
  if (parameter == "restitution_mean") o.restitution_mean = value;
  else if (parameter == "restitution_sd") o.restitution_sd = value;
  else if (parameter == "restitution_scale") o.restitution_scale = value;
  else if (parameter == "friction_angle_mean_deg") o.friction_angle_mean_deg = value;
  else if (parameter == "friction_coefficient_sd") o.friction_coefficient_sd = value;
  else if (parameter == "lateral_tilt_sd_deg") o.lateral_tilt_sd_deg = value;
  else if (parameter == "ploughing") o.ploughing = value;
  else throw std::logic_error("unknown material property " + parameter);
}

// The sample standard deviation of at least 2 values.
double sample_sd(const std::vector<double>& x) {
  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  double s = 0.0;
  for (double v : x) s += (v - mean) * (v - mean);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

std::string point_text(const Eigen::Vector2d& p) {
  return "(" + core::format_number(p.x()) + ", " + core::format_number(p.y()) + ")";
}

// Every observed stop must lie where a simulated block can come to rest: on the terrain.
// A stop beyond it (mapped past the DEM's edge, or given in another frame) can never be
// matched and would pull every distance, and the scale of its variable, off. Stops given
// as runouts without lateral offsets are checked against the terrain's extent along the
// runout direction. `shift` is the terrain's origin shift (input minus local coordinates).
void check_on_terrain(const io::ObservedStops& stops, const Case& c, const terrain::Surface& base,
                      const Eigen::Vector2d& shift, const std::string& file) {
  const geometry::Aabb& b = base.bounds();
  const Eigen::Vector2d left(-c.direction.y(), c.direction.x());
  auto check_point = [&](std::size_t k, const Eigen::Vector2d& p, const std::string& what) {
    const std::string off = mc::observed_stop_off_terrain(base, p, shift);
    if (!off.empty()) throw InputError(file, stops.rows[k] + ": " + what + off);
  };
  if (stops.has_points()) {
    for (std::size_t k = 0; k < stops.points.size(); ++k) {
      const Eigen::Vector2d p(stops.points[k][0], stops.points[k][1]);
      check_point(k, p, "observed stop " + point_text(p));
    }
    return;
  }
  if (!stops.lateral.empty()) {
    for (std::size_t k = 0; k < stops.runout.size(); ++k) {
      const Eigen::Vector2d p = c.origin + stops.runout[k] * c.direction + stops.lateral[k] * left;
      check_point(k, p, "the observed stop at runout " + core::format_number(stops.runout[k]) + " m, lateral " +
                            core::format_number(stops.lateral[k]) + " m " + point_text(p));
    }
    return;
  }
  // Runouts alone: the terrain's extent along the runout direction, from the origin.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const double x : {b.lo.x(), b.hi.x()})
    for (const double y : {b.lo.y(), b.hi.y()}) {
      const double along = c.direction.dot(Eigen::Vector2d(x, y) + shift - c.origin);
      lo = std::min(lo, along);
      hi = std::max(hi, along);
    }
  for (std::size_t k = 0; k < stops.runout.size(); ++k)
    if (!(stops.runout[k] >= lo && stops.runout[k] <= hi))
      throw InputError(file, stops.rows[k] + ": observed runout " + core::format_number(stops.runout[k]) +
                                 " m lies beyond the terrain, which spans runouts [" + core::format_number(lo) + ", " +
                                 core::format_number(hi) +
                                 "] m from the origin along the runout direction: no simulated block can stop there");
}

const char* unit_of(SummaryVariable v) { return v == SummaryVariable::speed ? "m/s" : "m"; }

// A published summary, checked: each statistic is given what it needs and nothing it does
// not take, with values in range. `key` ("groups[0].summaries[2]") names it in messages,
// at the file and line (or --set key) where it was given.
CaseSummary read_summary(const Summary& s, const std::string& key, const core::SettingsOrigins& origins,
                         std::int64_t realizations) {
  using Kind = stats::SummaryTarget::Kind;
  const auto fail = [&](const std::string& field, const std::string& what) {
    throw InputError(origins.of(field.empty() ? key : key + "." + field), key + ": " + what);
  };
  if (s.statistic.empty()) fail("statistic", "no statistic given (share_above, quantile, max or min)");
  const auto needs = [&](const std::optional<double>& x, const char* field, const char* meaning) {
    if (!x) fail("", s.statistic + " needs " + field + " (" + meaning + ")");
    if (!std::isfinite(*x)) fail(field, std::string(field) + " must be finite");
  };
  const auto refuses = [&](const std::optional<double>& x, const char* field) {
    if (x) fail(field, s.statistic + " takes no " + field);
  };
  const auto whole = [&](double x, const char* field, double lo) {
    if (!(x >= lo && x == std::floor(x) && x <= 1e9))
      fail(field, std::string(field) + " must be a whole number >= " + core::format_number(lo) + ", got " +
                      core::format_number(x));
  };
  CaseSummary out;
  out.variable = s.variable == "lateral" ? SummaryVariable::lateral
                 : s.variable == "speed" ? SummaryVariable::speed
                 : s.variable == "jump"  ? SummaryVariable::jump
                                         : SummaryVariable::runout;
  const std::string unit = unit_of(out.variable);
  stats::SummaryTarget& t = out.target;
  if (s.statistic == "share_above") {
    t.kind = Kind::share_above;
    needs(s.threshold, "threshold", "the value blocks above count");
    refuses(s.p, "p");
    t.threshold = *s.threshold;
    if (s.count) {
      // A count of n: its binomial standard error, at (count + 1)/(n + 2) so that a count
      // of 0 or n is not taken as exact.
      if (s.value || s.sd) fail(s.value ? "value" : "sd", "give count and n, or value and sd, not both");
      needs(s.n, "n", "the blocks counted");
      whole(*s.n, "n", 1.0);
      whole(*s.count, "count", 0.0);
      if (*s.count > *s.n) fail("count", "count " + core::format_number(*s.count) + " exceeds n " + core::format_number(*s.n));
      t.value = *s.count / *s.n;
      const double shrunk = (*s.count + 1.0) / (*s.n + 2.0);
      t.sd = std::sqrt(shrunk * (1.0 - shrunk) / *s.n);
    } else {
      if (!s.value) fail("", "share_above needs value and sd (a share in [0, 1] and its standard error), or count and n");
      refuses(s.n, "n (it goes with count)");
      needs(s.value, "value", "the share, in [0, 1]");
      if (!(*s.value >= 0.0 && *s.value <= 1.0))
        fail("value", "a share must be in [0, 1], got " + core::format_number(*s.value) + " (give 0.581, not 58.1 %)");
      needs(s.sd, "sd", "the share's standard error");
      t.value = *s.value;
      t.sd = *s.sd;
    }
    out.label = "share_above " + s.variable + " > " + core::format_number(t.threshold) + " " + unit;
  } else {
    refuses(s.threshold, "threshold");
    refuses(s.count, "count");
    needs(s.value, "value", ("the published value, " + unit).c_str());
    needs(s.sd, "sd", ("its standard uncertainty, " + unit).c_str());
    t.value = *s.value;
    t.sd = *s.sd;
    if (s.statistic == "quantile") {
      t.kind = Kind::quantile;
      refuses(s.n, "n");
      needs(s.p, "p", "the quantile's probability, in (0, 1)");
      if (!(*s.p > 0.0 && *s.p < 1.0)) fail("p", "p must be in (0, 1), got " + core::format_number(*s.p));
      t.p = *s.p;
      out.label = "quantile " + core::format_number(t.p) + " of " + s.variable + " (" + unit + ")";
    } else {
      t.kind = s.statistic == "max" ? Kind::max : Kind::min;
      refuses(s.p, "p");
      needs(s.n, "n", "the blocks the extreme is over");
      whole(*s.n, "n", 1.0);
      t.n = *s.n;
      // The extreme of n is compared with the simulation's distribution of it (its
      // quantile 0.5^(1/n) and the spread about it), which m < n realizations cannot reach.
      if (static_cast<double>(realizations) < t.n)
        throw InputError(origins.of({"realizations", key + ".n"}),
                         key + ": the " + s.statistic + " of n = " + core::format_number(t.n) +
                             " blocks needs at least as many realizations per simulation (realizations is " +
                             std::to_string(realizations) + ")");
      out.label = s.statistic + " " + s.variable + " of " + core::format_number(t.n) + " (" + unit + ")";
    }
  }
  if (!(t.sd > 0.0)) fail("sd", "sd must be > 0 (the value's standard uncertainty), got " + core::format_number(t.sd));
  return out;
}

}  // namespace

Problem::Problem(const Settings& settings, const core::SettingsOrigins& origins, unsigned threads)
    : settings_(settings), threads_(threads) {
  const Settings& s = settings_;
  const std::string& source = origins.source();
  if (s.scene.empty()) throw InputError(origins.of("scene"), "scene: no scene file given");
  if (s.groups.empty()) throw InputError(origins.of("groups"), "groups: at least one observed case is needed");
  if (s.parameters.empty())
    throw InputError(origins.of("parameters"), "parameters: at least one fitted parameter is needed");
  if (s.realizations < 2) throw InputError(origins.of("realizations"), "realizations must be at least 2");
  if (s.particles < 2) throw InputError(origins.of("particles"), "particles must be at least 2");
  if (s.generations < 1) throw InputError(origins.of("generations"), "generations must be at least 1");
  if (!(s.quantile > 0.0 && s.quantile < 1.0)) throw InputError(origins.of("quantile"), "quantile must be in (0, 1)");
  if (!(s.min_acceptance >= 0.0 && s.min_acceptance < 1.0))
    throw InputError(origins.of("min_acceptance"), "min_acceptance must be in [0, 1)");
  if (s.max_simulations < 0) throw InputError(origins.of("max_simulations"), "max_simulations must be >= 0");
  // Generation 0 (the prior) takes `particles` simulations and generation 1 at least as
  // many: a smaller budget could only return the prior.
  if (s.max_simulations > 0 && s.max_simulations < 2 * s.particles)
    throw InputError(origins.of({"max_simulations", "particles"}),
                     "max_simulations " + std::to_string(s.max_simulations) + " is below 2 x particles (" +
                         std::to_string(2 * s.particles) +
                         "): generation 0 (the prior) takes particles "
                         "simulations and generation 1 at least as many, so no posterior could be computed "
                         "(0 = no limit)");
  if (s.predictive_draws < 2) throw InputError(origins.of("predictive_draws"), "predictive_draws must be at least 2");
  variables_ = s.variables == "runout_lateral" ? std::vector<std::string>{"runout", "lateral"}
                                              : std::vector<std::string>{s.variables};

  base_scene_ = read_scene(s, origins, std::nullopt);
  std::set<std::string> labels;
  for (std::size_t k = 0; k < s.parameters.size(); ++k) {
    const FittedParameter& p = s.parameters[k];
    const std::string item = "parameters[" + std::to_string(k) + "]";
    const std::string where = item + " (" + p.label() + "): ";
    const auto key = [&](const char* name) { return item + "." + name; };
    if (p.is_roughness() && !p.material.empty())
      throw InputError(origins.of({key("material"), key("parameter")}),
                       where + "roughness_sigma is the terrain's: name no material");
    if (!p.is_roughness() && p.material.empty())
      throw InputError(origins.of(key("material")), where + "no material named");
    if (!labels.insert(p.label()).second)
      throw InputError(origins.of({key("material"), key("parameter")}), where + "fitted twice");
    if (!(std::isfinite(p.min) && std::isfinite(p.max) && p.min < p.max))
      throw InputError(origins.of({key("min"), key("max")}), where + "the prior needs finite min < max (both given)");
    if (p.prior == "normal" && !(p.sd > 0.0 && std::isfinite(p.sd) && std::isfinite(p.mean)))
      throw InputError(origins.of({key("sd"), key("mean"), key("prior")}),
                       where + "a normal prior needs a finite mean and sd > 0");
    if (p.prior == "uniform" && (!std::isnan(p.mean) || !std::isnan(p.sd)))
      throw InputError(origins.of({key(std::isnan(p.mean) ? "sd" : "mean"), key("prior")}),
                       where + "a uniform prior takes no mean or sd (prior: normal uses them)");
    if (p.prior == "normal") {
      // Drawn by rejection inside [min, max]: a prior with almost none of its mass there
      // says something else than was meant.
      const auto cdf = [&](double x) { return 0.5 * std::erfc(-(x - p.mean) / (p.sd * std::sqrt(2.0))); };
      const double mass = cdf(p.max) - cdf(p.min);
      if (!(mass >= 1e-3))
        throw InputError(origins.of({key("mean"), key("sd"), key("min"), key("max")}),
                         where + "a normal prior of mean " + core::format_number(p.mean) + " and sd " +
                             core::format_number(p.sd) + " has " + core::format_number(mass) + " of its mass in [" +
                             core::format_number(p.min) + ", " + core::format_number(p.max) +
                             "] (at least 0.001 needed)");
    }
    // The ranges the material is read with (terrain-gen, scene overrides).
    const terrain::Material::Ranges r = terrain::Material::ranges();
    const core::Range sigma_range = core::Range::closed(0.0, 100.0);  // the terrain file's
    const core::Range& range = p.is_roughness()                           ? sigma_range
                               : p.parameter == "restitution_mean"          ? r.restitution_mean
                               : p.parameter == "restitution_sd"          ? r.restitution_sd
                               : p.parameter == "restitution_scale"       ? r.restitution_scale
                               : p.parameter == "friction_angle_mean_deg" ? r.friction_angle_mean_deg
                               : p.parameter == "friction_coefficient_sd" ? r.friction_coefficient_sd
                               : p.parameter == "ploughing"               ? r.ploughing
                                                                          : r.lateral_tilt_sd_deg;
    if (!range.contains(p.min) || !range.contains(p.max))
      throw InputError(origins.of({key("min"), key("max")}), where + "the prior [" + core::format_number(p.min) + ", " +
                                                                 core::format_number(p.max) +
                                                                 "] leaves the property's range " + range.text(""));
    priors_.push_back(stats::Prior{p.prior, p.min, p.max, p.mean, p.sd});
  }

  for (std::size_t g = 0; g < s.groups.size(); ++g) {
    const Group& group = s.groups[g];
    Case c;
    c.name = group.name.empty() ? "group " + std::to_string(g) : group.name;
    const std::string item = "groups[" + std::to_string(g) + "]";
    const std::string where = item + " (" + c.name + "): ";
    c.scene = read_scene(s, origins, g, &c.origins);
    if (c.scene.terrain.empty()) throw InputError(c.origins.of("terrain"), "no terrain file given (key 'terrain')");
    if (c.scene.block_file.empty())
      throw InputError(c.origins.of("block_file"), "no block file given (key 'block_file')");
    auto& terrain = terrains_[c.scene.terrain];
    if (!terrain) terrain = std::make_unique<terrain::Terrain>(io::read_terrain_file(c.scene.terrain));
    auto& library = libraries_[c.scene.block_file];
    if (!library) library = std::make_unique<std::vector<block::Block>>(io::read_block_file(c.scene.block_file));
    c.terrain = terrain.get();
    c.library = library.get();
    c.vectors = io::read_scene_vectors(c.scene, *terrain);
    // Validates the case as dda-run would (names, points, the fitted materials), and its
    // releases at the scene's own seed: a block released into the ground is refused now,
    // not hours into the calibration.
    mc::SceneSettings probe = c.scene;
    probe.realizations = s.realizations;
    const mc::Scene scene = mc::Scene::build(probe, *terrain, *library, c.origins, c.vectors);
    std::vector<std::uint32_t> first(static_cast<std::size_t>(s.realizations));
    std::iota(first.begin(), first.end(), 0u);
    mc::check_releases(scene, first, threads_);
    for (std::size_t k = 0; k < s.parameters.size(); ++k) {
      const FittedParameter& p = s.parameters[k];
      if (p.is_roughness()) continue;
      bool found = false;
      for (const auto& m : scene.materials()) found = found || m.name == p.material;
      if (!found)
        throw InputError(origins.of("parameters[" + std::to_string(k) + "].material"),
                         where + "material '" + p.material + "' is not in the terrain file " + c.scene.terrain);
    }
    // Where runout is measured from, in the terrain's input coordinates.
    const Eigen::Vector3d to_input = terrain->origin_shift - scene.frame_shift();
    if (group.origin.empty()) {
      if (c.scene.release.points.empty())
        throw InputError(origins.of(item + ".origin"),
                         where + "origin: give it (the release comes from a file, not a point)");
      c.origin = Eigen::Vector2d(c.scene.release.points[0][0], c.scene.release.points[0][1]) + to_input.head<2>();
    } else if (group.origin.size() != 2 || !std::isfinite(group.origin[0]) || !std::isfinite(group.origin[1])) {
      throw InputError(origins.of(item + ".origin"), where + "origin must be [x, y] (m)");
    } else {
      c.origin = Eigen::Vector2d(group.origin[0], group.origin[1]);
    }
    const double azimuth =
        (group.main_direction_deg ? *group.main_direction_deg : c.scene.release.main_direction_deg) * M_PI / 180.0;
    if (!std::isfinite(azimuth))
      throw InputError(origins.of(item + ".main_direction_deg"), where + "main_direction_deg must be finite");
    c.direction = Eigen::Vector2d(std::cos(azimuth), std::sin(azimuth));

    if (!group.summaries.empty()) {
      if (!group.observed.empty())
        throw InputError(origins.of(item + ".observed"),
                         where + "give observed stops or summaries, not both (they are compared differently)");
      for (std::size_t k = 0; k < group.summaries.size(); ++k)
        c.summaries.push_back(
            read_summary(group.summaries[k], item + ".summaries[" + std::to_string(k) + "]", origins, s.realizations));
      cases_.push_back(std::move(c));
      continue;
    }
    if (group.observed.empty())
      throw InputError(origins.of(item + ".observed"),
                       where + "observed: no file of observed stops given (nor summaries)");
    const io::ObservedStops stops =
        io::read_observed_stops(group.observed, group.layer, terrain->crs_wkt, "groups[" + std::to_string(g) + "].observed");
    check_on_terrain(stops, c, scene.base_surface(), terrain->origin_shift.head<2>(), group.observed);
    if (stops.has_points()) {
      for (const auto& p : stops.points) c.observed.push_back(compared(c, Eigen::Vector2d(p[0], p[1]) - c.origin));
    } else {
      if (s.variables == "distance")
        throw InputError(group.observed, "gives runouts, not stop points: variables distance needs x, y of each stop");
      if (variables_.size() == 2 && stops.lateral.empty())
        throw InputError(group.observed, "gives runouts without lateral offsets: set variables: runout, or add a "
                                         "lateral column");
      for (std::size_t k = 0; k < stops.runout.size(); ++k)
        c.observed.push_back(variables_.size() == 1 ? std::vector<double>{stops.runout[k]}
                                                    : std::vector<double>{stops.runout[k], stops.lateral[k]});
    }
    cases_.push_back(std::move(c));
  }

  // The energy distance of stops and the discrepancy of summaries are on different
  // scales: averaged together, one kind would outweigh the other arbitrarily.
  for (std::size_t g = 1; g < cases_.size(); ++g)
    if (cases_[g].has_summaries() != cases_[0].has_summaries())
      throw InputError(origins.of("groups[" + std::to_string(g) + "]." +
                                  (cases_[g].has_summaries() ? "summaries" : "observed")),
                       "groups[" + std::to_string(g) + "] (" + cases_[g].name + "): the cases must all give observed "
                       "stops or all give summaries (the two distances are on different scales)");
  if (cases_[0].has_summaries()) return;

  // Each variable is compared in units of its observed spread over every case: the
  // sample standard deviation, undefined for a single stop and no scale when the stops
  // do not spread. No length stands in for it: it would weigh the variables arbitrarily.
  const std::string observed_source = cases_.size() == 1 ? s.groups[0].observed : source;
  std::size_t stops = 0;
  for (const Case& c : cases_) stops += c.observed.size();
  if (stops < 2)
    throw InputError(observed_source, "holds a single observed stop: at least 2 are needed (over all groups), since "
                                      "each compared variable is measured in units of the observed stops' standard "
                                      "deviation, undefined for one stop");
  for (std::size_t v = 0; v < variables_.size(); ++v) {
    std::vector<double> all;
    for (const Case& c : cases_)
      for (const auto& o : c.observed) all.push_back(o[v]);
    const double sd = sample_sd(all);
    if (!(sd > 1e-6))
      throw InputError(observed_source, "the observed " + std::string(variables_[v] == "runout"     ? "runouts"
                                                                      : variables_[v] == "distance" ? "distances"
                                                                                                    : "lateral offsets") +
                                            " do not spread (standard deviation " + core::format_number(sd) +
                                            " m): the distance measures each variable in units of that spread" +
                                            (variables_[v] == "lateral" ? "; compare runouts alone (variables: runout)" : ""));
    scale_.push_back(sd);
  }
}

mc::SceneSettings Problem::with_parameters(const mc::SceneSettings& base, const std::vector<double>& theta) const {
  mc::SceneSettings s = base;
  for (std::size_t k = 0; k < settings_.parameters.size(); ++k) {
    const FittedParameter& p = settings_.parameters[k];
    if (p.is_roughness()) continue;  // the terrain's, set in simulate()
    auto it = std::find_if(s.materials.begin(), s.materials.end(), [&](const auto& o) { return o.name == p.material; });
    if (it == s.materials.end()) {
      s.materials.emplace_back();
      s.materials.back().name = p.material;
      it = s.materials.end() - 1;
    }
    set_property(*it, p.parameter, theta[k]);
  }
  return s;
}

std::vector<double> Problem::compared(const Case& c, const Eigen::Vector2d& d) const {
  if (settings_.variables == "distance") return {d.norm()};
  const double runout = c.direction.dot(d);
  if (settings_.variables == "runout") return {runout};
  return {runout, c.direction.x() * d.y() - c.direction.y() * d.x()};
}

Simulated Problem::simulate(const std::vector<double>& theta, std::size_t c, std::uint64_t draw) const {
  const Case& cs = cases_[c];
  mc::SceneSettings s = with_parameters(cs.scene, theta);
  Fnv1a seed;
  seed.value(settings_.seed);
  seed.value(static_cast<std::uint64_t>(c));
  seed.value(draw);
  for (double t : theta) seed.value(t);
  s.seed = seed.h;
  s.realizations = settings_.realizations;
  s.outputs.hazard_cell_size = 0.0;
  s.engine.trajectory_interval = 0.0;
  terrain::Terrain ground = *cs.terrain;
  for (std::size_t k = 0; k < settings_.parameters.size(); ++k)
    if (settings_.parameters[k].is_roughness()) ground.roughness.sigma = theta[k];
  const mc::Scene scene = mc::Scene::build(s, std::move(ground), *cs.library, cs.origins, cs.vectors);
  std::vector<std::uint32_t> indices(static_cast<std::size_t>(s.realizations));
  std::iota(indices.begin(), indices.end(), 0u);
  std::vector<mc::Record> records(indices.size());
  mc::run_realizations(scene, indices, threads_,
                       [&](mc::RealizationResult&& r) { records[r.record.realization] = r.record; });
  Simulated out;
  const Eigen::Vector2d shift = cs.terrain->origin_shift.head<2>();
  for (const mc::Record& r : records) {
    if (dda::is_failure(r.end)) {
      ++out.failures;
      continue;
    }
    // Summaries are of every block, wherever it ended: one that left the terrain is
    // counted at its exit (a lower bound of its runout, past any line it crossed), so a
    // parameter set that sends blocks off the terrain is not rewarded by their absence.
    const Eigen::Vector2d d = r.final_position.head<2>() + shift - cs.origin;
    out.blocks[0].push_back(cs.direction.dot(d));
    out.blocks[1].push_back(cs.direction.x() * d.y() - cs.direction.y() * d.x());
    out.blocks[2].push_back(r.max_speed);
    out.blocks[3].push_back(r.max_jump_height);
    // Stops are compared so too: every observed block stopped (unstopped: drop leaves
    // out those that did not).
    if (r.end != dda::EndReason::rest) {
      ++out.not_at_rest;
      if (settings_.unstopped == "drop") continue;
    } else {
      ++out.at_rest;
    }
    out.values.push_back(compared(cs, d));
  }
  realizations_run_ += static_cast<std::int64_t>(records.size());
  failures_ += out.failures;
  not_at_rest_ += out.not_at_rest;
  return out;
}

std::vector<stats::SummaryComparison> Problem::compare(std::size_t c, const Simulated& sim) const {
  std::vector<stats::SummaryComparison> out;
  for (const CaseSummary& summary : cases_[c].summaries)
    out.push_back(stats::compare_summary(stats::Sample(sim.blocks[static_cast<std::size_t>(summary.variable)]),
                                         summary.target));
  return out;
}

double Problem::distance(const std::vector<double>& theta) const {
  double total = 0.0;
  for (std::size_t c = 0; c < cases_.size(); ++c) {
    const Simulated sim = simulate(theta, c);
    if (cases_[c].has_summaries()) {
      if (sim.blocks[0].size() < 2) return std::numeric_limits<double>::infinity();
      total += stats::summary_distance(compare(c, sim));
      continue;
    }
    // Fewer than 2 at rest: the scene's blocks do not stop, whatever is compared.
    if (sim.at_rest < 2) return std::numeric_limits<double>::infinity();
    total += stats::energy_distance(sim.values, cases_[c].observed, scale_);
  }
  return total / static_cast<double>(cases_.size());
}

std::vector<ParameterSummary> summarize(const stats::AbcGeneration& g) {
  std::vector<ParameterSummary> out;
  const std::size_t dim = g.theta.empty() ? 0 : g.theta[0].size();
  for (std::size_t k = 0; k < dim; ++k) {
    std::vector<double> x;
    for (const auto& t : g.theta) x.push_back(t[k]);
    ParameterSummary s;
    for (std::size_t i = 0; i < x.size(); ++i) s.mean += g.weight[i] * x[i];
    double var = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) var += g.weight[i] * (x[i] - s.mean) * (x[i] - s.mean);
    s.sd = std::sqrt(var);
    s.p05 = stats::weighted_quantile(x, g.weight, 0.05);
    s.p50 = stats::weighted_quantile(x, g.weight, 0.50);
    s.p95 = stats::weighted_quantile(x, g.weight, 0.95);
    out.push_back(s);
  }
  return out;
}

}  // namespace talus::calibrate
