#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/ensemble_statistic.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"

namespace gel::analysis {
namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
nlohmann::json optional_number(const std::optional<double>& v) { return v ? number(*v) : nlohmann::json(nullptr); }

// The ensemble-mean curve: each row holds the member means, so that one set of curve
// functions serves a run and an ensemble.
gel::v1::Curve mean_curve(const std::vector<gel::v1::Curve>& curves, const CurveEnsemble& e) {
  gel::v1::Curve mean;
  mean.set_particles(curves[0].particles());
  *mean.mutable_scene() = curves[0].scene();
  mean.set_program_version(curves[0].program_version());
  const std::size_t rows = e.rows.at("phi").mean.size();
  auto value = [&](const char* name, std::size_t k) { return e.rows.at(name).mean[k]; };
  for (std::size_t k = 0; k < rows; ++k) {
    auto* row = mean.add_rows();
    row->set_k(curves[0].rows(static_cast<int>(k)).k());
    row->set_phi(value("phi", k));
    row->set_target_phi(value("target_phi", k));
    row->set_p(value("P", k));
    row->set_p_top(value("P_top", k));
    row->set_p_bot(value("P_bot", k));
    row->set_contact_number(value("contact_number", k));
    row->set_stored_energy(value("stored_energy", k));
    row->set_dissipated_energy(value("dissipated_energy", k));
    // Mean counts are kept as rounded integers; the rates use them through differences only.
    row->mutable_ruptures()->set_normal(std::llround(value("ruptures_normal", k)));
    row->mutable_ruptures()->set_sliding(std::llround(value("ruptures_sliding", k)));
    row->mutable_ruptures()->set_rolling(std::llround(value("ruptures_rolling", k)));
    row->mutable_ruptures()->set_created(std::llround(value("bonds_created", k)));
    for (double v : e.phi_profile[k].mean) row->add_phi_profile(v);
    row->set_snapshot(curves[0].rows(static_cast<int>(k)).snapshot());
  }
  return mean;
}

}  // namespace

CurveAnalysis analyse_curves(const std::vector<gel::v1::Curve>& curves, const RunAnalysisOptions& options) {
  CurveAnalysis a;
  a.ensemble = curve_ensemble(curves);
  a.mean_curve = mean_curve(curves, a.ensemble);
  const int members = static_cast<int>(curves.size());
  // Fits trust only rows that every member reached at equilibrium with a spanning network: a
  // wait-limited row is the stress at an arbitrary time, and a row that does not span carries
  // drag, not a yield stress. Row 0 is the unloaded start.
  std::vector<bool> trusted(a.mean_curve.rows_size(), true);
  std::vector<double> phi, p;
  for (int k = 0; k < a.mean_curve.rows_size(); ++k) {
    int unequilibrated = 0, not_spanning = 0;
    for (const gel::v1::Curve& curve : curves) {
      unequilibrated += !curve.rows(k).equilibrated();
      not_spanning += !curve.rows(k).spans();
    }
    auto* row = a.mean_curve.mutable_rows(k);
    row->set_equilibrated(unequilibrated == 0);
    row->set_spans(not_spanning == 0);
    if (k == 0) continue;
    std::string reason;
    auto of_members = [&](int n) {
      return members == 1 ? std::string() : " in " + std::to_string(n) + " of " + std::to_string(members) + " members";
    };
    if (not_spanning > 0) reason = "network does not span" + of_members(not_spanning);
    else if (unequilibrated > 0 && !options.include_unequilibrated) reason = "not equilibrated" + of_members(unequilibrated);
    if (!reason.empty()) {
      trusted[k] = false;
      a.excluded_rows.push_back({row->k(), row->phi(), reason});
      continue;
    }
    a.fit_rows.push_back(row->k());
    phi.push_back(row->phi());
    p.push_back(row->p());
  }
  double lo = options.fit_phi_min, hi = options.fit_phi_max;
  if (lo <= 0 && hi <= 0) {
    lo = phi.empty() ? 0.0 : phi.front();
    hi = phi.empty() ? 0.0 : phi.back();
  } else if (hi <= 0) {
    hi = phi.empty() ? 0.0 : phi.back();
  }
  const std::string left_out =
      a.excluded_rows.empty() ? "" : " (" + std::to_string(a.excluded_rows.size()) + " untrusted rows left out)";
  try {
    a.power_law = fit_power_law(phi, p, lo, hi);
  } catch (const InvalidArgument& error) {
    a.power_law_error = error.what() + left_out;
  }
  try {
    a.gel_point = fit_gel_point(phi, p, lo, hi);
  } catch (const InvalidArgument& error) {
    a.gel_point_error = error.what() + left_out;
  }
  a.increments = curve_increments(a.mean_curve);
  std::vector<Increment> trusted_increments;
  for (const Increment& inc : a.increments) {
    const bool ok = inc.row >= 1 && inc.row < static_cast<int>(trusted.size()) && trusted[inc.row] && trusted[inc.row - 1];
    a.increment_trusted.push_back(ok);
    if (ok) trusted_increments.push_back(inc);
  }
  a.regimes = split_regimes(trusted_increments, options.multi_mode_fraction);
  return a;
}

