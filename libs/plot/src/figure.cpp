// SPDX-License-Identifier: MIT
#include "talus/plot/figure.hpp"

#include <cairo-svg.h>
#include <cairo.h>
#include <fontconfig/fontconfig.h>
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>
#include <unistd.h>

#include "talus/core/error.hpp"

namespace talus::plot {

namespace {

constexpr double kDpi = 120.0;        // pixels per inch of the PNG files
constexpr double kPt = kDpi / 72.0;   // pixels per point
constexpr double kFont = 10.0;        // pt: tick labels, axis labels
constexpr double kTick = 3.5;         // pt: tick length, and the gap to its label
constexpr double kMargin = 0.05;      // share of the data range added on each side
constexpr const char* kFace = "DejaVu Sans";

double finite_or(double x, double fallback) { return std::isfinite(x) ? x : fallback; }

}  // namespace

// ---------------------------------------------------------------------------------------
// Colours

Rgba Rgba::hex(std::uint32_t rgb, double alpha) {
  return {((rgb >> 16) & 0xff) / 255.0, ((rgb >> 8) & 0xff) / 255.0, (rgb & 0xff) / 255.0, alpha};
}

Rgba cycle_color(std::size_t k) {
  static constexpr std::uint32_t kCycle[] = {0x1f77b4, 0xff7f0e, 0x2ca02c, 0xd62728, 0x9467bd,
                                             0x8c564b, 0xe377c2, 0x7f7f7f, 0xbcbd22, 0x17becf};
  return Rgba::hex(kCycle[k % 10]);
}

namespace {

// 33 equally spaced samples of the published 256-entry tables (viridis, magma, plasma:
// van der Walt and Smith; cividis: Nuñez, Anderton and Renslow; all public domain);
// linear interpolation between them is within 5/255 of the full tables.
struct SampledTable {
  const char* name;
  std::array<std::uint32_t, 33> rgb;
};

constexpr SampledTable kSampled[] = {
    {"viridis",
     {
      0x440154, 0x470d60, 0x48186a, 0x482374, 0x472d7b, 0x453781, 0x424086, 0x3e4989, 0x3b528b,
      0x375b8d, 0x33638d, 0x2f6b8e, 0x2c728e, 0x297a8e, 0x26828e, 0x23898e, 0x21918c, 0x1f988b,
      0x1fa088, 0x22a785, 0x28ae80, 0x32b67a, 0x3fbc73, 0x4ec36b, 0x5ec962, 0x70cf57, 0x84d44b,
      0x98d83e, 0xaddc30, 0xc2df23, 0xd8e219, 0xece51b, 0xfde725
     }},
    {"magma",
     {
      0x000004, 0x030312, 0x0a0822, 0x130d34, 0x1d1147, 0x29115a, 0x36106b, 0x440f76, 0x51127c,
      0x5d177f, 0x6a1c81, 0x762181, 0x832681, 0x902a81, 0x9c2e7f, 0xaa337d, 0xb73779, 0xc43c75,
      0xd0416f, 0xdc4869, 0xe75263, 0xef5d5e, 0xf56b5c, 0xf9795d, 0xfc8961, 0xfd9869, 0xfea772,
      0xfeb67c, 0xfec488, 0xfed395, 0xfde2a3, 0xfcf0b2, 0xfcfdbf
     }},
    {"plasma",
     {
      0x0d0887, 0x220690, 0x310597, 0x3f049c, 0x4c02a1, 0x5901a5, 0x6600a7, 0x7201a8, 0x7e03a8,
      0x8a09a5, 0x9511a1, 0xa01a9c, 0xaa2395, 0xb32c8e, 0xbc3587, 0xc43e7f, 0xcc4778, 0xd35171,
      0xda5a6a, 0xe06363, 0xe66c5c, 0xeb7655, 0xf0804e, 0xf58b47, 0xf89540, 0xfba139, 0xfdac33,
      0xfeb82c, 0xfdc527, 0xfcd225, 0xf8df25, 0xf4ed27, 0xf0f921
     }},
    {"cividis",
     {
      0x00224e, 0x00285b, 0x002e6a, 0x053371, 0x1a386f, 0x273e6e, 0x32436d, 0x3b496c, 0x434e6c,
      0x4b546c, 0x535a6d, 0x5a5f6e, 0x61656f, 0x686a71, 0x6f7073, 0x767676, 0x7d7c78, 0x848279,
      0x8c8878, 0x938e78, 0x9b9476, 0xa39a74, 0xaba072, 0xb4a76f, 0xbcae6c, 0xc4b468, 0xcdbb63,
      0xd5c25e, 0xdec958, 0xe7d150, 0xf0d846, 0xf9e03a, 0xfee838
     }},
};

}  // namespace

const Colormap& Colormap::named(std::string_view name) {
  static const std::vector<Colormap> maps = [] {
    std::vector<Colormap> out;
    for (const SampledTable& t : kSampled) {
      std::vector<std::pair<double, Rgba>> stops;
      for (std::size_t k = 0; k < t.rgb.size(); ++k) stops.emplace_back(static_cast<double>(k) / 32.0, Rgba::hex(t.rgb[k]));
      out.push_back(Colormap(t.name, std::move(stops)));
    }
    // Deep blue, sea blue, green, pale yellow, brown, white.
    out.push_back(Colormap("terrain", {{0.00, {0.2, 0.2, 0.6, 1.0}},
                                       {0.15, {0.0, 0.6, 1.0, 1.0}},
                                       {0.25, {0.0, 0.8, 0.4, 1.0}},
                                       {0.50, {1.0, 1.0, 0.6, 1.0}},
                                       {0.75, {0.5, 0.36, 0.33, 1.0}},
                                       {1.00, {1.0, 1.0, 1.0, 1.0}}}));
    out.push_back(Colormap("gray", {{0.0, {0.0, 0.0, 0.0, 1.0}}, {1.0, {1.0, 1.0, 1.0, 1.0}}}));
    return out;
  }();
  for (const Colormap& m : maps)
    if (m.name_ == name) return m;
  throw std::invalid_argument("unknown colour map '" + std::string(name) + "'");
}

Colormap Colormap::listed(std::string name, const std::vector<Rgba>& colors) {
  std::vector<std::pair<double, Rgba>> stops;
  const double last = static_cast<double>(std::max<std::size_t>(colors.size(), 2) - 1);
  for (std::size_t k = 0; k < colors.size(); ++k) stops.emplace_back(static_cast<double>(k) / last, colors[k].with_alpha(1.0));
  if (stops.size() == 1) stops.emplace_back(1.0, stops.front().second);
  if (stops.empty()) stops = {{0.0, Rgba{}}, {1.0, Rgba{}}};
  return Colormap(std::move(name), std::move(stops));
}

Rgba Colormap::at(double t) const {
  t = std::clamp(finite_or(t, 0.0), 0.0, 1.0);
  const auto upper = std::upper_bound(stops_.begin() + 1, stops_.end() - 1, t,
                                      [](double v, const auto& stop) { return v < stop.first; });
  const auto& [t1, c1] = *upper;
  const auto& [t0, c0] = *(upper - 1);
  const double s = t1 > t0 ? (t - t0) / (t1 - t0) : 0.0;
  return {c0.r + s * (c1.r - c0.r), c0.g + s * (c1.g - c0.g), c0.b + s * (c1.b - c0.b), 1.0};
}

// ---------------------------------------------------------------------------------------
// What a panel holds

namespace {

// A colour as one pixel of a Cairo ARGB32 image (premultiplied by its opacity).
std::uint32_t argb(const Rgba& c) {
  const auto byte = [](double u) { return static_cast<std::uint32_t>(std::lround(255.0 * u)); };
  return byte(c.a) << 24 | byte(c.r * c.a) << 16 | byte(c.g * c.a) << 8 | byte(c.b * c.a);
}

}  // namespace

struct Axes::Item {
  enum class Kind { path, fill, markers, hline, image, text } kind;
  explicit Item(Kind k) : kind(k) {}
  std::vector<double> x, y;  // path, fill (closed polygons separated by NaN), markers; text: one point
  LineStyle style;           // path, hline; fill and markers: style.color
  double size = 0.0;         // markers: diameter (pt); text: size (pt)
  std::string text;
  bool sticky = false;       // limits fit it exactly (images, surfaces): no margin beyond it
  // image: ARGB32 rows from the top, and the extent it covers
  std::vector<std::uint32_t> pixels;
  int width = 0, height = 0;
  double x0 = 0.0, x1 = 0.0, y0 = 0.0, y1 = 0.0;
};

Axes::Axes(double left, double top, double width, double height) : box_{left, top, width, height} {}
Axes::~Axes() = default;
Axes::Axes(Axes&&) noexcept = default;
Axes& Axes::operator=(Axes&&) noexcept = default;

void Axes::line(std::vector<double> x, std::vector<double> y, LineStyle style, std::string label) {
  if (!label.empty()) entries_.push_back({Entry::Kind::line, style, 0.0, label});
  Item item(Item::Kind::path);
  item.x = std::move(x), item.y = std::move(y), item.style = style;
  items_.push_back(std::move(item));
}

void Axes::step(const std::vector<double>& x, const std::vector<double>& y, LineStyle style, std::string label) {
  std::vector<double> sx, sy;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (i > 0) sx.push_back(x[i]), sy.push_back(y[i - 1]);
    sx.push_back(x[i]), sy.push_back(y[i]);
  }
  line(std::move(sx), std::move(sy), style, std::move(label));
}

