#pragma once
// The analysis of a study: several ensembles (a scene on several seeds each), every observable
// of the study it implements (Seto et al., J. Rheol. 57, 2013) given with a 95 % interval and
// the number of seeds behind it (docs/study_analysis.md).
//
// Per ensemble, on the ensemble-mean curve (members matched by row index k up to the shortest,
// as curve_ensemble does):
//   - per row and per interval, the member means of the recorded observables and of the
//     increments of curve_increments;
//   - the two regime boundaries: elastic -> plastic where the mean cumulative dissipated energy
//     reaches the mean stored energy (interpolated in ln phi), single -> multi-mode where normal
//     breaks begin and go on (every later trusted interval breaks bonds);
//   - P = C phi^lambda over the trusted rows and over each regime's trusted rows, and the
//     gel-point form below the single -> multi-mode boundary;
//   - with run directories, xi^(0.5) per row and D_f of the generated network from the members'
//     snapshots, and the power law of xi^(0.5) against phi.
// Trusted rows are those of analyse_curves (run_analysis.hpp); row 0 never enters a fit.
//
// Uncertainty: percentile bootstrap over members. Each resample draws the members with
// replacement, recomputes the whole chain above on its own mean curve (boundaries included,
// so an exponent's interval carries the boundary's uncertainty) and the 2.5 / 97.5 percentiles
// of the resamples bound the interval. The draws come from std::mt19937_64 seeded from
// bootstrap_seed and the ensemble's name: the output is deterministic, and an ensemble's
// intervals do not depend on the other ensembles of the study.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gel/analysis/curve_analysis.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/structure.hpp"
#include "gel/v1/scene.pb.h"

