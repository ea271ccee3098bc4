// gelsim analyze / analyze-run / snapshot: structure analyses of configurations and compression
// runs (docs/analysis.md). "analyse" spellings are accepted as aliases.
//   gelsim analyze CONFIG... [--json] [--pixel 0.25] [--fit-range 2,10] [--window 0.1]
//   gelsim analyze-run DIR... [--json] [--fit-range PHIMIN,PHIMAX] [--no-structure] [--include-unequilibrated]
//     (DIR: a run's folder, or an ensemble's, which stands for its finished members: run_inputs.hpp)
//   gelsim snapshot CONFIG --out file.png|file.svg|file.pdf [--xi] [--size 1200] [--no-bonds]
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "gel/analysis/pictures.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/structure.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "run_inputs.hpp"

namespace {

using gel::analysis::StructureOptions;

// "A,B" -> (A, B); throws InvalidArgument naming the option.
std::pair<double, double> parse_range(const std::string& field, const std::string& text) {
  std::istringstream in(text);
  double a = 0, b = 0;
  char comma = 0;
  if (!(in >> a >> comma >> b) || comma != ',' || !(in >> std::ws).eof() || !(a < b))
    throw gel::InvalidArgument(field, "expected MIN,MAX with MIN < MAX, got '" + text + "'");
  return {a, b};
}

struct AnalyzeOptions {
  std::vector<std::string> configs;
  bool json = false;
  double pixel = gel::analysis::kDefaultPixel;
  std::string fit_range;
  double window = gel::analysis::kDefaultDfHalfWindow;
};

StructureOptions structure_options(double pixel, const std::string& fit_range, double window) {
  StructureOptions s;
  s.pixel = pixel;
  s.df_half_window = window;
  if (!fit_range.empty()) std::tie(s.fit_rmin, s.fit_rmax) = parse_range("fit_range", fit_range);
  return s;
}

int run_analyze(const AnalyzeOptions& o) {
  const StructureOptions options = structure_options(o.pixel, o.fit_range, o.window);
  std::vector<nlohmann::json> results;
  std::vector<std::optional<double>> df_fits, xis;
  std::vector<std::vector<double>> c_members;
  for (const auto& path : o.configs) {
    const gel::analysis::StructureAnalysis a = gel::analysis::analyse_structure(gel::read_configuration(path), options);
    nlohmann::json j = gel::analysis::to_json(a, options);
    j["config"] = path;
    results.push_back(j);
    df_fits.push_back(a.df_fit ? std::optional<double>(a.df_fit->df) : std::nullopt);
    xis.push_back(a.xi_05);
    c_members.push_back(a.correlation.c);
    if (!o.json) {
      std::printf("%s\n  particles %d, phi %.4f, contact number %.3f\n", path.c_str(), a.particles, a.phi, a.mean_contact_number);
      if (a.df_fit)
        std::printf("  D_f (C(r) slope over %.3g..%.3g a, %d bins) %.3f +- %.3f\n", a.df_fit->rmin, a.df_fit->rmax,
                    a.df_fit->points, a.df_fit->df, a.df_fit->stderr_);
      else
        std::printf("  D_f fit: %s\n", a.df_fit_error.c_str());
      if (a.xi_05) std::printf("  xi^(0.5) %.3f a\n", *a.xi_05);
      else std::printf("  xi^(0.5) undefined (Delta rho / rho does not cross 0.5 in the measured box sizes)\n");
      std::printf("  analysis %.3f s (pixel %.3g a, C(r) %.3f s)\n", a.seconds, a.pixel, a.correlation_seconds);
    }
  }
  if (o.json) {
    if (results.size() == 1) {
      std::cout << results[0].dump() << "\n";
    } else {
      nlohmann::json all;
      all["configurations"] = results;
      all["fractal_dimension_fit"] = gel::analysis::to_json(gel::analysis::mean_std(df_fits));
      all["xi_05"] = gel::analysis::to_json(gel::analysis::mean_std(xis));
      all["correlation"] = gel::analysis::to_json(gel::analysis::mean_std(c_members));
      std::cout << all.dump() << "\n";
    }
  } else if (results.size() > 1) {
    const auto df = gel::analysis::mean_std(df_fits);
    const auto xi = gel::analysis::mean_std(xis);
    if (df.mean) std::printf("ensemble of %zu: D_f %.3f +- %.3f (std)", results.size(), *df.mean, *df.std);
    if (xi.mean) std::printf(", xi^(0.5) %.2f +- %.2f a (%d missing)", *xi.mean, *xi.std, xi.missing);
    std::printf("\n");
  }
  return 0;
}

const gelsim::Registrar analyze_registrar{
    "analyze", "Structure of configurations: C(r), D_f(r) and its fit, Delta rho(l)/rho and xi^(0.5), phi(y)",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<AnalyzeOptions>();
      sub.alias("analyse");
      sub.add_option("config", o->configs, "configuration files (.json or .pb); several: also their mean and std")->required();
      sub.add_flag("--json", o->json, "print one JSON object");
      sub.add_option("--pixel", o->pixel, "pixel size [a] of the density field (default 0.25)");
      sub.add_option("--fit-range", o->fit_range, "RMIN,RMAX [a] of the D_f fit (default 2,10)");
      sub.add_option("--window", o->window, "half width in ln r of the D_f(r) slope window (default 0.1)");
      return [o] { return run_analyze(*o); };
    }};