void Axes::step_band(const std::vector<double>& x, const std::vector<double>& low, const std::vector<double>& high,
                     Rgba fill) {
  Item item(Item::Kind::fill);
  for (std::size_t i = 0; i < x.size(); ++i) {  // along the upper edge
    if (i > 0) item.x.push_back(x[i]), item.y.push_back(high[i - 1]);
    item.x.push_back(x[i]), item.y.push_back(high[i]);
  }
  for (std::size_t i = x.size(); i-- > 0;) {  // back along the lower edge
    item.x.push_back(x[i]), item.y.push_back(low[i]);
    if (i > 0) item.x.push_back(x[i]), item.y.push_back(low[i - 1]);
  }
  item.style.color = fill;
  items_.push_back(std::move(item));
}

void Axes::markers(std::vector<double> x, std::vector<double> y, Rgba color, double diameter, std::string label) {
  if (!label.empty()) entries_.push_back({Entry::Kind::marker, LineStyle{color, 1.3, Dash::solid}, diameter, label});
  Item item(Item::Kind::markers);
  item.x = std::move(x), item.y = std::move(y), item.style.color = color, item.size = diameter;
  items_.push_back(std::move(item));
}

void Axes::hline(double y, LineStyle style) {
  Item item(Item::Kind::hline);
  item.y = {y}, item.style = style;
  items_.push_back(std::move(item));
}

void Axes::image(const std::vector<double>& values, std::size_t nx, std::size_t ny, double x0, double y0, double dx,
                 double dy, const Colormap& map, double lo, double hi, double alpha) {
  if (nx == 0 || ny == 0) return;
  // Rasters wider than any panel's pixels (and Cairo's 32 767-pixel limit) keep every
  // stride-th cell along each side: the panel shows one pixel for many cells either way.
  constexpr std::size_t kMaxCells = 4096;
  const std::size_t stride = (std::max(nx, ny) + kMaxCells - 1) / kMaxCells;
  const std::size_t mx = (nx + stride - 1) / stride, my = (ny + stride - 1) / stride;
  Item item(Item::Kind::image);
  item.width = static_cast<int>(mx), item.height = static_cast<int>(my), item.sticky = true;
  item.x0 = x0 - dx / 2, item.x1 = item.x0 + static_cast<double>(mx * stride) * dx;
  item.y0 = y0 - dy / 2, item.y1 = item.y0 + static_cast<double>(my * stride) * dy;
  item.pixels.resize(mx * my, 0u);  // transparent
  const double span = hi > lo ? hi - lo : 1.0;
  for (std::size_t j = 0; j < my; ++j)
    for (std::size_t i = 0; i < mx; ++i) {
      const double v = values[j * stride * nx + i * stride];
      if (!std::isfinite(v)) continue;
      item.pixels[(my - 1 - j) * mx + i] = argb(map.at((v - lo) / span).with_alpha(alpha));
    }
  items_.push_back(std::move(item));
}

namespace {

// Nice round steps: 1, 2, 2.5, 5 times a power of ten, the smallest with at most
// `intervals` of them across [lo, hi].
double nice_step(double lo, double hi, int intervals) {
  const double raw = (hi - lo) / std::max(intervals, 1);
  if (!(raw > 0.0)) return 1.0;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * magnitude >= raw * (1 - 1e-9)) return m * magnitude;
  return 10.0 * magnitude;
}

struct Vertex {
  double x, y, z;
};

// The part of a convex polygon where z >= level (keep_above) or z <= level.
std::vector<Vertex> clip(const std::vector<Vertex>& poly, double level, bool keep_above) {
  std::vector<Vertex> out;
  const auto inside = [&](const Vertex& v) { return keep_above ? v.z >= level : v.z <= level; };
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vertex& a = poly[i];
    const Vertex& b = poly[(i + 1) % poly.size()];
    if (inside(a)) out.push_back(a);
    if (inside(a) != inside(b)) {
      const double s = (level - a.z) / (b.z - a.z);
      out.push_back({a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), level});
    }
  }
  return out;
}

}  // namespace

