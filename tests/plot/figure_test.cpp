// SPDX-License-Identifier: MIT
// Figures drawn with Cairo (libs/plot/src/figure.cpp): the colour maps against their
// published values, and where data lands in the pixels of a PNG read back with libpng
// (images, lines, log scales, filled contours), SVG size, byte-identical repeats, and a
// file that cannot be written.
#include "talus/plot/figure.hpp"

#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "talus/core/error.hpp"

namespace talus::plot {
namespace {

namespace fs = std::filesystem;

struct Pixels {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  Rgba at(std::uint32_t x, std::uint32_t y) const {
    const std::size_t k = 3 * (static_cast<std::size_t>(y) * width + x);
    return {rgb[k] / 255.0, rgb[k + 1] / 255.0, rgb[k + 2] / 255.0, 1.0};
  }
};

Pixels read_png(const fs::path& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  EXPECT_NE(png_image_begin_read_from_file(&image, path.c_str()), 0) << path;
  image.format = PNG_FORMAT_RGB;
  Pixels p{image.width, image.height, std::vector<std::uint8_t>(PNG_IMAGE_SIZE(image))};
  EXPECT_NE(png_image_finish_read(&image, nullptr, p.rgb.data(), 0, nullptr), 0) << path;
  return p;
}

std::string bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Within `tol` of each other per channel.
::testing::AssertionResult near(const Rgba& a, const Rgba& b, double tol = 2.5 / 255) {
  if (std::abs(a.r - b.r) <= tol && std::abs(a.g - b.g) <= tol && std::abs(a.b - b.b) <= tol)
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "(" << a.r * 255 << ", " << a.g * 255 << ", " << a.b * 255 << ") against ("
                                       << b.r * 255 << ", " << b.g * 255 << ", " << b.b * 255 << ")";
}

class PlotFigure : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("talus_plot_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST(PlotColormap, MatchesThePublishedTables) {
  // The ends and the middle entries of the 256-entry tables.
  EXPECT_TRUE(near(Colormap::named("viridis").at(0.0), Rgba::hex(0x440154)));
  EXPECT_TRUE(near(Colormap::named("viridis").at(1.0), Rgba::hex(0xfde725)));
  EXPECT_TRUE(near(Colormap::named("viridis").at(128.0 / 255), Rgba::hex(0x21918c), 3.0 / 255));
  EXPECT_TRUE(near(Colormap::named("magma").at(1.0), Rgba::hex(0xfcfdbf)));
  EXPECT_TRUE(near(Colormap::named("plasma").at(0.0), Rgba::hex(0x0d0887)));
  EXPECT_TRUE(near(Colormap::named("cividis").at(1.0), Rgba::hex(0xfee838)));
  EXPECT_TRUE(near(Colormap::named("terrain").at(0.5), Rgba{1.0, 1.0, 0.6, 1.0}));
  // Clamped outside [0, 1]; unknown names refused.
  EXPECT_TRUE(near(Colormap::named("viridis").at(-3.0), Rgba::hex(0x440154)));
  EXPECT_TRUE(near(Colormap::named("viridis").at(std::nan("")), Rgba::hex(0x440154)));
  EXPECT_THROW(Colormap::named("jet"), std::invalid_argument);
}

TEST_F(PlotFigure, ImageCellsLandWhereTheirCoordinatesSay) {
  // A 2 × 2 in figure, one 1 × 1 in panel from (0.5, 0.5) in: pixels 60–180 at 120 per
  // inch. Cells of 1 m centred at (0.5, 0.5) … (1.5, 1.5): the panel spans [0, 2] m.
  Figure fig(2.0, 2.0);
  Axes& ax = fig.add_axes(0.5, 0.5, 1.0, 1.0);
  const auto& map = Colormap::named("viridis");
  ax.image({0.0, 1.0, std::nan(""), 3.0}, 2, 2, 0.5, 0.5, 1.0, 1.0, map, 0.0, 3.0);
  const fs::path png = dir_ / "image.png";
  fig.save(png.string(), Format::png);
  const Pixels p = read_png(png);
  ASSERT_EQ(p.width, 240u);
  ASSERT_EQ(p.height, 240u);
  EXPECT_TRUE(near(p.at(90, 150), map.at(0.0)));        // x, y in [0, 1] m: value 0
  EXPECT_TRUE(near(p.at(150, 150), map.at(1.0 / 3)));   // x in [1, 2], y in [0, 1]: value 1
  EXPECT_TRUE(near(p.at(90, 90), Rgba{1, 1, 1, 1}));    // no value: blank
  EXPECT_TRUE(near(p.at(150, 90), map.at(1.0)));        // value 3
  EXPECT_TRUE(near(p.at(20, 20), Rgba{1, 1, 1, 1}));    // outside the panel

  // 10 000 × 2 cells of 0.2 mm (thinned to every third): the left half 0, the right half 3.
  Figure wide(2.0, 2.0);
  Axes& w = wide.add_axes(0.5, 0.5, 1.0, 1.0);
  std::vector<double> halves(20000, 0.0);
  for (std::size_t j = 0; j < 2; ++j)
    for (std::size_t i = 5000; i < 10000; ++i) halves[j * 10000 + i] = 3.0;
  w.image(halves, 10000, 2, 1e-4, 0.5, 2e-4, 1.0, map, 0.0, 3.0);
  const fs::path wpng = dir_ / "wide.png";
  wide.save(wpng.string(), Format::png);
  const Pixels pw = read_png(wpng);
  EXPECT_TRUE(near(pw.at(90, 120), map.at(0.0)));
  EXPECT_TRUE(near(pw.at(150, 120), map.at(1.0)));
}

TEST_F(PlotFigure, MapsGiveWholeCoordinatesClassColoursAndSeeThroughRasters) {
  // Class k of a listed map gets colour k exactly; the gray map runs black to white.
  const Colormap classes = Colormap::listed("classes", {Rgba::hex(0xffd700), Rgba::hex(0x2f6fdf), Rgba::hex(0xe0201b)});
  EXPECT_TRUE(near(classes.at(0.5), Rgba::hex(0x2f6fdf)));
  EXPECT_TRUE(near(classes.at(1.0), Rgba::hex(0xe0201b)));
  EXPECT_TRUE(near(Colormap::named("gray").at(0.0), Rgba{0, 0, 0, 1}));
  EXPECT_TRUE(near(Colormap::named("gray").at(1.0), Rgba{1, 1, 1, 1}));

  // Projected coordinates (2 601 000 … 2 601 100 m): the default ticks set the shared
  // digits apart in a line under the tick labels; whole tick labels leave that line empty.
  // A 2.5 in high figure, the panel's bottom at 1.5 in (pixel 180), its tick labels from
  // about pixel 192 to 211.
  const auto ink_below_labels = [&](bool whole) {
    Figure fig(3.0, 2.5);
    Axes& ax = fig.add_axes(0.5, 0.5, 2.0, 1.0);
    ax.line({2601000.0, 2601100.0}, {1180000.0, 1180050.0}, {Rgba{0, 0, 0, 1}, 1.0, Dash::solid});
    if (whole) ax.set_whole_tick_labels();
    const fs::path png = dir_ / (whole ? "whole.png" : "offset.png");
    fig.save(png.string(), Format::png);
    const Pixels p = read_png(png);
    int ink = 0;
    for (std::uint32_t y = 214; y < 245; ++y)
      for (std::uint32_t x = 0; x < p.width; ++x) ink += p.at(x, y).r < 0.5;
    return ink;
  };
  EXPECT_GT(ink_below_labels(false), 20);
  EXPECT_EQ(ink_below_labels(true), 0);

  // A raster at 50 % over white: half way from white to its colour.
  Figure fig(2.0, 2.0);
  Axes& ax = fig.add_axes(0.5, 0.5, 1.0, 1.0);
  ax.image({1.0}, 1, 1, 0.5, 0.5, 1.0, 1.0, Colormap::named("gray"), 0.0, 2.0, 0.5);
  const fs::path png = dir_ / "alpha.png";
  fig.save(png.string(), Format::png);
  EXPECT_TRUE(near(read_png(png).at(120, 120), Rgba{0.75, 0.75, 0.75, 1}));
}

TEST_F(PlotFigure, LinesAndMarkersFollowLinearAndLogScales) {
  Figure fig(2.0, 2.0);
  Axes& lin = fig.add_axes(0.5, 0.5, 1.0, 1.0);
  lin.set_xlim(0.0, 1.0);
  lin.set_ylim(0.0, 1.0);
  const Rgba red{1, 0, 0, 1};
  lin.hline(0.25, {red, 3.0, Dash::solid});  // at pixel row 60 + 0.75 · 120 = 150
  const fs::path a = dir_ / "line.png";
  fig.save(a.string(), Format::png);
  const Pixels pa = read_png(a);
  EXPECT_TRUE(near(pa.at(120, 150), red));
  EXPECT_TRUE(near(pa.at(120, 140), Rgba{1, 1, 1, 1}));

  Figure logfig(2.0, 2.0);
  Axes& log = logfig.add_axes(0.5, 0.5, 1.0, 1.0);
  log.set_scale(Scale::log, Scale::log);
  log.set_xlim(1.0, 100.0);
  log.set_ylim(1.0, 1000.0);
  const Rgba blue{0, 0, 1, 1};
  // (10, 100): half of the x decades, two thirds of the y decades: pixel (120, 100).
  log.markers({10.0}, {100.0}, blue, 6.0);
  const fs::path b = dir_ / "log.png";
  logfig.save(b.string(), Format::png);
  const Pixels pb = read_png(b);
  EXPECT_TRUE(near(pb.at(120, 100), blue));
  EXPECT_TRUE(near(pb.at(120, 120), Rgba{1, 1, 1, 1}));
}

TEST_F(PlotFigure, ContoursFillTheSurfaceByBands) {
  // z = x on the unit square: the bands run across x, lowest colour on the left. Two
  // triangles are drawn as polygons; 240 000 (a grid of 300 × 400 cells) as a raster.
  for (const int cells : {1, 300}) {
    std::vector<double> x, y;
    std::vector<std::array<std::int32_t, 3>> triangles;
    const int ny = cells == 1 ? 1 : 400;
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= cells; ++i) x.push_back(static_cast<double>(i) / cells), y.push_back(static_cast<double>(j) / ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < cells; ++i) {
        const std::int32_t a = j * (cells + 1) + i, b = a + 1, c = a + cells + 2, d = a + cells + 1;
        triangles.push_back({a, b, c});
        triangles.push_back({a, c, d});
      }
    Figure fig(2.0, 2.0);
    Axes& ax = fig.add_axes(0.5, 0.5, 1.0, 1.0);
    const auto& map = Colormap::named("viridis");
    ax.contours(x, y, x, triangles, 10, map, 1.0);
    ASSERT_TRUE(ax.has_data());
    const fs::path png = dir_ / ("contours-" + std::to_string(cells) + ".png");
    fig.save(png.string(), Format::png);
    const Pixels p = read_png(png);
    EXPECT_TRUE(near(p.at(63, 80), map.at(0.05), 4.0 / 255)) << cells;   // first band, x in [0, 0.1]
    EXPECT_TRUE(near(p.at(177, 150), map.at(0.95), 4.0 / 255)) << cells; // last band, x in [0.9, 1]
    EXPECT_TRUE(near(p.at(123, 70), map.at(0.55), 4.0 / 255)) << cells;  // x ≈ 0.525
  }
}

TEST_F(PlotFigure, SvgAndRepeatsAreExact) {
  const auto draw = [](const fs::path& path, Format f) {
    Figure fig(3.0, 2.0);
    Axes& ax = fig.add_axes(0.6, 0.4, 2.2, 1.2);
    ax.step({0.0, 1.0, 2.0, 5.0}, {0.0, 0.25, 0.75, 1.0}, {cycle_color(0), 1.3, Dash::solid}, "steps");
    ax.step_band({0.0, 1.0, 2.0, 5.0}, {0.0, 0.1, 0.6, 0.9}, {0.1, 0.4, 0.9, 1.0}, cycle_color(0).with_alpha(0.15));
    ax.set_xlabel("x (m)");
    ax.set_ylabel("F(x)");
    ax.set_title("a panel");
    ax.grid();
    ax.legend(Place::lower_right, kXSmall);
    fig.suptitle("a figure");
    fig.save(path.string(), f);
  };
  draw(dir_ / "a.png", Format::png);
  draw(dir_ / "b.png", Format::png);
  EXPECT_TRUE(bytes(dir_ / "a.png") == bytes(dir_ / "b.png"));
  draw(dir_ / "a.svg", Format::svg);
  draw(dir_ / "b.svg", Format::svg);
  const std::string svg = bytes(dir_ / "a.svg");
  EXPECT_TRUE(svg == bytes(dir_ / "b.svg"));
  EXPECT_NE(svg.find("width=\"216pt\" height=\"144pt\""), std::string::npos) << svg.substr(0, 300);
  // Only the four files: no temporary one left.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator{}), 4);
}

TEST_F(PlotFigure, AFileThatCannotBeWrittenIsNamed) {
  Figure fig(1.0, 1.0);
  fig.add_axes(0.2, 0.2, 0.6, 0.6).line({0.0, 1.0}, {0.0, 1.0}, {});
  for (Format f : {Format::png, Format::svg}) {
    const std::string path = (dir_ / "missing" / "x.png").string();
    try {
      fig.save(path, f);
      ADD_FAILURE() << "no error";
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(fs::exists(dir_ / "missing"));
}

}  // namespace
}  // namespace talus::plot
