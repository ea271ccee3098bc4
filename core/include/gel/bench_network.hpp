#pragma once
// The benchmark scene: a connected random network of N particles with about two bonds per
// particle (like a fractal gel) at phi ~ 0.12 in a box periodic in x, ready to be put between
// walls.
#include <cstdint>

#include "gel/configuration.hpp"

namespace gel {

// A branched random chain grown particle by particle: each new particle touches a random one
// of the last few placed (so the structure branches but keeps wandering through the box);
// overlapping placements are retried. Box: L_x : L_y = 3 : 5 sized for phi.
Configuration random_network(int particles, std::uint64_t seed, double phi = 0.12);

}  // namespace gel
