// Compression curves on disk (format in curve_io.hpp): JSON for programs, CSV for people and
// spreadsheets. Doubles are printed in shortest round-trip form, so JSON reads back exactly.
#include "gel/curve_io.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include <google/protobuf/util/json_util.h>

#include "gel/bond_law.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"

namespace gel {
namespace {

template <class T>
T field(const nlohmann::json& row, const char* name) {
  if (!row.contains(name)) throw InvalidArgument(std::string("rows.") + name, "missing");
  try {
    return row.at(name).get<T>();
  } catch (const nlohmann::json::exception& error) {
    throw InvalidArgument(std::string("rows.") + name, error.what());
  }
}

template <class T>
T optional_field(const nlohmann::json& row, const char* name, T fallback) {
  return row.contains(name) && !row.at(name).is_null() ? field<T>(row, name) : fallback;
}

// A component of a row's "stress" object, named "rows.stress.<name>" when wrong.
template <class T>
T stress_field(const nlohmann::json& stress, const char* name, std::optional<T> fallback = std::nullopt) {
  if (!stress.contains(name) || stress.at(name).is_null()) {
    if (fallback) return *fallback;
    throw InvalidArgument(std::string("rows.stress.") + name, "missing");
  }
  try {
    return stress.at(name).get<T>();
  } catch (const nlohmann::json::exception& error) {
    throw InvalidArgument(std::string("rows.stress.") + name, error.what());
  }
}

}  // namespace

nlohmann::json curve_row_to_json(const gel::v1::CurveRow& row) {
  nlohmann::json j;
  j["k"] = row.k();
  j["phi"] = row.phi();
  j["target_phi"] = row.target_phi();
  j["P"] = row.p();
  j["P_top"] = row.p_top();
  j["P_bot"] = row.p_bot();
  j["contact_number"] = row.contact_number();
  j["stored_energy"] = row.stored_energy();
  j["dissipated_energy"] = row.dissipated_energy();
  j["ruptures"] = {{"normal", row.ruptures().normal()},
                   {"sliding", row.ruptures().sliding()},
                   {"rolling", row.ruptures().rolling()}};
  j["bonds_created"] = row.ruptures().created();
  j["equilibrated"] = row.equilibrated();
  j["steps"] = row.steps();
  j["sim_time"] = row.sim_time();
  j["wall_seconds"] = row.wall_seconds();
  j["drag_energy"] = row.drag_energy();
  j["wall_work"] = row.wall_work();
  j["kinetic_energy"] = row.kinetic_energy();
  j["bond_creation_energy"] = row.bond_creation_energy();
  j["absorbed_by_walls"] = row.absorbed_by_walls();
  j["phi_profile"] = std::vector<double>(row.phi_profile().begin(), row.phi_profile().end());
  j["snapshot"] = row.snapshot();
  j["spans"] = row.spans();
  j["residual_force"] = row.residual_force();
  j["mean_bond_force"] = row.mean_bond_force();
  j["relax_iterations"] = row.relax_iterations();
  if (row.has_stress()) {
    const gel::v1::Stress& s = row.stress();
    auto list = [](const auto& values) { return std::vector<double>(values.begin(), values.end()); };
    j["stress"] = {{"xx", s.xx()}, {"yy", s.yy()}, {"xy", s.xy()}, {"xx_profile", list(s.xx_profile())},
                   {"yy_profile", list(s.yy_profile())}, {"xy_profile", list(s.xy_profile())}};
  }
  return j;
}

gel::v1::CurveRow curve_row_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw InvalidArgument("rows", "a row must be a JSON object");
  gel::v1::CurveRow row;
  row.set_k(field<int>(j, "k"));
  row.set_phi(field<double>(j, "phi"));
  row.set_target_phi(optional_field<double>(j, "target_phi", 0.0));
  row.set_p(field<double>(j, "P"));
  row.set_p_top(field<double>(j, "P_top"));
  row.set_p_bot(field<double>(j, "P_bot"));
  row.set_contact_number(field<double>(j, "contact_number"));
  row.set_stored_energy(field<double>(j, "stored_energy"));
  row.set_dissipated_energy(field<double>(j, "dissipated_energy"));
  const nlohmann::json ruptures = field<nlohmann::json>(j, "ruptures");
  if (!ruptures.is_object()) throw InvalidArgument("rows.ruptures", "must be an object");
  row.mutable_ruptures()->set_normal(optional_field<std::int64_t>(ruptures, "normal", 0));
  row.mutable_ruptures()->set_sliding(optional_field<std::int64_t>(ruptures, "sliding", 0));
  row.mutable_ruptures()->set_rolling(optional_field<std::int64_t>(ruptures, "rolling", 0));
  row.mutable_ruptures()->set_created(optional_field<std::int64_t>(j, "bonds_created", 0));
  row.set_equilibrated(field<bool>(j, "equilibrated"));
  row.set_steps(field<std::int64_t>(j, "steps"));
  row.set_sim_time(optional_field<double>(j, "sim_time", 0.0));
  row.set_wall_seconds(optional_field<double>(j, "wall_seconds", 0.0));
  row.set_drag_energy(optional_field<double>(j, "drag_energy", 0.0));
  row.set_wall_work(optional_field<double>(j, "wall_work", 0.0));
  row.set_kinetic_energy(optional_field<double>(j, "kinetic_energy", 0.0));
  row.set_bond_creation_energy(optional_field<double>(j, "bond_creation_energy", 0.0));
  row.set_absorbed_by_walls(optional_field<double>(j, "absorbed_by_walls", 0.0));
  for (const double phi : optional_field<std::vector<double>>(j, "phi_profile", {})) row.add_phi_profile(phi);
  row.set_snapshot(optional_field<std::string>(j, "snapshot", ""));
  // Curves written before the span was recorded only ever reported loaded rows as such.
  row.set_spans(optional_field<bool>(j, "spans", true));
  row.set_residual_force(optional_field<double>(j, "residual_force", 0.0));
  row.set_mean_bond_force(optional_field<double>(j, "mean_bond_force", 0.0));
  row.set_relax_iterations(optional_field<std::int64_t>(j, "relax_iterations", 0));
  // Rows recorded before the stress was have none (not a zero stress).
  if (j.contains("stress") && !j.at("stress").is_null()) {
    const nlohmann::json stress = j.at("stress");
    if (!stress.is_object()) throw InvalidArgument("rows.stress", "must be an object with xx, yy, xy");
    gel::v1::Stress* s = row.mutable_stress();
    s->set_xx(stress_field<double>(stress, "xx"));
    s->set_yy(stress_field<double>(stress, "yy"));
    s->set_xy(stress_field<double>(stress, "xy"));
    for (const double v : stress_field<std::vector<double>>(stress, "xx_profile", {})) s->add_xx_profile(v);
    for (const double v : stress_field<std::vector<double>>(stress, "yy_profile", {})) s->add_yy_profile(v);
    for (const double v : stress_field<std::vector<double>>(stress, "xy_profile", {})) s->add_xy_profile(v);
  }
  return row;
}

