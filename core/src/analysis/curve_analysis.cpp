#include "gel/analysis/curve_analysis.hpp"
#include "gel/analysis/ensemble_statistic.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "gel/errors.hpp"

namespace gel::analysis {

const char* regime_name(Regime regime) {
  switch (regime) {
    case Regime::kElastic: return "elastic";
    case Regime::kSingleModePlastic: return "single-mode-plastic";
    case Regime::kMultiModePlastic: return "multi-mode-plastic";
  }
  return "unknown";
}

std::vector<Increment> curve_increments(const gel::v1::Curve& curve) {
  if (curve.particles() <= 0) throw InvalidArgument("curve.particles", "the curve has no particle count");
  const double particles = curve.particles();
  std::vector<Increment> increments;
  for (int k = 1; k < curve.rows_size(); ++k) {
    const auto& lo = curve.rows(k - 1);
    const auto& hi = curve.rows(k);
    if (!(lo.phi() > 0 && hi.phi() > lo.phi())) continue;
    Increment inc;
    inc.row = k;
    inc.phi_lo = lo.phi(), inc.phi_hi = hi.phi();
    inc.phi_mid = std::sqrt(lo.phi() * hi.phi());
    inc.d_ln_phi = std::log(hi.phi() / lo.phi());
    inc.stored_rate = (hi.stored_energy() - lo.stored_energy()) / inc.d_ln_phi;
    inc.dissipated_rate = (hi.dissipated_energy() - lo.dissipated_energy()) / inc.d_ln_phi;
    inc.events_normal = static_cast<double>(hi.ruptures().normal() - lo.ruptures().normal());
    inc.events_sliding = static_cast<double>(hi.ruptures().sliding() - lo.ruptures().sliding());
    inc.events_rolling = static_cast<double>(hi.ruptures().rolling() - lo.ruptures().rolling());
    inc.gamma_normal = inc.events_normal / (particles * inc.d_ln_phi);
    inc.gamma_sliding = inc.events_sliding / (particles * inc.d_ln_phi);
    inc.gamma_rolling = inc.events_rolling / (particles * inc.d_ln_phi);
    increments.push_back(inc);
  }
  return increments;
}

Regime classify_increment(const Increment& inc, double multi_mode_fraction) {
  if (inc.stored_rate > inc.dissipated_rate) return Regime::kElastic;
  const double multi = inc.events_normal + inc.events_sliding;
  const double all = multi + inc.events_rolling;
  if (multi > 0 && multi >= multi_mode_fraction * all) return Regime::kMultiModePlastic;
  return Regime::kSingleModePlastic;
}

RegimeSplit split_regimes(const std::vector<Increment>& increments, double multi_mode_fraction) {
  RegimeSplit split;
  const int n = static_cast<int>(increments.size());
  for (const auto& inc : increments) split.label.push_back(classify_increment(inc, multi_mode_fraction));
  // Boundaries b1 <= b2: intervals [0, b1) elastic, [b1, b2) single-mode, [b2, n) multi-mode.
  // Prefix counts make every candidate O(1).
  std::vector<int> count[3];
  for (int r = 0; r < 3; ++r) {
    count[r].assign(n + 1, 0);
    for (int i = 0; i < n; ++i) count[r][i + 1] = count[r][i] + (split.label[i] == static_cast<Regime>(r));
  }
  int best_b1 = 0, best_b2 = 0, best_agree = -1;
  for (int b1 = 0; b1 <= n; ++b1)
    for (int b2 = b1; b2 <= n; ++b2) {
      const int agree = count[0][b1] + (count[1][b2] - count[1][b1]) + (count[2][n] - count[2][b2]);
      if (agree > best_agree) best_agree = agree, best_b1 = b1, best_b2 = b2;
    }
  split.disagreements = n - std::max(0, best_agree);
  for (int i = 0; i < n; ++i)
    split.assigned.push_back(i < best_b1 ? Regime::kElastic : i < best_b2 ? Regime::kSingleModePlastic : Regime::kMultiModePlastic);
  const int starts[3] = {0, best_b1, best_b2}, ends[3] = {best_b1, best_b2, n};
  for (int r = 0; r < 3; ++r)
    if (ends[r] > starts[r]) split.range[r] = std::make_pair(increments[starts[r]].phi_lo, increments[ends[r] - 1].phi_hi);
  if (best_b1 > 0 && best_b1 < n) split.single_mode_start_phi = increments[best_b1].phi_lo;
  if (best_b2 > 0 && best_b2 < n && best_b2 > best_b1) split.multi_mode_start_phi = increments[best_b2].phi_lo;
  // With an empty single-mode range the multi-mode regime starts where elastic ends.
  if (best_b2 == best_b1 && best_b1 > 0 && best_b1 < n) split.multi_mode_start_phi = increments[best_b1].phi_lo;
  return split;
}

MeanStd mean_std(const std::vector<std::vector<double>>& members) {
  MeanStd result;
  result.members = static_cast<int>(members.size());
  if (members.empty()) return result;
  std::size_t length = members[0].size();
  for (const auto& m : members) length = std::min(length, m.size());
  result.mean.assign(length, 0.0);
  result.std.assign(length, 0.0);
  std::vector<double> column(members.size());
  for (std::size_t i = 0; i < length; ++i) {
    for (std::size_t m = 0; m < members.size(); ++m) column[m] = members[m][i];
    mean_and_std(column, result.mean[i], result.std[i]);
  }
  return result;
}

namespace {

std::vector<double> common_radii(const std::vector<std::vector<double>>& radii) {
  double lo = 0, hi = std::numeric_limits<double>::infinity();
  for (const auto& r : radii) {
    if (r.empty()) return {};
    lo = std::max(lo, r.front());
    hi = std::min(hi, r.back());
  }
  std::vector<double> grid;
  for (double r : radii[0])
    if (r >= lo && r <= hi) grid.push_back(r);
  return grid;
}

std::vector<double> resample(const std::vector<double>& r, const std::vector<double>& values, const std::vector<double>& grid) {
  std::vector<double> out;
  out.reserve(grid.size());
  std::size_t j = 0;
  for (double g : grid) {
    while (j + 2 < r.size() && r[j + 1] < g) ++j;
    if (r.size() == 1 || g <= r[j]) {
      out.push_back(values[j]);
      continue;
    }
    const double t = (g - r[j]) / (r[j + 1] - r[j]);
    out.push_back(values[j] + std::clamp(t, 0.0, 1.0) * (values[j + 1] - values[j]));
  }
  return out;
}

}  // namespace

MeanStd mean_on_common_radii(const std::vector<std::vector<double>>& radii, const std::vector<std::vector<double>>& values,
                             std::vector<double>& grid) {
  grid = common_radii(radii);
  std::vector<std::vector<double>> resampled;
  for (std::size_t m = 0; m < radii.size(); ++m) resampled.push_back(resample(radii[m], values[m], grid));
  return mean_std(resampled);
}

OptionalMeanStd mean_std(const std::vector<std::optional<double>>& values) {
  OptionalMeanStd result;
  std::vector<std::vector<double>> present;
  for (const auto& v : values) {
    if (v) present.push_back({*v});
    else ++result.missing;
  }
  result.present = static_cast<int>(present.size());
  if (present.empty()) return result;
  const MeanStd m = mean_std(present);
  result.mean = m.mean[0];
  result.std = m.std[0];
  return result;
}

CurveEnsemble curve_ensemble(const std::vector<gel::v1::Curve>& curves) {
  if (curves.empty()) throw InvalidArgument("ensemble", "no member curve");
  int rows = curves[0].rows_size();
  for (const auto& c : curves) rows = std::min(rows, c.rows_size());
  // Rows are matched by their index k. phi_0 (and with it the whole schedule) differs a little
  // between seeds, because the walls start at each gel's lowest and highest particle; the phi
  // of a row is averaged like any other observable.
  for (const auto& c : curves)
    for (int k = 0; k < rows; ++k)
      if (c.rows(k).k() != curves[0].rows(k).k())
        throw InvalidArgument("ensemble", "members have different rows: row " + std::to_string(k) + " is k = " +
                                              std::to_string(c.rows(k).k()) + " in one and k = " +
                                              std::to_string(curves[0].rows(k).k()) + " in another");
  CurveEnsemble ensemble;
  ensemble.members = static_cast<int>(curves.size());
  using RowValue = std::function<double(const gel::v1::CurveRow&)>;
  const std::vector<std::pair<std::string, RowValue>> row_values = {
      {"phi", [](const auto& r) { return r.phi(); }},
      {"target_phi", [](const auto& r) { return r.target_phi(); }},
      {"P", [](const auto& r) { return r.p(); }},
      {"P_top", [](const auto& r) { return r.p_top(); }},
      {"P_bot", [](const auto& r) { return r.p_bot(); }},
      {"contact_number", [](const auto& r) { return r.contact_number(); }},
      {"stored_energy", [](const auto& r) { return r.stored_energy(); }},
      {"dissipated_energy", [](const auto& r) { return r.dissipated_energy(); }},
      {"ruptures_normal", [](const auto& r) { return static_cast<double>(r.ruptures().normal()); }},
      {"ruptures_sliding", [](const auto& r) { return static_cast<double>(r.ruptures().sliding()); }},
      {"ruptures_rolling", [](const auto& r) { return static_cast<double>(r.ruptures().rolling()); }},
      {"bonds_created", [](const auto& r) { return static_cast<double>(r.ruptures().created()); }},
  };
  // The product's one statistic (ensemble_statistic.hpp), kept on the rows every member reached.
  std::vector<const gel::v1::Curve*> members;
  for (const auto& c : curves) members.push_back(&c);
  for (const auto& [name, value] : row_values) {
    MeanStd& row = ensemble.rows[name];
    row.members = ensemble.members;
    for (const RowStatistic& s : ensemble_statistic(members, value)) {
      if (s.n != ensemble.members) break;
      row.mean.push_back(s.mean);
      row.std.push_back(s.std);
    }
  }
  using IncrementValue = std::function<double(const Increment&)>;
  const std::vector<std::pair<std::string, IncrementValue>> interval_values = {
      {"phi_mid", [](const Increment& i) { return i.phi_mid; }},
      {"stored_rate", [](const Increment& i) { return i.stored_rate; }},
      {"dissipated_rate", [](const Increment& i) { return i.dissipated_rate; }},
      {"gamma_normal", [](const Increment& i) { return i.gamma_normal; }},
      {"gamma_sliding", [](const Increment& i) { return i.gamma_sliding; }},
      {"gamma_rolling", [](const Increment& i) { return i.gamma_rolling; }},
  };
  std::vector<std::vector<Increment>> increments;
  for (const auto& c : curves) {
    gel::v1::Curve truncated = c;
    while (truncated.rows_size() > rows) truncated.mutable_rows()->RemoveLast();
    increments.push_back(curve_increments(truncated));
  }
  for (const auto& [name, value] : interval_values) {
    std::vector<std::vector<double>> members;
    for (const auto& incs : increments) {
      std::vector<double> v;
      for (const auto& inc : incs) v.push_back(value(inc));
      members.push_back(std::move(v));
    }
    ensemble.intervals[name] = mean_std(members);
  }
  for (int k = 0; k < rows; ++k) {
    std::vector<std::vector<double>> members;
    for (const auto& c : curves) members.emplace_back(c.rows(k).phi_profile().begin(), c.rows(k).phi_profile().end());
    ensemble.phi_profile.push_back(mean_std(members));
  }
  return ensemble;
}

}  // namespace gel::analysis
