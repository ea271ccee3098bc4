#pragma once
// Shared between the compression source files: the resolved protocol parameters as plain
// numbers (read once from the resolved scene, so the step loop never touches protobuf).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gel/compression.hpp"
#include "gel/system.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

struct CompressionSettings {
  double w0 = 0, phi_max = 0;
  int steps = 0;
  double v_wall = 0;              // each wall [a/t0]
  std::int64_t m_exam = 0;
  double a_tolerance = 0, b_tolerance = 0;
  double max_wait_time = 0;       // [t0] per target
  double stress_floor = 0;        // [P0]
  double rest_speed = 0;          // [a/t0]
  bool approach_shortcut = false;
  double adaptive_wall_max_factor = 1;    // 1 = the published constant wall speed
  double adaptive_wall_drag_fraction = 0;
  int profile_slices = 0;
  double checkpoint_seconds = 0;
  bool exam_all_ruptures = true;  // the third test counts resets too (MODEL.md)
  bool quasistatic = false;
  bool affine_steps = false;      // quasi-static approach: affine strain steps, not wall motion
  bool affine_after_spanning = false;  // wall motion until a relaxed row spans, affine steps after
  double strain_step = 0;         // max d ln(phi) per affine step
  RelaxOptions relax;
  std::int64_t relax_max_iterations = 0;  // per strain step
  double walk_dt_factor = 1;      // the walls' walk below walk_dt_stress takes this x dt
  double walk_dt_stress = 0;      // [F0/a^2]
  double loaded_wall_factor = 1;  // the walls at and above loaded_wall_stress move at this x v_wall
  double loaded_wall_stress = 0;  // [F0/a^2]
};

// docs/quasistatic.md "Loaded walls": the walls' speed for a walk chunk, from the wall stress
// at its start (so a resumed run decides the same).
inline double loaded_wall_speed(const CompressionSettings& settings, double v_wall, double wall_stress) {
  if (!(settings.loaded_wall_factor > 1.0) || !(std::abs(wall_stress) >= settings.loaded_wall_stress)) return v_wall;
  return settings.loaded_wall_factor * v_wall;
}

// docs/quasistatic.md "Walk step": while the walls carry less than walk_dt_stress, the walk
// takes up to walk_dt_factor x dt, and no more than half of Verlet's limit for the stiffest
// particle of the network as it is (omega dt <= 1, so that the contacts that stiffen within one
// chunk of steps cannot reach the limit 2); otherwise dt. fastest_frequency() (the engine's
// Gershgorin bound, a loop over the bonds) is only asked when the stress allows a longer step.
template <class Frequency>
double walk_time_step(const CompressionSettings& settings, double dt, double wall_stress, Frequency&& fastest_frequency) {
  if (!(settings.walk_dt_factor > 1.0) || !(std::abs(wall_stress) < settings.walk_dt_stress)) return dt;
  const double longest = settings.walk_dt_factor * dt;
  const double omega = fastest_frequency();
  const double stable = omega > 0.0 ? 1.0 / omega : longest;
  return std::max(dt, std::min(longest, stable));
}

// From a scene already passed through resolve_compression_scene.
CompressionSettings compression_settings(const gel::v1::Compression& resolved);

// equilibrium_reached() on the plain settings (the protocol's form).
bool equilibrium_reached(const EquilibriumSample& sample, const CompressionSettings& settings);

}  // namespace gel
