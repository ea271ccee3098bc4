#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "gel/analysis/pictures.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/curve_io.hpp"
#include "gel/configuration.hpp"

namespace gel::analysis {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, fmt, a, b, c);
  return buffer;
}

// Axis and key text, typeset by gnuplot's enhanced mode: symbols in italics, units in brackets.
std::string italic(const std::string& symbol) { return "{/:Italic " + symbol + "}"; }
const std::string kPhi = italic("φ");
const std::string kLength = italic("a");

// A number with a typeset minus sign (U+2212) instead of a hyphen.
std::string signed_number(const char* fmt, double value) {
  std::string text = format(fmt, value);
  if (!text.empty() && text[0] == '-') text.replace(0, 1, "−");
  return text;
}

// "λ" or "λ ± s" as an exponent, the uncertainty left out where there is none (two points).
std::string exponent_text(double exponent, double stderr_) {
  std::string text = signed_number("%.2f", exponent);
  if (std::isfinite(stderr_) && stderr_ > 0) text += " ± " + format("%.2f", stderr_);
  return "^{" + text + "}";
}

// Up to `count` indices spread evenly over [0, n), first and last included.
std::vector<std::size_t> spread(std::size_t n, int count) {
  std::vector<std::size_t> picked;
  if (n == 0) return picked;
  const std::size_t m = std::min<std::size_t>(n, static_cast<std::size_t>(std::max(1, count)));
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t index = m == 1 ? n - 1 : (i * (n - 1)) / (m - 1);
    if (picked.empty() || picked.back() != index) picked.push_back(index);
  }
  return picked;
}

void add_regime_lines(PlotFigure& figure, const RegimeSplit& regimes) {
  if (regimes.single_mode_start_phi) figure.vertical_lines.push_back({*regimes.single_mode_start_phi, "single-mode plastic"});
  if (regimes.multi_mode_start_phi) figure.vertical_lines.push_back({*regimes.multi_mode_start_phi, "multi-mode plastic"});
}

}  // namespace

