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
  // Time step: a fraction of the shortest period of one free bond. Above 1 velocity Verlet is
  // unstable for that mode (the stability guard would stop the run); below 1e-4 a run takes
  // 250x the steps of the reference 0.025 and no accuracy study asks for it.
  constexpr double kMinDtFraction = 1e-4, kMaxDtFraction = 1.0;
  const double period = shortest_period(params.bond);
  if (integration.dt() != 0.0) {
    require_positive("integration.dt", integration.dt());
    require_within("integration.dt", integration.dt(), kMinDtFraction * period, kMaxDtFraction * period,
                   "1e-4 to 1 times the shortest period of one bond, " + std::to_string(period) + " t0");
    params.dt = integration.dt();
  }
  if (integration.dt_fraction() != 0.0) {
    require_within("integration.dt_fraction", integration.dt_fraction(), kMinDtFraction, kMaxDtFraction,
                   "a fraction of the shortest period of one bond");
    params.dt_fraction = integration.dt_fraction();
  }
  if (params.dt == 0.0) params.dt = params.dt_fraction * period;
  if (integration.has_eta_factor()) {
    require_non_negative("integration.eta_factor", integration.eta_factor());
    params.eta_factor = integration.eta_factor();
    // The first half kick takes the drag explicitly, v += (dt/2)(F/m - gamma v / m): once
    // (dt/2) gamma/m passes 1 it reverses the velocity, and past 2 it amplifies it. The
    // rotational drag binds first (gamma_R / I = (10/3) gamma / m for a disk of I = 2/5 m a^2).
    const double half_kick_drag = 0.5 * params.dt * params.drag_rotation() / kInertia;
    if (!(half_kick_drag <= 1.0)) {
      const double largest = params.eta_factor / half_kick_drag;
      throw InvalidArgument("integration.eta_factor",
                            "must be at most " + std::to_string(largest) + " with this time step (the explicit half kick of the "
                            "rotational drag, dt gamma_R / 2I, is " + std::to_string(half_kick_drag) +
                            " and must stay at most 1; the reference is 0.1), got " + std::to_string(params.eta_factor));
    }
  }
  if (integration.threads() < 0 || integration.threads() > 1024)
    throw InvalidArgument("integration.threads", "must be 0 (the runner's choice) to 1024, got " + std::to_string(integration.threads()));
  if (integration.skin() != 0.0) {
    // The neighbour list holds every unbonded pair within 2a + skin: its size grows as
    // (2a + skin)^2 (at skin = 1e300 it is all N^2/2 pairs), while a skin beyond 2 a only
    // saves rebuilds that already cost a few percent at the default 0.3 a.
    require_positive("integration.skin", integration.skin());
    require_within("integration.skin", integration.skin(), 0.0, 2.0, "in a: at most one particle diameter");
    params.skin = integration.skin();
  }
  if (integration.guard_interval() != 0) {
    if (integration.guard_interval() < 0 || integration.guard_interval() > 1'000'000)
      throw InvalidArgument("integration.guard_interval",
                            "must be 1 to 1000000 steps between full stability checks, got " + std::to_string(integration.guard_interval()));
    params.guard_interval = integration.guard_interval();
  }
  if (integration.max_overlap() != 0.0) {
    // An overlap of 1 a puts a particle's centre on its neighbour's surface: no state beyond
    // that is a contact the overlap term can resolve.
    require_positive("integration.max_overlap", integration.max_overlap());
    require_within("integration.max_overlap", integration.max_overlap(), 0.0, 1.0, "in a: at most one radius");
    params.max_overlap = integration.max_overlap();
  }
  if (integration.max_speed() != 0.0) {
    require_positive("integration.max_speed", integration.max_speed());
    params.max_speed = integration.max_speed();
  }
  return params;
}

}  // namespace gel