namespace {

// Surfaces of more triangles than this are drawn as a raster of kRasterCells cells along
// the longer side (finer than a panel's pixels) instead of one polygon per triangle: a
// valley-scale DEM's millions of triangles then cost megabytes and a fraction of a second.
constexpr std::size_t kVectorTriangles = 200000;
constexpr int kRasterCells = 1200;

// The surface sampled at the centres of square cells of side `cell` from (x0, y0): NaN
// where no triangle covers a centre.
std::vector<double> sample_surface(const std::vector<double>& x, const std::vector<double>& y,
                                   const std::vector<double>& z, const std::vector<std::array<std::int32_t, 3>>& triangles,
                                   double x0, double y0, double cell, int nx, int ny) {
  std::vector<double> g(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), std::nan(""));
  for (const auto& t : triangles) {
    const double ax = x[t[0]], ay = y[t[0]], bx = x[t[1]], by = y[t[1]], cx = x[t[2]], cy = y[t[2]];
    const double det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy);
    if (std::abs(det) <= 1e-300) continue;
    const auto index = [&](double v, double origin, int n, bool up) {
      const double u = (v - origin) / cell - 0.5;
      return std::clamp(static_cast<int>(up ? std::ceil(u) : std::floor(u)), 0, n - 1);
    };
    const int i0 = index(std::min({ax, bx, cx}), x0, nx, true), i1 = index(std::max({ax, bx, cx}), x0, nx, false);
    const int j0 = index(std::min({ay, by, cy}), y0, ny, true), j1 = index(std::max({ay, by, cy}), y0, ny, false);
    for (int j = j0; j <= j1; ++j) {
      const double py = y0 + (j + 0.5) * cell;
      for (int i = i0; i <= i1; ++i) {
        const double px = x0 + (i + 0.5) * cell;
        const double l1 = ((by - cy) * (px - cx) + (cx - bx) * (py - cy)) / det;
        const double l2 = ((cy - ay) * (px - cx) + (ax - cx) * (py - cy)) / det;
        const double l3 = 1.0 - l1 - l2;
        if (l1 >= -1e-9 && l2 >= -1e-9 && l3 >= -1e-9)
          g[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)] =
              l1 * z[t[0]] + l2 * z[t[1]] + l3 * z[t[2]];
      }
    }
  }
  return g;
}

}  // namespace

void Axes::contours(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
                    const std::vector<std::array<std::int32_t, 3>>& triangles, int levels, const Colormap& map,
                    double alpha) {
  if (triangles.empty() || z.empty()) return;
  const auto [zmin_it, zmax_it] = std::minmax_element(z.begin(), z.end());
  const double step = nice_step(*zmin_it, *zmax_it, levels);
  const double first = std::floor(*zmin_it / step) * step;
  const int bands = std::max(1, static_cast<int>(std::ceil((*zmax_it - first) / step - 1e-9)));
  std::vector<Rgba> colors;
  for (int k = 0; k < bands; ++k) colors.push_back(map.at((k + 0.5) / bands).with_alpha(alpha));
  Item lines(Item::Kind::path);
  lines.style = {Rgba{0, 0, 0, 0.5}, 0.3, Dash::solid};
  const auto band_of = [&](double v) { return std::clamp(static_cast<int>(std::floor((v - first) / step)), 0, bands - 1); };
  if (triangles.size() > kVectorTriangles) {
    const auto [xl, xh] = std::minmax_element(x.begin(), x.end());
    const auto [yl, yh] = std::minmax_element(y.begin(), y.end());
    const double cell = std::max(*xh - *xl, *yh - *yl) / kRasterCells;
    if (!(cell > 0.0)) return;
    const int nx = std::max(1, static_cast<int>(std::ceil((*xh - *xl) / cell))), ny = std::max(1, static_cast<int>(std::ceil((*yh - *yl) / cell)));
    const auto g = sample_surface(x, y, z, triangles, *xl, *yl, cell, nx, ny);
    const auto at = [&](int i, int j) { return g[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)]; };
    Item image(Item::Kind::image);
    image.width = nx, image.height = ny, image.sticky = true;
    image.x0 = *xl, image.x1 = *xl + nx * cell, image.y0 = *yl, image.y1 = *yl + ny * cell;
    image.pixels.resize(g.size(), 0u);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!std::isfinite(at(i, j))) continue;
        image.pixels[static_cast<std::size_t>(ny - 1 - j) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)] =
            argb(colors[static_cast<std::size_t>(band_of(at(i, j)))]);
      }
    items_.push_back(std::move(image));
    // Contour lines by marching squares over the cell centres.
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        const double q[4] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
        if (!std::isfinite(q[0] + q[1] + q[2] + q[3])) continue;
        const double px[4] = {*xl + (i + 0.5) * cell, *xl + (i + 1.5) * cell, *xl + (i + 1.5) * cell, *xl + (i + 0.5) * cell};
        const double py[4] = {*yl + (j + 0.5) * cell, *yl + (j + 0.5) * cell, *yl + (j + 1.5) * cell, *yl + (j + 1.5) * cell};
        const double lo = std::min({q[0], q[1], q[2], q[3]}), hi = std::max({q[0], q[1], q[2], q[3]});
        for (int k = band_of(lo) + 1; k <= band_of(hi); ++k) {
          const double a = first + k * step;
          double cross_x[4], cross_y[4];
          int n = 0;
          for (int e = 0; e < 4; ++e) {
            const int f = (e + 1) % 4;
            if ((q[e] - a) * (q[f] - a) < 0.0) {
              const double s = (a - q[e]) / (q[f] - q[e]);
              cross_x[n] = px[e] + s * (px[f] - px[e]), cross_y[n] = py[e] + s * (py[f] - py[e]), ++n;
            }
          }
          for (int m = 0; m + 1 < n; m += 2) {
            lines.x.insert(lines.x.end(), {cross_x[m], cross_x[m + 1], std::nan("")});
            lines.y.insert(lines.y.end(), {cross_y[m], cross_y[m + 1], std::nan("")});
          }
        }
      }
    items_.push_back(std::move(lines));
    return;
  }
  // One fill item per band (its polygons in one path, so abutting pieces show no seam),
  // then one path of every contour segment.
  std::vector<Item> fills;
  for (int k = 0; k < bands; ++k) {
    fills.emplace_back(Item::Kind::fill).sticky = true;
    fills.back().style.color = colors[static_cast<std::size_t>(k)];
  }
  for (const auto& t : triangles) {
    const std::vector<Vertex> tri = {{x[t[0]], y[t[0]], z[t[0]]}, {x[t[1]], y[t[1]], z[t[1]]}, {x[t[2]], y[t[2]], z[t[2]]}};
    const double lo = std::min({tri[0].z, tri[1].z, tri[2].z}), hi = std::max({tri[0].z, tri[1].z, tri[2].z});
    const int k0 = band_of(lo), k1 = band_of(hi);
    for (int k = k0; k <= k1; ++k) {
      const double a = first + k * step, b = a + step;
      const auto piece = k0 == k1 ? tri : clip(clip(tri, a, true), b, false);
      if (piece.size() < 3) continue;
      for (const Vertex& v : piece) fills[k].x.push_back(v.x), fills[k].y.push_back(v.y);
      fills[k].x.push_back(std::nan("")), fills[k].y.push_back(std::nan(""));
      if (k > k0 || lo == a) {  // the level a crosses this triangle: its segment
        std::vector<Vertex> on;
        for (int e = 0; e < 3; ++e) {
          const Vertex& p = tri[e];
          const Vertex& q = tri[(e + 1) % 3];
          if ((p.z - a) * (q.z - a) < 0.0) {
            const double s = (a - p.z) / (q.z - p.z);
            on.push_back({p.x + s * (q.x - p.x), p.y + s * (q.y - p.y), a});
          }
        }
        if (on.size() == 2) {
          lines.x.insert(lines.x.end(), {on[0].x, on[1].x, std::nan("")});
          lines.y.insert(lines.y.end(), {on[0].y, on[1].y, std::nan("")});
        }
      }
    }
  }
  for (auto& f : fills) items_.push_back(std::move(f));
  items_.push_back(std::move(lines));
}