RunAnalysis analyse_runs(const std::vector<std::string>& dirs, const RunAnalysisOptions& options) {
  if (dirs.empty()) throw InvalidArgument("path", "no run directory given");
  RunAnalysis run;
  run.dirs = dirs;
  for (const auto& dir : dirs) run.curves.push_back(read_curve(dir));
  run.curve = analyse_curves(run.curves, options);
  if (!options.structures) return run;
  const int rows = run.curve.mean_curve.rows_size();
  std::vector<double> xi_phi, xi_value;
  for (int k = 0; k < rows; ++k) {
    RowStructure row;
    row.k = run.curve.mean_curve.rows(k).k();
    row.phi = run.curve.mean_curve.rows(k).phi();
    std::vector<std::vector<double>> c_members, df_members, r_c_members, r_df_members;
    std::vector<std::optional<double>> df_fits, xis;
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t m = 0; m < dirs.size(); ++m) {
      const std::string& name = run.curves[m].rows(k).snapshot();
      if (name.empty()) continue;
      const std::string path = (std::filesystem::path(dirs[m]) / name).string();
      if (!std::filesystem::exists(path)) continue;
      const StructureAnalysis s = analyse_structure(read_configuration(path), options.structure);
      row.snapshots.push_back(path);
      r_c_members.push_back(s.correlation.r);
      r_df_members.push_back(s.df_profile.r);
      c_members.push_back(s.correlation.c);
      df_members.push_back(s.df_profile.df);
      df_fits.push_back(s.df_fit ? std::optional<double>(s.df_fit->df) : std::nullopt);
      xis.push_back(s.xi_05);
    }
    if (row.snapshots.empty()) continue;
    row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    row.c = mean_on_common_radii(r_c_members, c_members, row.r_c);
    row.df = mean_on_common_radii(r_df_members, df_members, row.r_df);
    row.df_fit = mean_std(df_fits);
    row.xi_05 = mean_std(xis);
    if (row.xi_05.mean) xi_phi.push_back(row.phi), xi_value.push_back(*row.xi_05.mean);
    run.structure.push_back(std::move(row));
  }
  if (xi_phi.size() >= 3) {
    try {
      run.xi_power_law = fit_power_law(xi_phi, xi_value, xi_phi.front(), xi_phi.back());
    } catch (const InvalidArgument&) {
    }
  }
  return run;
}

nlohmann::json to_json(const PowerLawFit& f) {
  return {{"prefactor", number(f.prefactor)}, {"exponent", number(f.exponent)},
          {"exponent_stderr", number(f.exponent_stderr)}, {"log_prefactor_stderr", number(f.log_prefactor_stderr)},
          {"phi_min", f.x_min}, {"phi_max", f.x_max}, {"requested_phi_min", f.requested_min},
          {"requested_phi_max", f.requested_max}, {"points", f.points}, {"dropped_nonpositive", f.dropped},
          {"rms_log_residual", number(f.rms_log_residual)}};
}

nlohmann::json to_json(const GelPointFit& f) {
  return {{"prefactor", number(f.prefactor)}, {"phi_g", number(f.phi_g)}, {"exponent", number(f.exponent)},
          {"log_prefactor_stderr", number(f.log_prefactor_stderr)}, {"phi_g_stderr", number(f.phi_g_stderr)},
          {"exponent_stderr", number(f.exponent_stderr)}, {"phi_min", f.x_min}, {"phi_max", f.x_max},
          {"requested_phi_min", f.requested_min}, {"requested_phi_max", f.requested_max},
          {"points", f.points}, {"dropped_nonpositive", f.dropped}, {"iterations", f.iterations}, {"converged", f.converged}, {"at_bound", f.phi_g_at_bound},
          {"rms_log_residual", number(f.rms_log_residual)}};
}

nlohmann::json to_json(const MeanStd& v) { return {{"mean", v.mean}, {"std", v.std}, {"members", v.members}}; }

