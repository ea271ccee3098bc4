#pragma once
// Parameters of the bond law of MODEL.md and its two published presets.
#include <string>
#include <string_view>

#include "gel/v1/scene.pb.h"

namespace gel {

struct BondLaw {
  double k_normal = 0;             // k_N  [F0/a]
  double k_sliding = 0;            // k_S  [F0/a]
  double k_rolling = 0;            // k_R a^2 [F0 a]: rolling moment per radian of bending
  double overlap_coefficient = 0;  // C [F0/a^3]
  double f_normal_critical = 0;    // F_Nc [F0]
  double f_sliding_critical = 0;   // F_Sc [F0]
  double m_rolling_critical = 0;   // M_Rc [F0 a]

  // Maximum elastic strains delta_c, d_c, phi_c.
  double critical_stretch() const { return f_normal_critical / k_normal; }
  double critical_slide() const { return f_sliding_critical / k_sliding; }
  double critical_bending() const { return m_rolling_critical / k_rolling; }
  // Natural energy unit E_0 = k_R a^2 phi_c^2 / 2.
  double energy_unit() const;
};

// "bond1" or "bond2" of MODEL.md; throws InvalidArgument naming `field` otherwise.
BondLaw bond_preset(std::string_view name, const std::string& field = "bond.preset");

// Preset (if any) overridden by the non-zero fields of the message, then validated: every
// stiffness and threshold must be finite and positive.
BondLaw resolve_bond_law(const gel::v1::BondParameters& message);

}  // namespace gel