void Axes::text(double x, double y, std::string s, Rgba color, double size_pt) {
  Item item(Item::Kind::text);
  item.x = {x}, item.y = {y}, item.text = std::move(s), item.style.color = color, item.size = size_pt;
  items_.push_back(std::move(item));
}

void Axes::legend_entry(LineStyle style, std::string label) { entries_.push_back({Entry::Kind::line, style, 0.0, label}); }
void Axes::legend_patch(Rgba fill, std::string label) {
  entries_.push_back({Entry::Kind::band, LineStyle{fill, 1.3, Dash::solid}, 0.0, std::move(label)});
}

void Axes::colorbar(const Colormap& map, double lo, double hi, std::string label) {
  bar_ = Bar{&map, lo, hi, std::move(label)};
}

bool Axes::has_data() const {
  return std::any_of(items_.begin(), items_.end(), [](const Item& i) {
    return i.kind != Item::Kind::hline && i.kind != Item::Kind::text && (!i.x.empty() || !i.pixels.empty());
  });
}

// ---------------------------------------------------------------------------------------
// Rendering

namespace {

// The one font face of every figure, made once. At exit it is released with Cairo's and
// fontconfig's caches, which would otherwise stay allocated (a leak checker reports them).
class FontFace {
 public:
  static cairo_font_face_t* get() {
    static const FontFace face;
    return face.face_;
  }
  FontFace(const FontFace&) = delete;
  FontFace& operator=(const FontFace&) = delete;

 private:
  FontFace() : face_(cairo_toy_font_face_create(kFace, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL)) {}
  ~FontFace() {
    cairo_font_face_destroy(face_);
    cairo_debug_reset_static_data();
    FcFini();
  }
  cairo_font_face_t* face_;
};

struct Canvas {
  cairo_t* cr;

  void color(const Rgba& c) const { cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a); }
  void font(double size_pt) const {
    cairo_set_font_face(cr, FontFace::get());
    cairo_set_font_size(cr, size_pt * kPt);
  }
  double width(const std::string& s, double size_pt) const {
    font(size_pt);
    cairo_text_extents_t e;
    cairo_text_extents(cr, s.c_str(), &e);
    return e.x_advance;
  }
  double ascent(double size_pt) const {
    font(size_pt);
    cairo_font_extents_t f;
    cairo_font_extents(cr, &f);
    return f.ascent;
  }
  double descent(double size_pt) const {
    font(size_pt);
    cairo_font_extents_t f;
    cairo_font_extents(cr, &f);
    return f.descent;
  }
  // Text anchored at (x, y): ha 0 left, 0.5 centre, 1 right; va 0 top, 0.5 centre,
  // 1 bottom (of the font's ascent and descent); rotated counter-clockwise by `turn` × 90°.
  void text(const std::string& s, double x, double y, double size_pt, const Rgba& c, double ha, double va,
            int turn = 0) const {
    font(size_pt);
    cairo_font_extents_t f;
    cairo_font_extents(cr, &f);
    cairo_text_extents_t e;
    cairo_text_extents(cr, s.c_str(), &e);
    cairo_save(cr);
    cairo_translate(cr, x, y);
    if (turn) cairo_rotate(cr, -M_PI / 2 * turn);
    cairo_move_to(cr, -ha * e.x_advance, f.ascent - va * (f.ascent + f.descent));
    color(c);
    cairo_show_text(cr, s.c_str());
    cairo_restore(cr);
  }
  void dash(const LineStyle& s) const {
    const double w = s.width * kPt;
    cairo_set_line_width(cr, w);
    switch (s.dash) {
      case Dash::solid: cairo_set_dash(cr, nullptr, 0, 0.0); break;
      case Dash::dashed: { const double d[] = {3.7 * w, 1.6 * w}; cairo_set_dash(cr, d, 2, 0.0); break; }
      case Dash::dotted: { const double d[] = {1.0 * w, 1.65 * w}; cairo_set_dash(cr, d, 2, 0.0); break; }
      case Dash::dash_dot: { const double d[] = {6.4 * w, 1.6 * w, 1.0 * w, 1.6 * w}; cairo_set_dash(cr, d, 4, 0.0); break; }
    }
  }
};

struct Range {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
};

double to_scale(double v, Scale s) {
  if (s == Scale::linear) return v;
  return v > 0.0 ? std::log10(v) : std::numeric_limits<double>::quiet_NaN();
}

// The limits of one axis in scale space: the data with 5 % margins, but not beyond what a
// sticky item (image, surface) covers.
std::array<double, 2> limits(const Range& loose, const Range& sticky, const std::optional<std::array<double, 2>>& set,
                             Scale s) {
  if (set) return {to_scale((*set)[0], s), to_scale((*set)[1], s)};
  Range all = loose;
  if (!sticky.empty()) all.add(sticky.lo), all.add(sticky.hi);
  if (all.empty()) return {0.0, 1.0};
  double lo = all.lo, hi = all.hi;
  if (hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
    const double pad = s == Scale::log ? 1.0 : std::max(std::abs(lo) * 0.05, 0.5);
    return {lo - pad, hi + pad};
  }
  if (sticky.empty() || !loose.empty()) {
    const double m = kMargin * (hi - lo);
    lo -= m, hi += m;
    if (!sticky.empty()) lo = std::max(lo, std::min(sticky.lo, loose.lo)), hi = std::min(hi, std::max(sticky.hi, loose.hi));
  }
  return {lo, hi};
}

struct Tick {
  double at;  // scale space
  std::string label;
};

std::string trim_minus(std::string s) {
  if (s == "-0") return "0";
  if (!s.empty() && s[0] == '-') return "\u2212" + s.substr(1);
  return s;
}

