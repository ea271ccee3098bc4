#pragma once
// The particle loop of one FIRE iteration (System::relax, relax.cpp) as a free function
// over the structure-of-arrays, compiled per instruction set like the integrator's loops
// (simd_dispatch.hpp). Written branch-free so that it vectorises: a cap factor of exactly 1
// where the old loop skipped the cap, and a maximum (exact in any order) kept in fixed lanes,
// so every clone gives the bits of the scalar loop it replaces.
#include <cmath>
#include <cstddef>

#include "gel/units.hpp"
#include "rotation.hpp"
#include "simd_dispatch.hpp"

namespace gel::detail {

// Semi-implicit Euler with FIRE's mixing, v <- keep (v + dt F/m) + mix F, on the generalised
// velocity (v_x, v_y, a omega) and force (F_x, F_y, T/a).
struct FireMixing {
  double dt;
  double keep;         // 1 - alpha
  double mix;          // alpha |v'| / |F|
  double inv_m;        // 1/m
  double inv_rot;      // a^2 / I (FIRE's own inertia)
  double max_step;     // largest move of a particle in one iteration
};

[[gnu::always_inline]] inline void fire_update_one(std::size_t i, const FireMixing& k, double* __restrict x,
                                                   double* __restrict y, double* __restrict c, double* __restrict s,
                                                   double* __restrict vx, double* __restrict vy,
                                                   double* __restrict omega, const double* __restrict fx,
                                                   const double* __restrict fy, const double* __restrict torque,
                                                   double max_step_sq, double& largest_move_sq) {
  const double t = torque[i] / kRadius;
  double vxi = k.keep * (vx[i] + k.dt * fx[i] * k.inv_m) + k.mix * fx[i];
  double vyi = k.keep * (vy[i] + k.dt * fy[i] * k.inv_m) + k.mix * fy[i];
  double wi = k.keep * (kRadius * omega[i] + k.dt * t * k.inv_rot) + k.mix * t;  // a omega
  // A particle moves at most max_step per iteration (contact search and the small-angle
  // rotation rely on it).
  const double linear_sq = vxi * vxi + vyi * vyi, angular_sq = wi * wi;
  const double move_sq = k.dt * k.dt * (linear_sq < angular_sq ? angular_sq : linear_sq);
  const double shrink = move_sq > max_step_sq ? k.max_step / std::sqrt(move_sq) : 1.0;
  vxi *= shrink;
  vyi *= shrink;
  wi *= shrink;
  const double moved_sq = k.dt * k.dt * (vxi * vxi + vyi * vyi);
  largest_move_sq = largest_move_sq < moved_sq ? moved_sq : largest_move_sq;
  const double omega_new = wi / kRadius;
  vx[i] = vxi;
  vy[i] = vyi;
  omega[i] = omega_new;
  x[i] += k.dt * vxi;
  y[i] += k.dt * vyi;
  rotate_small(c[i], s[i], k.dt * omega_new);
}

// One FIRE move of particles [0, n); returns the largest squared translation.
GEL_SIMD_CLONES inline double fire_update(std::size_t n, FireMixing k, double* __restrict x, double* __restrict y,
                                          double* __restrict c, double* __restrict s, double* __restrict vx,
                                          double* __restrict vy, double* __restrict omega,
                                          const double* __restrict fx, const double* __restrict fy,
                                          const double* __restrict torque) {
  const double max_step_sq = k.max_step * k.max_step;
  double largest[kReductionLanes] = {};
  const std::size_t full = n - n % kReductionLanes;
  for (std::size_t start = 0; start < full; start += kReductionLanes)
    for (std::size_t lane = 0; lane < kReductionLanes; ++lane)
      fire_update_one(start + lane, k, x, y, c, s, vx, vy, omega, fx, fy, torque, max_step_sq, largest[lane]);
  for (std::size_t i = full; i < n; ++i)
    fire_update_one(i, k, x, y, c, s, vx, vy, omega, fx, fy, torque, max_step_sq, largest[i - full]);
  double largest_move_sq = 0;
  for (std::size_t lane = 0; lane < kReductionLanes; ++lane)
    largest_move_sq = largest_move_sq < largest[lane] ? largest[lane] : largest_move_sq;
  return largest_move_sq;
}

}  // namespace gel::detail
