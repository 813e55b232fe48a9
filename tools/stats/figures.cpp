// SPDX-License-Identifier: MIT
#include "figures.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include "talus/core/threads.hpp"
#include "talus/plot/figure.hpp"
#include "talus/stats/sample.hpp"

namespace talus::stats_tool {

namespace {

namespace fs = std::filesystem;
using plot::Axes;
using plot::Figure;
using plot::LineStyle;
using plot::Rgba;

std::string format(const char* fmt, double v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string safe(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
  return out;
}

std::string label_of(const Series& s) { return s.block == "all" ? s.run : s.run + "/" + s.block; }

std::string unit_label(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " (" + unit + ")";
}

const VariableSummary* variable(const Series& s, const std::string& name) {
  for (const auto& v : s.variables)
    if (v.name == name) return &v;
  return nullptr;
}

/// Panels of the series: one per run (its blocks, or the run itself), then all runs
/// together when there are several.
struct Panel {
  std::string title;
  std::vector<const Series*> members;
};

std::vector<Panel> panels_of(const Analysis& a) {
  std::vector<Panel> panels;
  std::set<std::size_t> runs;
  for (const auto& s : a.series) runs.insert(s.run_index);
  for (std::size_t r : runs) {
    Panel p;
    std::vector<const Series*> mine;
    for (const auto& s : a.series)
      if (s.run_index == r) mine.push_back(&s);
    for (const Series* s : mine)
      if (s->block != "all") p.members.push_back(s);
    if (p.members.empty()) p.members = mine;
    p.title = mine.front()->run;
    panels.push_back(std::move(p));
  }
  if (runs.size() > 1) {
    Panel all{"all runs", {}};
    for (const auto& s : a.series)
      if (s.block == "all") all.members.push_back(&s);
    panels.push_back(std::move(all));
  }
  return panels;
}

/// A grid of `rows` × `cols` panels placed by margins in inches, fixed for each kind of
/// figure and wide enough for its tick labels, axis labels, titles and suptitle.
std::vector<Axes*> grid(Figure& fig, std::size_t count, std::size_t rows, std::size_t cols, double left = 0.7,
                        double right = 0.2, double bottom = 0.55, double top = 0.7, double wgap = 0.9,
                        double hgap = 0.95) {
  const double w = (fig.width() - left - right - static_cast<double>(cols - 1) * wgap) / static_cast<double>(cols);
  const double h = (fig.height() - top - bottom - static_cast<double>(rows - 1) * hgap) / static_cast<double>(rows);
  std::vector<Axes*> axes;
  for (std::size_t k = 0; k < count; ++k) {
    const double c = static_cast<double>(k % cols), r = static_cast<double>(k / cols);
    axes.push_back(&fig.add_axes(left + c * (w + wgap), top + r * (h + hgap), w, h));
  }
  return axes;
}

/// Panels of 4.6 × 3.6 in, three a row, with `extra` inches right of each (legend or
/// colour bar).
std::pair<Figure, std::vector<Axes*>> panel_figure(std::size_t count, double extra = 0.0) {
  const std::size_t cols = std::min<std::size_t>(count, 3), rows = (count + cols - 1) / cols;
  Figure fig(4.6 * static_cast<double>(cols), 3.6 * static_cast<double>(rows));
  auto axes = grid(fig, count, rows, cols, 0.7, 0.2 + extra, 0.55, 0.7, 0.9 + extra);
  return {std::move(fig), std::move(axes)};
}

/// Step ECDF of a variable's sorted values with its DKW band F ± ε clipped to [0, 1].
bool ecdf_with_band(Axes& ax, const VariableSummary& v, const std::string& label, Rgba color) {
  if (!v.sample || v.sample->empty()) return false;
  const auto& x = v.sample->sorted();
  const double n = static_cast<double>(x.size());
  std::vector<double> xs = {x.front()}, f = {0.0}, lo = {0.0}, hi = {std::min(v.dkw_epsilon, 1.0)};
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double fi = static_cast<double>(i + 1) / n;
    xs.push_back(x[i]), f.push_back(fi);
    lo.push_back(std::clamp(fi - v.dkw_epsilon, 0.0, 1.0)), hi.push_back(std::clamp(fi + v.dkw_epsilon, 0.0, 1.0));
  }
  std::string text = label + " (n=" + std::to_string(x.size());
  if (v.censored && *v.censored) {
    char share[16];
    std::snprintf(share, sizeof share, "%.0f %%", 100.0 * *v.censored_share());
    text += ", " + std::to_string(*v.censored) + " censored, " + share + ")";
  } else {
    text += ")";
  }
  ax.step_band(xs, lo, hi, color.with_alpha(0.15));
  ax.step(xs, f, {color, 1.3, plot::Dash::solid}, text);
  return true;
}

void cdf_axes(Axes& ax, const std::string& title) {
  ax.set_title(title);
  ax.set_ylabel("F(x)");
  ax.set_ylim(0.0, 1.0);
  ax.grid();
}

struct Job {
  std::string stem;
  std::function<std::optional<Figure>()> draw;  // nothing when there is nothing to draw
};

std::optional<Figure> cdf_figure(const Analysis& a, const std::string& name, double confidence) {
  const auto panels = panels_of(a);
  auto [fig, axes] = panel_figure(panels.size());
  bool drawn = false;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    Axes& ax = *axes[p];
    bool mine = false;
    for (std::size_t k = 0; k < panels[p].members.size(); ++k)
      if (const auto* v = variable(*panels[p].members[k], name)) {
        mine |= ecdf_with_band(ax, *v, label_of(*panels[p].members[k]), plot::cycle_color(k));
        ax.set_xlabel(unit_label(name, v->unit));
      }
    cdf_axes(ax, panels[p].title);
    if (mine) ax.legend(plot::Place::lower_right, plot::kXSmall);
    drawn |= mine;
  }
  fig.suptitle(name + ": empirical CDF, " + format("%g", 100 * confidence) + " % DKW band");
  if (!drawn) return std::nullopt;
  return std::move(fig);
}

std::optional<Figure> convergence_figure(const Analysis& a, const std::string& name, double target) {
  static constexpr plot::Dash kStyles[] = {plot::Dash::solid, plot::Dash::dashed, plot::Dash::dotted,
                                           plot::Dash::dash_dot};
  const auto panels = panels_of(a);
  auto [fig, axes] = panel_figure(panels.size(), 1.1);
  bool drawn = false;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    Axes& ax = *axes[p];
    ax.set_scale(plot::Scale::log, plot::Scale::log);
    // The legend names the series by colour and the statistics by dash once each.
    std::vector<std::pair<std::string, plot::Dash>> statistics;
    for (std::size_t k = 0; k < panels[p].members.size(); ++k) {
      const auto* v = variable(*panels[p].members[k], name);
      if (!v) continue;
      bool mine = false;
      for (std::size_t m = 0; m < v->convergence.size(); ++m) {
        std::vector<double> n, err;
        for (const auto& point : v->convergence[m].curve)
          if (std::isfinite(point.relative_error) && point.relative_error > 0.0)
            n.push_back(static_cast<double>(point.n)), err.push_back(point.relative_error);
        if (n.empty()) continue;
        const plot::Dash dash = kStyles[m % 4];
        ax.line(std::move(n), std::move(err), {plot::cycle_color(k), 1.2, dash});
        const std::string stat = v->convergence[m].statistic.name();
        if (std::none_of(statistics.begin(), statistics.end(), [&](const auto& s) { return s.first == stat; }))
          statistics.emplace_back(stat, dash);
        mine = true;
      }
      if (mine) ax.legend_entry({plot::cycle_color(k), 1.2, plot::Dash::solid}, label_of(*panels[p].members[k]));
      drawn |= mine;
    }
    for (const auto& [stat, dash] : statistics) ax.legend_entry({Rgba{0.3, 0.3, 0.3, 1.0}, 1.2, dash}, stat);
    ax.hline(target, {Rgba{}, 0.8, plot::Dash::solid});
    ax.set_title(panels[p].title);
    ax.set_xlabel("realizations");
    ax.set_ylabel("relative error");
    ax.grid();
    if (!statistics.empty()) ax.legend(plot::Place::outside_right, plot::kXXSmall);
  }
  fig.suptitle(name + ": Monte-Carlo relative error (target " + format("%g", 100 * target) + " %)");
  if (!drawn) return std::nullopt;
  return std::move(fig);
}

