#pragma once
// The bond loop's data and kernels (System::bond_forces), in three passes:
//  1. forces: every bond's force and torques from the particles' positions and orientations,
//     into per-bond arrays. It gathers but never scatters and takes no branch, so it vectorises
//     (gathers on AVX2/AVX-512, clones per instruction set: simd_dispatch.hpp), and chunks of
//     bonds run on any thread.
//  2. exact: the rare bonds flagged by pass 1 (a threshold exceeded, a bending angle beyond the
//     series) are evaluated again exactly, in bond order, on one thread (resets, breaks and
//     their bookkeeping: System::bond_force_exact).
//  3. sum: each particle adds up the forces of its bonds in bond order (an incidence list), so
//     every sum is the same sequence of additions as a serial loop over the bonds would make,
//     whatever the number of threads, and particles in blocks run on any thread.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "gel/bond_evaluator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "simd_dispatch.hpp"

namespace gel::detail {

inline constexpr std::size_t kBondChunk = 256;       // bonds per task of pass 1 (one thread: its results stay in L1)
inline constexpr std::size_t kParticleBlock = 2048;  // particles per task of pass 3 and the integrator

// A bond's state as pass 1 writes it. As wide as a double: GCC picks the vector length of a loop
// from its narrowest type, and a byte per bond made pass 1 handle 32 bonds per iteration (four
// registers per quantity, spilled to the stack) instead of 8.
using BondState = std::int64_t;

// Per-bond results of pass 1 (and 2).
struct BondForceArrays {
  std::vector<double> force_x, force_y;  // on i (on j: opposite)
  std::vector<double> torque_i, torque_j;
  std::vector<double> delta;             // gap
  std::vector<BondState> state;       // kCommon, kFlagged (pass 2 redoes it) or kBroken (no force)

  static constexpr BondState kCommon = 0, kFlagged = 1, kBroken = 2;
};

// The bonds as arrays, a mirror of System::bonds_ (GCC vectorises gathers whose indices come
// from an array, not from a field of an array of structs), and each particle's bonds in bond
// order: entry 2b for a bond b whose i it is, 2b + 1 for one whose j it is.
struct BondArrays {
  std::vector<std::int32_t> i, j;
  std::vector<double> bix, biy, bjx, bjy;
  std::vector<double> shift_x, shift_y;
  std::vector<std::int32_t> incidence_start;  // particle p's entries: [start[p], start[p + 1])
  std::vector<std::int32_t> incidence;
  bool valid = false;  // false: rebuilt from bonds_ before the next use