std::vector<std::string> render_run_pictures(const RunAnalysis& run, const std::string& out_dir,
                                             const PictureOptions& options) {
  namespace fs = std::filesystem;
  const std::string ext = picture_extension(parse_picture_format(options.format));
  fs::create_directories(out_dir);
  std::vector<std::string> written;
  auto output = [&](const std::string& name) { return (fs::path(out_dir) / (name + ext)).string(); };
  const CurveAnalysis& ca = run.curve;
  const bool ensemble = ca.ensemble.members > 1;
  // Only in the kept scripts' first line: the caption is where a paper says it.
  const std::string members = ensemble ? format(" (mean and standard deviation of %.0f runs)", ca.ensemble.members) : std::string();
  auto render = [&](PlotFigure& figure, const std::string& name) {
    figure.width = options.plot_width;
    figure.height = options.plot_height;
    // Error bars say what they are where a reader looks, the axis title (the figure title
    // lives only in the kept script).
    const bool error_bars = std::any_of(figure.series.begin(), figure.series.end(), [](const PlotSeries& s) { return !s.y_error.empty(); });
    if (error_bars) figure.y_label += format("   (mean ± s.d. over n = %.0f runs)", ca.ensemble.members);
    render_plot(figure, output(name));
    written.push_back(output(name));
  };
  const auto& rows = ca.ensemble.rows;
  const std::vector<double>& phi = rows.at("phi").mean;
  const std::string pressure = italic("P") + "_y";

  {
    PlotFigure f;
    f.title = "Compressive yield stress P_y(phi)" + members;
    f.x_label = kPhi;
    f.y_label = pressure + "  [" + italic("F") + "_0/" + kLength + "^2]";
    f.log_x = f.log_y = true;
    f.series.push_back({pressure, phi, rows.at("P").mean, ensemble ? rows.at("P").std : std::vector<double>{}, "linespoints"});
    if (ca.power_law) {
      const auto& p = *ca.power_law;
      PlotSeries fit{pressure + " ∝ " + kPhi + exponent_text(p.exponent, p.exponent_stderr), {}, {}, {}, "lines", true};
      for (int i = 0; i <= 50; ++i) {
        const double x = p.x_min * std::pow(p.x_max / p.x_min, i / 50.0);
        fit.x.push_back(x), fit.y.push_back(p.prefactor * std::pow(x, p.exponent));
      }
      f.series.push_back(fit);
    }
    // A gel-point fit with φ_g on its bound fixes no gel point: drawn, it would be keyed
    // "(φ − 0.000)^λ" and claim one. The axis title says so instead.
    if (ca.gel_point && ca.gel_point->phi_g_at_bound) f.x_label += "   (gel-point fit: " + kPhi + "_g at its bound, not drawn)";
    if (ca.gel_point && !ca.gel_point->phi_g_at_bound) {
      const auto& g = *ca.gel_point;
      // φ_g written as its value, which keeps the key narrow enough to stay beside the data.
      PlotSeries fit{pressure + " ∝ (" + kPhi + " − " + format("%.3f", g.phi_g) + ")" + exponent_text(g.exponent, g.exponent_stderr),
                     {}, {}, {}, "lines", true};
      for (int i = 0; i <= 50; ++i) {
        const double x = g.x_min * std::pow(g.x_max / g.x_min, i / 50.0);
        fit.x.push_back(x), fit.y.push_back(g.prefactor * std::pow(x - g.phi_g, g.exponent));
      }
      f.series.push_back(fit);
    }
    add_regime_lines(f, ca.regimes);
    render(f, "pressure");
  }
  if (!run.structure.empty()) {
    PlotFigure c, d;
    c.title = "Density correlation C(r)" + members;
    c.x_label = italic("r") + "  [" + kLength + "]";
    c.y_label = italic("C") + "(" + italic("r") + ")";
    c.log_x = c.log_y = true;
    c.ordered_series = true;
    d.title = "Fractal-dimension profile D_f(r) = 2 + d ln C / d ln r" + members;
    d.x_label = c.x_label;
    d.y_label = italic("D") + "_f(" + italic("r") + ")";
    d.log_x = true;
    d.ordered_series = true;
    for (std::size_t i : spread(run.structure.size(), options.curves_per_plot)) {
      const RowStructure& row = run.structure[i];
      const std::string label = kPhi + format(" = %.3f", row.phi);
      std::vector<double> r(row.r_c.begin() + 1, row.r_c.end()), cc(row.c.mean.begin() + 1, row.c.mean.end());
      c.series.push_back({label, r, cc, {}, "lines"});
      d.series.push_back({label, row.r_df, row.df.mean, {}, "lines"});
    }
    render(c, "correlation");
    render(d, "fractal_dimension");

    PlotFigure x;
    const std::string xi_symbol = italic("ξ") + "^{(0.5)}";
    x.title = "Correlation length xi^(0.5)(phi)" + members;
    x.x_label = kPhi;
    x.y_label = xi_symbol + "  [" + kLength + "]";
    x.log_x = x.log_y = true;
    PlotSeries xi{xi_symbol, {}, {}, {}, "linespoints"};
    std::vector<double> xi_std;
    for (const auto& row : run.structure)
      if (row.xi_05.mean) xi.x.push_back(row.phi), xi.y.push_back(*row.xi_05.mean), xi_std.push_back(row.xi_05.std.value_or(0));
    if (ensemble) xi.y_error = xi_std;
    x.series.push_back(xi);
    if (run.xi_power_law) {
      const auto& p = *run.xi_power_law;
      PlotSeries fit{xi_symbol + " ∝ " + kPhi + exponent_text(p.exponent, p.exponent_stderr), {}, {}, {}, "lines", true};
      for (int i = 0; i <= 50; ++i) {
        const double v = p.x_min * std::pow(p.x_max / p.x_min, i / 50.0);
        fit.x.push_back(v), fit.y.push_back(p.prefactor * std::pow(v, p.exponent));
      }
      x.series.push_back(fit);
    }
    render(x, "xi");
  }
  {
    PlotFigure f;
    f.title = "Mean contact number z(phi)" + members;
    f.x_label = kPhi;
    f.y_label = "contact number " + italic("z");
    f.log_x = true;
    f.series.push_back({"", phi, rows.at("contact_number").mean, ensemble ? rows.at("contact_number").std : std::vector<double>{},
                        "linespoints"});
    add_regime_lines(f, ca.regimes);
    render(f, "contact_number");
  }
  const auto& iv = ca.ensemble.intervals;
  {
    PlotFigure f;
    f.title = "Energy increments dE/d ln phi, stored and dissipated" + members;
    f.x_label = kPhi;
    // In the model's unit E0 where the bond law defines it (MODEL.md "Observables"), else F0 a.
    const std::optional<double> e0 = energy_unit_e0(ca.mean_curve.scene());
    const double unit = e0.value_or(1.0);
    auto in_unit = [unit](std::vector<double> values) {
      for (double& v : values) v /= unit;
      return values;
    };
    f.y_label = std::string("d") + italic("E") + "/d ln " + kPhi + "  [" +
                (e0 ? italic("E") + "_0" : italic("F") + "_0 " + kLength) + "]";
    f.log_x = true;
    f.series.push_back({"stored", iv.at("phi_mid").mean, in_unit(iv.at("stored_rate").mean),
                        ensemble ? in_unit(iv.at("stored_rate").std) : std::vector<double>{}, "linespoints"});
    f.series.push_back({"dissipated", iv.at("phi_mid").mean, in_unit(iv.at("dissipated_rate").mean),
                        ensemble ? in_unit(iv.at("dissipated_rate").std) : std::vector<double>{}, "linespoints"});
    add_regime_lines(f, ca.regimes);
    render(f, "energy_increments");
  }
  {
    PlotFigure f;
    f.title = "Rupture rates by cause, Gamma = (1/N) dN / d ln phi" + members;
    f.x_label = kPhi;
    f.y_label = "Γ = (1/" + italic("N") + ") d" + italic("N") + "/d ln " + kPhi;
    f.log_x = true;
    for (const char* cause : {"normal", "sliding", "rolling"}) {
      const std::string key = std::string("gamma_") + cause;
      f.series.push_back({cause, iv.at("phi_mid").mean, iv.at(key).mean, ensemble ? iv.at(key).std : std::vector<double>{}, "linespoints"});
    }
    add_regime_lines(f, ca.regimes);
    render(f, "rupture_rates");
  }
  if (!ca.ensemble.phi_profile.empty()) {
    PlotFigure f;
    f.title = "Packing-fraction profile phi(y) along the compression axis, y/H from the bottom wall (0) to the top (1)" + members;
    f.x_label = "height between the walls " + italic("y") + "/" + italic("H");
    f.y_label = kPhi + "(" + italic("y") + ")";
    f.ordered_series = true;
    for (std::size_t k : spread(ca.ensemble.phi_profile.size(), options.curves_per_plot)) {
      const MeanStd& p = ca.ensemble.phi_profile[k];
      if (p.mean.empty()) continue;
      PlotSeries s{kPhi + format(" = %.3f", phi[k]), {}, p.mean, ensemble ? p.std : std::vector<double>{}, "linespoints"};
      for (std::size_t i = 0; i < p.mean.size(); ++i) s.x.push_back((i + 0.5) / p.mean.size());
      f.series.push_back(s);
    }
    render(f, "profiles");
  }
  if (options.snapshots && !run.curves.empty()) {
    const fs::path folder = fs::path(out_dir) / "snapshots";
    fs::create_directories(folder);
    const gel::v1::Curve& first = run.curves[0];
    for (int k = 0; k < first.rows_size(); ++k) {
      const std::string& name = first.rows(k).snapshot();
      if (name.empty()) continue;
      const fs::path source = fs::path(run.dirs[0]) / name;
      if (!fs::exists(source)) continue;
      SnapshotStyle style;
      style.size = options.snapshot_size;
      style.antialias = options.snapshot_antialias;
      for (const auto& row : run.structure)
        if (row.k == first.rows(k).k() && !row.snapshots.empty() && row.snapshots[0] == source.string())
          style.xi_circle = row.xi_05.mean;  // for one run the member's own value
      const std::string path = (folder / format("k_%03.0f", first.rows(k).k())).string() + ext;
      render_snapshot(read_configuration(source.string()), path, style);
      written.push_back(path);
    }
  }
  return written;
}

}  // namespace gel::analysis
