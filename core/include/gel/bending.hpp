#pragma once
// Three-point bending of a straight chain (MODEL.md "Three-point bending"): the validation of
// the contact model. Load the middle particle with (F_ex, 0) and each end with (-F_ex/2, 0),
// perpendicular to the chain; wait for equilibrium; unload; wait again.
#include <cstdint>

#include "gel/configuration.hpp"
#include "gel/system.hpp"

namespace gel {

struct BendingOptions {
  int chain = 11;             // particles
  double force = 0.1;         // F_ex [F0]
  double max_time = 20000;    // simulated time allowed per phase [t0]
  double tolerance = 1e-7;    // equilibrium: every particle slower than this [a/t0]
  double recovered_deflection = 1e-3;  // residual deflection below which the chain recovered [a]
};

struct BendingResult {
  double max_deflection = 0;       // largest deflection of the middle particle under load [a]
  double loaded_deflection = 0;    // deflection at equilibrium under load [a]
  double residual_deflection = 0;  // deflection at equilibrium after unloading [a]
  bool loaded_equilibrium = false;
  bool unloaded_equilibrium = false;
  bool recovered = false;          // |residual| < recovered_deflection
  EventCounts events;
  double sim_time = 0;
  std::int64_t steps = 0;
};

// A straight chain along y, particles touching and bonded, in an open box.
Configuration straight_chain(int particles);

// The effects bending needs: all but walls and periodic_x.
unsigned bending_effects();

// Runs the scene with the given bond law and integration settings (params.effects is used as
// given; pass bending_effects() for the published scene).
BendingResult run_bending(const SimParams& params, const BendingOptions& options);

// Deflection of the middle particle from the line through the two end particles [a].
double chain_deflection(const System& system);

}  // namespace gel
