#include "gel/analysis/study_analysis.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "gel/analysis/fits.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/fnv1a.hpp"

namespace gel::analysis {
namespace {

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

Regime regime_at(double phi, const std::optional<double>& elastic_end, const std::optional<double>& multi_start) {
  if (!elastic_end || phi < *elastic_end) return Regime::kElastic;
  if (multi_start && phi >= *multi_start) return Regime::kMultiModePlastic;
  return Regime::kSingleModePlastic;
}

std::string regime_rule(double multi_mode_fraction) {
  char fraction[32];
  std::snprintf(fraction, sizeof fraction, "%g", multi_mode_fraction);
  return std::string(
             "elastic -> plastic: the first trusted row (k >= 1) where the mean cumulative dissipated energy is >= the "
             "mean cumulative stored energy, its phi interpolated linearly in ln phi between it and the previous trusted "
             "row, where stored - dissipated changes sign (that row's own phi when no trusted row precedes it); "
             "single -> multi-mode: phi_lo of the first trusted interval at or above that boundary from which every "
             "trusted interval has a mean normal-break rate gamma_normal > 0 (where normal breaks begin and go on), "
             "the first one's also >= ") +
         fraction +
         " of the mean total rupture rate (normal + sliding + rolling); none without an elastic -> plastic boundary. "
         "Rows below the first boundary are elastic, from it to the second single-mode plastic, from the second on "
         "multi-mode plastic (a boundary row belongs to the later regime); an interval takes the regime of its phi_mid.";
}

class EnsembleStatistics {
 public:
  EnsembleStatistics(const MemberTables& tables, double multi_mode_fraction) : t_(tables), fraction_(multi_mode_fraction) {
    layout_.rows = t_.rows;
    layout_.intervals = static_cast<int>(t_.interval_upper.size());
    layout_.xi_rows = static_cast<int>(t_.xi_rows.size());
    for (int r = 1; r < t_.rows; ++r)
      if (t_.trusted[r]) trusted_rows_.push_back(r);
  }
  const Layout& layout() const { return layout_; }

  // The statistics of the members weighted by how often a resample drew each (all ones: the
  // ensemble itself) into `out` (layout().size(), NaN where a statistic has no value).
  void evaluate(const std::vector<double>& weights, std::vector<double>& out, Details& details) const {
    const int n = t_.members;
    out.assign(layout_.size(), kMissing);
    details = Details{};
    double total = 0;
    for (double w : weights) total += w;
    for (int o = 0; o < kRowObservables; ++o)
      for (int r = 0; r < t_.rows; ++r) out[layout_.row(o, r)] = weighted_mean(t_.row_values[o], r * n, weights, total);
    for (int o = 0; o < kIntervalObservables; ++o)
      for (int i = 0; i < layout_.intervals; ++i)
        out[layout_.interval(o, i)] = weighted_mean(t_.interval_values[o], i * n, weights, total);
    auto row_mean = [&](int observable, int r) { return out[layout_.row(observable, r)]; };

    const std::optional<double> elastic_end = elastic_to_plastic(row_mean);
    const std::optional<double> multi_start = elastic_end ? single_to_multi_mode(out, *elastic_end) : std::nullopt;
    details.boundary[kElasticToPlastic] = elastic_end;
    details.boundary[kSingleToMultiMode] = multi_start;
    if (elastic_end) out[layout_.boundary(kElasticToPlastic)] = *elastic_end;
    if (multi_start) out[layout_.boundary(kSingleToMultiMode)] = *multi_start;

    std::vector<double> phi(t_.rows), p(t_.rows);
    for (int r = 0; r < t_.rows; ++r) phi[r] = row_mean(kPhi, r), p[r] = row_mean(kP, r);
    std::vector<int> fit_rows[kPressureFits];
    for (int r : trusted_rows_) {
      fit_rows[kAllRows].push_back(r);
      fit_rows[1 + static_cast<int>(regime_at(phi[r], elastic_end, multi_start))].push_back(r);
    }
    for (int f = 0; f < kPressureFits; ++f) {
      details.pressure[f] = fit_power_law_over(fit_rows[f], phi, p);
      if (details.pressure[f].fit) {
        out[layout_.pressure_fit(f, 0)] = details.pressure[f].fit->exponent;
        out[layout_.pressure_fit(f, 1)] = details.pressure[f].fit->prefactor;
      }
    }

    // The gel-point form describes the network before normal breaks take over; with too few
    // rows there it is fitted over every trusted row rather than not at all.
    std::vector<int> below;
    for (int r : trusted_rows_)
      if (multi_start && phi[r] < *multi_start) below.push_back(r);
    details.gel_point_rows = static_cast<int>(below.size()) >= kMinimumGelPointRows ? below : trusted_rows_;
    std::vector<double> gel_phi, gel_p;
    for (int r : details.gel_point_rows) gel_phi.push_back(phi[r]), gel_p.push_back(p[r]);
    try {
      if (gel_phi.empty()) throw InvalidArgument("fit_range", "no trusted row");
      details.gel_point = fit_gel_point(gel_phi, gel_p, *std::min_element(gel_phi.begin(), gel_phi.end()),
                                        *std::max_element(gel_phi.begin(), gel_phi.end()));
      out[layout_.gel_point(0)] = details.gel_point->phi_g;
      out[layout_.gel_point(1)] = details.gel_point->exponent;
      out[layout_.gel_point(2)] = details.gel_point->prefactor;
    } catch (const InvalidArgument& error) {
      details.gel_point_error = error.what();
    }

    // Structure: a member without the value does not count in the mean (its weight is left out).
    std::vector<int> xi_fit_rows;
    std::vector<double> xi_phi(t_.rows, kMissing), xi_mean(t_.rows, kMissing);
    for (int j = 0; j < layout_.xi_rows; ++j) {
      const double mean = weighted_mean_present(t_.xi[j], weights);
      out[layout_.xi(j)] = mean;
      const int r = t_.xi_rows[j];
      xi_phi[r] = phi[r], xi_mean[r] = mean;
      if (t_.xi_complete[j]) xi_fit_rows.push_back(r);
    }
    details.xi = fit_power_law_over(xi_fit_rows, xi_phi, xi_mean);
    if (details.xi.fit) {
      out[layout_.xi_fit(0)] = details.xi.fit->exponent;
      out[layout_.xi_fit(1)] = details.xi.fit->prefactor;
    }
    out[layout_.df_initial()] = weighted_mean_present(t_.df_initial, weights);
  }

