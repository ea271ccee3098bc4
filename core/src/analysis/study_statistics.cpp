#include "study_statistics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gel/errors.hpp"

namespace gel::analysis::study_detail {

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

EnsembleStatistics::EnsembleStatistics(const MemberTables& tables, double multi_mode_fraction)
    : t_(tables), fraction_(multi_mode_fraction) {
  layout_.rows = t_.rows;
  layout_.intervals = static_cast<int>(t_.interval_upper.size());
  layout_.xi_rows = static_cast<int>(t_.xi_rows.size());
  for (int r = 1; r < t_.rows; ++r)
    if (t_.trusted[r]) trusted_rows_.push_back(r);
}

void EnsembleStatistics::evaluate(const std::vector<double>& weights, std::vector<double>& out, Details& details) const {
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

double EnsembleStatistics::weighted_mean(const std::vector<double>& values, int offset, const std::vector<double>& weights, double total) const {
  double sum = 0;
  for (int m = 0; m < t_.members; ++m) sum += weights[m] * values[offset + m];
  return sum / total;
}

double EnsembleStatistics::weighted_mean_present(const std::vector<double>& values, const std::vector<double>& weights) {
  double sum = 0, total = 0;
  for (std::size_t m = 0; m < values.size(); ++m)
    if (std::isfinite(values[m])) sum += weights[m] * values[m], total += weights[m];
  return total > 0 ? sum / total : kMissing;
}

// The first trusted row where the mean dissipated energy has caught up with the stored one.
// Every trusted row before it still stores more than it dissipated, so the difference changes
// sign between it and the previous trusted row: interpolated there, linearly in ln phi.
template <class RowMean>
std::optional<double> EnsembleStatistics::elastic_to_plastic(const RowMean& row_mean) const {
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
std::optional<double> EnsembleStatistics::single_to_multi_mode(const std::vector<double>& out, double elastic_end) const {
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

FitOutcome EnsembleStatistics::fit_power_law_over(const std::vector<int>& rows, const std::vector<double>& x, const std::vector<double>& y) const {
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

}  // namespace gel::analysis::study_detail
