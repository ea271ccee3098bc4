// gelsim plot: every picture of a compression run or of an ensemble of runs.
//   gelsim plot DIR... [--out PICDIR] [--format png|svg|pdf] [--fit-range PHIMIN,PHIMAX] [--no-snapshots]
// DIR is a run's folder, or an ensemble's (its finished seed_<seed>/ members: run_inputs.hpp).
// PICDIR defaults to DIR/plots of the first DIR; analysis.json (what analyze-run --json prints)
// is written next to the pictures.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "run_inputs.hpp"

namespace {

struct PlotOptions {
  std::vector<std::string> dirs;
  std::string out, fit_range, format = "png";
  bool svg = false, no_snapshots = false, no_antialias = false;
  double pixel = gel::analysis::kDefaultPixel;
  int snapshot_size = 1000;
  std::string plot_size;
};

int run_plot(const PlotOptions& o) {
  gel::analysis::RunAnalysisOptions options;
  options.structure.pixel = o.pixel;
  if (!o.fit_range.empty()) {
    std::istringstream in(o.fit_range);
    char comma = 0;
    if (!(in >> options.fit_phi_min >> comma >> options.fit_phi_max) || comma != ',' || !(options.fit_phi_min < options.fit_phi_max))
      throw gel::InvalidArgument("fit_range", "expected PHIMIN,PHIMAX, got '" + o.fit_range + "'");
  }
  const std::string out = o.out.empty() ? (std::filesystem::path(o.dirs[0]) / "plots").string() : o.out;
  const gel::analysis::RunAnalysis run = gel::analysis::analyse_runs(gelsim::runs_of(o.dirs), options);
  gel::analysis::PictureOptions pictures;
  pictures.format = o.svg ? "svg" : o.format;
  pictures.snapshots = !o.no_snapshots;
  pictures.snapshot_size = o.snapshot_size;
  pictures.snapshot_antialias = !o.no_antialias;
  if (!o.plot_size.empty()) {
    std::istringstream in(o.plot_size);
    char comma = 0;
    if (!(in >> pictures.plot_width >> comma >> pictures.plot_height) || comma != ',' || pictures.plot_width < 100 ||
        pictures.plot_height < 100)
      throw gel::InvalidArgument("plot_size", "expected WIDTH,HEIGHT of at least 100 each, got '" + o.plot_size + "'");
  }
  const auto written = gel::analysis::render_run_pictures(run, out, pictures);
  gel::write_file_atomically((std::filesystem::path(out) / "analysis.json").string(), gel::analysis::to_json(run).dump(1) + "\n");
  for (const auto& path : written) std::cout << path << "\n";
  std::cout << (std::filesystem::path(out) / "analysis.json").string() << "\n";
  return 0;
}

const gelsim::Registrar plot_registrar{
    "plot", "Draw every picture of a compression run or an ensemble (gnuplot plots, cairo snapshots)",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<PlotOptions>();
      sub.add_option("dir", o->dirs, "compression output directories (several, or an ensemble's folder: an ensemble)")->required();
      sub.add_option("--out", o->out, "picture folder (default DIR/plots)");
      auto* format = sub.add_option("--format", o->format, "png (default), svg or pdf")->check(CLI::IsMember({"png", "svg", "pdf"}));
      sub.add_flag("--svg", o->svg, "the same as --format svg")->excludes(format);
      sub.add_option("--fit-range", o->fit_range, "PHIMIN,PHIMAX of the fits (default: all rows after k = 0)");
      sub.add_option("--pixel", o->pixel, "pixel size [a] of the structure analyses (default 0.25)");
      sub.add_flag("--no-snapshots", o->no_snapshots, "plots only");
      sub.add_flag("--no-antialias", o->no_antialias, "snapshots with hard edges: much smaller PNG files");
      sub.add_option("--plot-size", o->plot_size, "WIDTH,HEIGHT of the plots in pixels (default 900,650)");
      sub.add_option("--snapshot-size", o->snapshot_size, "pixels of the longer side of the snapshots (default 1000)");
      return [o] { return run_plot(*o); };
    }};

}  // namespace
