// The evaluator's free functions (gel/bond_evaluator.hpp): one bond's energy and forces for
// any set of effects, for tests and analyses outside the engine's loops.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "gel/bond_evaluator.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "system_internal.hpp"

namespace gel {
using namespace engine;

BondEnergy bond_energy(const BondGeometry& g, const BondLaw& law, unsigned effects) {
  BondEnergy energy;
  if (effects & kNormalSpring) energy.normal += 0.5 * law.k_normal * g.delta * g.delta;
  if ((effects & kOverlapRepulsion) && g.delta < 0)
    energy.normal += 0.25 * law.overlap_coefficient * g.delta * g.delta * g.delta * g.delta;
  if (effects & kSliding) {
    const double ux = g.xi_jx - g.xi_ix, uy = g.xi_jy - g.xi_iy;
    const double u_n = ux * g.nx + uy * g.ny;
    const double dx = kRadius * (ux - u_n * g.nx), dy = kRadius * (uy - u_n * g.ny);
    energy.sliding = 0.5 * law.k_sliding * (dx * dx + dy * dy);
  }
  if (effects & kRolling) {
    const double phi = bending_angle(g.xi_ix * g.xi_jy - g.xi_iy * g.xi_jx);
    energy.rolling = 0.5 * law.k_rolling * phi * phi;
  }
  return energy;
}

BondForces evaluate_bond(const BondGeometry& g, const BondLaw& law, unsigned effects) {
  constexpr unsigned kTerms = kNormalSpring | kOverlapRepulsion | kSliding | kRolling;
  static constexpr auto table = []<std::size_t... kMasks>(std::index_sequence<kMasks...>) {
    return std::array<BondForces (*)(const BondGeometry&, const BondLaw&), sizeof...(kMasks)>{
        &BondEvaluator<kMasks>::evaluate...};
  }(std::make_index_sequence<kTerms + 1>{});
  return table[effects & kTerms](g, law);
}

}  // namespace gel