std::optional<Figure> barrier_figure(const Analysis& a, const std::string& barrier) {
  const auto panels = panels_of(a);
  Figure fig(10.0, 3.4 * static_cast<double>(panels.size()));
  const auto axes = grid(fig, 2 * panels.size(), panels.size(), 2);
  bool drawn = false;
  for (std::size_t p = 0; p < panels.size(); ++p)
    for (std::size_t c = 0; c < 2; ++c) {
      const std::string what = c == 0 ? "passing_height" : "kinetic_energy";
      Axes& ax = *axes[2 * p + c];
      bool mine = false;
      for (std::size_t k = 0; k < panels[p].members.size(); ++k)
        if (const auto* v = variable(*panels[p].members[k], barrier + "." + what)) {
          mine |= ecdf_with_band(ax, *v, label_of(*panels[p].members[k]), plot::cycle_color(k));
          ax.set_xlabel(unit_label(c == 0 ? "passing height" : "kinetic energy", v->unit));
        }
      cdf_axes(ax, panels[p].title);
      if (mine) ax.legend(plot::Place::lower_right, plot::kXXSmall);
      drawn |= mine;
    }
  fig.suptitle("barrier " + barrier + ": blocks crossing it (first crossing)");
  if (!drawn) return std::nullopt;
  return fig;
}

