#pragma once
// Small scenes shared by the engine tests.
#include "gel/configuration.hpp"
#include "gel/units.hpp"

namespace gel {

// A straight vertical chain of n bonded particles at x = 5, from y = 5 up, in an L_x wide box
// with room above it: install_walls() puts a wall at each end.
inline Configuration vertical_chain(int n, double lx) {
  Configuration config;
  config.lx = lx;
  config.ly = 2.0 * n + 10;
  for (int k = 0; k < n; ++k) config.add_particle(5, 5 + kDiameter * k);
  for (int k = 0; k + 1 < n; ++k) config.add_bond_at_contact(k, k + 1);
  return config;
}

// Two bonded particles along x in an open 40 x 40 box, the second moved by `gap` from contact.
inline Configuration pair_along_x(double gap) {
  Configuration config;
  config.lx = config.ly = 40;
  config.periodic_y = false;
  config.add_particle(10, 10);
  config.add_particle(10 + kDiameter, 10);
  config.add_bond_at_contact(0, 1);
  config.x[1] += gap;
  return config;
}

}  // namespace gel
