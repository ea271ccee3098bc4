#pragma once
// Pictures (docs/analysis.md): snapshots of configurations drawn with cairo, and
// plots drawn by gnuplot, as PNG, SVG or PDF chosen by the file name's ending. They are meant
// to go into a paper as they are: no title inside (the caption says what a figure shows),
// typeset labels, keys off the data, and vector output (SVG, PDF) besides PNG.
//
// Snapshots: disks (blue), particles stuck to a wall (red), bonds as dark lines between the
// centres (minimum image, drawn on both sides of the periodic boundary), the walls as grey
// bars, optionally a circle of diameter 4 xi^(0.5) in the middle of the region, and a labelled
// scale bar (1, 2 or 5 times a power of ten of a, about a fifth of the box width) in the corner
// of the region that has the fewest particles. The region drawn is the box in x and the wall gap
// (or the box) in y, scaled so that the longer side has `size` pixels (PNG) or points (SVG, PDF).
//
// Plots: a figure is a set of series (lines, points, error bars) on linear or log axes plus
// labelled vertical lines (each label above the frame, where it cannot cover a point); it is
// written as NAME.dat (the data, one gnuplot index per series) and NAME.gp (the script) into a
// `gnuplot/` folder next to the picture, the script naming both files relative to that folder,
// so that `cd gnuplot && gnuplot NAME.gp` redraws the picture wherever the folder has been
// copied, and gnuplot is run on the script (pngcairo, svg or pdfcairo terminal). Titles and
// labels are gnuplot enhanced text: "P_y", "a^2", "φ^{4.14}", "{/:Italic r}" (UTF-8 for Greek
// letters). The axis ranges are taken from the data (error bars included), the key goes into
// an inside corner that no data, bar or vertical line reaches, or outside the plot area when
// there is none. gnuplot is looked up on PATH; without it,
// render_plot throws std::runtime_error saying so.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gel/configuration.hpp"

namespace gel::analysis {

enum class PictureFormat { png, svg, pdf };
// "png", "svg" or "pdf"; throws InvalidArgument ("format") otherwise.
PictureFormat parse_picture_format(const std::string& name);
// ".png", ".svg" or ".pdf".
std::string picture_extension(PictureFormat format);
// By the ending of the file name (any case); throws InvalidArgument ("out") for another ending.
PictureFormat picture_format_of_path(const std::string& path);

// Colours (r, g, b in 0..1) so that tests can look for them.
struct Rgb {
  double r, g, b;
};
inline constexpr Rgb kParticleColour{0.27, 0.51, 0.71};
inline constexpr Rgb kWallParticleColour{0.84, 0.15, 0.16};
inline constexpr Rgb kBondColour{0.10, 0.10, 0.10};

struct SnapshotStyle {
  int size = 1200;                  // pixels (PNG) / points (SVG, PDF) of the longer side
  bool bonds = true;
  std::optional<double> xi_circle;  // draw a circle of diameter 4 * this
  std::string title;                // printed in the upper-left corner when not empty
  // Smooth edges. Off, a PNG has only the few drawing colours and compresses about 3x better
  // (pictures meant to be stored in the repository).
  bool antialias = true;
  bool scale_bar = true;
};
// Throws InvalidArgument ("out") unless path ends in .png, .svg or .pdf, std::runtime_error
// when cairo cannot write the file.
void render_snapshot(const Configuration& config, const std::string& path, const SnapshotStyle& style = {});

struct PlotSeries {
  std::string title;                  // in the key; empty: not in the key
  std::vector<double> x, y;
  std::vector<double> y_error;        // drawn as error bars when not empty
  std::string style = "linespoints";  // gnuplot "with" style: lines, points, linespoints
  bool dashed = false;                // a fit or a model rather than data
};

struct PlotFigure {
  // Not drawn: the first line of the kept script, saying what the figure shows.
  std::string title;
  std::string x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<PlotSeries> series;
  std::vector<std::pair<double, std::string>> vertical_lines;  // x, label
  int width = 900, height = 650;  // pixels; a PDF has the same proportions at 150 per inch
  // The data series are steps of one parameter (e.g. C(r) at increasing phi): their colours
  // run along a sequential scale instead of the distinct colours of unrelated series.
  bool ordered_series = false;
};

// The gnuplot executable on PATH, or empty.
std::string find_gnuplot();
// Writes `path` (.png, .svg or .pdf) with gnuplot. Points that a log axis cannot show (<= 0)
// are left out of the data file; on a log y axis an error bar reaching down to or below zero
// (or far below the data) is drawn down to the bottom of the axis.
void render_plot(const PlotFigure& figure, const std::string& path);

}  // namespace gel::analysis
