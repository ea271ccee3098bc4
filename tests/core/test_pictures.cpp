// Pictures (docs/analysis.md): snapshots read back pixel by pixel, plots through gnuplot and the
// scripts kept beside them.
#include <cairo.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "gel/analysis/pictures.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "analysis_samples.hpp"

#if defined(__SANITIZE_ADDRESS__)
// cairo's text drawing (snapshot titles) loads fontconfig, which keeps its font caches until the
// process ends by design; LeakSanitizer reports them. They are not ours: suppress them by
// library, nothing else. One definition for the whole core_tests binary (test_run_analysis.cpp
// draws snapshots too).
extern "C" const char* __lsan_default_suppressions() { return "leak:libfontconfig.so\n"; }
#endif

namespace gel::analysis {
namespace {

// Colour of device pixel (x, y) of a PNG, as 0..255 per channel.
struct Pixel {
  int r, g, b;
};

Pixel png_pixel(cairo_surface_t* image, int x, int y) {
  const unsigned char* data = cairo_image_surface_get_data(image);
  const int stride = cairo_image_surface_get_stride(image);
  const auto word = *reinterpret_cast<const std::uint32_t*>(data + y * stride + 4 * x);
  return {static_cast<int>((word >> 16) & 255), static_cast<int>((word >> 8) & 255), static_cast<int>(word & 255)};
}

void expect_colour(const Pixel& p, const Rgb& c) {
  EXPECT_NEAR(p.r, 255 * c.r, 2);
  EXPECT_NEAR(p.g, 255 * c.g, 2);
  EXPECT_NEAR(p.b, 255 * c.b, 2);
}

TEST(Pictures, SnapshotHasTheBoxSizeAndParticlesWhereTheyAre) {
  // 40 a x 20 a between walls at y = 0 and 20: with one radius of margin above and below the
  // drawn region is 40 x 22 a, 400 px wide at size 400 (10 px per a), y pointing up.
  Configuration c;
  c.lx = 40, c.ly = 20, c.periodic_y = false;
  c.add_particle(10, 10);                       // free, unbonded
  c.add_particle(30, 1);                        // on the bottom wall
  c.add_particle(20, 15), c.add_particle(22, 15);
  c.add_bond_at_contact(2, 3);
  c.wall = {kNoWall, kBottomWall, kNoWall, kNoWall};
  c.wall_bottom = 0, c.wall_top = 20;
  const std::string dir = temp_dir("snapshot");
  const std::string png = dir + "/s.png", svg = dir + "/s.svg";
  render_snapshot(c, png, {400, true, 3.0, ""});
  cairo_surface_t* image = cairo_image_surface_create_from_png(png.c_str());
  ASSERT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
  EXPECT_EQ(cairo_image_surface_get_width(image), 400);
  EXPECT_EQ(cairo_image_surface_get_height(image), 220);
  auto device = [](double x, double y) { return std::pair<int, int>(static_cast<int>(x * 10), static_cast<int>((21 - y) * 10)); };
  auto [fx, fy] = device(10, 10);
  expect_colour(png_pixel(image, fx, fy), kParticleColour);
  auto [wx, wy] = device(30, 1);
  expect_colour(png_pixel(image, wx, wy), kWallParticleColour);
  auto [bx, by] = device(21, 15);  // the contact point, on the bond line
  expect_colour(png_pixel(image, bx, by), kBondColour);
  auto [ex, ey] = device(5, 5);    // empty space
  const Pixel empty = png_pixel(image, ex, ey);
  EXPECT_EQ(empty.r + empty.g + empty.b, 3 * 255);
  cairo_surface_destroy(image);
  render_snapshot(c, svg);
  std::ifstream in(svg);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("<svg"), std::string::npos);
  EXPECT_THROW(render_snapshot(c, dir + "/s.jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, GnuplotDrawsALogLogPlot) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.title = "test";
  f.log_x = f.log_y = true;
  f.width = 320, f.height = 240;
  PlotSeries s{"data", {0.1, 0.2, 0.4}, {1, 8, 64}, {0.1, 0.5, 3}, "linespoints"};
  f.series.push_back(s);
  f.series.push_back({"skipped on log axes", {0.1, 0.2}, {-1, 0}, {}, "lines"});
  f.vertical_lines.push_back({0.3, "boundary"});
  const std::string dir = temp_dir("plot");
  render_plot(f, dir + "/p.png");
  cairo_surface_t* image = cairo_image_surface_create_from_png((dir + "/p.png").c_str());
  ASSERT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
  EXPECT_EQ(cairo_image_surface_get_width(image), 320);
  EXPECT_EQ(cairo_image_surface_get_height(image), 240);
  int dark = 0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      const Pixel p = png_pixel(image, x, y);
      dark += p.r + p.g + p.b < 300;
    }
  EXPECT_GT(dark, 200);  // axes, text and the curve
  cairo_surface_destroy(image);
  EXPECT_TRUE(std::filesystem::exists(dir + "/gnuplot/p.gp"));
  std::filesystem::remove_all(dir);
}

TEST(Pictures, SnapshotHasAScaleBarAndWritesPdf) {
  // An empty periodic 40 a x 20 a box, 10 px per a (400 x 200 px): the bar (5 a, a fifth of
  // the width rounded down to 1, 2 or 5 a) lies in the bottom-right corner.
  Configuration c;
  c.lx = 40, c.ly = 20;
  const std::string dir = temp_dir("scale_bar");
  auto dark_pixels_bottom_right = [&](bool scale_bar) {
    SnapshotStyle style;
    style.size = 400;
    style.scale_bar = scale_bar;
    render_snapshot(c, dir + "/s.png", style);
    cairo_surface_t* image = cairo_image_surface_create_from_png((dir + "/s.png").c_str());
    EXPECT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
    int dark = 0, dark_run = 0, longest_run = 0;
    for (int y = 150; y < 200; ++y) {
      dark_run = 0;
      for (int x = 200; x < 400; ++x) {
        const Pixel p = png_pixel(image, x, y);
        const bool is_dark = p.r + p.g + p.b < 100;
        dark += is_dark;
        dark_run = is_dark ? dark_run + 1 : 0;
        longest_run = std::max(longest_run, dark_run);
      }
    }
    cairo_surface_destroy(image);
    return std::pair<int, int>(dark, longest_run);
  };
  const auto [with_bar, bar_length] = dark_pixels_bottom_right(true);
  EXPECT_GT(with_bar, 100);
  EXPECT_NEAR(bar_length, 50, 2);  // 5 a at 10 px per a
  EXPECT_EQ(dark_pixels_bottom_right(false).first, 0);
  render_snapshot(c, dir + "/s.pdf");
  EXPECT_EQ(file_text(dir + "/s.pdf").substr(0, 5), "%PDF-");
  EXPECT_EQ(picture_format_of_path("A.PDF"), PictureFormat::pdf);
  EXPECT_THROW(parse_picture_format("jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, PlotScriptIsForAPaperAndRunsWhereverItIsCopied) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.title = "what the figure shows";
  f.x_label = "{/:Italic φ}";
  f.y_label = "{/:Italic P}_y  [{/:Italic F}_0/{/:Italic a}^2]";
  f.log_x = f.log_y = true;
  f.width = 320, f.height = 240;
  // Falling from the upper left: the key belongs in the upper right. The first bar reaches
  // below zero, which a log axis cannot show: it must end at the axis' bottom.
  f.series.push_back({"{/:Italic P}_y", {0.1, 0.2, 0.4}, {64, 8, 1}, {70, 0.5, 0.2}, "linespoints"});
  f.series.push_back({"{/:Italic P}_y ∝ {/:Italic φ}^{−3}", {0.1, 0.4}, {64, 1}, {}, "lines", true});
  const std::string dir = temp_dir("paper_plot");
  render_plot(f, dir + "/p.png");
  const std::string script = file_text(dir + "/gnuplot/p.gp");
  EXPECT_EQ(script.find("set title"), std::string::npos);
  EXPECT_EQ(script.find(dir), std::string::npos) << "absolute path in the kept script";
  EXPECT_EQ(script.find("noenhanced"), std::string::npos);
  EXPECT_NE(script.find("set key inside top right"), std::string::npos) << script;
  EXPECT_NE(script.find("set format y \"%g\""), std::string::npos);
  EXPECT_NE(script.find("using 1:2:3:4 with yerrorlines"), std::string::npos);
  // The bar's lower end: at the bottom of the y range, not left out.
  double y_lo = 0, y_hi = 0;
  ASSERT_EQ(std::sscanf(script.c_str() + script.find("set yrange ["), "set yrange [%lf:%lf]", &y_lo, &y_hi), 2);
  std::istringstream data(file_text(dir + "/gnuplot/p.dat"));
  std::string line;
  while (std::getline(data, line) && (line.empty() || line[0] == '#')) {
  }
  double x = 0, y = 0, low = 0, high = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "%lf %lf %lf %lf", &x, &y, &low, &high), 4) << line;
  EXPECT_EQ(y, 64);
  EXPECT_EQ(low, y_lo);
  EXPECT_GT(low, 0);
  EXPECT_EQ(high, 134);

  // The kept folder copied elsewhere redraws the picture there.
  const std::string copy = dir + "/copied";
  std::filesystem::create_directories(copy + "/gnuplot");
  for (const char* name : {"p.gp", "p.dat"}) std::filesystem::copy_file(dir + "/gnuplot/" + name, copy + "/gnuplot/" + name);
  ASSERT_EQ(std::system(("cd '" + copy + "/gnuplot' && gnuplot p.gp 2>/dev/null").c_str()), 0);
  EXPECT_GT(std::filesystem::file_size(copy + "/p.png"), 1000u);

  render_plot(f, dir + "/p.pdf");
  EXPECT_EQ(file_text(dir + "/p.pdf").substr(0, 5), "%PDF-");
  EXPECT_NE(file_text(dir + "/gnuplot/p_pdf.gp").find("set terminal pdfcairo"), std::string::npos);
  EXPECT_THROW(render_plot(f, dir + "/p.jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, KeyLeavesThePlotAreaWhenDataFillEveryCorner) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.width = 320, f.height = 240;
  f.series.push_back({"zigzag", {0, 1, 2, 3, 4}, {0, 1, 0, 1, 0}, {}, "lines"});
  f.series.push_back({"zagzig", {0, 1, 2, 3, 4}, {1, 0, 1, 0, 1}, {}, "lines"});
  const std::string dir = temp_dir("key_outside");
  render_plot(f, dir + "/k.svg");
  const std::string script = file_text(dir + "/gnuplot/k_svg.gp");
  EXPECT_EQ(script.find("set key inside"), std::string::npos) << script;
  EXPECT_NE(script.find("set key outside"), std::string::npos) << script;
  EXPECT_NE(file_text(dir + "/k.svg").find("<svg"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, VerticalLineLabelsSitAboveTheFrameWhereNoPointIs) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  // Points along the whole height beside both lines: inside the frame every place a label could
  // take along a line covers some of them. The two lines are closer than a label is long, so
  // the second label goes up a row instead of overprinting the first.
  PlotFigure f;
  f.width = 320, f.height = 240;
  PlotSeries dense{"data", {}, {}, {}, "points"};
  for (int i = 0; i <= 40; ++i)
    for (double x : {0.43, 0.47, 0.53, 0.57}) dense.x.push_back(x), dense.y.push_back(i / 40.0);
  f.series.push_back(dense);
  f.series.push_back({"edges", {0.0, 1.0}, {0.0, 1.0}, {}, "points"});
  f.vertical_lines = {{0.45, "single-mode plastic"}, {0.55, "multi-mode plastic"}};
  const std::string dir = temp_dir("vertical_labels");
  render_plot(f, dir + "/v.png");
  const std::string script = file_text(dir + "/gnuplot/v.gp");
  std::vector<double> row_offsets;
  std::istringstream lines(script);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("set label", 0) != 0) continue;
    // set label N "TEXT" at X, graph Y ... offset DX,DY ...
    const std::size_t at = line.find("\" at ");
    ASSERT_NE(at, std::string::npos) << line;
    double x = 0, y = 0, dx = 0, dy = 0;
    ASSERT_EQ(std::sscanf(line.c_str() + at, "\" at %lf, graph %lf", &x, &y), 2) << line;
    const std::size_t offset = line.find(" offset ");
    ASSERT_NE(offset, std::string::npos) << line;
    ASSERT_EQ(std::sscanf(line.c_str() + offset, " offset %lf,%lf", &dx, &dy), 2) << line;
    EXPECT_GE(y, 1.0) << "label inside the frame, where it can cover a point: " << line;
    EXPECT_GT(dy, 0.0) << line;
    row_offsets.push_back(dy);
  }
  ASSERT_EQ(row_offsets.size(), 2u) << script;
  EXPECT_NE(row_offsets[0], row_offsets[1]) << "overlapping labels on one row";
  EXPECT_NE(script.find("set tmargin"), std::string::npos) << "no room above the frame";
  EXPECT_GT(std::filesystem::file_size(dir + "/v.png"), 1000u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel::analysis
