#pragma once
// The effects a scene can switch on. The step loop is instantiated per effect set at compile
// time (see core/src/engine/bond_loop.cpp), so an effect that is off costs nothing per bond or per particle.
#include <string>
#include <vector>

namespace gel {

enum Effect : unsigned {
  kNormalSpring = 1u << 0,     // k_N delta
  kOverlapRepulsion = 1u << 1, // C delta^3 for delta < 0
  kSliding = 1u << 2,          // k_S d
  kRolling = 1u << 3,          // k_R a^2 phi
  kThresholds = 1u << 4,       // breaking and resetting
  kBondCreation = 1u << 5,     // new bond on contact
  kDrag = 1u << 6,             // Stokes drag
  kWalls = 1u << 7,            // sticky walls in y
  kPeriodicX = 1u << 8,        // periodic boundary in x
};
inline constexpr unsigned kAllEffects = (1u << 9) - 1;

// "normal", "overlap", "sliding", "rolling", "thresholds", "creation", "drag", "walls",
// "periodic_x". An empty list means all. Throws InvalidArgument (field "effects") on an
// unknown name.
unsigned parse_effects(const std::vector<std::string>& names);
std::vector<std::string> effect_names(unsigned effects);

}  // namespace gel