  void assign(const std::vector<Bond>& bonds, std::size_t particles) {
    const std::size_t n = bonds.size();
    for (auto* column : {&bix, &biy, &bjx, &bjy, &shift_x, &shift_y}) column->resize(n);
    i.resize(n);
    j.resize(n);
    for (std::size_t b = 0; b < n; ++b) set(b, bonds[b]);
    incidence_start.assign(particles + 1, 0);
    for (std::size_t b = 0; b < n; ++b) {
      ++incidence_start[static_cast<std::size_t>(i[b]) + 1];
      ++incidence_start[static_cast<std::size_t>(j[b]) + 1];
    }
    for (std::size_t p = 0; p < particles; ++p) incidence_start[p + 1] += incidence_start[p];
    incidence.resize(2 * n);
    std::vector<std::int32_t> fill(incidence_start.begin(), incidence_start.end() - 1);
    for (std::size_t b = 0; b < n; ++b) {
      incidence[static_cast<std::size_t>(fill[static_cast<std::size_t>(i[b])]++)] = static_cast<std::int32_t>(2 * b);
      incidence[static_cast<std::size_t>(fill[static_cast<std::size_t>(j[b])]++)] = static_cast<std::int32_t>(2 * b + 1);
    }
    valid = true;
  }
  // A bond whose contact points changed (a reset): the incidence is unchanged.
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

// One thread's pass-1 results for one chunk, in L1 until its scatter (System::bond_forces).
struct BondChunkForces {
  double force_x[kBondChunk], force_y[kBondChunk];
  double torque_i[kBondChunk], torque_j[kBondChunk];
  double delta[kBondChunk];
  BondState state[kBondChunk];
};

// What a task of pass 1 tells the serial pass 2: the smallest delta of its common bonds, and
// whether it flagged any (so that pass 2 reads only the tasks that did, not every bond's state).
struct ChunkSummary {
  double min_delta = std::numeric_limits<double>::infinity();
  bool any_flagged = false;
};

struct BondScratch {
  BondArrays bonds;
  BondForceArrays forces;  // several threads: every bond's results
  BondChunkForces chunk;   // one thread
  std::vector<ChunkSummary> chunk_summaries;  // several threads: pass 1's summary per task
};

// n and the gap of a bond from the separation r_j - r_i (image shift included); the contact
// directions are filled in by the caller. Shared by pass 1 and the exact path, so both compute
// the same bits.
[[gnu::always_inline]] inline BondGeometry line_of_centres(double dx, double dy) {
  const double r = std::sqrt(dx * dx + dy * dy);
  const double inv_r = 1.0 / r;
  BondGeometry g;
  g.nx = dx * inv_r;
  g.ny = dy * inv_r;
  g.delta = r - kDiameter;
  return g;
}

// What the sum pass needs of one bond: the force on i (on j: opposite) and both torques.
// Pass 1 over bonds [begin, begin + count), into the out_* arrays (offset to begin already).
// The outputs are restrict parameters: GCC honours restrict on parameters, not on local pointers,
// and without it the loop needs more run-time alias checks than it will version for.
template <unsigned kEffects, bool kShift, bool kCheckThresholds>
GEL_SIMD_CLONES void bond_chunk_forces(const BondArrays& bonds, std::size_t begin, std::size_t count,
                                       const double* __restrict x, const double* __restrict y,
                                       const double* __restrict c, const double* __restrict s, const BondLaw& law,
                                       double* __restrict out_fx, double* __restrict out_fy,
                                       double* __restrict out_ti, double* __restrict out_tj,
                                       double* __restrict out_delta, BondState* __restrict out_state) {
  using Evaluator = BondEvaluator<kEffects>;
  const std::int32_t* __restrict bond_i = bonds.i.data() + begin;
  const std::int32_t* __restrict bond_j = bonds.j.data() + begin;
  const double* __restrict bix = bonds.bix.data() + begin;
  const double* __restrict biy = bonds.biy.data() + begin;
  const double* __restrict bjx = bonds.bjx.data() + begin;
  const double* __restrict bjy = bonds.bjy.data() + begin;
  const double* __restrict shift_x = bonds.shift_x.data() + begin;
  const double* __restrict shift_y = bonds.shift_y.data() + begin;
  for (std::size_t k = 0; k < count; ++k) {
    const std::int32_t i = bond_i[k], j = bond_j[k];
    double dx = x[j] - x[i], dy = y[j] - y[i];
    if constexpr (kShift) {
      dx += shift_x[k];
      dy += shift_y[k];
    }
    BondGeometry g = line_of_centres(dx, dy);
    bool exact = false;
    if constexpr (Evaluator::needs_contact_points()) {
      g.xi_ix = c[i] * bix[k] - s[i] * biy[k];
      g.xi_iy = s[i] * bix[k] + c[i] * biy[k];
      g.xi_jx = c[j] * bjx[k] - s[j] * bjy[k];
      g.xi_jy = s[j] * bjx[k] + c[j] * bjy[k];
    }
    if constexpr (Evaluator::needs_rolling()) exact = std::abs(Evaluator::rolling_cross(g)) >= kBendingSeriesLimit;
    const BondForces f = Evaluator::template evaluate<true>(g, law);
    if constexpr (kCheckThresholds) exact = exact | exceeds_a_threshold(f, law);
    const BondLoads o = bond_loads(f, g);
    out_fx[k] = o.force_x;
    out_fy[k] = o.force_y;
    out_ti[k] = o.torque_i;
    out_tj[k] = o.torque_j;
    out_delta[k] = g.delta;
    out_state[k] = static_cast<BondState>(exact);  // kCommon or kFlagged
  }
}

// The smallest gap among the common bonds of [begin, begin + count) (exact ones are pass 2's),
// and whether any bond there is flagged for pass 2.
inline ChunkSummary summarise_chunk(const BondForceArrays& forces, std::size_t begin, std::size_t count) {
  ChunkSummary summary;
  for (std::size_t k = begin; k < begin + count; ++k) {
    if (forces.state[k] == BondForceArrays::kCommon)
      summary.min_delta = std::min(summary.min_delta, forces.delta[k]);
    else
      summary.any_flagged = true;
  }
  return summary;
}

// Pass 3 for particles [begin, end): force and torque of each from its bonds, in bond order.
inline void sum_bond_forces(const BondArrays& bonds, const BondForceArrays& forces, std::size_t begin, std::size_t end,
                            double* __restrict fx, double* __restrict fy, double* __restrict torque) {
  const std::int32_t* __restrict start = bonds.incidence_start.data();
  const std::int32_t* __restrict incidence = bonds.incidence.data();
  const double* __restrict force_x = forces.force_x.data();
  const double* __restrict force_y = forces.force_y.data();
  const double* __restrict torque_i = forces.torque_i.data();
  const double* __restrict torque_j = forces.torque_j.data();
  const BondState* __restrict state = forces.state.data();
  for (std::size_t p = begin; p < end; ++p) {
    double sum_x = 0.0, sum_y = 0.0, sum_t = 0.0;
    for (std::int32_t e = start[p]; e < start[p + 1]; ++e) {
      const std::size_t b = static_cast<std::size_t>(incidence[e]) >> 1;
      if (state[b] == BondForceArrays::kBroken) [[unlikely]] continue;
      if (incidence[e] & 1) {
        sum_x -= force_x[b];
        sum_y -= force_y[b];
        sum_t += torque_j[b];
      } else {
        sum_x += force_x[b];
        sum_y += force_y[b];
        sum_t += torque_i[b];
      }
    }
    fx[p] = sum_x;
    fy[p] = sum_y;
    torque[p] = sum_t;
  }
}

}  // namespace gel::detail