// What the labels of a linear axis leave out: an offset subtracted from every tick (the
// shared leading digits of projected coordinates: 2 600 200 m shows as 200 with
// "+2600000") and then a power of ten factored out (outside 1e-3 … 1e4, as matplotlib).
struct Scaling {
  double offset = 0.0;
  int exponent = 0;
  bool any() const { return offset != 0.0 || exponent != 0; }
  std::string text() const {
    std::string s = exponent ? "1e" + std::to_string(exponent) : "";
    if (offset != 0.0) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.15g", std::abs(offset));
      s += (offset > 0.0 ? "+" : "\u2212") + std::string(buf);
    }
    return s;
  }
};

// Ticks of a linear axis over [lo, hi] and what their labels leave out (nothing when
// `whole`: the labels give the values themselves).
std::vector<Tick> linear_ticks(double lo, double hi, int intervals, Scaling& scaling, bool whole = false) {
  const double step = nice_step(lo, hi, intervals);
  std::vector<double> at;
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step)
    at.push_back(std::abs(t) < 1e-9 * step ? 0.0 : t);
  scaling = {};
  if (at.empty()) return {};
  double biggest = 0.0;
  for (double t : at) biggest = std::max(biggest, std::abs(t));
  // An offset when the ticks share their leading digits: the range is under 1 % of them.
  const double span = at.back() - at.front() + step;
  if (!whole && biggest >= 1e4 && span < 1e-2 * biggest) {
    const double unit = std::pow(10.0, std::ceil(std::log10(span)));
    scaling.offset = std::floor(at.front() / unit) * unit;
    biggest = 0.0;
    for (double t : at) biggest = std::max(biggest, std::abs(t - scaling.offset));
  }
  if (!whole && (biggest >= 1e4 || (biggest > 0.0 && biggest < 1e-3)))
    scaling.exponent = static_cast<int>(std::floor(std::log10(biggest)));
  const double unit = std::pow(10.0, scaling.exponent);
  const double scaled = step / unit;
  int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(scaled) + 1e-9)));
  const double mantissa = scaled / std::pow(10.0, std::floor(std::log10(scaled) + 1e-9));
  if (std::abs(mantissa - 2.5) < 1e-6 && scaled < 10.0) ++decimals;  // 0.25, 2.5; not 25 or 250
  std::vector<Tick> ticks;
  for (double t : at) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, (t - scaling.offset) / unit);
    ticks.push_back({t, trim_minus(buf)});
  }
  return ticks;
}

std::string log_label(double v) {
  char buf[64];
  const double k = std::log10(v);
  if (std::abs(k - std::round(k)) < 1e-9 && (k > 4.5 || k < -3.5))
    std::snprintf(buf, sizeof buf, "1e%d", static_cast<int>(std::round(k)));
  else
    std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Ticks of a log axis over [lo, hi] (decades in scale space): the decades, and 2 and 5
// times them when fewer than two decades fall inside.
std::vector<Tick> log_ticks(double lo, double hi) {
  std::vector<Tick> ticks;
  for (double k = std::ceil(lo - 1e-9); k <= hi + 1e-9; k += 1.0) ticks.push_back({k, log_label(std::pow(10.0, k))});
  if (ticks.size() < 2) {
    ticks.clear();
    for (double k = std::floor(lo) - 1; k <= hi + 1e-9; k += 1.0)
      for (double m : {1.0, 2.0, 5.0}) {
        const double at = k + std::log10(m);
        if (at >= lo - 1e-9 && at <= hi + 1e-9) ticks.push_back({at, log_label(m * std::pow(10.0, k))});
      }
  }
  return ticks;
}

struct Frame {
  double px, py, pw, ph;              // the panel's box (pixels)
  std::array<double, 2> xl, yl;       // limits in scale space
  Scale xs, ys;
  double X(double x) const { return px + (to_scale(x, xs) - xl[0]) / (xl[1] - xl[0]) * pw; }
  double Y(double y) const { return py + ph - (to_scale(y, ys) - yl[0]) / (yl[1] - yl[0]) * ph; }
  double XS(double u) const { return px + (u - xl[0]) / (xl[1] - xl[0]) * pw; }  // from scale space
  double YS(double v) const { return py + ph - (v - yl[0]) / (yl[1] - yl[0]) * ph; }
};

// Traces a polyline (breaking at non-finite points) or NaN-separated closed polygons.
void trace(cairo_t* cr, const Frame& f, const std::vector<double>& x, const std::vector<double>& y, bool closed) {
  bool open = false;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double u = f.X(x[i]), v = f.Y(y[i]);
    if (!std::isfinite(u) || !std::isfinite(v)) {
      if (open && closed) cairo_close_path(cr);
      open = false;
      continue;
    }
    if (open)
      cairo_line_to(cr, u, v);
    else
      cairo_move_to(cr, u, v), open = true;
  }
  if (open && closed) cairo_close_path(cr);
}

void draw_item(const Canvas& c, const Frame& f, const Axes::Item& item) {
  cairo_t* cr = c.cr;
  switch (item.kind) {
    case Axes::Item::Kind::path:
      trace(cr, f, item.x, item.y, false);
      c.color(item.style.color);
      c.dash(item.style);
      cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
      cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
      cairo_stroke(cr);
      break;
    case Axes::Item::Kind::fill:
      trace(cr, f, item.x, item.y, true);
      c.color(item.style.color);
      cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
      cairo_fill(cr);
      break;
    case Axes::Item::Kind::markers: {
      const double r = item.size * kPt / 2;
      for (std::size_t i = 0; i < item.x.size(); ++i) {
        const double u = f.X(item.x[i]), v = f.Y(item.y[i]);
        if (!std::isfinite(u) || !std::isfinite(v)) continue;
        cairo_new_sub_path(cr);
        cairo_arc(cr, u, v, r, 0.0, 2 * M_PI);
      }
      c.color(item.style.color);
      cairo_fill(cr);
      break;
    }
    case Axes::Item::Kind::hline: {
      const double v = f.Y(item.y[0]);
      if (!std::isfinite(v)) break;
      cairo_move_to(cr, f.px, v);
      cairo_line_to(cr, f.px + f.pw, v);
      c.color(item.style.color);
      c.dash(item.style);
      cairo_stroke(cr);
      break;
    }
    case Axes::Item::Kind::image: {
      cairo_surface_t* img = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, item.width, item.height);
      cairo_surface_flush(img);
      unsigned char* data = cairo_image_surface_get_data(img);
      const int stride = cairo_image_surface_get_stride(img);
      for (int j = 0; j < item.height; ++j)
        std::copy_n(item.pixels.data() + static_cast<std::size_t>(j) * item.width, item.width,
                    reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(j) * stride));
      cairo_surface_mark_dirty(img);
      const double u0 = f.X(item.x0), u1 = f.X(item.x1), v0 = f.Y(item.y1), v1 = f.Y(item.y0);
      cairo_save(cr);
      cairo_rectangle(cr, u0, v0, u1 - u0, v1 - v0);
      cairo_clip(cr);
      cairo_translate(cr, u0, v0);
      cairo_scale(cr, (u1 - u0) / item.width, (v1 - v0) / item.height);
      cairo_set_source_surface(cr, img, 0.0, 0.0);
      cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
      cairo_paint(cr);
      cairo_restore(cr);
      cairo_surface_destroy(img);
      break;
    }
    case Axes::Item::Kind::text:
      c.text(item.text, f.X(item.x[0]), f.Y(item.y[0]), item.size, item.style.color, 0.0, 0.75);
      break;
  }
}