struct AnalyzeRunOptions {
  std::vector<std::string> dirs;
  bool json = false;
  double pixel = gel::analysis::kDefaultPixel;
  std::string fit_range, r_fit_range;
  bool no_structure = false;
  bool include_unequilibrated = false;
};

int run_analyze_run(const AnalyzeRunOptions& o) {
  gel::analysis::RunAnalysisOptions options;
  options.structure = structure_options(o.pixel, o.r_fit_range, gel::analysis::kDefaultDfHalfWindow);
  if (!o.fit_range.empty()) std::tie(options.fit_phi_min, options.fit_phi_max) = parse_range("fit_range", o.fit_range);
  options.structures = !o.no_structure;
  options.include_unequilibrated = o.include_unequilibrated;
  const gel::analysis::RunAnalysis run = gel::analysis::analyse_runs(gelsim::runs_of(o.dirs), options);
  if (o.json) {
    std::cout << gel::analysis::to_json(run).dump() << "\n";
    return 0;
  }
  const auto& ca = run.curve;
  std::printf("runs %d, rows %zu\n", ca.ensemble.members, ca.ensemble.rows.at("phi").mean.size());
  for (const auto& row : ca.excluded_rows)
    std::printf("left out   k %2d phi %.4f: %s\n", row.k, row.phi, row.reason.c_str());
  if (!ca.excluded_rows.empty())
    std::printf("           (fits and regimes use %zu rows; --include-unequilibrated takes back the spanning ones)\n",
                ca.fit_rows.size());
  if (ca.power_law)
    std::printf("power law   P = %.4g phi^lambda, lambda = %.3f +- %.3f (phi %.3f..%.3f, %d points%s)\n", ca.power_law->prefactor,
                ca.power_law->exponent, ca.power_law->exponent_stderr, ca.power_law->x_min, ca.power_law->x_max,
                ca.power_law->points, ca.power_law->dropped ? (", " + std::to_string(ca.power_law->dropped) + " with P <= 0 left out").c_str() : "");
  else
    std::printf("power law   %s\n", ca.power_law_error.c_str());
  if (ca.gel_point)
    std::printf("gel point   P = %.4g (phi - %.4f +- %.4f)^(%.3f +- %.3f) (phi %.3f..%.3f, %d points)%s\n", ca.gel_point->prefactor,
                ca.gel_point->phi_g, ca.gel_point->phi_g_stderr, ca.gel_point->exponent, ca.gel_point->exponent_stderr,
                ca.gel_point->x_min, ca.gel_point->x_max, ca.gel_point->points,
                ca.gel_point->phi_g_at_bound ? "  (phi_g on its bound: the data fix no gel point)" : "");
  else
    std::printf("gel point   %s\n", ca.gel_point_error.c_str());
  for (int r = 0; r < 3; ++r) {
    const auto& range = ca.regimes.range[r];
    if (range) std::printf("regime %-20s phi %.4f .. %.4f\n", gel::analysis::regime_name(static_cast<gel::analysis::Regime>(r)),
                           range->first, range->second);
    else std::printf("regime %-20s (none)\n", gel::analysis::regime_name(static_cast<gel::analysis::Regime>(r)));
  }
  for (const auto& row : run.structure) {
    std::printf("k %2d phi %.4f  D_f %s  xi^(0.5) %s  (%zu snapshot%s, %.2f s)\n", row.k, row.phi,
                row.df_fit.mean ? (std::to_string(*row.df_fit.mean).substr(0, 5)).c_str() : "-",
                row.xi_05.mean ? (std::to_string(*row.xi_05.mean).substr(0, 6) + " a").c_str() : "undefined",
                row.snapshots.size(), row.snapshots.size() == 1 ? "" : "s", row.seconds);
  }
  if (run.xi_power_law)
    std::printf("xi^(0.5) ~ phi^%.3f +- %.3f\n", run.xi_power_law->exponent, run.xi_power_law->exponent_stderr);
  return 0;
}

