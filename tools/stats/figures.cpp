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
#include "talus/core/error.hpp"
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

/// The unit a variable is drawn in and the factor to it: energies in kJ when
/// Settings::energy_unit asks, everything else as stored.
std::pair<std::string, double> shown_unit(const VariableSummary& v, const Settings& settings) {
  if (v.unit == "J" && settings.energy_unit == "kJ") return {"kJ", 1e-3};
  return {v.unit, 1.0};
}

/// Step ECDF of a variable's sorted values (times `scale`) with its DKW band F ± ε clipped
/// to [0, 1].
bool ecdf_with_band(Axes& ax, const VariableSummary& v, const std::string& label, Rgba color, double scale = 1.0) {
  if (!v.sample || v.sample->empty()) return false;
  const auto& x = v.sample->sorted();
  const double n = static_cast<double>(x.size());
  std::vector<double> xs = {scale * x.front()}, f = {0.0}, lo = {0.0}, hi = {std::min(v.dkw_epsilon, 1.0)};
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double fi = static_cast<double>(i + 1) / n;
    xs.push_back(scale * x[i]), f.push_back(fi);
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

std::optional<Figure> cdf_figure(const Analysis& a, const std::string& name, const Settings& settings) {
  const double confidence = settings.confidence;
  const auto panels = panels_of(a);
  auto [fig, axes] = panel_figure(panels.size());
  bool drawn = false;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    Axes& ax = *axes[p];
    bool mine = false;
    for (std::size_t k = 0; k < panels[p].members.size(); ++k)
      if (const auto* v = variable(*panels[p].members[k], name)) {
        const auto [unit, scale] = shown_unit(*v, settings);
        mine |= ecdf_with_band(ax, *v, label_of(*panels[p].members[k]), plot::cycle_color(k), scale);
        ax.set_xlabel(unit_label(name, unit));
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

std::optional<Figure> barrier_figure(const Analysis& a, const std::string& barrier, const Settings& settings) {
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
          const auto [unit, scale] = shown_unit(*v, settings);
          mine |= ecdf_with_band(ax, *v, label_of(*panels[p].members[k]), plot::cycle_color(k), scale);
          ax.set_xlabel(unit_label(c == 0 ? "passing height" : "kinetic energy", unit));
        }
      cdf_axes(ax, panels[p].title);
      if (mine) ax.legend(plot::Place::lower_right, plot::kXXSmall);
      drawn |= mine;
    }
  fig.suptitle("barrier " + barrier + ": blocks crossing it (first crossing)");
  if (!drawn) return std::nullopt;
  return fig;
}

/// The design sheet of one barrier of one run, along the line from its first vertex:
/// first crossings per segment (bars), then Q95 and Q99 of the kinetic energy and of the
/// passing height per segment with their bootstrap intervals (whiskers); legends right of
/// the panels.
std::optional<Figure> sheet_figure(const std::vector<BarrierSegment>& sheet, const std::string& run_name,
                                   const std::string& barrier, const Settings& settings) {
  std::vector<const BarrierSegment*> segments;
  const BarrierSegment* whole = nullptr;
  for (const auto& s : sheet) {
    if (s.barrier != barrier) continue;
    if (s.segment == "all")
      whole = &s;
    else
      segments.push_back(&s);
  }
  if (segments.empty() || whole == nullptr || whole->crossings == 0) return std::nullopt;
  const double scale = settings.energy_unit == "kJ" ? 1e-3 : 1.0;
  Figure fig(9.0, 8.0);
  const auto axes = grid(fig, 3, 3, 1, 0.9, 2.3, 0.6, 0.85, 0.0, 0.55);
  // Bars of the crossings: a step band from 0 over each segment.
  std::vector<double> edges, zero, counts;
  for (const auto* s : segments) edges.push_back(s->from), counts.push_back(static_cast<double>(s->crossings));
  edges.push_back(segments.back()->to), counts.push_back(counts.back());
  zero.assign(edges.size(), 0.0);
  axes[0]->step_band(edges, zero, counts, plot::cycle_color(0).with_alpha(0.6));
  axes[0]->legend_patch(plot::cycle_color(0).with_alpha(0.6), "first crossings");
  axes[0]->set_ylabel("crossings per segment");
  // Q95 and Q99 at each segment's middle, with their intervals.
  const auto quantiles = [&](Axes& ax, const auto& value, const auto& interval, double factor) {
    for (std::size_t q = 0; q < 2; ++q) {
      std::vector<double> x, y, wx, wy;
      for (const auto* s : segments) {
        // Q95 left of the segment's middle, Q99 right of it: their whiskers apart.
        const double mid = 0.5 * (s->from + s->to) + (q == 0 ? -0.12 : 0.12) * (s->to - s->from);
        if (std::isnan((s->*value)[q])) continue;
        x.push_back(mid), y.push_back(factor * (s->*value)[q]);
        const stats::Interval ci = (s->*interval)[q];
        if (std::isnan(ci.lo) || std::isnan(ci.hi)) continue;
        wx.insert(wx.end(), {mid, mid, std::nan("")}), wy.insert(wy.end(), {factor * ci.lo, factor * ci.hi, std::nan("")});
      }
      const Rgba color = plot::cycle_color(q == 0 ? 1 : 3);
      ax.line(wx, wy, {color, 1.2, plot::Dash::solid});
      ax.markers(x, y, color, 5.0, q == 0 ? "Q95" : "Q99");
    }
    ax.legend_entry({Rgba{0.3, 0.3, 0.3, 1.0}, 1.2, plot::Dash::solid},
                    format("%g", 100 * settings.confidence) + " % interval");
  };
  quantiles(*axes[1], &BarrierSegment::energy, &BarrierSegment::energy_ci, scale);
  axes[1]->set_ylabel("kinetic energy (" + settings.energy_unit + ")");
  quantiles(*axes[2], &BarrierSegment::height, &BarrierSegment::height_ci, 1.0);
  axes[2]->set_ylabel("passing height (m)");
  axes[2]->set_xlabel("position along the line from its first vertex (m)");
  for (Axes* ax : axes) {
    ax->set_xlim(0.0, whole->to);
    ax->grid();
    ax->legend(plot::Place::outside_right, plot::kSmall);
  }
  const int ead = ead_energy_class(whole->energy[1]);
  fig.suptitle(run_name + ": barrier " + barrier + ", crossings and design values by " +
               core::format_number(settings.barrier_segment_length) + " m segment");
  axes[0]->set_title(std::to_string(whole->crossings) + " first crossings; whole line Q99 " +
                         format("%.4g", scale * whole->energy[1]) + " " + settings.energy_unit + ", " +
                         format("%.3g", whole->height[1]) + " m" +
                         (ead >= 0 ? ", EAD energy class " + std::to_string(ead) : ""),
                     plot::kSmall);
  return fig;
}

// ---- Maps: one subject per file, on a hillshade, in the terrain's coordinates --------

/// The plan extent of a map (x0, x1, y0, y1; m): the terrain's, else the raster's.
std::optional<std::array<double, 4>> map_extent(const PlanView& plan, const terrain::DemGrid* raster) {
  const auto of_grid = [](const terrain::DemGrid& g) {
    const auto& s = g.spec;
    return std::array<double, 4>{s.x0 - 0.5 * s.dx, s.x0 + (s.nx - 0.5) * s.dx, s.y0 - 0.5 * s.dy,
                                 s.y0 + (s.ny - 0.5) * s.dy};
  };
  if (!plan.hillshade.z.empty()) return of_grid(plan.hillshade);
  if (raster && !raster->z.empty()) return of_grid(*raster);
  if (plan.terrain_x.empty()) return std::nullopt;
  const auto [x0, x1] = std::minmax_element(plan.terrain_x.begin(), plan.terrain_x.end());
  const auto [y0, y1] = std::minmax_element(plan.terrain_y.begin(), plan.terrain_y.end());
  return std::array<double, 4>{*x0, *x1, *y0, *y1};
}

/// A map figure 10 in wide: the map at equal scale with whole coordinates on its axes,
/// its colour bar (`bar`), and the legend right of both (1.2 in left for the northings,
/// and right as much as the legend's `labels` and barrier names need), so that no label
/// covers the data. Its height follows the extent's aspect.
std::pair<Figure, Axes*> map_figure(const PlanView& plan, const std::optional<std::array<double, 4>>& extent, bool bar,
                                    const std::vector<std::string>& labels) {
  constexpr double kWidth = 10.0, kLeft = 1.2, kTop = 0.7, kBottom = 0.7, kBar = 1.05;
  // The legend's width: its handle and padding, and about 0.066 in a character at 8.3 pt.
  std::size_t longest = std::string("release point").size();
  for (const auto& name : plan.barrier_names) longest = std::max(longest, name.size() + 8);
  for (const auto& label : labels) {
    const auto chars = std::count_if(label.begin(), label.end(), [](char c) { return (c & 0xC0) != 0x80; });
    longest = std::max(longest, static_cast<std::size_t>(chars));
  }
  const double kRight = std::max(1.6, 0.6 + 0.066 * static_cast<double>(longest));
  double aspect = 0.75;
  if (extent && (*extent)[1] > (*extent)[0] && (*extent)[3] > (*extent)[2])
    aspect = ((*extent)[3] - (*extent)[2]) / ((*extent)[1] - (*extent)[0]);
  const double height = std::clamp((kWidth - kLeft - kRight - (bar ? kBar : 0.0)) * aspect, 2.0, 7.5);
  Figure fig(kWidth, height + kTop + kBottom);
  Axes* ax = &fig.add_axes(kLeft, kTop, kWidth - kLeft - kRight, height);
  if (extent) ax->set_xlim((*extent)[0], (*extent)[1]), ax->set_ylim((*extent)[2], (*extent)[3]);
  ax->set_equal_aspect();
  ax->set_whole_tick_labels();
  const bool projected = !plan.crs_name.empty();
  ax->set_xlabel(projected ? "easting (m), " + plan.crs_name : "x (m)");
  ax->set_ylabel(projected ? "northing (m)" : "y (m)");
  const terrain::DemGrid& h = plan.hillshade;
  if (!h.z.empty())
    ax->image(h.z, static_cast<std::size_t>(h.spec.nx), static_cast<std::size_t>(h.spec.ny), h.spec.x0, h.spec.y0,
              h.spec.dx, h.spec.dy, plot::Colormap::named("gray"), -0.6, 1.0);
  return {std::move(fig), ax};
}

/// The release zone (outlined, or its points) and the barrier lines (white-cased so they
/// show on any colour, each its own colour and dash), named in the legend only.
void draw_map_features(Axes& ax, const PlanView& plan) {
  if (!plan.release_rings.empty()) {
    std::vector<double> x, y;
    const bool points = plan.release_kind == "point";
    for (const auto& ring : plan.release_rings) {
      for (const auto& p : ring) x.push_back(p[0]), y.push_back(p[1]);
      if (plan.release_kind == "polygon" && !ring.empty()) x.push_back(ring.front()[0]), y.push_back(ring.front()[1]);
      if (!points) x.push_back(std::nan("")), y.push_back(std::nan(""));
    }
    if (points) {
      ax.markers(x, y, Rgba{1, 1, 1, 1}, 7.0);
      ax.markers(std::move(x), std::move(y), Rgba{0, 0, 0, 1}, 4.5, "release point");
    } else {
      ax.line(x, y, {Rgba{1, 1, 1, 1}, 3.0, plot::Dash::solid});
      ax.line(std::move(x), std::move(y), {Rgba{0, 0, 0, 1}, 1.3, plot::Dash::dashed}, "release zone");
    }
  }
  // Colours no colour map or class legend uses (the hazard classes are red, blue, yellow).
  static constexpr std::uint32_t kColors[] = {0x000000, 0xff00ff, 0x00c8e0, 0x00a040, 0xff8c00};
  static constexpr plot::Dash kDashes[] = {plot::Dash::solid, plot::Dash::dashed, plot::Dash::dash_dot};
  for (std::size_t k = 0; k < plan.barrier_lines.size(); ++k) {
    const auto& line = plan.barrier_lines[k];
    if (line.empty()) continue;
    std::vector<double> x, y;
    for (const auto& p : line) x.push_back(p[0]), y.push_back(p[1]);
    const LineStyle style{Rgba::hex(kColors[k % 5]), 2.2, kDashes[(k / 5) % 3]};
    ax.line(x, y, {Rgba{1, 1, 1, 1}, 4.6, plot::Dash::solid});
    ax.line(std::move(x), std::move(y), style,
            "barrier " + (k < plan.barrier_names.size() ? plan.barrier_names[k] : std::to_string(k + 1)));
  }
}

std::string with_unit(const std::string& title, const std::string& unit) {
  return unit.empty() || unit == "class" ? title : title + " (" + unit + ")";
}

std::optional<Figure> plan_figure(const Analysis& a, const std::string& run_name, std::size_t r) {
  const PlanView& plan = a.runs[r].plan;
  std::vector<const Series*> mine, blocks;
  for (const auto& s : a.series)
    if (s.run_index == r) (s.block == "all" ? mine : blocks).push_back(&s);
  std::vector<std::string> labels = {"trajectories (10000 of 10000)", "blocks at rest (10000)"};
  for (const Series* s : blocks) labels.push_back("at rest: " + s->block + " (10000)");
  const bool bands = plan.hillshade.z.empty() && !plan.terrain_triangles.empty();
  auto [fig, ax] =
      map_figure(plan, map_extent(plan, a.runs[r].hazard ? &a.runs[r].hazard->layers.front().grid : nullptr), bands,
                 labels);
  // Without a hillshade (a TIN too large for the plan view is left out), elevation bands.
  if (bands) {
    const auto& map = plot::Colormap::named("terrain");
    ax->contours(plan.terrain_x, plan.terrain_y, plan.terrain_z, plan.terrain_triangles, 20, map, 0.7);
    const auto [lo, hi] = std::minmax_element(plan.terrain_z.begin(), plan.terrain_z.end());
    ax->colorbar(map, *lo, *hi, "ground elevation (m)");
  }
  // Trajectories: one polyline per realization.
  std::vector<double> x, y;
  std::set<std::int64_t> drawn;
  for (std::size_t i = 0; i < plan.trajectory_position.size(); ++i) {
    if (i > 0 && plan.trajectory_realization[i] != plan.trajectory_realization[i - 1])
      x.push_back(std::nan("")), y.push_back(std::nan(""));
    x.push_back(plan.trajectory_position[i][0]), y.push_back(plan.trajectory_position[i][1]);
    drawn.insert(plan.trajectory_realization[i]);
  }
  std::uint64_t realizations = 0;
  if (!mine.empty()) realizations = mine.front()->realizations;
  if (!x.empty())
    ax->line(std::move(x), std::move(y), {Rgba{0.05, 0.1, 0.55, 0.45}, 0.6, plot::Dash::solid},
             "trajectories (" + std::to_string(drawn.size()) + " of " + std::to_string(realizations) + ")");
  const auto& shown = blocks.empty() ? mine : blocks;
  std::size_t stopped = 0;
  for (std::size_t k = 0; k < shown.size(); ++k) {
    const auto& p = shown[k]->stop_points;
    if (p.empty()) continue;
    std::vector<double> px, py;
    for (const auto& q : p) px.push_back(q[0]), py.push_back(q[1]);
    stopped += p.size();
    const std::string who = blocks.empty() ? "blocks at rest" : "at rest: " + shown[k]->block;
    // White-ringed, in the colours after the trajectories' blue, so they stand out on them.
    ax->markers(px, py, Rgba{1, 1, 1, 1}, 6.0);
    ax->markers(std::move(px), std::move(py), plot::cycle_color(k + 1), 4.2, who + " (" + std::to_string(p.size()) + ")");
  }
  draw_map_features(*ax, plan);
  const std::string what = !drawn.empty() && stopped > 0 ? "trajectories and where blocks came to rest"
                           : !drawn.empty()              ? "trajectories"
                           : stopped > 0                 ? "where blocks came to rest"
                                                         : "terrain, release and barriers";
  fig.suptitle(run_name + ": " + what);
  ax->set_title(std::to_string(realizations) + " realizations", plot::kSmall);
  ax->legend(plot::Place::outside_right, plot::kSmall);
  return std::move(fig);
}

/// The class colours of a class layer (hazard_class: FOEN's residual, yellow, blue and
/// red; intensity: yellow, orange, red) and their names, from class 1 up.
std::vector<std::pair<Rgba, std::string>> classes_of(const HazardLayer& layer, const Settings& settings) {
  if (layer.name == "hazard_class")
    return {{Rgba::hex(0xfff5c0), "residual hazard"},
            {Rgba::hex(0xffd700), "low hazard (yellow)"},
            {Rgba::hex(0x2f6fdf), "medium hazard (blue)"},
            {Rgba::hex(0xe0201b), "high hazard (red)"}};
  const std::string e1 = core::format_number(settings.intensity_thresholds[0] * 1e-3) + " kJ";
  const std::string e2 = core::format_number(settings.intensity_thresholds[1] * 1e-3) + " kJ";
  return {{Rgba::hex(0xfde725), "low: E < " + e1},
          {Rgba::hex(0xf28e2b), "medium: " + e1 + " \u2264 E < " + e2},
          {Rgba::hex(0xc0392b), "high: E \u2265 " + e2}};
}

/// One hazard raster as a map: the raster at 80 % opacity over the hillshade (cells never
/// reached, and class 0, left clear), its colour bar or class legend, release zone and
/// barriers.
Figure layer_map(const Analysis& a, const std::string& run_name, std::size_t r, const HazardLayer& layer,
                 const Settings& settings) {
  const PlanView& plan = a.runs[r].plan;
  const std::string& u = layer.band.unit;
  const std::string unit = u == "1" ? "-" : u == "count" ? "" : u;
  const bool classes = u == "class";
  std::vector<std::string> labels;
  if (classes)
    for (const auto& entry : classes_of(layer, settings)) labels.push_back(entry.second);
  auto [fig, ax] = map_figure(plan, map_extent(plan, &layer.grid), !classes, labels);
  const bool counts = layer.name == "reach_probability" || layer.name == "passage_count" ||
                      layer.name == "deposition_count" || layer.name.rfind("frequency_", 0) == 0;
  std::vector<double> shown = layer.grid.z;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double& v : shown) {
    if ((counts || classes) && v == 0.0) v = std::nan("");
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  const bool empty = !(lo <= hi);
  if (empty) lo = 0.0, hi = 1.0;
  const auto& spec = layer.grid.spec;
  const auto nx = static_cast<std::size_t>(spec.nx), ny = static_cast<std::size_t>(spec.ny);
  if (classes) {
    const auto named = classes_of(layer, settings);
    std::vector<Rgba> colors;
    for (const auto& [color, name] : named) colors.push_back(color);
    const plot::Colormap map = plot::Colormap::listed("classes", colors);
    ax->image(shown, nx, ny, spec.x0, spec.y0, spec.dx, spec.dy, map, 1.0, static_cast<double>(named.size()), 0.85);
    for (const auto& [color, name] : named) ax->legend_patch(color.with_alpha(0.85), name);
  } else {
    const auto starts = [&](const char* prefix) { return layer.name.rfind(prefix, 0) == 0; };
    const auto& map = plot::Colormap::named(starts("energy_")   ? "magma"
                                            : starts("height_") ? "cividis"
                                            : starts("speed_")  ? "plasma"
                                                                : "viridis");
    ax->image(shown, nx, ny, spec.x0, spec.y0, spec.dx, spec.dy, map, lo, hi, 0.8);
    ax->colorbar(map, lo, hi, with_unit(layer.title, unit));
  }
  draw_map_features(*ax, plan);
  std::uint64_t realizations = 0;
  for (const auto& s : a.series)
    if (s.run_index == r && s.block == "all") realizations = s.realizations;
  std::string note = std::to_string(realizations) + " realizations, " + core::format_number(spec.dx) + " m cells";
  const bool per_year = classes || layer.name.rfind("frequency_", 0) == 0;
  if (per_year && r < settings.release_frequencies.size())
    note += ", " + core::format_number(settings.release_frequencies[r]) + " releases per year";
  const bool statistic = !counts && !classes;
  if (statistic && settings.hazard_min_passages > 1)
    note += "; cells with at least " + std::to_string(settings.hazard_min_passages) + " passages";
  if (statistic) note += "; per cell over the blocks that passed";
  if (empty) note += classes ? "; no cell above class 0 (none)" : "; no cell with a value";
  fig.suptitle(run_name + ": " + with_unit(layer.title, unit) + (statistic ? " per cell" : ""));
  ax->set_title(note, plot::kSmall);
  ax->legend(plot::Place::outside_right, plot::kSmall);
  return std::move(fig);
}

std::optional<Figure> hazard_figure(const Analysis& a, const std::string& run_name, std::size_t r) {
  const auto& layers = a.runs[r].hazard->layers;
  // Panels as high as the grid's aspect needs (a map 3.2 in wide beside its colour bar),
  // so that a wide terrain leaves no empty band between the rows.
  const auto& g = layers.front().grid.spec;
  const double aspect = g.nx > 0 && g.ny > 0 ? (g.ny * g.dy) / (g.nx * g.dx) : 0.75;
  const std::size_t cols = std::min<std::size_t>(layers.size(), 3), rows = (layers.size() + cols - 1) / cols;
  const double panel = std::clamp(3.2 * aspect, 1.0, 3.6);
  Figure fig(5.1 * static_cast<double>(cols), (panel + 0.95) * static_cast<double>(rows) + 0.5);
  const auto axes = grid(fig, layers.size(), rows, cols, 0.7, 0.7, 0.55, 0.95, 1.4, 0.95);
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
    draw_map_features(ax, a.runs[r].plan);
    ax.colorbar(map, lo, hi, "");
    ax.set_title(title, plot::kSmall);
    ax.set_equal_aspect();
  }
  fig.suptitle(run_name + ": hazard maps");
  return fig;
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
    if (settings.plot_hazard_summary && a.runs[r].hazard && !a.runs[r].hazard->layers.empty())
      jobs.push_back({"hazard-" + safe(runs[r].name), [&, r] { return hazard_figure(a, runs[r].name, r); }});
  for (std::size_t r = 0; r < a.runs.size(); ++r)
    if (a.runs[r].hazard)
      for (const HazardLayer& layer : a.runs[r].hazard->layers)
        jobs.push_back({"map-" + safe(runs[r].name) + "-" + layer.name,
                        [&, r, l = &layer]() -> std::optional<Figure> { return layer_map(a, runs[r].name, r, *l, settings); }});
  for (const auto& b : barriers)
    jobs.push_back({"barrier-" + safe(b), [&, b] { return barrier_figure(a, b, settings); }});
  for (std::size_t r = 0; r < a.runs.size(); ++r)
    for (const auto& s : a.runs[r].barrier_sheet)
      if (s.segment == "all")
        jobs.push_back({"sheet-" + safe(runs[r].name) + "-" + safe(s.barrier), [&, r, b = s.barrier] {
                          return sheet_figure(a.runs[r].barrier_sheet, runs[r].name, b, settings);
                        }});
  for (const auto& v : plain)
    jobs.push_back({"convergence-" + safe(v), [&, v] { return convergence_figure(a, v, settings.convergence_target); }});
  for (const auto& v : plain)
    jobs.push_back({"cdf-" + safe(v), [&, v] { return cdf_figure(a, v, settings); }});
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
