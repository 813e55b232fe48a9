// SPDX-License-Identifier: MIT
#pragma once
// Figures of panels (axes) drawn with Cairo into PNG or SVG files: lines, steps, bands,
// markers, colour-mapped images and triangulated surfaces, with ticks, grids, titles,
// legends and colorbars (docs/stats.md, "Plots"). A figure collects what is drawn and
// renders it when saved, so the limits of each panel come from all of its data.
// Lengths of the layout are in inches, line widths and font sizes in points; figures are
// rendered at 120 pixels per inch (PNG) or as vectors (SVG, 72 points per inch).
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace talus::plot {

class Renderer;

/// A colour with opacity, each in [0, 1].
struct Rgba {
  double r = 0.0, g = 0.0, b = 0.0, a = 1.0;
  static Rgba hex(std::uint32_t rgb, double alpha = 1.0);
  Rgba with_alpha(double alpha) const { return {r, g, b, alpha}; }
};

/// The k-th colour of the ten-colour cycle that tells series apart (wraps around).
Rgba cycle_color(std::size_t k);

enum class Dash { solid, dashed, dotted, dash_dot };

struct LineStyle {
  Rgba color;
  double width = 1.3;  ///< pt
  Dash dash = Dash::solid;
};

/// A colour map of [0, 1]: "viridis", "magma", "plasma", "cividis" (perceptually uniform,
/// from their published tables), "terrain" (blue–green–yellow–brown–white) or "gray"
/// (black to white, for hillshades).
class Colormap {
 public:
  /// Throws std::invalid_argument for an unknown name.
  static const Colormap& named(std::string_view name);
  /// A map of classes: colour k at t = k / (n − 1) (an image over [0, n − 1] gives class k
  /// its colour exactly).
  static Colormap listed(std::string name, const std::vector<Rgba>& colors);
  Rgba at(double t) const;  ///< t clamped to [0, 1]
  const std::string& name() const { return name_; }

 private:
  Colormap(std::string name, std::vector<std::pair<double, Rgba>> stops) : name_(std::move(name)), stops_(std::move(stops)) {}
  std::string name_;
  std::vector<std::pair<double, Rgba>> stops_;  ///< increasing positions, 0 first, 1 last
};

enum class Scale { linear, log };
/// Where a legend goes: inside a corner of the panel, or right of it (and of its colour
/// bar), top-aligned.
enum class Place { lower_right, upper_left, upper_right, outside_right };

/// One panel. Everything added is drawn in the order added, clipped to the panel.
class Axes {
 public:
  /// A polyline through (x[i], y[i]); points with a non-finite coordinate break it.
  void line(std::vector<double> x, std::vector<double> y, LineStyle style, std::string label = "");
  /// A step function holding y[i] from x[i] to x[i + 1] (as matplotlib's where="post").
  void step(const std::vector<double>& x, const std::vector<double>& y, LineStyle style, std::string label = "");
  /// The region between the steps of `low` and `high` at x (where="post"), filled.
  void step_band(const std::vector<double>& x, const std::vector<double>& low, const std::vector<double>& high, Rgba fill);
  /// Round markers of `diameter` points.
  void markers(std::vector<double> x, std::vector<double> y, Rgba color, double diameter, std::string label = "");
  /// A line across the whole panel at y (included in the y limits).
  void hline(double y, LineStyle style);
  /// A raster of ny rows of nx cells (row j at y0 + j·dy, cell centres), values row by row,
  /// coloured by `map` over [lo, hi] with opacity `alpha`; non-finite values are
  /// transparent. The cells span
  /// [x0 − dx/2, x0 + (nx − ½)dx] × [y0 − dy/2, y0 + (ny − ½)dy]. Of a raster of more than
  /// 4 096 cells along a side, every k-th cell is drawn (k the smallest that fits).
  void image(const std::vector<double>& values, std::size_t nx, std::size_t ny, double x0, double y0, double dx,
             double dy, const Colormap& map, double lo, double hi, double alpha = 1.0);
  /// Filled contour bands of a triangulated surface (`levels` bands between the extreme
  /// values, coloured by `map` with opacity `alpha`) and their contour lines.
  void contours(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
                const std::vector<std::array<std::int32_t, 3>>& triangles, int levels, const Colormap& map,
                double alpha);
  /// Text at a data point, left-aligned on its baseline.
  void text(double x, double y, std::string s, Rgba color, double size_pt);

  void set_scale(Scale x, Scale y) { xscale_ = x, yscale_ = y; }
  void set_xlim(double lo, double hi) { xlim_ = {lo, hi}; }
  void set_ylim(double lo, double hi) { ylim_ = {lo, hi}; }
  /// One data unit is as long in x as in y: the panel shrinks around its centre.
  void set_equal_aspect() { equal_ = true; }
  void set_title(std::string s, double size_pt = 12.0) { title_ = std::move(s), title_size_ = size_pt; }
  void set_xlabel(std::string s) { xlabel_ = std::move(s); }
  void set_ylabel(std::string s) { ylabel_ = std::move(s); }
  void grid() { grid_ = true; }
  /// Tick labels of linear axes and of the colour bar give whole values, with no offset
  /// or power of ten set apart (map coordinates: 2601050, not 1050 and "+2600000"; an
  /// energy of 400000 J, not 4 and "1e5"), and as few ticks as keep the labels apart.
  void set_whole_tick_labels() { whole_ticks_ = true; }
  /// A legend of the labelled lines, bands and markers, in their order.
  void legend(Place place, double size_pt) { legend_ = {place, size_pt}; }
  /// Adds a legend entry drawn as a line of this style (for entries no single item stands for).
  void legend_entry(LineStyle style, std::string label);
  /// Adds a legend entry drawn as a filled patch (a class of a map).
  void legend_patch(Rgba fill, std::string label);
  /// A colour bar right of the panel for `map` over [lo, hi], labelled `label`.
  void colorbar(const Colormap& map, double lo, double hi, std::string label);
  /// True when something with data has been added.
  bool has_data() const;

  struct Item;
  struct Entry {
    enum class Kind { line, band, marker } kind;
    LineStyle style;
    double size = 0.0;
    std::string label;
  };
  struct Bar {
    const Colormap* map;
    double lo, hi;
    std::string label;
  };

  Axes(double left, double top, double width, double height);
  ~Axes();
  Axes(Axes&&) noexcept;
  Axes& operator=(Axes&&) noexcept;

 private:
  friend class Renderer;
  std::array<double, 4> box_;  ///< left, top, width, height (in)
  std::vector<Item> items_;
  std::vector<Entry> entries_;
  Scale xscale_ = Scale::linear, yscale_ = Scale::linear;
  std::optional<std::array<double, 2>> xlim_, ylim_;
  bool equal_ = false, grid_ = false, whole_ticks_ = false;
  std::string title_, xlabel_, ylabel_;
  double title_size_ = 12.0;
  std::optional<std::pair<Place, double>> legend_;
  std::optional<Bar> bar_;
};

enum class Format { png, svg };

/// A figure of `width` × `height` inches.
class Figure {
 public:
  Figure(double width, double height);
  /// A panel whose box is `width` × `height` inches at (left, top) from the figure's top
  /// left corner. The reference stays valid while the figure lives.
  Axes& add_axes(double left, double top, double width, double height);
  void suptitle(std::string s, double size_pt = 12.0) { suptitle_ = std::move(s), suptitle_size_ = size_pt; }
  /// Renders and writes `path` (written under a temporary name in the same directory and
  /// renamed when complete). Throws core::RuntimeError naming the file when it cannot.
  void save(const std::string& path, Format format) const;
  double width() const { return width_; }
  double height() const { return height_; }

 private:
  double width_, height_;
  std::vector<std::unique_ptr<Axes>> axes_;
  std::string suptitle_;
  double suptitle_size_ = 12.0;
};

/// Matplotlib-like relative font sizes for a 10 pt base.
inline constexpr double kSmall = 8.33, kXSmall = 6.94, kXXSmall = 5.79;

}  // namespace talus::plot
