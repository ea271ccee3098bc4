#include "gel/bond_law.hpp"

#include "gel/errors.hpp"

namespace gel {

double BondLaw::energy_unit() const {
  const double phi_c = critical_bending();
  return 0.5 * k_rolling * phi_c * phi_c;
}

BondLaw bond_preset(std::string_view name, const std::string& field) {
  // MODEL.md table: the maximum elastic strains are 0.05 for both sets, so the stiffnesses
  // follow from the thresholds (k = threshold / strain).
  BondLaw law;
  law.overlap_coefficient = 8e4;
  law.m_rolling_critical = 1.0;
  if (name == "bond1") {
    law.f_normal_critical = 1.0;
    law.f_sliding_critical = 1.0;
  } else if (name == "bond2") {
    law.f_normal_critical = 5.0;
    law.f_sliding_critical = 5.0;
  } else {
    throw InvalidArgument(field, "unknown bond preset " + quoted(std::string(name)) + " (known: bond1, bond2)");
  }
  constexpr double kCriticalStrain = 0.05;
  law.k_normal = law.f_normal_critical / kCriticalStrain;
  law.k_sliding = law.f_sliding_critical / kCriticalStrain;
  law.k_rolling = law.m_rolling_critical / kCriticalStrain;
  return law;
}

BondLaw resolve_bond_law(const gel::v1::BondParameters& message) {
  BondLaw law;
  if (!message.preset().empty()) law = bond_preset(message.preset());
  auto override_if_set = [](double value, double& target) {
    if (value != 0.0) target = value;
  };
  override_if_set(message.k_normal(), law.k_normal);
  override_if_set(message.k_sliding(), law.k_sliding);
  override_if_set(message.k_rolling(), law.k_rolling);
  override_if_set(message.overlap_coefficient(), law.overlap_coefficient);
  override_if_set(message.f_normal_critical(), law.f_normal_critical);
  override_if_set(message.f_sliding_critical(), law.f_sliding_critical);
  override_if_set(message.m_rolling_critical(), law.m_rolling_critical);
  require_positive("bond.k_normal", law.k_normal);
  require_positive("bond.k_sliding", law.k_sliding);
  require_positive("bond.k_rolling", law.k_rolling);
  require_non_negative("bond.overlap_coefficient", law.overlap_coefficient);
  require_positive("bond.f_normal_critical", law.f_normal_critical);
  require_positive("bond.f_sliding_critical", law.f_sliding_critical);
  require_positive("bond.m_rolling_critical", law.m_rolling_critical);
  return law;
}

}  // namespace gel
