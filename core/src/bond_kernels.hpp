#pragma once
// The arithmetic half of the bond loop (System::bond_forces): the forces and torques of a chunk
// of bonds, from the particles' positions and orientations, into per-bond arrays. It gathers but
// never scatters, and it takes no branch, so it vectorises (gathers on AVX2/AVX-512, clones per
// instruction set: simd_dispatch.hpp). The scatter onto the particles, in bond order, and the
// rare bonds that need the exact path (a threshold exceeded, a bending angle beyond the
// series) stay scalar in System::bond_forces.
#include <cstddef>
#include <cstdint>
#include <vector>

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

// The bonds as arrays, a mirror of System::bonds_ kept by the loop: GCC vectorises gathers whose
// indices come from an array, not from a field of an array of structs.
struct BondArrays {
  std::vector<std::int32_t> i, j;
  std::vector<double> bix, biy, bjx, bjy;
  std::vector<double> shift_x, shift_y;
  bool valid = false;  // false: rebuilt from bonds_ before the next use

  void assign(const std::vector<Bond>& bonds) {
    const std::size_t n = bonds.size();
    for (auto* column : {&bix, &biy, &bjx, &bjy, &shift_x, &shift_y}) column->resize(n);
    i.resize(n);
    j.resize(n);
    for (std::size_t b = 0; b < n; ++b) set(b, bonds[b]);
    valid = true;
  }
  void set(std::size_t b, const Bond& bond) {
    i[b] = bond.i;
    j[b] = bond.j;
    bix[b] = bond.bix;
    biy[b] = bond.biy;
    bjx[b] = bond.bjx;
    bjy[b] = bond.bjy;
    shift_x[b] = bond.shift_x;
    shift_y[b] = bond.shift_y;
  }
};

// Bonds [begin, begin + count) (count <= kBondChunk).
template <unsigned kEffects, bool kShift, bool kCheckThresholds>
GEL_SIMD_CLONES void bond_chunk_forces(const BondArrays& bonds, std::size_t begin, std::size_t count,
                                       const double* __restrict x, const double* __restrict y,
                                       const double* __restrict c, const double* __restrict s, const BondLaw& law,
                                       BondChunkForces& __restrict out) {
  using Evaluator = BondEvaluator<kEffects>;
  const std::int32_t* __restrict bond_i = bonds.i.data() + begin;
  const std::int32_t* __restrict bond_j = bonds.j.data() + begin;
  const double* __restrict bix = bonds.bix.data() + begin;
  const double* __restrict biy = bonds.biy.data() + begin;
  const double* __restrict bjx = bonds.bjx.data() + begin;
  const double* __restrict bjy = bonds.bjy.data() + begin;
  const double* __restrict shift_x = bonds.shift_x.data() + begin;
  const double* __restrict shift_y = bonds.shift_y.data() + begin;
  const double f_sliding_sq = law.f_sliding_critical * law.f_sliding_critical;
  for (std::size_t k = 0; k < count; ++k) {
    const std::int32_t i = bond_i[k], j = bond_j[k];
    double dx = x[j] - x[i], dy = y[j] - y[i];
    if constexpr (kShift) {
      dx += shift_x[k];
      dy += shift_y[k];
    }
    const double r = std::sqrt(dx * dx + dy * dy);
    const double inv_r = 1.0 / r;
    BondGeometry g;
    g.nx = dx * inv_r;
    g.ny = dy * inv_r;
    g.delta = r - kDiameter;
    bool exact = false;
    if constexpr (Evaluator::needs_contact_points()) {
      g.xi_ix = c[i] * bix[k] - s[i] * biy[k];
      g.xi_iy = s[i] * bix[k] + c[i] * biy[k];
      g.xi_jx = c[j] * bjx[k] - s[j] * bjy[k];
      g.xi_jy = s[j] * bjx[k] + c[j] * bjy[k];
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
  BondArrays bonds;
  BondChunkForces forces;
};

}  // namespace gel::detail
