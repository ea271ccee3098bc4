#pragma once
// What the compression protocol measures on the engine between steps: the phi(y) profile,
// whether the bonds connect the two walls, and the approach shortcut's geometry.
#include <vector>

#include "gel/system.hpp"

namespace gel {

// Packing fraction in `slices` equal slices between the walls, bottom to top.
std::vector<double> phi_profile(const System& system, int slices);
// The virial stress (gel/virial_stress.hpp) as a curve row records it, over the same slices.
gel::v1::Stress stress_record(const System& system, int slices);
// A StabilityError naming `what` when value is not finite.
void require_finite_state(const char* what, double value);
// Particles connected through bonds to the top wall (the wall particles included).
std::vector<char> top_wall_group(const System& system);
bool group_touches_bottom_wall(const System& system, const std::vector<char>& group);
// Whether the bonds connect the two walls.
bool network_spans(const System& system);
// How far the group can move down before one of its particles touches a particle outside it or
// the bottom wall.
double distance_to_first_contact(const System& system, const std::vector<char>& group);

}  // namespace gel