std::optional<double> energy_unit_e0(const gel::v1::Scene& scene) {
  if (!scene.has_bond()) return std::nullopt;
  try {
    const BondLaw law = resolve_bond_law(scene.bond());
    if (law.k_rolling > 0) return law.m_rolling_critical * law.m_rolling_critical / (2 * law.k_rolling);
  } catch (const InvalidArgument&) {
  }
  return std::nullopt;
}

nlohmann::json curve_to_json(const gel::v1::Curve& curve) {
  nlohmann::json j;
  j["program_version"] = curve.program_version();
  j["particles"] = curve.particles();
  j["parameters"] = nlohmann::json::parse(scene_to_json(curve.scene()));
  // In the F0 a that the rows use, so that energies can be compared with the model's.
  if (const auto e0 = energy_unit_e0(curve.scene())) j["E0"] = *e0;
  j["rows"] = nlohmann::json::array();
  for (const gel::v1::CurveRow& row : curve.rows()) j["rows"].push_back(curve_row_to_json(row));
  return j;
}

gel::v1::Curve curve_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw InvalidArgument("curve", "must be a JSON object");
  gel::v1::Curve curve;
  curve.set_program_version(j.value("program_version", ""));
  if (j.contains("particles")) curve.set_particles(field<int>(j, "particles"));
  if (j.contains("parameters")) *curve.mutable_scene() = scene_from_json(j.at("parameters").dump());
  if (!j.contains("rows") || !j.at("rows").is_array()) throw InvalidArgument("rows", "must be a list");
  for (const nlohmann::json& row : j.at("rows")) *curve.add_rows() = curve_row_from_json(row);
  return curve;
}

void write_curve(const gel::v1::Curve& curve, const std::string& dir) {
  std::filesystem::create_directories(dir);
  const std::filesystem::path base(dir);
  write_file_atomically((base / "curve.json").string(), curve_to_json(curve).dump(1) + "\n");
  write_file_atomically((base / "curve.csv").string(), curve_to_csv(curve));
  write_file_atomically((base / "profiles.csv").string(), profiles_to_csv(curve));
}

gel::v1::Curve read_curve(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / "curve.json").string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& error) {
    throw InvalidArgument("path", "'" + path + "' is not JSON: " + error.what());
  }
  return curve_from_json(j);
}

}  // namespace gel
