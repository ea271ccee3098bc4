#pragma once
// The statistics of one study ensemble, shared by study_analysis.cpp (which reads the members and
// runs the bootstrap) and study_statistics.cpp (which evaluates the regime rules and the fits on
// one weighting of the members): the members' tables, the layout of the statistics in one flat
// vector, and EnsembleStatistics, which fills it.
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gel/analysis/fits.hpp"
#include "gel/analysis/study_analysis.hpp"

namespace gel::analysis::study_detail {

constexpr double kMissing = std::numeric_limits<double>::quiet_NaN();
// Below 3 members a percentile interval is two or three distinct means: not an interval.
constexpr int kMinimumMembersForInterval = 3;
// A power law through 2 points always fits; 3 is the least that can disagree with it.
constexpr int kMinimumPowerLawPoints = 3;
// fit_gel_point needs 4 points (3 parameters and a residual).
constexpr int kMinimumGelPointRows = 4;

enum RowObservable : int {
  kPhi, kP, kPTop, kPBot, kContactNumber, kStoredEnergy, kDissipatedEnergy,
  kRupturesNormal, kRupturesSliding, kRupturesRolling, kRowObservables
};
enum IntervalObservable : int { kStoredRate, kDissipatedRate, kGammaNormal, kGammaSliding, kGammaRolling, kIntervalObservables };
// Power laws of P: over every trusted row, then one per regime (index 1 + Regime).
enum PressureFit : int { kAllRows, kElasticRows, kSingleModeRows, kMultiModeRows, kPressureFits };
enum Boundary : int { kElasticToPlastic, kSingleToMultiMode, kBoundaries };

// Every member's numbers, read once, so that a resample costs weighted means and fits only.
struct MemberTables {
  int members = 0, rows = 0;
  std::vector<int> k;           // per row index
  std::vector<bool> trusted;    // per row index (row 0 never)
  std::vector<int> equilibrated, spanning;  // members, per row index
  std::vector<int> interval_upper;          // row index of each interval's upper row
  std::vector<bool> interval_trusted;
  // [observable][row * members + m] and [observable][interval * members + m]
  std::vector<std::vector<double>> row_values, interval_values;
  // Structure: rows (by index) where some member's snapshot gave xi^(0.5); [j][m], NaN when
  // that member has none; xi_complete[j]: every member has it.
  std::vector<int> xi_rows;
  std::vector<std::vector<double>> xi;
  std::vector<bool> xi_complete;
  std::vector<double> df_initial;  // [m], NaN when missing
};

// Positions of the statistics in one flat vector, so that the ensemble and every resample are
// evaluated, stored and summarised by the same code.
struct Layout {
  int rows = 0, intervals = 0, xi_rows = 0;
  int row(int observable, int r) const { return observable * rows + r; }
  int interval(int observable, int i) const { return kRowObservables * rows + observable * intervals + i; }
  int boundary(int which) const { return interval(kIntervalObservables, 0) + which; }
  // parameter 0: exponent, 1: prefactor
  int pressure_fit(int fit, int parameter) const { return boundary(kBoundaries) + 2 * fit + parameter; }
  // parameter 0: phi_g, 1: exponent, 2: prefactor
  int gel_point(int parameter) const { return pressure_fit(kPressureFits, 0) + parameter; }
  int xi(int j) const { return gel_point(3) + j; }
  int xi_fit(int parameter) const { return xi(xi_rows) + parameter; }
  int df_initial() const { return xi_fit(2); }
  int size() const { return df_initial() + 1; }
};

struct FitOutcome {
  std::optional<PowerLawFit> fit;
  std::vector<int> rows;  // row indices
  std::string error;
};

// What the fits of one evaluation used: kept for the ensemble itself, whose JSON states it.
struct Details {
  std::optional<double> boundary[kBoundaries];
  FitOutcome pressure[kPressureFits];
  std::optional<GelPointFit> gel_point;
  std::vector<int> gel_point_rows;
  std::string gel_point_error;
  FitOutcome xi;
};

// The regime of a row or interval at phi, given the two boundaries (a boundary belongs to the
// later regime).
Regime regime_at(double phi, const std::optional<double>& elastic_end, const std::optional<double>& multi_start);
// The regime rule in words, as the analysis states it in its JSON.
std::string regime_rule(double multi_mode_fraction);

// The statistics of an ensemble on one weighting of its members: the mean rows and intervals,
// the regime boundaries, the power laws of P per regime, the gel-point form, xi^(0.5) and D_f.
class EnsembleStatistics {
 public:
  EnsembleStatistics(const MemberTables& tables, double multi_mode_fraction);
  const Layout& layout() const { return layout_; }

  // The statistics of the members weighted by how often a resample drew each (all ones: the
  // ensemble itself) into `out` (layout().size(), NaN where a statistic has no value).
  void evaluate(const std::vector<double>& weights, std::vector<double>& out, Details& details) const;

 private:
  double weighted_mean(const std::vector<double>& values, int offset, const std::vector<double>& weights, double total) const;
  static double weighted_mean_present(const std::vector<double>& values, const std::vector<double>& weights);
  template <class RowMean>
  std::optional<double> elastic_to_plastic(const RowMean& row_mean) const;
  std::optional<double> single_to_multi_mode(const std::vector<double>& out, double elastic_end) const;
  FitOutcome fit_power_law_over(const std::vector<int>& rows, const std::vector<double>& x, const std::vector<double>& y) const;

  const MemberTables& t_;
  double fraction_;
  Layout layout_;
  std::vector<int> trusted_rows_;  // row indices, k >= 1
};

}  // namespace gel::analysis::study_detail
