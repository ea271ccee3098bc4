// The per-bond state and the per-particle contact loads of a frame (gel/export.hpp): a loop over
// the bonds of a configuration around the engine's evaluator, so that an exported force is the
// force the engine applies for that geometry. Run only when a frame is written.
#include <cmath>

#include "gel/bond_evaluator.hpp"
#include "gel/export.hpp"
#include "gel/units.hpp"

namespace gel::exporting {
namespace {

// The bond's geometry as the engine sees it: minimum-image separation, lab-frame contact
// directions R(theta) b.
BondGeometry geometry_of(const Configuration& c, const BondRecord& bond) {
  double dx = 0, dy = 0;
  c.separation(bond.i, bond.j, dx, dy);
  const double r = std::sqrt(dx * dx + dy * dy);
  BondGeometry g{};
  g.nx = dx / r;
  g.ny = dy / r;
  g.delta = r - kDiameter;
  const double ci = std::cos(c.theta[bond.i]), si = std::sin(c.theta[bond.i]);
  const double cj = std::cos(c.theta[bond.j]), sj = std::sin(c.theta[bond.j]);
  g.xi_ix = ci * bond.bix - si * bond.biy;
  g.xi_iy = si * bond.bix + ci * bond.biy;
  g.xi_jx = cj * bond.bjx - sj * bond.bjy;
  g.xi_jy = sj * bond.bjx + cj * bond.bjy;
  return g;
}

}  // namespace

BondState bond_state(const Configuration& c, const BondLaw* law, unsigned effects) {
  BondState s;
  const std::size_t nb = c.bonds.size();
  for (auto* column : {&s.gap, &s.contact_ix, &s.contact_iy, &s.contact_jx, &s.contact_jy, &s.sliding_x, &s.sliding_y, &s.bending})
    column->resize(nb);
  s.with_forces = law != nullptr;
  if (law)
    for (auto* column : {&s.normal_force, &s.sliding_force_x, &s.sliding_force_y, &s.rolling_moment}) column->resize(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    const BondGeometry g = geometry_of(c, c.bonds[b]);
    s.gap[b] = g.delta;
    s.contact_ix[b] = g.xi_ix;
    s.contact_iy[b] = g.xi_iy;
    s.contact_jx[b] = g.xi_jx;
    s.contact_jy[b] = g.xi_jy;
    // The sliding displacement and bending angle of MODEL.md: the evaluator's with unit springs.
    BondLaw unit{};
    unit.k_sliding = 1;
    unit.k_rolling = 1;
    const BondForces strain = evaluate_bond(g, unit, kSliding | kRolling);
    s.sliding_x[b] = strain.sliding_x;
    s.sliding_y[b] = strain.sliding_y;
    s.bending[b] = strain.rolling_moment;
    if (!law) continue;
    const BondForces f = evaluate_bond(g, *law, effects);
    s.normal_force[b] = f.normal_force;
    s.sliding_force_x[b] = f.sliding_x;
    s.sliding_force_y[b] = f.sliding_y;
    s.rolling_moment[b] = f.rolling_moment;
  }
  return s;
}

ParticleLoads particle_loads(const Configuration& c, const BondState& s) {
  ParticleLoads loads;
  if (!s.with_forces) return loads;
  loads.fx.assign(c.size(), 0.0);
  loads.fy.assign(c.size(), 0.0);
  loads.torque.assign(c.size(), 0.0);
  for (std::size_t b = 0; b < c.bonds.size(); ++b) {
    const BondRecord& bond = c.bonds[b];
    const BondGeometry g = geometry_of(c, bond);
    const BondForces f{s.normal_force[b], s.sliding_force_x[b], s.sliding_force_y[b], s.rolling_moment[b]};
    const BondLoads load = bond_loads(f, g);
    loads.fx[bond.i] += load.force_x;
    loads.fy[bond.i] += load.force_y;
    loads.torque[bond.i] += load.torque_i;
    loads.fx[bond.j] -= load.force_x;
    loads.fy[bond.j] -= load.force_y;
    loads.torque[bond.j] += load.torque_j;
  }
  return loads;
}

}  // namespace gel::exporting
