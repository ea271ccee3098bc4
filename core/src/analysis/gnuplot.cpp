#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
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

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// A string as a gnuplot double-quoted literal.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

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
  const bool png = ends_with(path, ".png"), svg = ends_with(path, ".svg");
  if (!png && !svg) throw InvalidArgument("out", "plot file must end in .png or .svg: " + path);
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty())
    throw std::runtime_error("gnuplot is not installed (not found on PATH): install the Debian package gnuplot-nox "
                             "(scripts/setup.sh does) to draw plots");
  namespace fs = std::filesystem;
  const fs::path picture = fs::absolute(path);
  const fs::path sources = picture.parent_path() / "gnuplot";
  fs::create_directories(sources);
  const std::string stem = picture.stem().string() + (svg ? "_svg" : "");
  const fs::path data_path = sources / (stem + ".dat"), script_path = sources / (stem + ".gp");
  const fs::path log_path = sources / (stem + ".log");

  std::ostringstream data;
  data << std::setprecision(10);
  std::vector<bool> has_points;
  for (const auto& s : figure.series) {
    data << "# " << s.title << "\n";
    bool any = false;
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if ((figure.log_x && s.x[i] <= 0) || (figure.log_y && s.y[i] <= 0)) continue;
      data << s.x[i] << ' ' << s.y[i];
      if (!s.y_error.empty()) data << ' ' << (i < s.y_error.size() && std::isfinite(s.y_error[i]) ? s.y_error[i] : 0.0);
      data << '\n';
      any = true;
    }
    if (!any) data << "NaN NaN" << (s.y_error.empty() ? "" : " NaN") << "\n";  // keeps the index
    has_points.push_back(any);
    data << "\n\n";
  }
  write_file_atomically(data_path.string(), data.str());

  std::ostringstream gp;
  if (png) gp << "set terminal pngcairo size " << figure.width << "," << figure.height << " enhanced font \"sans,11\"\n";
  else gp << "set terminal svg size " << figure.width << "," << figure.height << " enhanced font \"sans,11\" background rgb \"white\"\n";
  gp << "set output " << quoted(picture.string()) << "\n";
  gp << "set title " << quoted(figure.title) << " noenhanced\n";
  gp << "set xlabel " << quoted(figure.x_label) << "\n";
  gp << "set ylabel " << quoted(figure.y_label) << "\n";
  gp << "set grid\nset key inside " << figure.key_position << " box opaque noenhanced\nset bars small\n";
  // A log axis would otherwise widen to whole decades and squeeze a short range of phi; with the
  // range fixed to the data, ticks at 1, 1.5, 2, 3, ... times powers of ten keep it labelled.
  if (figure.log_x) {
    gp << "set logscale x\nset autoscale xfix\nset offsets graph 0.03, graph 0.03, 0, 0\n";
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const auto& series : figure.series)
      for (double x : series.x)
        if (std::isfinite(x) && x > 0) lo = std::min(lo, x), hi = std::max(hi, x);
    if (lo < hi) {
      std::vector<double> ticks;
      for (const std::vector<double>& mantissas : {std::vector<double>{1, 1.5, 2, 3, 4, 5, 6, 7, 8}, std::vector<double>{1, 2, 5}, std::vector<double>{1}}) {
        ticks.clear();
        for (int e = static_cast<int>(std::floor(std::log10(lo))) - 1; e <= static_cast<int>(std::ceil(std::log10(hi))); ++e)
          for (double m : mantissas) {
            const double t = m * std::pow(10.0, e);
            if (t >= lo * 0.97 && t <= hi * 1.03) ticks.push_back(t);
          }
        if (ticks.size() <= 10) break;
      }
      if (ticks.size() >= 2) {
        gp << "set format x \"%g\"\nset xtics (";
        for (std::size_t i = 0; i < ticks.size(); ++i) gp << (i ? ", " : "") << std::setprecision(6) << ticks[i];
        gp << ")\n";
      }
    }
  }
  if (figure.log_y) gp << "set logscale y\n";
  int arrow = 1;
  for (const auto& [x, label] : figure.vertical_lines) {
    if (!std::isfinite(x) || (figure.log_x && x <= 0)) continue;
    gp << "set arrow " << arrow << " from " << x << ", graph 0 to " << x << ", graph 1 nohead dt 2 lw 1.5 lc rgb \"#555555\"\n";
    gp << "set label " << arrow << " " << quoted(label) << " at " << x << ", graph 0.03 rotate by 90 left offset -0.8,0 noenhanced\n";
    ++arrow;
  }
  if (std::find(has_points.begin(), has_points.end(), true) == has_points.end()) {
    // Nothing to draw (e.g. xi^(0.5) undefined at every phi): an empty labelled frame saying so,
    // since gnuplot refuses to plot only undefined points.
    gp << "unset logscale\nunset arrow\nset xrange [0:1]\nset yrange [0:1]\nset format x \"\"\nset format y \"\"\n"
       << "set label 99 \"no data\" at graph 0.5, graph 0.5 center\nplot -1 notitle";
  } else {
    gp << "plot ";
    bool first = true;
    for (std::size_t i = 0; i < figure.series.size(); ++i) {
      if (!has_points[i]) continue;
      const auto& s = figure.series[i];
      if (!first) gp << ", \\\n     ";
      first = false;
      gp << quoted(data_path.string()) << " index " << i;
      if (!s.y_error.empty()) gp << " using 1:2:3 with yerrorlines";
      else gp << " using 1:2 with " << s.style;
      gp << " lw 1.5 title " << quoted(s.title);
    }
  }
  gp << "\nunset output\n";
  write_file_atomically(script_path.string(), gp.str());

  // gnuplot as a child process, its messages into the log (no shell: paths are passed as is).
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::string script_arg = script_path.string();
  char* argv[] = {const_cast<char*>("gnuplot"), script_arg.data(), nullptr};
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
    throw std::runtime_error("gnuplot failed on " + script_path.string() + ": " + log);
  }
}

}  // namespace gel::analysis
