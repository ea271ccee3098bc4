// analyse_study: reads each ensemble's members into tables, evaluates the statistics on the
// ensemble and on every bootstrap resample (study_statistics.cpp), and gathers the estimates.
// The JSON of the result and of the members' structure.json: study_analysis_json.cpp.
#include "gel/analysis/study_analysis.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "gel/errors.hpp"
#include "gel/fnv1a.hpp"
#include "study_statistics.hpp"

namespace gel::analysis {
namespace {

using namespace study_detail;

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

}  // namespace

StudyAnalysis analyse_study(const std::vector<StudyEnsembleInput>& ensembles, const StudyAnalysisOptions& options) {
  validate(ensembles, options);
  StudyAnalysis study;
  study.bootstrap_samples = options.bootstrap_samples;
  study.bootstrap_seed = options.bootstrap_seed;
  for (std::size_t i = 0; i < ensembles.size(); ++i) study.ensembles.push_back(analyse_ensemble(ensembles[i], i, options));
  return study;
}

}  // namespace gel::analysis