 private:
  double weighted_mean(const std::vector<double>& values, int offset, const std::vector<double>& weights, double total) const {
    double sum = 0;
    for (int m = 0; m < t_.members; ++m) sum += weights[m] * values[offset + m];
    return sum / total;
  }

  static double weighted_mean_present(const std::vector<double>& values, const std::vector<double>& weights) {
    double sum = 0, total = 0;
    for (std::size_t m = 0; m < values.size(); ++m)
      if (std::isfinite(values[m])) sum += weights[m] * values[m], total += weights[m];
    return total > 0 ? sum / total : kMissing;
  }

  // The first trusted row where the mean dissipated energy has caught up with the stored one.
  // Every trusted row before it still stores more than it dissipated, so the difference changes
  // sign between it and the previous trusted row: interpolated there, linearly in ln phi.
  template <class RowMean>
  std::optional<double> elastic_to_plastic(const RowMean& row_mean) const {
    int previous = -1;
    for (int r : trusted_rows_) {
      const double difference = row_mean(kStoredEnergy, r) - row_mean(kDissipatedEnergy, r);
      if (difference <= 0) {
        if (previous < 0) return row_mean(kPhi, r);
        const double before = row_mean(kStoredEnergy, previous) - row_mean(kDissipatedEnergy, previous);
        const double lo = std::log(row_mean(kPhi, previous)), hi = std::log(row_mean(kPhi, r));
        return std::exp(lo + before / (before - difference) * (hi - lo));
      }
      if (std::isfinite(difference)) previous = r;
    }
    return std::nullopt;
  }

  // Where normal breaks begin in the plastic range: the lower end of the first trusted interval
  // at or above the elastic -> plastic boundary from which every trusted interval breaks bonds
  // (gamma_normal > 0, and at least `fraction_` of all ruptures in the first one). Sliding
  // resets outnumber breaks 20-50 to 1 once both occur (1408-particle gels, both bond sets), so a
  // share of all ruptures never marks the onset; "from which every interval" keeps a stray early
  // break from doing so.
  std::optional<double> single_to_multi_mode(const std::vector<double>& out, double elastic_end) const {
    std::optional<double> onset;
    for (int i = 0; i < layout_.intervals; ++i) {
      if (!t_.interval_trusted[i]) continue;
      const double phi_lo = out[layout_.row(kPhi, t_.interval_upper[i] - 1)];
      if (phi_lo < elastic_end) continue;
      const double normal = out[layout_.interval(kGammaNormal, i)];
      const double all = normal + out[layout_.interval(kGammaSliding, i)] + out[layout_.interval(kGammaRolling, i)];
      if (!(normal > 0)) {
        onset.reset();
      } else if (!onset && normal >= fraction_ * all) {
        onset = phi_lo;
      }
    }
    return onset;
  }