namespace gel::analysis {

struct StudyEnsembleInput {
  std::string name;                    // "bond1"
  std::vector<gel::v1::Curve> curves;  // one per member (seed), rows k = 0.. in order
  std::vector<std::uint64_t> seeds;    // same length as curves
  // Optional: each member's run directory (curve.json + snapshots/...), for the structure
  // observables; empty: skip them.
  std::vector<std::string> dirs;
};

struct StudyAnalysisOptions {
  int bootstrap_samples = 1000;
  std::uint64_t bootstrap_seed = 1;
  bool include_unequilibrated = false;  // as RunAnalysisOptions
  bool structures = true;               // analyse snapshots when dirs are given
  StructureOptions structure;
  // The share of all ruptures that normal breaks must reach where they begin (0: any break);
  // see single -> multi-mode below.
  double multi_mode_fraction = 0;
};

inline constexpr double kStudyConfidence = 0.95;
inline constexpr const char* kStudyAnalysisFormat = "gel.study-analysis.v1";

// A number measured on an ensemble: `value` on all its members, [lo, hi] the percentile
// bootstrap interval. lo/hi are missing with fewer than 3 members behind the value, without
// resamples, or when fewer than half of the resamples give a value (a fit that fails, a
// boundary that is not found); the interval then is over the resamples that have one.
struct Estimate {
  double value = 0;
  std::optional<double> lo, hi;
  int n = 0;                     // members (seeds) behind the value
  int resamples = 0;             // resamples drawn (0 when n < 3)
  int resamples_with_value = 0;
};

// A power law (P or xi^(0.5) against phi) fitted on the mean curve, with its bootstrap.
struct PowerLawEstimate {
  Estimate exponent, prefactor;
  double phi_min = 0, phi_max = 0;
  int points = 0;
  double rms_log_residual = 0;
  std::vector<int> rows;  // k of the rows fitted
};
// A fit that may fail: `error` says why when `fit` is missing (fewer than 3 points).
struct OptionalPowerLaw {
  std::optional<PowerLawEstimate> fit;
  std::string error;
};

struct GelPointEstimate {
  Estimate phi_g, exponent, prefactor;
  double phi_min = 0, phi_max = 0;
  int points = 0;
  bool at_bound = false, converged = false;  // of the fit on all members
  int resamples_at_bound = 0;
  std::vector<int> rows;
};

struct StudyRow {
  int k = 0;
  Estimate phi, p, p_top, p_bot, contact_number, stored_energy, dissipated_energy;
  Estimate ruptures_normal, ruptures_sliding, ruptures_rolling;  // cumulative, per particle
  int equilibrated_members = 0, spanning_members = 0;
  bool trusted = false;            // enters the fits and the regimes (never row 0)
  std::optional<Regime> regime;    // trusted rows only
};

struct StudyInterval {
  int k = 0;                                   // upper row
  double phi_lo = 0, phi_hi = 0, phi_mid = 0;  // mean phi of its rows; phi_mid = sqrt(lo hi)
  Estimate stored_rate, dissipated_rate;       // dE / d ln phi [F0 a]
  Estimate gamma_normal, gamma_sliding, gamma_rolling;  // (1/N) dN / d ln phi
  bool trusted = false;          // both rows trusted (row 0, the initial state, counts as such)
  std::optional<Regime> regime;  // trusted intervals only, from their phi_mid
};

struct StudyXiRow {
  int k = 0;
  double phi = 0;  // mean phi of the row
  Estimate xi;     // over the members whose snapshot gave xi^(0.5)
};

struct StudyEnsembleAnalysis {
  std::string name;
  std::vector<std::uint64_t> seeds;
  int members = 0;
  int particles = 0;  // of the first member
  std::vector<StudyRow> rows;
  std::vector<StudyInterval> intervals;
  std::vector<ExcludedRow> excluded_rows;  // as analyse_curves lists them
  std::optional<Estimate> elastic_to_plastic_phi, single_to_multi_mode_phi;
  // The first trusted row already dissipated as much as it stores: the boundary is that row's
  // phi, an upper bound (the elastic regime lies below the rows at equilibrium and spanning).
  bool elastic_to_plastic_at_first_trusted_row = false;
  std::string regime_rule;
  OptionalPowerLaw power_law_all;
  OptionalPowerLaw power_law_regime[3];  // indexed by Regime
  std::optional<GelPointEstimate> gel_point;
  std::string gel_point_error;
  std::vector<StudyXiRow> xi_05;
  OptionalPowerLaw xi_power_law;
  std::optional<Estimate> fractal_dimension_initial;
  double structure_seconds = 0;  // snapshot analyses, all members
};

struct StudyAnalysis {
  int bootstrap_samples = 0;
  std::uint64_t bootstrap_seed = 0;
  double confidence = kStudyConfidence;
  std::vector<StudyEnsembleAnalysis> ensembles;
};

// The structure numbers of one member that a study's analysis uses: xi^(0.5) of each row's
// snapshot and D_f of the row-0 snapshot (the generated network). Kept beside the member's
// curve as DIR/structure.json, so that a study can be analysed, and archived, without the
// snapshots (megabytes a member against kilobytes): analyse_study reads that file where it
// exists and was made with the same structure options, and the snapshots otherwise.
struct MemberStructure {
  std::vector<std::optional<double>> xi_05;  // per curve row, by index; empty: no snapshot or no value
  std::optional<double> df_initial;
  nlohmann::json options;  // the StructureOptions it was computed with (member_structure_options)
};
inline constexpr const char* kMemberStructureFormat = "gel.member-structure.v1";
inline constexpr const char* kMemberStructureFile = "structure.json";

// From the member's snapshots DIR/<row.snapshot> (rows without one, or whose file is gone, stay
// empty). Throws InvalidArgument("path") for a snapshot that exists but cannot be read.
MemberStructure member_structure(const std::string& dir, const gel::v1::Curve& curve, const StructureOptions& options);
nlohmann::json member_structure_options(const StructureOptions& options);
// {"format": "gel.member-structure.v1", "rows": [{"k", "xi_05": number|null}], "D_f_initial", "options"}
nlohmann::json to_json(const MemberStructure& structure, const gel::v1::Curve& curve);
// DIR/structure.json if it exists, is of this format, matches the curve's rows and was made with
// these options; otherwise nothing.
std::optional<MemberStructure> read_member_structure(const std::string& dir, const gel::v1::Curve& curve,
                                                     const StructureOptions& options);

// Throws InvalidArgument naming the field: "ensembles" (none), "ensembles[i].curves" (no
// member, members whose rows differ), "ensembles[i].seeds" (not one per curve),
// "ensembles[i].dirs" (given, but not one per curve), "ensembles[i].name" (empty or
// duplicate), "ensembles[i].curves[m].particles", "bootstrap_samples", "multi_mode_fraction";
// and "path" from reading a snapshot that exists but cannot be read.
StudyAnalysis analyse_study(const std::vector<StudyEnsembleInput>& ensembles, const StudyAnalysisOptions& options = {});

// {"format": "gel.study-analysis.v1", "bootstrap_samples", "bootstrap_seed", "confidence",
//  "ensembles": [...]}: docs/study_analysis.md gives the whole shape.
nlohmann::json to_json(const StudyAnalysis& analysis);
nlohmann::json to_json(const Estimate& estimate);

}  // namespace gel::analysis
