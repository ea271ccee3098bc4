#include <cmath>
#include <string>
#include <vector>

#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"

namespace gel {

double SimParams::drag_translation() const {
  // 6 pi eta a with eta = eta_factor sqrt(k_R m)/(3 pi a): 2 eta_factor sqrt(k_R m).
  return eta_factor * 2.0 * std::sqrt(bond.k_rolling / (kRadius * kRadius) * kMass) * kRadius;
}

double SimParams::drag_rotation() const {
  // 8 pi eta a^3 = (4/3) a^2 (6 pi eta a).
  return drag_translation() * (4.0 / 3.0) * kRadius * kRadius;
}

double shortest_period(const BondLaw& bond) { return shortest_period(bond, kInertia); }

double shortest_period(const BondLaw& bond, double inertia) {
  // Modes of one bond between two free particles: stretching (reduced mass m/2) and the
  // rotational modes, where a particle turning alone loads both the sliding and the rolling
  // spring: I d^2theta/dt^2 = -(k_S a^2 + k_R a^2) theta per bond, times 2 for the pair.
  const double translational = 2.0 * std::max(bond.k_normal, bond.k_sliding) / kMass;
  const double rotational = 2.0 * (bond.k_sliding * kRadius * kRadius + bond.k_rolling) / inertia;
  const double omega_max = std::sqrt(std::max(translational, rotational));
  return 2.0 * kPi / omega_max;
}

SimParams resolve_sim_params(const gel::v1::Scene& scene) {
  SimParams params;
  params.bond = resolve_bond_law(scene.bond());
  params.effects = parse_effects(std::vector<std::string>(scene.effects().begin(), scene.effects().end()));
  const gel::v1::Integration& integration = scene.integration();
  if (integration.dt() != 0.0) {
    require_positive("integration.dt", integration.dt());
    params.dt = integration.dt();
  }
  if (integration.dt_fraction() != 0.0) {
    require_positive("integration.dt_fraction", integration.dt_fraction());
    if (integration.dt_fraction() > 1.0)
      throw InvalidArgument("integration.dt_fraction", "must be at most 1 (a fraction of the shortest period)");
    params.dt_fraction = integration.dt_fraction();
  }
  if (params.dt == 0.0) params.dt = params.dt_fraction * shortest_period(params.bond);
  if (integration.has_eta_factor()) {
    require_non_negative("integration.eta_factor", integration.eta_factor());
    params.eta_factor = integration.eta_factor();
  }
  if (integration.threads() < 0 || integration.threads() > 1024)
    throw InvalidArgument("integration.threads", "must be 0 (the runner's choice) to 1024, got " + std::to_string(integration.threads()));
  if (integration.skin() != 0.0) {
    require_positive("integration.skin", integration.skin());
    params.skin = integration.skin();
  }
  if (integration.guard_interval() != 0) {
    if (integration.guard_interval() < 0)
      throw InvalidArgument("integration.guard_interval", "must be positive");
    params.guard_interval = integration.guard_interval();
  }
  if (integration.max_overlap() != 0.0) {
    require_positive("integration.max_overlap", integration.max_overlap());
    params.max_overlap = integration.max_overlap();
  }
  if (integration.max_speed() != 0.0) {
    require_positive("integration.max_speed", integration.max_speed());
    params.max_speed = integration.max_speed();
  }
  return params;
}

}  // namespace gel
