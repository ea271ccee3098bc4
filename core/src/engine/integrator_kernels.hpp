#pragma once
// The particle loops of the velocity-Verlet step with Stokes drag (System::step), as free
// functions over the structure-of-arrays so that they can be compiled per instruction set
// (simd_dispatch.hpp). The first half kick takes the drag explicitly, the second implicitly
// ((v + h F)/(1 + h gamma)), which keeps the scheme second order and stable for any drag.
#include <cstddef>

#include "gel/units.hpp"
#include "rotation.hpp"
#include "simd_dispatch.hpp"

namespace gel::detail {

struct KickCoefficients {
  double dt;
  double h, h_rot;            // dt / 2m, dt / 2I
  double gamma, gamma_rot;    // Stokes drag coefficients
};

// Reductions of the first half kick: the largest max(|v|^2, a^2 omega^2) and the drag power.
struct KickTotals {
  double max_speed_sq = 0;
  double drag_power = 0;
};

template <bool kDragOn>
[[gnu::always_inline]] inline void kick_and_drift_one(std::size_t i, const KickCoefficients& k, double* __restrict x,
                                                      double* __restrict y, double* __restrict c, double* __restrict s,
                                                      double* __restrict vx, double* __restrict vy,
                                                      double* __restrict omega, const double* __restrict fx,
                                                      const double* __restrict fy, const double* __restrict torque,
                                                      double& drag_power, double& max_speed_sq) {
  double vxi = vx[i], vyi = vy[i], wi = omega[i];
  if constexpr (kDragOn) {
    drag_power += k.gamma * (vxi * vxi + vyi * vyi) + k.gamma_rot * wi * wi;
    vxi += k.h * (fx[i] - k.gamma * vxi);
    vyi += k.h * (fy[i] - k.gamma * vyi);
    wi += k.h_rot * (torque[i] - k.gamma_rot * wi);
  } else {
    vxi += k.h * fx[i];
    vyi += k.h * fy[i];
    wi += k.h_rot * torque[i];
  }
  vx[i] = vxi;
  vy[i] = vyi;
  omega[i] = wi;
  x[i] += k.dt * vxi;
  y[i] += k.dt * vyi;
  rotate_small(c[i], s[i], wi * k.dt);
  const double linear_sq = vxi * vxi + vyi * vyi, angular_sq = kRadius * kRadius * wi * wi;
  const double speed_sq = linear_sq > angular_sq ? linear_sq : angular_sq;
  max_speed_sq = speed_sq > max_speed_sq ? speed_sq : max_speed_sq;
}

// First half kick and drift of particles [0, n).
template <bool kDragOn>
GEL_SIMD_CLONES KickTotals kick_and_drift(std::size_t n, KickCoefficients k, double* __restrict x, double* __restrict y,
                                          double* __restrict c, double* __restrict s, double* __restrict vx,
                                          double* __restrict vy, double* __restrict omega, const double* __restrict fx,
                                          const double* __restrict fy, const double* __restrict torque) {
  double drag[kReductionLanes] = {}, speed[kReductionLanes] = {};
  const std::size_t full = n - n % kReductionLanes;
  for (std::size_t start = 0; start < full; start += kReductionLanes)
    for (std::size_t lane = 0; lane < kReductionLanes; ++lane)
      kick_and_drift_one<kDragOn>(start + lane, k, x, y, c, s, vx, vy, omega, fx, fy, torque, drag[lane], speed[lane]);
  for (std::size_t i = full; i < n; ++i)
    kick_and_drift_one<kDragOn>(i, k, x, y, c, s, vx, vy, omega, fx, fy, torque, drag[i - full], speed[i - full]);
  KickTotals totals;
  for (std::size_t lane = 0; lane < kReductionLanes; ++lane) {
    totals.drag_power += drag[lane];
    totals.max_speed_sq = speed[lane] > totals.max_speed_sq ? speed[lane] : totals.max_speed_sq;
  }
  return totals;
}

template <bool kDragOn>
[[gnu::always_inline]] inline void second_kick_one(std::size_t i, const KickCoefficients& k, double damp, double damp_rot,
                                                   double* __restrict vx, double* __restrict vy,
                                                   double* __restrict omega, const double* __restrict fx,
                                                   const double* __restrict fy, const double* __restrict torque,
                                                   double& drag_power) {
  if constexpr (kDragOn) {
    const double vxi = (vx[i] + k.h * fx[i]) * damp;
    const double vyi = (vy[i] + k.h * fy[i]) * damp;
    const double wi = (omega[i] + k.h_rot * torque[i]) * damp_rot;
    vx[i] = vxi;
    vy[i] = vyi;
    omega[i] = wi;
    drag_power += k.gamma * (vxi * vxi + vyi * vyi) + k.gamma_rot * wi * wi;
  } else {
    vx[i] += k.h * fx[i];
    vy[i] += k.h * fy[i];
    omega[i] += k.h_rot * torque[i];
  }
}

// Second half kick of particles [0, n); returns the drag power after it.
template <bool kDragOn>
GEL_SIMD_CLONES double second_kick(std::size_t n, KickCoefficients k, double* __restrict vx, double* __restrict vy,
                                   double* __restrict omega, const double* __restrict fx, const double* __restrict fy,
                                   const double* __restrict torque) {
  const double damp = 1.0 / (1.0 + k.h * k.gamma), damp_rot = 1.0 / (1.0 + k.h_rot * k.gamma_rot);
  double drag[kReductionLanes] = {};
  const std::size_t full = n - n % kReductionLanes;
  for (std::size_t start = 0; start < full; start += kReductionLanes)
    for (std::size_t lane = 0; lane < kReductionLanes; ++lane)
      second_kick_one<kDragOn>(start + lane, k, damp, damp_rot, vx, vy, omega, fx, fy, torque, drag[lane]);
  for (std::size_t i = full; i < n; ++i)
    second_kick_one<kDragOn>(i, k, damp, damp_rot, vx, vy, omega, fx, fy, torque, drag[i - full]);
  double drag_power = 0;
  for (std::size_t lane = 0; lane < kReductionLanes; ++lane) drag_power += drag[lane];
  return drag_power;
}

}  // namespace gel::detail