void draw_barriers(Axes& ax, const PlanView& plan) {
  const Rgba crimson = Rgba::hex(0xdc143c);
  for (std::size_t k = 0; k < plan.barrier_lines.size(); ++k) {
    const auto& line = plan.barrier_lines[k];
    if (line.empty()) continue;
    std::vector<double> x, y;
    for (const auto& p : line) x.push_back(p[0]), y.push_back(p[1]);
    ax.line(x, y, {crimson, 2.0, plot::Dash::solid});
    if (k < plan.barrier_names.size()) ax.text(line.front()[0], line.front()[1], plan.barrier_names[k], crimson, plot::kSmall);
  }
}

std::optional<Figure> plan_figure(const Analysis& a, const std::string& run_name, std::size_t r) {
  const PlanView& plan = a.runs[r].plan;
  Figure fig(9.0, 6.0);
  Axes& ax = *grid(fig, 1, 1, 1, 0.7, 0.3, 0.55, 0.45).front();
  if (!plan.terrain_triangles.empty()) {
    const auto& map = plot::Colormap::named("terrain");
    ax.contours(plan.terrain_x, plan.terrain_y, plan.terrain_z, plan.terrain_triangles, 20, map, 0.7);
    const auto [lo, hi] = std::minmax_element(plan.terrain_z.begin(), plan.terrain_z.end());
    ax.colorbar(map, *lo, *hi, "ground elevation (m)");
  }
  // Trajectories: one polyline per realization.
  std::vector<double> x, y;
  for (std::size_t i = 0; i < plan.trajectory_position.size(); ++i) {
    if (i > 0 && plan.trajectory_realization[i] != plan.trajectory_realization[i - 1])
      x.push_back(std::nan("")), y.push_back(std::nan(""));
    x.push_back(plan.trajectory_position[i][0]), y.push_back(plan.trajectory_position[i][1]);
  }
  if (!x.empty()) ax.line(std::move(x), std::move(y), {Rgba{0.0, 0.0, 0.5, 0.5}, 0.5, plot::Dash::solid});
  std::vector<const Series*> mine, blocks;
  for (const auto& s : a.series)
    if (s.run_index == r) (s.block == "all" ? mine : blocks).push_back(&s);
  const auto& shown = blocks.empty() ? mine : blocks;
  bool labelled = false;
  for (std::size_t k = 0; k < shown.size(); ++k) {
    const auto& p = shown[k]->stop_points;
    if (p.empty()) continue;
    std::vector<double> px, py;
    for (const auto& q : p) px.push_back(q[0]), py.push_back(q[1]);
    ax.markers(std::move(px), std::move(py), plot::cycle_color(k), std::sqrt(6.0) + 1.0, "stop: " + label_of(*shown[k]));
    labelled = true;
  }
  draw_barriers(ax, plan);
  ax.set_equal_aspect();
  ax.set_xlabel("x (m)");
  ax.set_ylabel("y (m)");
  ax.set_title(run_name + ": trajectories and stop points");
  if (labelled) ax.legend(plot::Place::upper_right, plot::kXSmall);
  return fig;
}