// `beside`: what lies right of the panel before an outside legend (its colour bar, pixels).
void draw_legend(const Canvas& c, const Frame& f, const std::vector<Axes::Entry>& entries, Place place, double size,
                 double beside) {
  if (entries.empty()) return;
  const double em = size * kPt;
  double text_w = 0.0;
  for (const auto& e : entries) text_w = std::max(text_w, c.width(e.label, size));
  const double handle = 2.0 * em, gap = 0.8 * em, pad = 0.4 * em, row = 1.5 * em;
  const double w = 2 * pad + handle + gap + text_w;
  const double h = 2 * pad + row * static_cast<double>(entries.size()) - 0.5 * em;
  const double out = 0.5 * em;
  double x = 0.0, y = 0.0;
  switch (place) {
    case Place::lower_right: x = f.px + f.pw - out - w, y = f.py + f.ph - out - h; break;
    case Place::upper_right: x = f.px + f.pw - out - w, y = f.py + out; break;
    case Place::upper_left: x = f.px + out, y = f.py + out; break;
    case Place::outside_right: x = f.px + f.pw + beside + out, y = f.py; break;
  }
  cairo_t* cr = c.cr;
  cairo_rectangle(cr, x, y, w, h);
  c.color({1, 1, 1, 0.8});
  cairo_fill_preserve(cr);
  c.color(Rgba{0.8, 0.8, 0.8, 1.0});
  cairo_set_line_width(cr, 0.8 * kPt);
  cairo_set_dash(cr, nullptr, 0, 0.0);
  cairo_stroke(cr);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const auto& e = entries[k];
    const double mid = y + pad + row * static_cast<double>(k) + 0.5 * em;
    switch (e.kind) {
      case Axes::Entry::Kind::line:
        cairo_move_to(cr, x + pad, mid);
        cairo_line_to(cr, x + pad + handle, mid);
        c.color(e.style.color);
        c.dash(e.style);
        cairo_stroke(cr);
        break;
      case Axes::Entry::Kind::band:
        cairo_rectangle(cr, x + pad, mid - 0.35 * em, handle, 0.7 * em);
        c.color(e.style.color);
        cairo_fill(cr);
        break;
      case Axes::Entry::Kind::marker:
        cairo_new_sub_path(cr);
        cairo_arc(cr, x + pad + handle / 2, mid, e.size * kPt / 2, 0.0, 2 * M_PI);
        c.color(e.style.color);
        cairo_fill(cr);
        break;
    }
    c.text(e.label, x + pad + handle + gap, mid, size, {0, 0, 0, 1}, 0.0, 0.5);
  }
}

// The tick marks and labels of a vertical scale at x (labels left of it, or right when
// `right`); returns the widest label.
double vertical_ticks(const Canvas& c, double x, const std::vector<Tick>& ticks, const std::function<double(double)>& at,
                      bool right) {
  cairo_t* cr = c.cr;
  double widest = 0.0;
  const double len = kTick * kPt * (right ? 1 : -1);
  for (const auto& t : ticks) {
    const double v = at(t.at);
    cairo_move_to(cr, x, v);
    cairo_line_to(cr, x + len, v);
    widest = std::max(widest, c.width(t.label, kFont));
    c.text(t.label, x + len + (right ? 1 : -1) * kTick * kPt, v, kFont, {0, 0, 0, 1}, right ? 0.0 : 1.0, 0.5);
  }
  c.color({0, 0, 0, 1});
  cairo_set_line_width(cr, 0.8 * kPt);
  cairo_set_dash(cr, nullptr, 0, 0.0);
  cairo_stroke(cr);
  return widest;
}

void draw_colorbar(const Canvas& c, const Frame& f, const Axes::Bar& bar, bool whole) {
  cairo_t* cr = c.cr;
  const double pad = 0.1 * kDpi, w = std::clamp(f.ph / 20.0, 0.08 * kDpi, 0.16 * kDpi);
  const double h = f.ph * 0.9, x = f.px + f.pw + pad, y = f.py + (f.ph - h) / 2;
  const double lo = bar.lo, hi = bar.hi > bar.lo ? bar.hi : bar.lo + 1.0;
  cairo_pattern_t* g = cairo_pattern_create_linear(0.0, y + h, 0.0, y);
  for (int k = 0; k <= 32; ++k) {
    const Rgba col = bar.map->at(k / 32.0);
    cairo_pattern_add_color_stop_rgb(g, k / 32.0, col.r, col.g, col.b);
  }
  cairo_rectangle(cr, x, y, w, h);
  cairo_set_source(cr, g);
  cairo_fill(cr);
  cairo_pattern_destroy(g);
  cairo_rectangle(cr, x, y, w, h);
  c.color({0, 0, 0, 1});
  cairo_set_line_width(cr, 0.8 * kPt);
  cairo_stroke(cr);
  Scaling scaling;
  const auto ticks = linear_ticks(lo, hi, std::max(2, static_cast<int>(h / kPt / (2 * kFont))), scaling, whole);
  const double widest =
      vertical_ticks(c, x + w, ticks, [&](double t) { return y + h - (t - lo) / (hi - lo) * h; }, true);
  if (scaling.any()) c.text(scaling.text(), x, y - 0.3 * kFont * kPt, kFont, {0, 0, 0, 1}, 0.0, 1.0);
  if (!bar.label.empty())
    c.text(bar.label, x + w + 2 * kTick * kPt + widest + 0.4 * kFont * kPt, y + h / 2, kFont, {0, 0, 0, 1}, 0.5, 0.0,
           1);
}

// The width a colour bar takes right of its panel, labels included (pixels).
double colorbar_width(const Canvas& c, const Axes::Bar& bar, double panel_height, bool whole) {
  const double lo = bar.lo, hi = bar.hi > bar.lo ? bar.hi : bar.lo + 1.0;
  Scaling scaling;
  double widest = 0.0;
  for (const auto& t :
       linear_ticks(lo, hi, std::max(2, static_cast<int>(0.9 * panel_height / kPt / (2 * kFont))), scaling, whole))
    widest = std::max(widest, c.width(t.label, kFont));
  return 0.1 * kDpi + std::clamp(panel_height / 20.0, 0.08 * kDpi, 0.16 * kDpi) + 2 * kTick * kPt + widest +
         (bar.label.empty() ? 0.0 : 0.4 * kFont * kPt + c.ascent(kFont) + c.descent(kFont));
}

}  // namespace

