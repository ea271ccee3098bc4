#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "gel/analysis/pictures.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"

extern char** environ;

namespace gel::analysis {
namespace {

// A string as a gnuplot double-quoted literal.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Distinct colours for unrelated series, chosen to stay apart for colour-blind readers and in
// grey print (with the point shapes below); no yellow, which vanishes on white.
constexpr const char* kSeriesColours[] = {"#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#000000"};
constexpr int kSeriesPointTypes[] = {7, 5, 9, 13, 11, 15, 3};  // filled circle, square, triangles, diamond, ...
// Fits and models: dark, dashed, so that they read as lines through the data, not as data.
constexpr const char* kDashedColours[] = {"#222222", "#888888", "#8c510a"};
constexpr int kDashTypes[] = {2, 4, 5};

// A sequential scale from dark navy through teal to ochre, lightness rising along it, for series
// that are steps of one parameter.
std::string ramp_colour(std::size_t i, std::size_t n) {
  const double anchors[3][3] = {{0.10, 0.10, 0.45}, {0.05, 0.55, 0.55}, {0.85, 0.62, 0.10}};
  const double t = n <= 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(n - 1);
  const int segment = t < 0.5 ? 0 : 1;
  const double u = t < 0.5 ? 2 * t : 2 * t - 1;
  char out[8];
  int channel[3];
  for (int c = 0; c < 3; ++c)
    channel[c] = static_cast<int>(std::lround(255 * ((1 - u) * anchors[segment][c] + u * anchors[segment + 1][c])));
  std::snprintf(out, sizeof out, "#%02x%02x%02x", channel[0], channel[1], channel[2]);
  return out;
}

// The visible characters of an enhanced-text string: what its width on the page depends on.
std::size_t visible_length(const std::string& enhanced) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < enhanced.size(); ++i) {
    const unsigned char c = enhanced[i];
    if (c == '{' && i + 1 < enhanced.size() && enhanced[i + 1] == '/') {  // a font switch: "{/:Italic "
      while (i < enhanced.size() && enhanced[i] != ' ' && enhanced[i] != '}') ++i;
      continue;
    }
    if (c == '{' || c == '}' || c == '^' || c == '_' || c == '@' || c == '&') continue;
    if ((c & 0xC0) == 0x80) continue;  // a UTF-8 continuation byte
    ++count;
  }
  return count;
}

struct DataPoint {
  double x, y, y_low, y_high;
};

// One axis: linear or log, and the range drawn.
struct Axis {
  bool log = false;
  double lo = 0, hi = 1;
  // Position in the plot area, 0 at the lower/left end, 1 at the upper/right.
  double fraction(double v) const {
    if (log) return (std::log(v) - std::log(lo)) / (std::log(hi) - std::log(lo));
    return (v - lo) / (hi - lo);
  }
};

// A little room beyond the outermost data so that no point sits on the frame.
Axis padded_axis(bool log, double lo, double hi) {
  Axis axis;
  axis.log = log;
  if (!(lo <= hi)) lo = log ? 0.1 : 0, hi = 1;  // no data
  if (log) {
    if (hi / lo < 1.0001) lo /= 1.5, hi *= 1.5;  // one value: a range around it
    const double pad = std::pow(hi / lo, 0.04);
    axis.lo = lo / pad, axis.hi = hi * pad;
  } else {
    if (hi - lo <= 0) {  // one value: a range around it
      const double half = lo != 0 ? 0.5 * std::abs(lo) : 0.5;
      lo -= half, hi += half;
    }
    const double span = hi - lo;
    axis.lo = lo - 0.04 * span, axis.hi = hi + 0.04 * span;
  }
  return axis;
}