std::optional<Figure> hazard_figure(const Analysis& a, const std::string& run_name, std::size_t r) {
  const auto& layers = a.runs[r].hazard->layers;
  auto [fig, axes] = panel_figure(layers.size(), 0.5);
  for (std::size_t k = 0; k < layers.size(); ++k) {
    const HazardLayer& layer = layers[k];
    std::string title = layer.title;
    // Viridis for reach and counts, magma for energies, cividis for heights, plasma for speeds.
    const auto starts = [&](const char* prefix) { return layer.name.rfind(prefix, 0) == 0; };
    const auto& map = plot::Colormap::named(starts("energy_")   ? "magma"
                                            : starts("height_") ? "cividis"
                                            : starts("speed_")  ? "plasma"
                                                                : "viridis");
    const std::string& u = layer.band.unit;
    const std::string unit = u == "1" ? "-" : u == "count" ? "" : u;
    if (!unit.empty()) title += " (" + unit + ")";
    // Counts and probabilities: cells never reached are left blank, not coloured as zero.
    const bool counts = layer.name == "reach_probability" || layer.name == "passage_count" ||
                        layer.name == "deposition_count";
    std::vector<double> shown = layer.grid.z;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double& v : shown) {
      if (counts && v == 0.0) v = std::nan("");
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
    if (!(lo <= hi)) lo = 0.0, hi = 1.0;
    const auto& spec = layer.grid.spec;
    Axes& ax = *axes[k];
    ax.image(shown, static_cast<std::size_t>(spec.nx), static_cast<std::size_t>(spec.ny), spec.x0, spec.y0, spec.dx,
             spec.dy, map, lo, hi);
    draw_barriers(ax, a.runs[r].plan);
    ax.colorbar(map, lo, hi, "");
    ax.set_title(title, plot::kSmall);
    ax.set_equal_aspect();
  }
  fig.suptitle(run_name + ": hazard maps");
  return std::move(fig);
}

std::optional<Figure> validation_figure(const Validation& v, double confidence) {
  auto [fig, axes] = panel_figure(v.variables.size());
  for (std::size_t k = 0; k < v.variables.size(); ++k) {
    const ValidationVariable& var = v.variables[k];
    Axes& ax = *axes[k];
    const auto steps = [](const std::vector<double>& x) {
      std::vector<double> xs = {x.front()}, f = {0.0};
      for (std::size_t i = 0; i < x.size(); ++i)
        xs.push_back(x[i]), f.push_back(static_cast<double>(i + 1) / static_cast<double>(x.size()));
      return std::pair{xs, f};
    };
    if (!var.simulated.empty()) {
      const auto [xs, fs] = steps(var.simulated);
      const double eps = stats::dkw_epsilon(var.simulated.size(), 1.0 - confidence);
      std::vector<double> lo, hi;
      for (double f : fs) lo.push_back(std::clamp(f - eps, 0.0, 1.0)), hi.push_back(std::clamp(f + eps, 0.0, 1.0));
      ax.step_band(xs, lo, hi, plot::cycle_color(0).with_alpha(0.15));
      ax.step(xs, fs, {plot::cycle_color(0), 1.3, plot::Dash::solid},
              "simulated " + v.series + " (n=" + std::to_string(var.simulated.size()) + ")");
    }
    if (!var.observed.empty()) {
      const auto [xo, fo] = steps(var.observed);
      ax.step(xo, fo, {plot::cycle_color(3), 1.6, plot::Dash::solid},
              "observed (n=" + std::to_string(var.observed.size()) + ")");
      ax.markers(std::vector<double>(xo.begin() + 1, xo.end()), std::vector<double>(fo.begin() + 1, fo.end()),
                 plot::cycle_color(3), 3.0);
    }
    ax.set_title(var.name + ": KS D = " + format("%.3f", var.ks_distance) + ", p = " + format("%.3g", var.ks_p_value) +
                     "; " + format("%.0f", 100 * var.inside_p5_p95) + " % of observed in P5\u2013P95",
                 plot::kSmall);
    ax.set_xlabel(unit_label(var.name, var.unit));
    ax.set_ylabel("F(x)");
    ax.set_ylim(0.0, 1.0);
    ax.grid();
    ax.legend(plot::Place::lower_right, plot::kXSmall);
  }
  fig.suptitle("Validation against " + fs::path(v.file).filename().string() + ": CDFs, " +
               format("%g", 100 * confidence) + " % DKW band of the simulation");
  return std::move(fig);
}

}  // namespace