class Renderer {
 public:
  static void axes(const Canvas& c, const Axes& a) {
    cairo_t* cr = c.cr;
    Range xl, yl, xs, ys;  // loose and sticky data ranges, scale space
    for (const auto& item : a.items_) {
      Range& rx = item.sticky ? xs : xl;
      Range& ry = item.sticky ? ys : yl;
      if (item.kind == Axes::Item::Kind::image) {
        rx.add(to_scale(item.x0, a.xscale_)), rx.add(to_scale(item.x1, a.xscale_));
        ry.add(to_scale(item.y0, a.yscale_)), ry.add(to_scale(item.y1, a.yscale_));
      } else if (item.kind == Axes::Item::Kind::hline) {
        ry.add(to_scale(item.y[0], a.yscale_));
      } else if (item.kind != Axes::Item::Kind::text) {
        for (double v : item.x) rx.add(to_scale(v, a.xscale_));
        for (double v : item.y) ry.add(to_scale(v, a.yscale_));
      }
    }
    Frame f{a.box_[0] * kDpi, a.box_[1] * kDpi, a.box_[2] * kDpi, a.box_[3] * kDpi,
            limits(xl, xs, a.xlim_, a.xscale_), limits(yl, ys, a.ylim_, a.yscale_), a.xscale_, a.yscale_};
    if (a.bar_) f.pw = std::max(f.pw - colorbar_width(c, *a.bar_, f.ph, a.whole_ticks_), 0.3 * f.pw);
    if (a.equal_) {
      const double scale = std::min(f.pw / (f.xl[1] - f.xl[0]), f.ph / (f.yl[1] - f.yl[0]));
      const double w = scale * (f.xl[1] - f.xl[0]), h = scale * (f.yl[1] - f.yl[0]);
      f.px += (f.pw - w) / 2, f.py += (f.ph - h) / 2, f.pw = w, f.ph = h;
    }
    // Ticks: about one per three label heights along x, two along y (matplotlib's density).
    Scaling xscaling, yscaling;
    const bool whole = a.whole_ticks_;
    auto xt = a.xscale_ == Scale::log
                  ? log_ticks(f.xl[0], f.xl[1])
                  : linear_ticks(f.xl[0], f.xl[1], std::clamp(static_cast<int>(f.pw / kPt / (3 * kFont)), 2, 9), xscaling,
                                 whole);
    // Whole map coordinates are long: fewer ticks until a label and a gap fit between two.
    for (int n = static_cast<int>(xt.size()) - 1; whole && a.xscale_ == Scale::linear && n > 2 && xt.size() > 2; --n) {
      double widest = 0.0;
      for (const auto& t : xt) widest = std::max(widest, c.width(t.label, kFont));
      if (f.XS(xt[1].at) - f.XS(xt[0].at) > widest + 1.2 * kFont * kPt) break;
      xt = linear_ticks(f.xl[0], f.xl[1], n - 1, xscaling, whole);
    }
    const auto yt = a.yscale_ == Scale::log
                        ? log_ticks(f.yl[0], f.yl[1])
                        : linear_ticks(f.yl[0], f.yl[1], std::clamp(static_cast<int>(f.ph / kPt / (2 * kFont)), 2, 9),
                                       yscaling, whole);
    cairo_rectangle(cr, f.px, f.py, f.pw, f.ph);
    c.color({1, 1, 1, 1});
    cairo_fill(cr);
    cairo_save(cr);
    cairo_rectangle(cr, f.px, f.py, f.pw, f.ph);
    cairo_clip(cr);
    if (a.grid_) {
      for (const auto& t : xt) cairo_move_to(cr, f.XS(t.at), f.py), cairo_line_to(cr, f.XS(t.at), f.py + f.ph);
      for (const auto& t : yt) cairo_move_to(cr, f.px, f.YS(t.at)), cairo_line_to(cr, f.px + f.pw, f.YS(t.at));
      c.color(Rgba::hex(0xb0b0b0, 0.3));
      c.dash({Rgba{}, 0.8, Dash::solid});
      cairo_stroke(cr);
    }
    for (const auto& item : a.items_)
      if (item.kind != Axes::Item::Kind::text) draw_item(c, f, item);
    cairo_restore(cr);
    for (const auto& item : a.items_)  // annotations may run past the frame
      if (item.kind == Axes::Item::Kind::text) draw_item(c, f, item);
    // Frame and ticks.
    cairo_rectangle(cr, f.px, f.py, f.pw, f.ph);
    c.color({0, 0, 0, 1});
    c.dash({Rgba{}, 0.8, Dash::solid});
    cairo_stroke(cr);
    const double len = kTick * kPt;
    double label_h = 0.0;
    for (const auto& t : xt) {
      const double u = f.XS(t.at);
      if (u < f.px - 0.5 || u > f.px + f.pw + 0.5) continue;
      cairo_move_to(cr, u, f.py + f.ph);
      cairo_line_to(cr, u, f.py + f.ph + len);
      c.text(t.label, u, f.py + f.ph + 2 * len, kFont, {0, 0, 0, 1}, 0.5, 0.0);
      label_h = c.ascent(kFont) + c.descent(kFont);
    }
    c.color({0, 0, 0, 1});
    c.dash({Rgba{}, 0.8, Dash::solid});
    cairo_stroke(cr);
    std::vector<Tick> yin;
    for (const auto& t : yt)
      if (f.YS(t.at) >= f.py - 0.5 && f.YS(t.at) <= f.py + f.ph + 0.5) yin.push_back(t);
    const double widest = vertical_ticks(c, f.px, yin, [&](double v) { return f.YS(v); }, false);
    if (xscaling.any()) c.text(xscaling.text(), f.px + f.pw, f.py + f.ph + 2 * len + label_h, kFont, {0, 0, 0, 1}, 1.0, 0.0);
    if (yscaling.any()) c.text(yscaling.text(), f.px, f.py - 0.3 * kFont * kPt, kFont, {0, 0, 0, 1}, 0.0, 1.0);
    const double below = f.py + f.ph + 2 * len + (label_h > 0 ? label_h : c.ascent(kFont) + c.descent(kFont)) + len;
    if (!a.xlabel_.empty()) c.text(a.xlabel_, f.px + f.pw / 2, below, kFont, {0, 0, 0, 1}, 0.5, 0.0);
    if (!a.ylabel_.empty())
      c.text(a.ylabel_, f.px - 2 * len - widest - len, f.py + f.ph / 2, kFont, {0, 0, 0, 1}, 0.5, 1.0, 1);
    if (!a.title_.empty())
      c.text(a.title_, f.px + f.pw / 2, f.py - 6.0 * kPt - (yscaling.any() ? label_h : 0.0), a.title_size_, {0, 0, 0, 1}, 0.5, 1.0);
    if (a.legend_)
      draw_legend(c, f, a.entries_, a.legend_->first, a.legend_->second,
                  a.bar_ ? colorbar_width(c, *a.bar_, f.ph, a.whole_ticks_) : 0.0);
    if (a.bar_) draw_colorbar(c, f, *a.bar_, a.whole_ticks_);
  }
};