  FitOutcome fit_power_law_over(const std::vector<int>& rows, const std::vector<double>& x, const std::vector<double>& y) const {
    FitOutcome outcome;
    outcome.rows = rows;
    if (static_cast<int>(rows.size()) < kMinimumPowerLawPoints) {
      outcome.error = "fewer than " + std::to_string(kMinimumPowerLawPoints) + " rows to fit (" + std::to_string(rows.size()) + ")";
      return outcome;
    }
    std::vector<double> xs, ys;
    for (int r : rows) xs.push_back(x[r]), ys.push_back(y[r]);
    try {
      PowerLawFit fit = fit_power_law(xs, ys, *std::min_element(xs.begin(), xs.end()), *std::max_element(xs.begin(), xs.end()));
      if (fit.points < kMinimumPowerLawPoints) {
        outcome.error = "fewer than " + std::to_string(kMinimumPowerLawPoints) + " rows with a positive value (" +
                        std::to_string(fit.points) + ")";
        return outcome;
      }
      outcome.fit = fit;
    } catch (const InvalidArgument& error) {
      outcome.error = error.what();
    }
    return outcome;
  }

  const MemberTables& t_;
  double fraction_;
  Layout layout_;
  std::vector<int> trusted_rows_;  // row indices, k >= 1
};

std::string ensemble_field(std::size_t index) { return "ensembles[" + std::to_string(index) + "]"; }

void validate(const std::vector<StudyEnsembleInput>& ensembles, const StudyAnalysisOptions& options) {
  if (ensembles.empty()) throw InvalidArgument("ensembles", "no ensemble to analyse");
  if (options.bootstrap_samples < 0)
    throw InvalidArgument("bootstrap_samples", "must be >= 0, got " + std::to_string(options.bootstrap_samples));
  if (!(options.multi_mode_fraction >= 0 && options.multi_mode_fraction <= 1))
    throw InvalidArgument("multi_mode_fraction", "must be in [0, 1]");
  std::set<std::string> names;
  for (std::size_t i = 0; i < ensembles.size(); ++i) {
    const StudyEnsembleInput& e = ensembles[i];
    const std::string field = ensemble_field(i);
    if (e.name.empty()) throw InvalidArgument(field + ".name", "is empty");
    if (!names.insert(e.name).second) throw InvalidArgument(field + ".name", "duplicate ensemble name '" + e.name + "'");
    if (e.curves.empty()) throw InvalidArgument(field + ".curves", "ensemble '" + e.name + "' has no member");
    if (e.seeds.size() != e.curves.size())
      throw InvalidArgument(field + ".seeds", std::to_string(e.seeds.size()) + " seeds for " + std::to_string(e.curves.size()) +
                                                  " member curves in ensemble '" + e.name + "'");
    if (!e.dirs.empty() && e.dirs.size() != e.curves.size())
      throw InvalidArgument(field + ".dirs", std::to_string(e.dirs.size()) + " directories for " +
                                                 std::to_string(e.curves.size()) + " member curves in ensemble '" + e.name + "'");
    for (std::size_t m = 0; m < e.curves.size(); ++m) {
      const std::string member = field + ".curves[" + std::to_string(m) + "]";
      if (e.curves[m].particles() <= 0) throw InvalidArgument(member + ".particles", "the curve has no particle count");
      if (e.curves[m].rows_size() == 0) throw InvalidArgument(member + ".rows", "the curve has no row");
    }
  }
}

// The curve tables of the members, matched by row index up to the shortest member.
MemberTables member_tables(const StudyEnsembleInput& e, const CurveAnalysis& curve_analysis) {
  MemberTables t;
  t.members = static_cast<int>(e.curves.size());
  t.rows = curve_analysis.mean_curve.rows_size();
  const int n = t.members;
  std::set<int> fit_rows(curve_analysis.fit_rows.begin(), curve_analysis.fit_rows.end());
  t.row_values.assign(kRowObservables, std::vector<double>(static_cast<std::size_t>(t.rows) * n));
  t.equilibrated.assign(t.rows, 0);
  t.spanning.assign(t.rows, 0);
  for (int r = 0; r < t.rows; ++r) {
    t.k.push_back(e.curves[0].rows(r).k());
    // analyse_curves decides which rows the fits trust (it lists the rest with their reason).
    t.trusted.push_back(r >= 1 && fit_rows.count(t.k.back()) > 0);
    for (int m = 0; m < n; ++m) {
      const gel::v1::CurveRow& row = e.curves[m].rows(r);
      const double particles = e.curves[m].particles();
      const double values[kRowObservables] = {
          row.phi(), row.p(), row.p_top(), row.p_bot(), row.contact_number(), row.stored_energy(), row.dissipated_energy(),
          static_cast<double>(row.ruptures().normal()) / particles, static_cast<double>(row.ruptures().sliding()) / particles,
          static_cast<double>(row.ruptures().rolling()) / particles};
      for (int o = 0; o < kRowObservables; ++o) t.row_values[o][static_cast<std::size_t>(r) * n + m] = values[o];
      t.equilibrated[r] += row.equilibrated();
      t.spanning[r] += row.spans();
    }
  }
  // Increments per member (curve_increments skips an interval without compression; one that
  // some member lacks is left out, so that every interval is a mean over all members).
  std::vector<std::map<int, Increment>> increments(n);
  for (int m = 0; m < n; ++m)
    for (const Increment& inc : curve_increments(e.curves[m]))
      if (inc.row < t.rows) increments[m][inc.row] = inc;
  for (int r = 1; r < t.rows; ++r) {
    bool everywhere = true;
    for (int m = 0; m < n; ++m) everywhere = everywhere && increments[m].count(r) > 0;
    if (!everywhere) continue;
    t.interval_upper.push_back(r);
    // Row 0 is the generated network: a defined state to count increments from.
    t.interval_trusted.push_back(t.trusted[r] && (r == 1 || t.trusted[r - 1]));
  }
  t.interval_values.assign(kIntervalObservables, std::vector<double>(t.interval_upper.size() * n));
  for (std::size_t i = 0; i < t.interval_upper.size(); ++i)
    for (int m = 0; m < n; ++m) {
      const Increment& inc = increments[m].at(t.interval_upper[i]);
      const double values[kIntervalObservables] = {inc.stored_rate, inc.dissipated_rate, inc.gamma_normal, inc.gamma_sliding,
                                                   inc.gamma_rolling};
      for (int o = 0; o < kIntervalObservables; ++o) t.interval_values[o][i * n + m] = values[o];
    }
  t.df_initial.assign(n, kMissing);
  return t;
}

// xi^(0.5) of every member's snapshot per row and D_f of its row-0 snapshot: from the member's
// structure.json where it holds them, else from DIR/<row.snapshot> as analyse_runs reads them
// (skipped when not named or not on disk).
double load_structures(const StudyEnsembleInput& e, const StructureOptions& options, MemberTables& t) {
  const auto start = std::chrono::steady_clock::now();
  const int n = t.members;
  std::vector<std::vector<double>> xi(t.rows, std::vector<double>(n, kMissing));
  for (int m = 0; m < n; ++m) {
    const std::optional<MemberStructure> stored = read_member_structure(e.dirs[m], e.curves[m], options);
    const MemberStructure s = stored ? *stored : member_structure(e.dirs[m], e.curves[m], options);
    for (int r = 0; r < t.rows; ++r)
      if (s.xi_05[static_cast<std::size_t>(r)]) xi[r][m] = *s.xi_05[static_cast<std::size_t>(r)];
    if (s.df_initial) t.df_initial[m] = *s.df_initial;
  }
  for (int r = 0; r < t.rows; ++r) {
    const auto present = std::count_if(xi[r].begin(), xi[r].end(), [](double v) { return std::isfinite(v); });
    if (present == 0) continue;
    t.xi_rows.push_back(r);
    t.xi.push_back(xi[r]);
    t.xi_complete.push_back(present == n);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The resampling stream of one ensemble: bootstrap_seed and the ensemble's name (FNV-1a), so
// that its intervals do not depend on the other ensembles or their order. std::seed_seq and
// mt19937_64 are specified exactly by the standard: the same numbers with any library.
std::mt19937_64 resampling_engine(std::uint64_t seed, const std::string& name) {
  const std::uint64_t hash = fnv1a(name);
  std::seed_seq sequence{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                         static_cast<std::uint32_t>(hash), static_cast<std::uint32_t>(hash >> 32)};
  return std::mt19937_64(sequence);
}

// Linear interpolation between order statistics.
double percentile(const std::vector<double>& sorted, double p) {
  const double position = p * static_cast<double>(sorted.size() - 1);
  const std::size_t below = static_cast<std::size_t>(std::floor(position));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (position - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

// The bootstrap of one ensemble: the statistics of every resample, one row of `size` each.
class Resamples {
 public:
  Resamples(const EnsembleStatistics& statistics, int members, int count, std::mt19937_64 engine)
      : size_(statistics.layout().size()), count_(count) {
    values_.resize(static_cast<std::size_t>(count) * size_);
    std::vector<double> weights(members), out;
    Details details;
    for (int b = 0; b < count; ++b) {
      std::fill(weights.begin(), weights.end(), 0.0);
      // engine() % members: the modulo bias is below members / 2^64.
      for (int j = 0; j < members; ++j) weights[engine() % static_cast<std::uint64_t>(members)] += 1;
      statistics.evaluate(weights, out, details);
      std::copy(out.begin(), out.end(), values_.begin() + static_cast<std::ptrdiff_t>(b) * size_);
      gel_point_at_bound_ += details.gel_point && details.gel_point->phi_g_at_bound;
    }
  }
  int count() const { return count_; }
  int gel_point_at_bound() const { return gel_point_at_bound_; }

  // The estimate of statistic `index`, worth `value` on the ensemble with n members behind it.
  Estimate estimate(int index, double value, int n) const {
    Estimate e;
    e.value = value;
    e.n = n;
    if (n < kMinimumMembersForInterval || count_ == 0) return e;
    e.resamples = count_;
    std::vector<double> present;
    for (int b = 0; b < count_; ++b) {
      const double v = values_[static_cast<std::size_t>(b) * size_ + index];
      if (std::isfinite(v)) present.push_back(v);
    }
    e.resamples_with_value = static_cast<int>(present.size());
    if (2 * e.resamples_with_value < count_) return e;
    std::sort(present.begin(), present.end());
    e.lo = percentile(present, (1 - kStudyConfidence) / 2);
    e.hi = percentile(present, (1 + kStudyConfidence) / 2);
    return e;
  }

 private:
  int size_, count_;
  std::vector<double> values_;
  int gel_point_at_bound_ = 0;
};

StudyEnsembleAnalysis analyse_ensemble(const StudyEnsembleInput& input, std::size_t index, const StudyAnalysisOptions& options) {
  RunAnalysisOptions run_options;
  run_options.include_unequilibrated = options.include_unequilibrated;
  run_options.multi_mode_fraction = options.multi_mode_fraction;
  run_options.structures = false;
  CurveAnalysis curve_analysis;
  try {
    curve_analysis = analyse_curves(input.curves, run_options);
  } catch (const InvalidArgument& error) {
    throw InvalidArgument(ensemble_field(index) + ".curves", error.what());
  }
  MemberTables tables = member_tables(input, curve_analysis);

  StudyEnsembleAnalysis a;
  a.name = input.name;
  a.seeds = input.seeds;
  a.members = tables.members;
  a.particles = input.curves[0].particles();
  a.excluded_rows = curve_analysis.excluded_rows;
  a.regime_rule = regime_rule(options.multi_mode_fraction);
  if (options.structures && !input.dirs.empty()) a.structure_seconds = load_structures(input, options.structure, tables);

  const EnsembleStatistics statistics(tables, options.multi_mode_fraction);
  const Layout& layout = statistics.layout();
  std::vector<double> value;
  Details details;
  statistics.evaluate(std::vector<double>(tables.members, 1.0), value, details);
  const int resample_count = tables.members >= kMinimumMembersForInterval ? options.bootstrap_samples : 0;
  const Resamples resamples(statistics, tables.members, resample_count, resampling_engine(options.bootstrap_seed, input.name));
  auto estimate = [&](int i, int n) { return resamples.estimate(i, value[i], n); };
  const int n = tables.members;

  for (int r = 0; r < tables.rows; ++r) {
    StudyRow row;
    row.k = tables.k[r];
    Estimate* fields[kRowObservables] = {&row.phi, &row.p, &row.p_top, &row.p_bot, &row.contact_number,
                                         &row.stored_energy, &row.dissipated_energy, &row.ruptures_normal,
                                         &row.ruptures_sliding, &row.ruptures_rolling};
    for (int o = 0; o < kRowObservables; ++o) *fields[o] = estimate(layout.row(o, r), n);
    row.equilibrated_members = tables.equilibrated[r];
    row.spanning_members = tables.spanning[r];
    row.trusted = tables.trusted[r];
    if (row.trusted)
      row.regime = regime_at(row.phi.value, details.boundary[kElasticToPlastic], details.boundary[kSingleToMultiMode]);
    a.rows.push_back(std::move(row));
  }
  for (int i = 0; i < layout.intervals; ++i) {
    StudyInterval interval;
    const int upper = tables.interval_upper[i];
    interval.k = tables.k[upper];
    interval.phi_lo = value[layout.row(kPhi, upper - 1)];
    interval.phi_hi = value[layout.row(kPhi, upper)];
    interval.phi_mid = std::sqrt(interval.phi_lo * interval.phi_hi);
    Estimate* fields[kIntervalObservables] = {&interval.stored_rate, &interval.dissipated_rate, &interval.gamma_normal,
                                              &interval.gamma_sliding, &interval.gamma_rolling};
    for (int o = 0; o < kIntervalObservables; ++o) *fields[o] = estimate(layout.interval(o, i), n);
    interval.trusted = tables.interval_trusted[i];
    if (interval.trusted)
      interval.regime = regime_at(interval.phi_mid, details.boundary[kElasticToPlastic], details.boundary[kSingleToMultiMode]);
    a.intervals.push_back(std::move(interval));
  }
  if (details.boundary[kElasticToPlastic]) {
    a.elastic_to_plastic_phi = estimate(layout.boundary(kElasticToPlastic), n);
    // No trusted row stores more than it has dissipated: the boundary is the first trusted row
    // itself, and the elastic regime (if any) lies below the rows that can be trusted.
    for (const StudyRow& row : a.rows)
      if (row.trusted) {
        a.elastic_to_plastic_at_first_trusted_row = *details.boundary[kElasticToPlastic] == row.phi.value;
        break;
      }
  }
  if (details.boundary[kSingleToMultiMode]) a.single_to_multi_mode_phi = estimate(layout.boundary(kSingleToMultiMode), n);

  auto power_law = [&](const FitOutcome& outcome, int exponent_index, int prefactor_index, int members) {
    OptionalPowerLaw result;
    if (!outcome.fit) {
      result.error = outcome.error;
      return result;
    }
    PowerLawEstimate fit;
    fit.exponent = estimate(exponent_index, members);
    fit.prefactor = estimate(prefactor_index, members);
    fit.phi_min = outcome.fit->x_min;
    fit.phi_max = outcome.fit->x_max;
    fit.points = outcome.fit->points;
    fit.rms_log_residual = outcome.fit->rms_log_residual;
    for (int r : outcome.rows) fit.rows.push_back(tables.k[r]);
    result.fit = std::move(fit);
    return result;
  };
  a.power_law_all = power_law(details.pressure[kAllRows], layout.pressure_fit(kAllRows, 0), layout.pressure_fit(kAllRows, 1), n);
  for (int regime = 0; regime < 3; ++regime)
    a.power_law_regime[regime] =
        power_law(details.pressure[1 + regime], layout.pressure_fit(1 + regime, 0), layout.pressure_fit(1 + regime, 1), n);

  if (details.gel_point) {
    GelPointEstimate g;
    g.phi_g = estimate(layout.gel_point(0), n);
    g.exponent = estimate(layout.gel_point(1), n);
    g.prefactor = estimate(layout.gel_point(2), n);
    g.phi_min = details.gel_point->x_min;
    g.phi_max = details.gel_point->x_max;
    g.points = details.gel_point->points;
    g.at_bound = details.gel_point->phi_g_at_bound;
    g.converged = details.gel_point->converged;
    g.resamples_at_bound = resamples.gel_point_at_bound();
    for (int r : details.gel_point_rows) g.rows.push_back(tables.k[r]);
    a.gel_point = std::move(g);
  } else {
    a.gel_point_error = details.gel_point_error;
  }

  for (int j = 0; j < layout.xi_rows; ++j) {
    const auto& members = tables.xi[j];
    const int present = static_cast<int>(std::count_if(members.begin(), members.end(), [](double v) { return std::isfinite(v); }));
    const int r = tables.xi_rows[j];
    a.xi_05.push_back({tables.k[r], value[layout.row(kPhi, r)], estimate(layout.xi(j), present)});
  }
  if (options.structures && !input.dirs.empty())
    a.xi_power_law = power_law(details.xi, layout.xi_fit(0), layout.xi_fit(1), n);
  else
    a.xi_power_law.error = input.dirs.empty() ? "no run directories given" : "structures not analysed";
  const int df_present = static_cast<int>(
      std::count_if(tables.df_initial.begin(), tables.df_initial.end(), [](double v) { return std::isfinite(v); }));
  if (df_present > 0) a.fractal_dimension_initial = estimate(layout.df_initial(), df_present);
  return a;
}

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
nlohmann::json optional_number(const std::optional<double>& v) { return v ? number(*v) : nlohmann::json(nullptr); }
nlohmann::json optional_estimate(const std::optional<Estimate>& e) { return e ? to_json(*e) : nlohmann::json(nullptr); }
nlohmann::json regime_json(const std::optional<Regime>& r) { return r ? nlohmann::json(regime_name(*r)) : nlohmann::json(nullptr); }

nlohmann::json to_json(const PowerLawEstimate& f) {
  return {{"exponent", to_json(f.exponent)}, {"prefactor", to_json(f.prefactor)}, {"phi_min", f.phi_min},
          {"phi_max", f.phi_max}, {"points", f.points}, {"rms_log_residual", number(f.rms_log_residual)}, {"rows", f.rows}};
}

// A fit that failed is null, with its reason beside it under "<key>_error".
void put_fit(nlohmann::json& j, const std::string& key, const OptionalPowerLaw& f) {
  j[key] = f.fit ? to_json(*f.fit) : nlohmann::json(nullptr);
  if (!f.fit) j[key + "_error"] = f.error;
}

nlohmann::json to_json(const StudyEnsembleAnalysis& a) {
  nlohmann::json j;
  j["name"] = a.name;
  j["seeds"] = a.seeds;
  j["members"] = a.members;
  j["particles"] = a.particles;
  nlohmann::json rows = nlohmann::json::array();
  for (const StudyRow& r : a.rows)
    rows.push_back({{"k", r.k}, {"phi", to_json(r.phi)}, {"P", to_json(r.p)}, {"P_top", to_json(r.p_top)},
                    {"P_bot", to_json(r.p_bot)}, {"contact_number", to_json(r.contact_number)},
                    {"stored_energy", to_json(r.stored_energy)}, {"dissipated_energy", to_json(r.dissipated_energy)},
                    {"ruptures_normal", to_json(r.ruptures_normal)}, {"ruptures_sliding", to_json(r.ruptures_sliding)},
                    {"ruptures_rolling", to_json(r.ruptures_rolling)}, {"equilibrated_members", r.equilibrated_members},
                    {"spanning_members", r.spanning_members}, {"trusted", r.trusted}, {"regime", regime_json(r.regime)}});
  j["rows"] = rows;
  nlohmann::json intervals = nlohmann::json::array();
  for (const StudyInterval& i : a.intervals)
    intervals.push_back({{"k", i.k}, {"phi_lo", i.phi_lo}, {"phi_hi", i.phi_hi}, {"phi_mid", i.phi_mid},
                         {"stored_rate", to_json(i.stored_rate)}, {"dissipated_rate", to_json(i.dissipated_rate)},
                         {"gamma_normal", to_json(i.gamma_normal)}, {"gamma_sliding", to_json(i.gamma_sliding)},
                         {"gamma_rolling", to_json(i.gamma_rolling)}, {"regime", regime_json(i.regime)},
                         {"trusted", i.trusted}});
  j["intervals"] = intervals;
  nlohmann::json excluded = nlohmann::json::array();
  for (const ExcludedRow& row : a.excluded_rows) excluded.push_back({{"k", row.k}, {"phi", row.phi}, {"reason", row.reason}});
  j["excluded_rows"] = excluded;
  j["regimes"] = {{"elastic_to_plastic_phi", optional_estimate(a.elastic_to_plastic_phi)},
                  {"elastic_to_plastic_at_first_trusted_row", a.elastic_to_plastic_at_first_trusted_row},
                  {"single_to_multi_mode_phi", optional_estimate(a.single_to_multi_mode_phi)},
                  {"rule", a.regime_rule}};
  nlohmann::json power_law = nlohmann::json::object();
  put_fit(power_law, "all", a.power_law_all);
  put_fit(power_law, "elastic", a.power_law_regime[static_cast<int>(Regime::kElastic)]);
  put_fit(power_law, "single_mode_plastic", a.power_law_regime[static_cast<int>(Regime::kSingleModePlastic)]);
  put_fit(power_law, "multi_mode_plastic", a.power_law_regime[static_cast<int>(Regime::kMultiModePlastic)]);
  j["power_law"] = power_law;
  if (a.gel_point) {
    const GelPointEstimate& g = *a.gel_point;
    j["gel_point"] = {{"phi_g", to_json(g.phi_g)}, {"exponent", to_json(g.exponent)}, {"prefactor", to_json(g.prefactor)},
                      {"phi_min", g.phi_min}, {"phi_max", g.phi_max}, {"points", g.points}, {"at_bound", g.at_bound},
                      {"converged", g.converged}, {"resamples_at_bound", g.resamples_at_bound}, {"rows", g.rows}};
  } else {
    j["gel_point"] = {{"error", a.gel_point_error}};
  }
  nlohmann::json xi = nlohmann::json::array();
  for (const StudyXiRow& row : a.xi_05) xi.push_back({{"k", row.k}, {"phi", row.phi}, {"xi", to_json(row.xi)}});
  j["xi_05"] = xi;
  put_fit(j, "xi_power_law", a.xi_power_law);
  j["fractal_dimension_initial"] = optional_estimate(a.fractal_dimension_initial);
  j["structure_seconds"] = a.structure_seconds;
  return j;
}

}  // namespace

nlohmann::json member_structure_options(const StructureOptions& o) {
  return {{"pixel", o.pixel},
          {"fit_rmin", o.fit_rmin},
          {"fit_rmax", o.fit_rmax},
          {"df_half_window", o.df_half_window},
          {"correlation", {{"bin", o.correlation.bin}, {"r_max", o.correlation.r_max}}},
          {"fluctuation", {{"l_min", o.fluctuation.l_min}, {"l_max", o.fluctuation.l_max}, {"factor", o.fluctuation.factor}}}};
}

MemberStructure member_structure(const std::string& dir, const gel::v1::Curve& curve, const StructureOptions& options) {
  MemberStructure s;
  s.options = member_structure_options(options);
  s.xi_05.resize(static_cast<std::size_t>(curve.rows_size()));
  for (int r = 0; r < curve.rows_size(); ++r) {
    const std::string& name = curve.rows(r).snapshot();
    if (name.empty()) continue;
    const std::string path = (std::filesystem::path(dir) / name).string();
    if (!std::filesystem::exists(path)) continue;
    const StructureAnalysis a = analyse_structure(read_configuration(path), options);
    s.xi_05[static_cast<std::size_t>(r)] = a.xi_05;
    if (r == 0 && a.df_fit) s.df_initial = a.df_fit->df;
  }
  return s;
}

nlohmann::json to_json(const MemberStructure& s, const gel::v1::Curve& curve) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < curve.rows_size(); ++r)
    rows.push_back({{"k", curve.rows(r).k()}, {"xi_05", optional_number(s.xi_05[static_cast<std::size_t>(r)])}});
  return {{"format", kMemberStructureFormat}, {"rows", rows}, {"D_f_initial", optional_number(s.df_initial)},
          {"options", s.options}};
}

std::optional<MemberStructure> read_member_structure(const std::string& dir, const gel::v1::Curve& curve,
                                                     const StructureOptions& options) {
  const std::filesystem::path path = std::filesystem::path(dir) / kMemberStructureFile;
  if (!std::filesystem::exists(path)) return std::nullopt;
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  // Anything but the file this code writes for this curve and these options is recomputed.
  if (!j.is_object() || j.value("format", "") != kMemberStructureFormat || !j.contains("rows") ||
      !j.at("rows").is_array() || j.at("rows").size() != static_cast<std::size_t>(curve.rows_size()) ||
      j.value("options", nlohmann::json()) != member_structure_options(options))
    return std::nullopt;
  MemberStructure s;
  s.options = j.at("options");
  for (int r = 0; r < curve.rows_size(); ++r) {
    const nlohmann::json& row = j.at("rows")[static_cast<std::size_t>(r)];
    if (!row.is_object() || row.value("k", -1) != curve.rows(r).k()) return std::nullopt;
    const nlohmann::json& xi = row.value("xi_05", nlohmann::json());
    s.xi_05.push_back(xi.is_number() ? std::optional<double>(xi.get<double>()) : std::nullopt);
  }
  const nlohmann::json& df = j.value("D_f_initial", nlohmann::json());
  if (df.is_number()) s.df_initial = df.get<double>();
  return s;
}

StudyAnalysis analyse_study(const std::vector<StudyEnsembleInput>& ensembles, const StudyAnalysisOptions& options) {
  validate(ensembles, options);
  StudyAnalysis study;
  study.bootstrap_samples = options.bootstrap_samples;
  study.bootstrap_seed = options.bootstrap_seed;
  for (std::size_t i = 0; i < ensembles.size(); ++i) study.ensembles.push_back(analyse_ensemble(ensembles[i], i, options));
  return study;
}

nlohmann::json to_json(const Estimate& e) {
  nlohmann::json j = {{"value", number(e.value)}, {"lo", optional_number(e.lo)}, {"hi", optional_number(e.hi)}, {"n", e.n}};
  if (e.resamples > 0 && e.resamples_with_value < e.resamples) j["resamples_with_value"] = e.resamples_with_value;
  return j;
}

nlohmann::json to_json(const StudyAnalysis& analysis) {
  nlohmann::json ensembles = nlohmann::json::array();
  for (const StudyEnsembleAnalysis& e : analysis.ensembles) ensembles.push_back(to_json(e));
  return {{"format", kStudyAnalysisFormat}, {"bootstrap_samples", analysis.bootstrap_samples},
          {"bootstrap_seed", analysis.bootstrap_seed}, {"confidence", analysis.confidence}, {"ensembles", ensembles}};
}

}  // namespace gel::analysis
