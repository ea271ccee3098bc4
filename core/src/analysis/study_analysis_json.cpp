// The JSON of a study analysis (gel.study-analysis.v1) and a member's structure.json (its one
// writer and its reader), and the structure observables of one member computed from its snapshots.
#include "gel/analysis/study_analysis.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "gel/configuration.hpp"

namespace gel::analysis {
namespace {

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