Figure::Figure(double width, double height) : width_(width), height_(height) {}

Axes& Figure::add_axes(double left, double top, double width, double height) {
  axes_.push_back(std::make_unique<Axes>(left, top, width, height));
  return *axes_.back();
}

namespace {

// Writes an opaque ARGB32 image as an 8-bit RGB PNG. Plots are mostly flat colour: the
// "sub" filter and zlib level 3 halve the drawing time of the study's figures against
// libpng's defaults (adaptive filters, level 6). Returns false when the file cannot be
// written. No C++ object lives across the setjmp.
// libpng's default handlers print to stderr; the caller reports a failed write in one line.
void png_quiet_error(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void png_quiet_warning(png_structp, png_const_charp) {}

bool write_png(const char* path, const unsigned char* data, int width, int height, int stride, unsigned char* row) {
  std::FILE* file = std::fopen(path, "wb");
  if (!file) return false;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, png_quiet_error, png_quiet_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, info ? &info : nullptr);
    std::fclose(file);
    return false;
  }
  png_init_io(png, file);
  png_set_compression_level(png, 3);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  for (int j = 0; j < height; ++j) {
    const auto* pixel = reinterpret_cast<const std::uint32_t*>(data + static_cast<std::ptrdiff_t>(j) * stride);
    for (int i = 0; i < width; ++i) {
      row[3 * i] = static_cast<unsigned char>(pixel[i] >> 16);
      row[3 * i + 1] = static_cast<unsigned char>(pixel[i] >> 8);
      row[3 * i + 2] = static_cast<unsigned char>(pixel[i]);
    }
    png_write_row(png, row);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return std::fclose(file) == 0;
}

// Cairo numbers the surfaces and images of its SVG output with counters shared by the
// whole process, so a figure's ids would depend on what was drawn before it (and, with
// threads, when). Renumbers them from 1 in order of first appearance.
std::string renumber_svg_ids(const std::string& svg) {
  std::string out;
  out.reserve(svg.size());
  std::map<std::string, int> seen;
  int surfaces = 0, images = 0;
  std::size_t at = 0;
  while (at < svg.size()) {
    std::size_t hit = std::string::npos, skip = 0;
    for (const char* prefix : {"id=\"surface", "id=\"image", "#surface", "#image"}) {
      const std::size_t h = svg.find(prefix, at);
      if (h < hit) hit = h, skip = std::char_traits<char>::length(prefix);
    }
    if (hit == std::string::npos) break;
    std::size_t end = hit + skip;
    while (end < svg.size() && std::isdigit(static_cast<unsigned char>(svg[end]))) ++end;
    out.append(svg, at, hit + skip - at);
    if (end > hit + skip) {
      const bool image = svg.compare(hit + skip - 5, 5, "image") == 0;
      const std::string key = (image ? "i" : "s") + svg.substr(hit + skip, end - hit - skip);
      auto [it, fresh] = seen.try_emplace(key, 0);
      if (fresh) it->second = image ? ++images : ++surfaces;
      out += std::to_string(it->second);
    }
    at = end;
  }
  out.append(svg, at, std::string::npos);
  return out;
}

cairo_status_t append_to_string(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

void check(cairo_status_t status, const std::string& path) {
  if (status != CAIRO_STATUS_SUCCESS)
    throw core::RuntimeError(path + ": cannot write the plot (" + cairo_status_to_string(status) + ")");
}

}  // namespace

void Figure::save(const std::string& path, Format format) const {
  namespace fs = std::filesystem;
  const fs::path final_path(path);
  const fs::path temp = final_path.parent_path() /
                        ("." + final_path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                         std::to_string(reinterpret_cast<std::uintptr_t>(this)));
  std::string svg;
  cairo_surface_t* surface =
      format == Format::png
          ? cairo_image_surface_create(CAIRO_FORMAT_ARGB32, static_cast<int>(std::lround(width_ * kDpi)),
                                       static_cast<int>(std::lround(height_ * kDpi)))
          : cairo_svg_surface_create_for_stream(append_to_string, &svg, width_ * 72.0, height_ * 72.0);
  cairo_t* cr = cairo_create(surface);
  if (format == Format::svg) cairo_scale(cr, 72.0 / kDpi, 72.0 / kDpi);
  const Canvas c{cr};
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  for (const auto& a : axes_) Renderer::axes(c, *a);
  if (!suptitle_.empty())
    c.text(suptitle_, width_ * kDpi / 2, 0.1 * kDpi, suptitle_size_, {0, 0, 0, 1}, 0.5, 0.0);
  const cairo_status_t drawn = cairo_status(cr);
  cairo_destroy(cr);
  cairo_status_t written = CAIRO_STATUS_SUCCESS;
  if (format == Format::png) {
    if (drawn == CAIRO_STATUS_SUCCESS) {
      cairo_surface_flush(surface);
      const int w = cairo_image_surface_get_width(surface);
      std::vector<unsigned char> row(3 * static_cast<std::size_t>(w));
      if (!write_png(temp.c_str(), cairo_image_surface_get_data(surface), w, cairo_image_surface_get_height(surface),
                     cairo_image_surface_get_stride(surface), row.data()))
        written = CAIRO_STATUS_WRITE_ERROR;
    }
  } else {
    cairo_surface_finish(surface);
    written = cairo_surface_status(surface);
    if (drawn == CAIRO_STATUS_SUCCESS && written == CAIRO_STATUS_SUCCESS) {
      std::FILE* file = std::fopen(temp.c_str(), "wb");
      const std::string text = renumber_svg_ids(svg);
      const bool ok = file && std::fwrite(text.data(), 1, text.size(), file) == text.size();
      if ((file && std::fclose(file) != 0) || !ok) written = CAIRO_STATUS_WRITE_ERROR;
    }
  }
  cairo_surface_destroy(surface);
  std::error_code ec;
  if (drawn != CAIRO_STATUS_SUCCESS || written != CAIRO_STATUS_SUCCESS) {
    fs::remove(temp, ec);
    check(drawn != CAIRO_STATUS_SUCCESS ? drawn : written, path);
  }
  fs::rename(temp, final_path, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw core::RuntimeError(path + ": cannot write the plot (" + ec.message() + ")");
  }
}

}  // namespace talus::plot