nlohmann::json to_json(const OptionalMeanStd& v) {
  return {{"mean", optional_number(v.mean)}, {"std", optional_number(v.std)}, {"present", v.present}, {"missing", v.missing}};
}

nlohmann::json to_json(const CurveAnalysis& a) {
  nlohmann::json j;
  j["members"] = a.ensemble.members;
  j["ensemble_rule"] = kCompleteRowsRule;
  nlohmann::json rows = nlohmann::json::object();
  for (const auto& [name, v] : a.ensemble.rows) rows[name] = to_json(v);
  j["rows"] = rows;
  nlohmann::json intervals = nlohmann::json::object();
  for (const auto& [name, v] : a.ensemble.intervals) intervals[name] = to_json(v);
  j["intervals"] = intervals;
  j["power_law"] = a.power_law ? to_json(*a.power_law) : nlohmann::json(nullptr);
  if (!a.power_law) j["power_law_error"] = a.power_law_error;
  j["gel_point"] = a.gel_point ? to_json(*a.gel_point) : nlohmann::json(nullptr);
  if (!a.gel_point) j["gel_point_error"] = a.gel_point_error;
  j["fit_rows"] = a.fit_rows;
  nlohmann::json excluded = nlohmann::json::array();
  for (const ExcludedRow& row : a.excluded_rows) excluded.push_back({{"k", row.k}, {"phi", row.phi}, {"reason", row.reason}});
  j["excluded_rows"] = excluded;
  nlohmann::json regimes;
  regimes["single_mode_start_phi"] = optional_number(a.regimes.single_mode_start_phi);
  regimes["multi_mode_start_phi"] = optional_number(a.regimes.multi_mode_start_phi);
  regimes["disagreements"] = a.regimes.disagreements;
  nlohmann::json ranges = nlohmann::json::object();
  for (int r = 0; r < 3; ++r)
    ranges[regime_name(static_cast<Regime>(r))] =
        a.regimes.range[r] ? nlohmann::json::array({a.regimes.range[r]->first, a.regimes.range[r]->second}) : nlohmann::json(nullptr);
  regimes["ranges"] = ranges;
  nlohmann::json per_interval = nlohmann::json::array();
  // The model states energy increments in its natural unit E0 (MODEL.md "Observables"): the
  // rates are given in F0 a and, where the bond law defines E0, in E0 too.
  const std::optional<double> e0 = energy_unit_e0(a.mean_curve.scene());
  j["E0"] = optional_number(e0);
  // regimes.label/assigned run over the trusted increments only.
  for (std::size_t i = 0, t = 0; i < a.increments.size(); ++i) {
    const Increment& inc = a.increments[i];
    const bool trusted = a.increment_trusted[i];
    nlohmann::json interval = {{"k", inc.row}, {"phi_lo", inc.phi_lo}, {"phi_hi", inc.phi_hi},
                               {"stored_rate", inc.stored_rate}, {"dissipated_rate", inc.dissipated_rate},
                               {"gamma_normal", inc.gamma_normal}, {"gamma_sliding", inc.gamma_sliding},
                               {"gamma_rolling", inc.gamma_rolling}, {"trusted", trusted},
                               {"label", trusted ? nlohmann::json(regime_name(a.regimes.label[t])) : nlohmann::json(nullptr)},
                               {"regime", trusted ? nlohmann::json(regime_name(a.regimes.assigned[t])) : nlohmann::json(nullptr)}};
    if (e0) {
      interval["stored_rate_E0"] = inc.stored_rate / *e0;
      interval["dissipated_rate_E0"] = inc.dissipated_rate / *e0;
    }
    per_interval.push_back(std::move(interval));
    t += trusted;
  }
  regimes["intervals"] = per_interval;
  j["regimes"] = regimes;
  return j;
}

nlohmann::json to_json(const RunAnalysis& run) {
  nlohmann::json j = to_json(run.curve);
  j["dirs"] = run.dirs;
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : run.structure) {
    rows.push_back({{"k", row.k}, {"phi", row.phi}, {"snapshots", row.snapshots},
                    {"correlation", {{"r", row.r_c}, {"C", row.c.mean}, {"C_std", row.c.std}}},
                    {"fractal_dimension_profile", {{"r", row.r_df}, {"D_f", row.df.mean}, {"D_f_std", row.df.std}}},
                    {"fractal_dimension_fit", to_json(row.df_fit)}, {"xi_05", to_json(row.xi_05)},
                    {"seconds", row.seconds}});
  }
  j["structure"] = rows;
  j["xi_power_law"] = run.xi_power_law ? to_json(*run.xi_power_law) : nlohmann::json(nullptr);
  return j;
}

}  // namespace gel::analysis
