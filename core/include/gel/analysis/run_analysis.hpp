#pragma once
// Analysis of compression runs: one output directory (curve.json + snapshots/), or several
// directories of the same protocol on different seeds as an ensemble (docs/analysis.md). What `gelsim analyze-run` prints and `gelsim plot` draws.
//
// The curve-level analyses work on the ensemble-mean curve (for one run: the run itself):
// phi, P and the cumulative energies and rupture counts averaged per row k. On it:
//   - the power law P = C phi^lambda over [fit_phi_min, fit_phi_max] (default: every row after
//     the initial state k = 0, which carries no stress), on the trusted rows only: rows that
//     every member reached at mechanical equilibrium with a spanning network. A wait-limited
//     row is the stress at an arbitrary time and biases lambda, phi_g and lambda'; the rows left
//     out are listed with their reason (excluded_rows), and include_unequilibrated takes back
//     the spanning rows that did not equilibrate;
//   - the gel-point form over the same range (missing, with the reason, when it fails);
//   - increments, rupture rates and the regime split (curve_analysis.hpp), the split over the
//     increments between trusted rows only (the rest are listed, without a regime);
//   - per row with a snapshot, the structure of each member's snapshot (structure.hpp), and per
//     row the ensemble mean/std of C(r), D_f(r), the D_f fit and xi^(0.5); a power law of
//     xi^(0.5) against phi over the rows where it exists.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gel/analysis/curve_analysis.hpp"
#include "gel/analysis/fits.hpp"
#include "gel/analysis/structure.hpp"
#include "gel/v1/scene.pb.h"

namespace gel::analysis {

struct RunAnalysisOptions {
  StructureOptions structure;
  double fit_phi_min = 0, fit_phi_max = 0;  // 0, 0: rows k >= 1
  double multi_mode_fraction = kDefaultMultiModeFraction;
  bool structures = true;  // analyse the snapshots
  bool include_unequilibrated = false;  // fit and split rows that did not reach equilibrium too
};

// A row the fits and the regime split left out, and why ("not equilibrated in 3 of 8 members").
struct ExcludedRow {
  int k = 0;
  double phi = 0;
  std::string reason;
};

// Per row k, over the members whose snapshot of row k exists.
struct RowStructure {
  int k = 0;
  double phi = 0;                         // ensemble-mean phi of the row
  std::vector<std::string> snapshots;     // paths analysed
  MeanStd c, df;                          // on the common r grid (see analyse_runs)
  std::vector<double> r_c, r_df;
  OptionalMeanStd df_fit, xi_05;
  double seconds = 0;                     // analysis time over all members
};

struct CurveAnalysis {
  gel::v1::Curve mean_curve;              // ensemble mean (the curve itself for one run)
  CurveEnsemble ensemble;
  std::optional<PowerLawFit> power_law;
  std::string power_law_error;
  std::optional<GelPointFit> gel_point;
  std::string gel_point_error;
  std::vector<int> fit_rows;               // k of the rows the fits used
  std::vector<ExcludedRow> excluded_rows;  // rows k >= 1 the fits and the regime split left out
  std::vector<Increment> increments;       // every interval of the mean curve
  std::vector<bool> increment_trusted;     // per increment: both its rows trusted
  RegimeSplit regimes;                     // over the trusted increments, in order
};

struct RunAnalysis {
  std::vector<std::string> dirs;
  std::vector<gel::v1::Curve> curves;
  CurveAnalysis curve;
  std::vector<RowStructure> structure;
  std::optional<PowerLawFit> xi_power_law;  // xi^(0.5) = C phi^lambda over rows with xi
};

// Curve-level analyses only (no snapshots needed): what the service attaches to a stored curve.
CurveAnalysis analyse_curves(const std::vector<gel::v1::Curve>& curves, const RunAnalysisOptions& options = {});
nlohmann::json to_json(const CurveAnalysis& analysis);

// Reads DIR/curve.json and DIR/<row.snapshot> of every DIR. Throws InvalidArgument ("path").
RunAnalysis analyse_runs(const std::vector<std::string>& dirs, const RunAnalysisOptions& options = {});
nlohmann::json to_json(const RunAnalysis& analysis);

nlohmann::json to_json(const PowerLawFit& fit);
nlohmann::json to_json(const GelPointFit& fit);
nlohmann::json to_json(const MeanStd& value);
nlohmann::json to_json(const OptionalMeanStd& value);

}  // namespace gel::analysis

namespace gel::analysis {

// Every picture of a run or an ensemble into out_dir (created): pressure (P_y(phi), log-log,
// std error bars for an ensemble, power-law and gel-point fits, regime boundaries),
// correlation (C(r) for up to `curves_per_plot` phi_k), fractal_dimension (D_f(r), same rows),
// xi (xi^(0.5)(phi) and its power law), contact_number, energy_increments, rupture_rates,
// profiles (phi(y) of the recorded rows), and snapshots/k_NNN of the first member with the
// 4 xi circle; `format` is png, svg or pdf (pictures.hpp). Returns the files written.
struct PictureOptions {
  std::string format = "png";
  int curves_per_plot = 6;
  bool snapshots = true;
  int snapshot_size = 1000;
  int plot_width = 900, plot_height = 650;
  bool snapshot_antialias = true;
};
std::vector<std::string> render_run_pictures(const RunAnalysis& run, const std::string& out_dir,
                                             const PictureOptions& options = {});

}  // namespace gel::analysis
