#pragma once
// Compression curves on disk: DIR/curve.json and DIR/curve.csv (docs/gelsim.md "Data out").
//
// curve.json: {"program_version", "particles", "parameters": <resolved scene, proto JSON>,
//              "rows": [{"k", "phi", "target_phi", "P", "P_top", "P_bot", "contact_number",
//                        "stored_energy", "dissipated_energy",
//                        "ruptures": {"normal", "sliding", "rolling"}, "bonds_created",
//                        "equilibrated", "steps", "sim_time", "wall_seconds", "drag_energy",
//                        "wall_work", "kinetic_energy", "bond_creation_energy",
//                        "absorbed_by_walls", "phi_profile": [...], "snapshot", "spans",
//                        "residual_force", "mean_bond_force", "relax_iterations",
//                        "stress": {"xx", "yy", "xy", "xx_profile": [...], "yy_profile": [...],
//                                   "xy_profile": [...]} (absent in rows recorded before it)}]}
// curve.csv: one row per equilibrium, the header names every column with its unit
// ("name [unit]"; the profile is in profiles.csv). read_curve reads curve.json.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gel/v1/scene.pb.h"
#include "curve_csv.hpp"  // curve_to_csv, profiles_to_csv: the one curve table

namespace gel {

nlohmann::json curve_row_to_json(const gel::v1::CurveRow& row);
gel::v1::CurveRow curve_row_from_json(const nlohmann::json& row);
nlohmann::json curve_to_json(const gel::v1::Curve& curve);
// The model's energy unit E0 = k_R a^2 phi_c^2 / 2 = M_Rc^2 / (2 k_R a^2) of the scene's bond
// law, in F0 a; none when the scene has no bond law or no rolling spring.
std::optional<double> energy_unit_e0(const gel::v1::Scene& scene);
gel::v1::Curve curve_from_json(const nlohmann::json& json);  // throws InvalidArgument

// DIR/curve.json, DIR/curve.csv and DIR/profiles.csv, each atomically.
void write_curve(const gel::v1::Curve& curve, const std::string& dir);
gel::v1::Curve read_curve(const std::string& dir);  // reads DIR/curve.json

}  // namespace gel