const gelsim::Registrar analyze_run_registrar{
    "analyze-run", "Analyse compression output directories (one run, or several seeds as an ensemble)",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<AnalyzeRunOptions>();
      sub.alias("analyse-run");
      sub.add_option("dir", o->dirs, "compression output directories (curve.json, snapshots/), or an ensemble's folder (seed_<seed>/)")->required();
      sub.add_flag("--json", o->json, "print one JSON object");
      sub.add_option("--fit-range", o->fit_range, "PHIMIN,PHIMAX of the power-law and gel-point fits (default: all rows after k = 0)");
      sub.add_option("--r-fit-range", o->r_fit_range, "RMIN,RMAX [a] of the D_f fit of each snapshot (default 2,10)");
      sub.add_option("--pixel", o->pixel, "pixel size [a] (default 0.25)");
      sub.add_flag("--no-structure", o->no_structure, "curve analyses only, no snapshots");
      sub.add_flag("--include-unequilibrated", o->include_unequilibrated,
                   "fit and split rows that did not reach equilibrium too (default: only rows every member equilibrated)");
      return [o] { return run_analyze_run(*o); };
    }};

struct SnapshotOptions {
  std::string config, out;
  bool xi = false, no_bonds = false, no_antialias = false;
  int size = 1200;
  double pixel = gel::analysis::kDefaultPixel;
};

int run_snapshot(const SnapshotOptions& o) {
  const gel::Configuration config = gel::read_configuration(o.config);
  gel::analysis::SnapshotStyle style;
  style.size = o.size;
  style.bonds = !o.no_bonds;
  style.antialias = !o.no_antialias;
  // No title inside the picture (the caption says what it shows); N and phi go to stderr.
  std::cerr << "N = " << config.size() << ", phi = " << config.packing_fraction() << "\n";
  if (o.xi) {
    const auto a = gel::analysis::analyse_structure(config, structure_options(o.pixel, "", gel::analysis::kDefaultDfHalfWindow));
    style.xi_circle = a.xi_05;
    if (!a.xi_05) std::cerr << "gelsim: xi^(0.5) is undefined for this configuration; no circle drawn\n";
  }
  gel::analysis::render_snapshot(config, o.out, style);
  std::cout << o.out << "\n";
  return 0;
}

const gelsim::Registrar snapshot_registrar{
    "snapshot", "Draw a configuration (PNG or SVG): disks, bonds, wall particles, optional 4 xi^(0.5) circle",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<SnapshotOptions>();
      sub.add_option("config", o->config, "configuration file")->required();
      sub.add_option("--out", o->out, "picture file, .png, .svg or .pdf")->required();
      sub.add_flag("--xi", o->xi, "draw a circle of diameter 4 xi^(0.5)");
      sub.add_flag("--no-bonds", o->no_bonds, "leave the bonds out");
      sub.add_flag("--no-antialias", o->no_antialias, "hard edges: a much smaller PNG");
      sub.add_option("--size", o->size, "pixels (PNG) or points (SVG) of the longer side (default 1200)");
      sub.add_option("--pixel", o->pixel, "pixel size [a] for xi^(0.5) (default 0.25)");
      return [o] { return run_snapshot(*o); };
    }};

}  // namespace