// Tick commands for one axis ("x" or "y"). A log axis shorter than two decades gets ticks at
// 1, 1.5, 2, 3, ... times powers of ten (or, where those are more than 8, at 1, 2, 3, 5; 1, 2,
// 5; 1), since gnuplot's decade ticks would leave it with one label or none; a longer one gets
// gnuplot's decade ticks, written as powers of ten once "%g" would make long labels of them.
std::string tick_commands(const std::string& name, const Axis& axis) {
  std::ostringstream gp;
  if (!axis.log) {
    gp << "set format " << name << " \"%g\"\n";
    return gp.str();
  }
  gp << "set logscale " << name << "\n";
  if (axis.hi / axis.lo < 100) {
    std::vector<double> ticks;
    for (const std::vector<double>& mantissas :
         {std::vector<double>{1, 1.5, 2, 3, 4, 5, 6, 7, 8}, std::vector<double>{1, 2, 3, 5}, std::vector<double>{1, 2, 5},
          std::vector<double>{1}}) {
      ticks.clear();
      for (int e = static_cast<int>(std::floor(std::log10(axis.lo))); e <= static_cast<int>(std::ceil(std::log10(axis.hi))); ++e)
        for (double m : mantissas) {
          const double t = m * std::pow(10.0, e);
          if (t >= axis.lo && t <= axis.hi) ticks.push_back(t);
        }
      if (ticks.size() <= 8) break;
    }
    gp << "set format " << name << " \"%g\"\n";
    if (ticks.size() >= 2) {
      gp << "set " << name << "tics (";
      for (std::size_t i = 0; i < ticks.size(); ++i) gp << (i ? ", " : "") << std::setprecision(6) << ticks[i];
      gp << ")\n";
    }
    return gp.str();
  }
  const bool short_labels = axis.lo >= 0.9e-3 && axis.hi <= 1.1e4;
  gp << "set format " << name << (short_labels ? " \"%g\"\n" : " \"10^{%L}\"\n");
  return gp.str();
}

// A rectangle in plot-area fractions.
struct Box {
  double x0, y0, x1, y1;
};

// Whether the segment (ax, ay)-(bx, by) meets the box (Liang-Barsky clipping).
bool segment_meets_box(double ax, double ay, double bx, double by, const Box& box) {
  double t0 = 0, t1 = 1;
  const double dx = bx - ax, dy = by - ay;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {ax - box.x0, box.x1 - ax, ay - box.y0, box.y1 - ay};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
    if (t0 > t1) return false;
  }
  return true;
}

// What is drawn inside the plot area, in plot-area fractions: lines (a point is a line of
// length zero), so that the key can be put where nothing is.
struct Obstacles {
  std::vector<Box> lines;  // from (x0, y0) to (x1, y1)
  int count_in(const Box& box) const {
    int n = 0;
    for (const auto& l : lines) n += segment_meets_box(l.x0, l.y0, l.x1, l.y1, box);
    return n;
  }
};

// The font, and the guesses of text extents and of the plot area that placing the key and the
// labels needs (gnuplot does not report them before drawing).
struct Page {
  double font_points;
  double char_width, line_height;  // in PNG pixels
  double plot_width, plot_height;  // the plot area, in PNG pixels
};

Page page_of(const PlotFigure& figure) {
  Page page;
  // 18 points on a 900 x 650 picture: at a column's width in a paper that is the size of the
  // caption's text; scaled with the picture so that a smaller one keeps its proportions.
  const double scale = std::min(figure.width / 900.0, figure.height / 650.0);
  page.font_points = std::max(7.0, std::round(18.0 * scale));
  // Measured on pngcairo's "sans": a character of mixed text is about 0.7 times the point size
  // wide in pixels, a line of the key about 1.5 times it high.
  page.char_width = 0.7 * page.font_points;
  page.line_height = 1.5 * page.font_points;
  // Margins: tick labels and the label left and below, a little room above and right.
  page.plot_width = std::max(50.0, figure.width - 11.0 * page.char_width);
  page.plot_height = std::max(50.0, figure.height - 4.0 * page.line_height);
  return page;
}

}  // namespace

PictureFormat parse_picture_format(const std::string& name) {
  if (name == "png") return PictureFormat::png;
  if (name == "svg") return PictureFormat::svg;
  if (name == "pdf") return PictureFormat::pdf;
  throw InvalidArgument("format", "expected png, svg or pdf, got '" + name + "'");
}

std::string picture_extension(PictureFormat format) {
  switch (format) {
    case PictureFormat::svg: return ".svg";
    case PictureFormat::pdf: return ".pdf";
    case PictureFormat::png: break;
  }
  return ".png";
}

PictureFormat picture_format_of_path(const std::string& path) {
  std::string ending = std::filesystem::path(path).extension().string();
  for (char& c : ending) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ending == ".png") return PictureFormat::png;
  if (ending == ".svg") return PictureFormat::svg;
  if (ending == ".pdf") return PictureFormat::pdf;
  throw InvalidArgument("out", "picture file must end in .png, .svg or .pdf: " + path);
}

