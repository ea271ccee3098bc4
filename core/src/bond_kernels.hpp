#pragma once
// The arithmetic half of the bond loop (System::bond_forces): the forces and torques of a chunk
// of bonds, from the particles' positions and orientations, into per-bond arrays. It gathers but
// never scatters, and it takes no branch, so it vectorises (gathers on AVX2/AVX-512, clones per
// instruction set: simd_dispatch.hpp). The scatter onto the particles, in bond order, and the
// rare bonds that need the exact path (a threshold exceeded, a bending angle beyond the
// series) stay scalar in System::bond_forces.
#include <cstddef>
#include <cstdint>

#include "gel/bond_evaluator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "simd_dispatch.hpp"

namespace gel::detail {

// Bonds per chunk: the chunk's outputs (6 x 8 B per bond) stay in L1 between the two halves.
inline constexpr std::size_t kBondChunk = 256;

struct BondChunkForces {
  double force_x[kBondChunk];   // on i (on j: opposite)
  double force_y[kBondChunk];
  double torque_i[kBondChunk];
  double torque_j[kBondChunk];
  double delta[kBondChunk];     // gap
  std::uint8_t exact[kBondChunk];  // 1: this bond takes the exact scalar path instead
};

// The chunk's bonds transposed into arrays: GCC vectorises gathers whose indices come from an
// array, not from a field of an array of structs.
struct BondChunkInputs {
  std::int32_t i[kBondChunk], j[kBondChunk];
  double bix[kBondChunk], biy[kBondChunk], bjx[kBondChunk], bjy[kBondChunk];
  double shift_x[kBondChunk], shift_y[kBondChunk];
};

// Bonds [0, count) of `bonds` (count <= kBondChunk).
template <unsigned kEffects, bool kShift, bool kCheckThresholds>
GEL_SIMD_CLONES void bond_chunk_forces(const Bond* __restrict bonds, std::size_t count, const double* __restrict x,
                                       const double* __restrict y, const double* __restrict c,
                                       const double* __restrict s, const BondLaw& law,
                                       BondChunkInputs& __restrict in, BondChunkForces& __restrict out) {
  using Evaluator = BondEvaluator<kEffects>;
  for (std::size_t k = 0; k < count; ++k) {
    const Bond& bond = bonds[k];
    in.i[k] = bond.i;
    in.j[k] = bond.j;
    if constexpr (Evaluator::needs_contact_points()) {
      in.bix[k] = bond.bix;
      in.biy[k] = bond.biy;
      in.bjx[k] = bond.bjx;
      in.bjy[k] = bond.bjy;
    }
    if constexpr (kShift) {
      in.shift_x[k] = bond.shift_x;
      in.shift_y[k] = bond.shift_y;
    }
  }
  const double f_sliding_sq = law.f_sliding_critical * law.f_sliding_critical;
  for (std::size_t k = 0; k < count; ++k) {
    const std::int32_t i = in.i[k], j = in.j[k];
    double dx = x[j] - x[i], dy = y[j] - y[i];
    if constexpr (kShift) {
      dx += in.shift_x[k];
      dy += in.shift_y[k];
    }
    const double r = std::sqrt(dx * dx + dy * dy);
    const double inv_r = 1.0 / r;
    BondGeometry g;
    g.nx = dx * inv_r;
    g.ny = dy * inv_r;
    g.delta = r - kDiameter;
    bool exact = false;
    if constexpr (Evaluator::needs_contact_points()) {
      g.xi_ix = c[i] * in.bix[k] - s[i] * in.biy[k];
      g.xi_iy = s[i] * in.bix[k] + c[i] * in.biy[k];
      g.xi_jx = c[j] * in.bjx[k] - s[j] * in.bjy[k];
      g.xi_jy = s[j] * in.bjx[k] + c[j] * in.bjy[k];
    }
    if constexpr (Evaluator::needs_rolling()) exact = std::abs(Evaluator::rolling_cross(g)) >= kBendingSeriesLimit;
    const BondForces f = Evaluator::template evaluate<true>(g, law);
    if constexpr (kCheckThresholds) {
      const double ft_sq = f.sliding_x * f.sliding_x + f.sliding_y * f.sliding_y;
      exact = exact | (f.normal_force > law.f_normal_critical) | (ft_sq > f_sliding_sq) |
              (std::abs(f.rolling_moment) > law.m_rolling_critical);
    }
    out.force_x[k] = f.normal_force * g.nx + f.sliding_x;
    out.force_y[k] = f.normal_force * g.ny + f.sliding_y;
    // a n x F_T acts on both particles (on j: (-a n) x (-F_T)).
    const double sliding_torque = kRadius * (g.nx * f.sliding_y - g.ny * f.sliding_x);
    out.torque_i[k] = f.rolling_moment + sliding_torque;
    out.torque_j[k] = -f.rolling_moment + sliding_torque;
    out.delta[k] = g.delta;
    out.exact[k] = exact;
  }
}

struct BondChunkScratch {
  BondChunkInputs inputs;
  BondChunkForces forces;
};

}  // namespace gel::detail