std::vector<std::string> draw_figures(const std::vector<Run>& runs, const Analysis& a, const Settings& settings,
                                      const std::string& dir) {
  // Every variable of any series in first-seen order; the plain ones (no barrier prefix)
  // get CDF and convergence figures, the barriers one figure each.
  std::vector<std::string> variables;
  for (const auto& s : a.series)
    for (const auto& v : s.variables)
      if (std::find(variables.begin(), variables.end(), v.name) == variables.end()) variables.push_back(v.name);
  std::vector<std::string> plain, barriers;
  for (const auto& v : variables) {
    if (v.find('.') == std::string::npos) plain.push_back(v);
    const std::string suffix = ".passing_height";
    if (v.size() > suffix.size() && v.compare(v.size() - suffix.size(), suffix.size(), suffix) == 0)
      barriers.push_back(v.substr(0, v.size() - suffix.size()));
  }
  std::sort(barriers.begin(), barriers.end());
  barriers.erase(std::unique(barriers.begin(), barriers.end()), barriers.end());

  // The kinds that take longest first, so that the workers finish close together.
  std::vector<Job> jobs;
  for (std::size_t r = 0; r < a.runs.size(); ++r)
    if (a.runs[r].hazard && !a.runs[r].hazard->layers.empty())
      jobs.push_back({"hazard-" + safe(runs[r].name), [&, r] { return hazard_figure(a, runs[r].name, r); }});
  for (const auto& b : barriers) jobs.push_back({"barrier-" + safe(b), [&, b] { return barrier_figure(a, b); }});
  for (const auto& v : plain)
    jobs.push_back({"convergence-" + safe(v), [&, v] { return convergence_figure(a, v, settings.convergence_target); }});
  for (const auto& v : plain)
    jobs.push_back({"cdf-" + safe(v), [&, v] { return cdf_figure(a, v, settings.confidence); }});
  for (std::size_t r = 0; r < a.runs.size(); ++r)
    jobs.push_back({"plan-" + safe(runs[r].name), [&, r] { return plan_figure(a, runs[r].name, r); }});
  if (a.validation && !a.validation->variables.empty())
    jobs.push_back({"validation", [&] { return validation_figure(*a.validation, settings.confidence); }});

  std::vector<std::vector<std::string>> written(jobs.size());
  std::vector<std::exception_ptr> errors(jobs.size());
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t j; (j = next++) < jobs.size();) {
      try {
        const auto fig = jobs[j].draw();
        if (!fig) continue;
        for (const auto& f : settings.plot_formats) {
          const std::string path = (fs::path(dir) / (jobs[j].stem + "." + f)).string();
          fig->save(path, f == "svg" ? plot::Format::svg : plot::Format::png);
          written[j].push_back(path);
        }
      } catch (...) {
        errors[j] = std::current_exception();
      }
    }
  };
  const std::size_t wanted = settings.plot_jobs > 0 ? static_cast<std::size_t>(settings.plot_jobs)
                                                     : static_cast<std::size_t>(core::default_thread_count());
  const std::size_t threads = std::clamp<std::size_t>(wanted, 1, std::max<std::size_t>(jobs.size(), 1));
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  std::vector<std::string> paths;
  for (const auto& w : written) paths.insert(paths.end(), w.begin(), w.end());
  return paths;
}

}  // namespace talus::stats_tool
