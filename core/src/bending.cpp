#include "gel/bending.hpp"

#include <algorithm>
#include <cmath>

#include "gel/errors.hpp"
#include "gel/units.hpp"

namespace gel {

Configuration straight_chain(int particles) {
  if (particles < 3) throw InvalidArgument("bending.chain", "a chain needs at least 3 particles");
  if (particles % 2 == 0) throw InvalidArgument("bending.chain", "needs an odd number of particles (a middle one)");
  Configuration config;
  const double length = kDiameter * particles;
  config.lx = config.ly = 4.0 * length;  // open box: only sizes the neighbour grid
  config.periodic_y = false;
  for (int k = 0; k < particles; ++k) config.add_particle(0.0, kDiameter * k, 0.0);
  for (int k = 0; k + 1 < particles; ++k) config.add_bond_at_contact(k, k + 1);
  return config;
}

unsigned bending_effects() { return kAllEffects & ~(kWalls | kPeriodicX); }

double chain_deflection(const System& system) {
  const std::size_t last = system.size() - 1, middle = last / 2;
  const auto& x = system.x();
  const auto& y = system.y();
  // Distance of the middle particle from the chord through the ends, signed along +x.
  const double cx = x[last] - x[0], cy = y[last] - y[0];
  const double chord = std::sqrt(cx * cx + cy * cy);
  return (cy * (x[middle] - x[0]) - cx * (y[middle] - y[0])) / chord;
}

namespace {

// Runs until every particle is slower than the tolerance (checked every 100 steps, after the
// loading transient) or the time limit; tracks the largest deflection seen.
bool relax(System& system, const BendingOptions& options, double& max_deflection) {
  const double end_time = system.time() + options.max_time;
  const std::int64_t check_every = 100;
  while (system.time() < end_time) {
    system.run(check_every);
    max_deflection = std::max(max_deflection, std::abs(chain_deflection(system)));
    if (system.max_speed() < options.tolerance) return true;
  }
  return false;
}

}  // namespace

BendingResult run_bending(const SimParams& params, const BendingOptions& options) {
  require_positive("bending.force", options.force);
  require_positive("bending.max_time", options.max_time);
  require_positive("bending.tolerance", options.tolerance);
  System system(straight_chain(options.chain), params);
  const std::int32_t last = options.chain - 1, middle = last / 2;
  BendingResult result;

  system.set_external_force(middle, options.force, 0.0);
  system.set_external_force(0, -0.5 * options.force, 0.0);
  system.set_external_force(last, -0.5 * options.force, 0.0);
  result.loaded_equilibrium = relax(system, options, result.max_deflection);
  result.loaded_deflection = chain_deflection(system);

  system.clear_external_forces();
  double ignored = 0;
  result.unloaded_equilibrium = relax(system, options, ignored);
  result.residual_deflection = chain_deflection(system);
  result.recovered = std::abs(result.residual_deflection) < options.recovered_deflection;
  result.events = system.events();
  result.sim_time = system.time();
  result.steps = system.step_count();
  return result;
}

}  // namespace gel