std::string find_gnuplot() {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const std::string candidate = dir + "/gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

void render_plot(const PlotFigure& figure, const std::string& path) {
  const PictureFormat format = picture_format_of_path(path);
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty())
    throw std::runtime_error("gnuplot is not installed (not found on PATH): install the Debian package gnuplot-nox "
                             "(scripts/setup.sh does) to draw plots");
  namespace fs = std::filesystem;
  const fs::path picture = fs::absolute(path);
  const fs::path sources = picture.parent_path() / "gnuplot";
  fs::create_directories(sources);
  // PNG, SVG and PDF of one figure may share a folder: each keeps its own script and data.
  std::string stem = picture.stem().string();
  if (format != PictureFormat::png) stem.append("_").append(picture_extension(format), 1);
  const std::string data_name = stem + ".dat", script_name = stem + ".gp";
  const fs::path log_path = sources / (stem + ".log");

  // The points each series can show on these axes.
  std::vector<std::vector<DataPoint>> shown(figure.series.size());
  for (std::size_t k = 0; k < figure.series.size(); ++k) {
    const auto& s = figure.series[k];
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if ((figure.log_x && s.x[i] <= 0) || (figure.log_y && s.y[i] <= 0)) continue;
      const double error = i < s.y_error.size() && std::isfinite(s.y_error[i]) ? std::abs(s.y_error[i]) : 0.0;
      shown[k].push_back({s.x[i], s.y[i], s.y[i] - error, s.y[i] + error});
    }
  }

  // Ranges from the data and the bars. On a log y axis the lowest bar end counts only down to a
  // decade below the lowest point, so that one bar of nearly 100 % does not squash the data.
  double x_lo = HUGE_VAL, x_hi = -HUGE_VAL, y_lo = HUGE_VAL, y_hi = -HUGE_VAL, bar_lo = HUGE_VAL;
  for (const auto& points : shown)
    for (const auto& p : points) {
      x_lo = std::min(x_lo, p.x), x_hi = std::max(x_hi, p.x);
      y_lo = std::min(y_lo, figure.log_y ? p.y : p.y_low), y_hi = std::max(y_hi, p.y_high);
      if (p.y_low > 0) bar_lo = std::min(bar_lo, p.y_low);
    }
  const bool has_points = x_lo <= x_hi;
  if (figure.log_y && has_points && bar_lo < y_lo) y_lo = std::max(bar_lo, y_lo / 10);
  const Axis x_axis = padded_axis(figure.log_x, x_lo, x_hi), y_axis = padded_axis(figure.log_y, y_lo, y_hi);
  // A bar end the log axis cannot reach is drawn to the axis' bottom, where gnuplot would
  // otherwise drop the whole bar.
  if (figure.log_y)
    for (auto& points : shown)
      for (auto& p : points) p.y_low = std::max(p.y_low, y_axis.lo);

  std::ostringstream data;
  data << std::setprecision(10);
  for (std::size_t k = 0; k < figure.series.size(); ++k) {
    const auto& s = figure.series[k];
    data << "# " << s.title << (s.y_error.empty() ? "\n# x y\n" : "\n# x y y_low y_high\n");
    for (const auto& p : shown[k]) {
      data << p.x << ' ' << p.y;
      if (!s.y_error.empty()) data << ' ' << p.y_low << ' ' << p.y_high;
      data << '\n';
    }
    if (shown[k].empty()) data << "NaN NaN" << (s.y_error.empty() ? "" : " NaN NaN") << "\n";  // keeps the index
    data << "\n\n";
  }
  write_file_atomically((sources / data_name).string(), data.str());

  const Page page = page_of(figure);
  std::ostringstream gp;
  gp << "# " << figure.title << "\n"
     << "# Redraws ../" << picture.filename().string() << " from " << data_name
     << " when run in this folder: cd into it, then gnuplot " << script_name << "\n";
  gp << "set encoding utf8\n";
  switch (format) {
    case PictureFormat::png:
      gp << "set terminal pngcairo size " << figure.width << "," << figure.height << " enhanced font \"sans,"
         << page.font_points << "\"\n";
      break;
    case PictureFormat::svg:
      // The svg terminal's points come out smaller than pngcairo's on the same canvas.
      gp << "set terminal svg size " << figure.width << "," << figure.height << " enhanced font \"sans,"
         << std::round(page.font_points * 1.4) << "\" background rgb \"white\"\n";
      break;
    case PictureFormat::pdf:
      // 150 per inch looks like the PNG; a paper scales it to its column anyway.
      gp << "set terminal pdfcairo size " << std::setprecision(4) << figure.width / 150.0 << "in," << figure.height / 150.0
         << "in enhanced font \"sans," << page.font_points << "\"\n";
      break;
  }
  gp << "set output " << quoted("../" + picture.filename().string()) << "\n";
  gp << "set minussign\n";  // a typeset minus in the tick labels
  gp << "set xlabel " << quoted(figure.x_label) << "\n";
  gp << "set ylabel " << quoted(figure.y_label) << "\n";
  gp << "set grid back lc rgb \"#dadada\" lw 1 dt solid\nset border back\nset bars small\n";
  const double line_width = std::max(1.0, 2.0 * figure.width / 900.0);
  // The vector terminals draw points at about 1.7 times pngcairo's size for the same setting.
  const double point_size = std::max(0.5, 1.1 * figure.width / 900.0) * (format == PictureFormat::png ? 1.0 : 0.6);
  gp << "set pointsize " << std::setprecision(3) << point_size << "\n";
  gp << std::setprecision(10);

  Obstacles obstacles;
  for (std::size_t k = 0; k < figure.series.size(); ++k) {
    const bool joined = figure.series[k].style != "points";
    const auto& points = shown[k];
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double x = x_axis.fraction(points[i].x), y = y_axis.fraction(points[i].y);
      obstacles.lines.push_back({x, y, x, y});
      if (!figure.series[k].y_error.empty())
        obstacles.lines.push_back({x, y_axis.fraction(points[i].y_low), x, y_axis.fraction(points[i].y_high)});
      if (joined && i + 1 < points.size())
        obstacles.lines.push_back({x, y, x_axis.fraction(points[i + 1].x), y_axis.fraction(points[i + 1].y)});
    }
  }

  int arrow = 1;
  if (has_points) {
    gp << "set xrange [" << x_axis.lo << ":" << x_axis.hi << "]\nset yrange [" << y_axis.lo << ":" << y_axis.hi << "]\n";
    gp << tick_commands("x", x_axis) << tick_commands("y", y_axis);
    // Vertical lines, each labelled above the frame, outside the plot area where no point or bar
    // can be: beside its line, on the right unless the text would run past the frame; a label
    // that would overlap an earlier one goes up a row.
    std::vector<Box> vertical_lines;
    std::vector<std::vector<std::pair<double, double>>> label_rows;  // per row, the labels' [x0, x1]
    for (const auto& [x, label] : figure.vertical_lines) {
      if (!std::isfinite(x) || (figure.log_x && x <= 0) || x <= x_axis.lo || x >= x_axis.hi) continue;
      const double fx = x_axis.fraction(x);
      const double width = (visible_length(label) + 1.0) * page.char_width / page.plot_width;
      const bool right = fx + width <= 1.0;
      const double x0 = right ? fx : fx - width, x1 = x0 + width;
      std::size_t row = 0;
      auto overlaps = [&](const std::pair<double, double>& other) { return x0 < other.second && other.first < x1; };
      while (row < label_rows.size() && std::any_of(label_rows[row].begin(), label_rows[row].end(), overlaps)) ++row;
      if (row == label_rows.size()) label_rows.emplace_back();
      label_rows[row].push_back({x0, x1});
      vertical_lines.push_back({fx, 0.0, fx, 1.0});
      gp << "set arrow " << arrow << " from " << x << ", graph 0 to " << x
         << ", graph 1 nohead back dt 2 lw 1.5 lc rgb \"#666666\"\n";
      // Text is centred on its anchor across its baseline: the offset lifts it clear of the frame.
      gp << "set label " << arrow << " " << quoted(label) << " at " << x << ", graph 1 " << (right ? "left" : "right")
         << " offset " << (right ? "0.3" : "-0.3") << "," << std::setprecision(3) << 0.8 + 1.2 * row
         << std::setprecision(10) << " textcolor rgb \"#444444\"\n";
      ++arrow;
    }
    // Room above the frame for the rows of labels (gnuplot's margins are in character heights).
    if (!label_rows.empty()) gp << "set tmargin " << std::setprecision(3) << 1.2 * label_rows.size() + 1.0 << std::setprecision(10) << "\n";
    obstacles.lines.insert(obstacles.lines.end(), vertical_lines.begin(), vertical_lines.end());

    // The key: the first inside corner whose box nothing drawn reaches, else outside, right or
    // below, whichever takes less of the plot area.
    std::size_t entries = 0, longest = 0;
    for (std::size_t k = 0; k < figure.series.size(); ++k)
      if (!shown[k].empty() && !figure.series[k].title.empty())
        ++entries, longest = std::max(longest, visible_length(figure.series[k].title));
    if (entries == 0) {
      gp << "unset key\n";
    } else {
      // Sample line (4 characters), gaps and text, plus a margin to the frame and the data.
      const double entry_width = (longest + 7.0) * page.char_width, key_height = (entries + 0.6) * page.line_height;
      const double w = entry_width / page.plot_width + 0.02, h = key_height / page.plot_height + 0.02;
      const std::pair<const char*, Box> corners[] = {{"top left", {0, 1 - h, w, 1}},
                                                     {"top right", {1 - w, 1 - h, 1, 1}},
                                                     {"bottom right", {1 - w, 0, 1, h}},
                                                     {"bottom left", {0, 0, w, h}}};
      const char* chosen = nullptr;
      if (w < 0.95 && h < 0.95)
        for (const auto& [name, box] : corners)
          if (obstacles.count_in(box) == 0) {
            chosen = name;
            break;
          }
      const double columns_below = std::max(1.0, std::floor(0.95 * figure.width / entry_width));
      const double rows_below = std::ceil(entries / columns_below);
      const double cost_right = entry_width / page.plot_width, cost_below = (rows_below + 0.5) * page.line_height / page.plot_height;
      // gnuplot's key is wider than its text: in a right corner the text is set flush right,
      // next to its sample at the frame, so that the spare width is on the side of the data.
      // Not opaque: where the guess of the text's extent fails, data should show, not vanish.
      if (chosen && std::strstr(chosen, "right")) gp << "set key inside " << chosen << " Right noreverse nobox\n";
      else if (chosen) gp << "set key inside " << chosen << " Left reverse nobox\n";
      else if (cost_right < cost_below) gp << "set key outside right top vertical Left reverse nobox\n";
      // Below, gnuplot leaves too little room between a key of several rows and the x label.
      else gp << "set key outside below center horizontal Left reverse nobox\nset bmargin " << rows_below + 4.5 << "\n";
    }
  }

  std::size_t data_index = 0, dashed_index = 0, colour_count = 0;
  for (std::size_t k = 0; k < figure.series.size(); ++k)
    if (!figure.series[k].dashed) ++colour_count;
  if (!has_points) {
    // Nothing to draw (e.g. xi^(0.5) undefined at every phi): an empty labelled frame saying so,
    // since gnuplot refuses to plot only undefined points.
    gp << "unset key\nset xrange [0:1]\nset yrange [0:1]\nset format x \"\"\nset format y \"\"\n"
       << "set label 99 \"no data\" at graph 0.5, graph 0.5 center\nplot -1 notitle";
  } else {
    gp << "plot ";
    bool first = true;
    for (std::size_t k = 0; k < figure.series.size(); ++k) {
      if (shown[k].empty()) continue;
      const auto& s = figure.series[k];
      if (!first) gp << ", \\\n     ";
      first = false;
      gp << quoted(data_name) << " index " << k;
      if (!s.y_error.empty()) gp << " using 1:2:3:4 with " << (s.style == "points" ? "yerrorbars" : "yerrorlines");
      else gp << " using 1:2 with " << s.style;
      if (s.dashed) {
        const std::size_t i = dashed_index++ % std::size(kDashedColours);
        gp << " lc rgb \"" << kDashedColours[i] << "\" dt " << kDashTypes[i];
      } else {
        const std::size_t i = data_index++;
        const std::string colour = figure.ordered_series ? ramp_colour(i, colour_count) : kSeriesColours[i % std::size(kSeriesColours)];
        gp << " lc rgb \"" << colour << "\"";
        if (s.style != "lines" || !s.y_error.empty()) gp << " pt " << kSeriesPointTypes[i % std::size(kSeriesPointTypes)];
      }
      gp << " lw " << std::setprecision(3) << line_width << std::setprecision(10);
      if (s.title.empty()) gp << " notitle";
      else gp << " title " << quoted(s.title);
    }
  }
  gp << "\nunset output\n";
  write_file_atomically((sources / script_name).string(), gp.str());

  // gnuplot as a child process in the scripts' folder, so that their relative paths hold, its
  // messages into the log (no shell: paths are passed as they are).
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::string change_directory = "cd " + quoted(sources.string());
  std::string script_arg = (sources / script_name).string();
  char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>("-e"), change_directory.data(), script_arg.data(), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, gnuplot.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start " + gnuplot + ": " + std::strerror(spawned));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waiting for gnuplot failed");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::string log;
    try {
      log = read_file(log_path.string());
    } catch (...) {
    }
    if (log.size() > 2000) log = log.substr(log.size() - 2000);
    throw std::runtime_error("gnuplot failed on " + script_arg + ": " + log);
  }
}

}  // namespace gel::analysis
