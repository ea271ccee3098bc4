#include "curve_csv.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace gel {

std::string exact(double value) {
  char buffer[32];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

std::string curve_csv_header() {
  return "k,phi [1],target_phi [1],P [F0/a^2],P_top [F0/a^2],P_bot [F0/a^2],contact_number [1],"
         "stored_energy [F0 a],dissipated_energy [F0 a],ruptures_normal [count],ruptures_sliding [count],"
         "ruptures_rolling [count],bonds_created [count],equilibrated [0/1],steps [count],sim_time [t0],"
         "wall_seconds [s],drag_energy [F0 a],wall_work [F0 a],kinetic_energy [F0 a],"
         "bond_creation_energy [F0 a],absorbed_by_walls [F0 a],snapshot,spans [0/1],residual_force [F0],"
         "mean_bond_force [F0],relax_iterations [count],sigma_xx [F0/a^2],sigma_yy [F0/a^2],sigma_xy [F0/a^2]";
}

std::string curve_csv_row(const gel::v1::CurveRow& r) {
  std::ostringstream out;
  out << r.k() << ',' << exact(r.phi()) << ',' << exact(r.target_phi()) << ',' << exact(r.p()) << ','
      << exact(r.p_top()) << ',' << exact(r.p_bot()) << ',' << exact(r.contact_number()) << ','
      << exact(r.stored_energy()) << ',' << exact(r.dissipated_energy()) << ',' << r.ruptures().normal() << ','
      << r.ruptures().sliding() << ',' << r.ruptures().rolling() << ',' << r.ruptures().created() << ','
      << (r.equilibrated() ? 1 : 0) << ',' << r.steps() << ',' << exact(r.sim_time()) << ','
      << exact(r.wall_seconds()) << ',' << exact(r.drag_energy()) << ',' << exact(r.wall_work()) << ','
      << exact(r.kinetic_energy()) << ',' << exact(r.bond_creation_energy()) << ','
      << exact(r.absorbed_by_walls()) << ',' << r.snapshot() << ',' << (r.spans() ? 1 : 0) << ','
      << exact(r.residual_force()) << ',' << exact(r.mean_bond_force()) << ',' << r.relax_iterations();
  // Rows recorded before the stress was leave its cells empty (read as NaN), not 0.
  if (r.has_stress())
    out << ',' << exact(r.stress().xx()) << ',' << exact(r.stress().yy()) << ',' << exact(r.stress().xy());
  else
    out << ",,,";
  return out.str();
}

std::string curve_to_csv(const gel::v1::Curve& curve) {
  std::string text = curve_csv_header() + "\n";
  for (const gel::v1::CurveRow& row : curve.rows()) text += curve_csv_row(row) + "\n";
  return text;
}

std::string profiles_to_csv(const gel::v1::Curve& curve) {
  std::ostringstream out;
  int slices = 0, stress_slices = 0;
  for (const gel::v1::CurveRow& r : curve.rows()) {
    slices = std::max(slices, r.phi_profile_size());
    stress_slices = std::max(stress_slices, r.stress().yy_profile_size());
  }
  static constexpr const char* kComponents[] = {"xx", "yy", "xy"};
  out << "k,phi [1]";
  for (int s = 0; s < slices; ++s) out << ",slice_" << s << " [1]";
  for (const char* component : kComponents)
    for (int s = 0; s < stress_slices; ++s) out << ",sigma_" << component << '_' << s << " [F0/a^2]";
  out << '\n';
  // A row with fewer slices than the widest leaves the rest of its cells empty.
  auto cells = [&out](const auto& values, int width) {
    for (int s = 0; s < width; ++s) {
      out << ',';
      if (s < values.size()) out << exact(values.Get(s));
    }
  };
  for (const gel::v1::CurveRow& r : curve.rows()) {
    out << r.k() << ',' << exact(r.phi());
    cells(r.phi_profile(), slices);
    cells(r.stress().xx_profile(), stress_slices);
    cells(r.stress().yy_profile(), stress_slices);
    cells(r.stress().xy_profile(), stress_slices);
    out << '\n';
  }
  return out.str();
}

}  // namespace gel
