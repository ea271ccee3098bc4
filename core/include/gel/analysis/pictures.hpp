#pragma once
// Pictures (README "Analysis and pictures"): snapshots of configurations drawn with cairo, and
// plots drawn by gnuplot, as PNG or SVG chosen by the file name's ending.
//
// Snapshots: disks (blue), particles stuck to a wall (red), bonds as dark lines between the
// centres (minimum image, drawn on both sides of the periodic boundary), the walls as grey
// bars, and optionally a circle of diameter 4 xi^(0.5) in the middle of the region. The region
// drawn is the box in x and the wall gap (or the box) in y, scaled so that the longer side has
// `size` pixels (PNG) or points (SVG).
//
// Plots: a figure is a set of series (lines, points, error bars) on linear or log axes plus
// labelled vertical lines; it is written as NAME.dat (the data, one gnuplot index per series)
// and NAME.gp (the script) into a `gnuplot/` folder next to the picture, so a plot can be
// re-drawn or restyled by hand, and gnuplot is run on the script (pngcairo or svg terminal).
// gnuplot is looked up on PATH; without it, render_plot throws std::runtime_error saying so.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gel/configuration.hpp"

namespace gel::analysis {

// Colours (r, g, b in 0..1) so that tests can look for them.
struct Rgb {
  double r, g, b;
};
inline constexpr Rgb kParticleColour{0.27, 0.51, 0.71};
inline constexpr Rgb kWallParticleColour{0.84, 0.15, 0.16};
inline constexpr Rgb kBondColour{0.10, 0.10, 0.10};

struct SnapshotStyle {
  int size = 1200;                  // pixels (PNG) / points (SVG) of the longer side
  bool bonds = true;
  std::optional<double> xi_circle;  // draw a circle of diameter 4 * this
  std::string title;                // printed in the upper-left corner when not empty
  // Smooth edges. Off, a PNG has only the few drawing colours and compresses about 3x better
  // (pictures meant to be stored in the repository).
  bool antialias = true;
};
// Throws InvalidArgument ("out") unless path ends in .png or .svg, std::runtime_error when
// cairo cannot write the file.
void render_snapshot(const Configuration& config, const std::string& path, const SnapshotStyle& style = {});

struct PlotSeries {
  std::string title;
  std::vector<double> x, y;
  std::vector<double> y_error;   // drawn as error bars when not empty
  std::string style = "linespoints";  // gnuplot "with" style: lines, points, linespoints
};

struct PlotFigure {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<PlotSeries> series;
  std::vector<std::pair<double, std::string>> vertical_lines;  // x, label
  int width = 900, height = 650;
  std::string key_position = "top left";  // gnuplot "set key inside ..." placement
};

// The gnuplot executable on PATH, or empty.
std::string find_gnuplot();
// Writes `path` (.png or .svg) with gnuplot. Points that a log axis cannot show (<= 0) are left
// out of the data file.
void render_plot(const PlotFigure& figure, const std::string& path);

}  // namespace gel::analysis
