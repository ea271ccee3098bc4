#pragma once
// The bond loop's data and kernels (System::bond_forces, bond_loop.cpp). The particles are cut
// into contiguous blocks (one per run on one thread, kParticleBlock each on several), and each
// block's owner computes the forces on its particles:
//  - forces: the bonds touching the block, in bond order, a chunk at a time into L1 arrays. This
//    part gathers but never scatters and takes no branch, so it vectorises (gathers on
//    AVX2/AVX-512, clones per instruction set: simd_dispatch.hpp).
//  - exact: the rare bonds flagged there (a threshold exceeded, a bending angle beyond the
//    series) are evaluated again exactly; what they change (breaks, resets, the energy ledger)
//    is recorded and applied after the region, on one thread, in bond order.
//  - scatter: each result is added to the ends of the bond that lie in the block, in bond order.
// A bond whose ends lie in two blocks is computed by both owners (the same code on the same
// inputs: the same bits), so no block waits for another, and every particle's force is the
// same sequence of additions (its bonds in bond order) for any number of threads and blocks.
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

inline constexpr std::size_t kBondChunk = 256;       // bonds per chunk of the forces part (its results stay in L1)
inline constexpr std::size_t kParticleBlock = 2048;  // particles per task of the bond loop (several threads) and the integrator

// A bond's state as the forces part writes it. As wide as a double: GCC picks the vector length
// of a loop from its narrowest type, and a byte per bond made the loop handle 32 bonds per
// iteration (four registers per quantity, spilled to the stack) instead of 8.
using BondState = std::int64_t;
inline constexpr BondState kCommon = 0, kFlagged = 1;

// Bonds as arrays, in the order of System::bonds_ (GCC vectorises gathers whose indices come
// from an array, not from a field of an array of structs).
struct BondArrays {
  std::vector<std::int32_t> i, j;
  std::vector<double> bix, biy, bjx, bjy;
  std::vector<double> shift_x, shift_y;

  std::size_t size() const { return i.size(); }
  void clear() {
    i.clear();
    j.clear();
    for (auto* column : {&bix, &biy, &bjx, &bjy, &shift_x, &shift_y}) column->clear();
  }
  void push_back(const Bond& bond) {
    i.push_back(bond.i);
    j.push_back(bond.j);
    bix.push_back(bond.bix);
    biy.push_back(bond.biy);
    bjx.push_back(bond.bjx);
    bjy.push_back(bond.bjy);
    shift_x.push_back(bond.shift_x);
    shift_y.push_back(bond.shift_y);
  }
  // A bond whose contact points changed (a reset).
  void set(std::size_t k, const Bond& bond) {
    bix[k] = bond.bix;
    biy[k] = bond.biy;
    bjx[k] = bond.bjx;
    bjy[k] = bond.bjy;
  }
};

// Which ends of a bond lie in a block.
using BondEnds = std::uint8_t;
inline constexpr BondEnds kEndI = 1, kEndJ = 2;

// A break or reset found by the exact path, applied after the region (System::handle_threshold).
struct BondEventRecord {
  std::int32_t bond;
  BondEvent event;
  double nx, ny;  // line of centres, for a reset's new contact points
};

// One block's bonds and what its last pass found. Aligned so that two owners never write to one
// cache line.
struct alignas(64) BondBlock {
  std::size_t begin = 0, end = 0;  // its particles
  BondArrays bonds;                // the bonds touching it, in bond order
  std::vector<std::int32_t> bond;  // each one's index in System::bonds_
  std::vector<BondEnds> ends;
  double min_delta = std::numeric_limits<double>::infinity();  // of the bonds that did not break
  std::vector<BondEventRecord> events;  // those it records: the bonds whose i is its own, in bond order

  std::int32_t push_back(const Bond& b, std::size_t index, BondEnds which) {
    bonds.push_back(b);
    bond.push_back(static_cast<std::int32_t>(index));
    ends.push_back(which);
    return static_cast<std::int32_t>(bond.size() - 1);
  }
};

// System::bonds_ cut into blocks of particles; invalidated by every change of bonds_ except a
// reset, which set() copies into both blocks of the bond.
struct BondBlocks {
  std::size_t block_size = 0;
  std::vector<BondBlock> blocks;
  // Bond b's entry in the block of its i (2b) and of its j (2b + 1; -1 when that is the same block).
  std::vector<std::int32_t> place;
  bool valid = false;

  void assign(const std::vector<Bond>& all, std::size_t particles, std::size_t size) {
    block_size = size;
    blocks.resize((particles + size - 1) / size);
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      BondBlock& block = blocks[k];
      block.begin = k * size;
      block.end = std::min(particles, block.begin + size);
      block.bonds.clear();
      block.bond.clear();
      block.ends.clear();
    }
    place.resize(2 * all.size());
    for (std::size_t b = 0; b < all.size(); ++b) {
      const std::size_t bi = static_cast<std::size_t>(all[b].i) / size, bj = static_cast<std::size_t>(all[b].j) / size;
      if (bi == bj) {
        place[2 * b] = blocks[bi].push_back(all[b], b, kEndI | kEndJ);
        place[2 * b + 1] = -1;
      } else {
        place[2 * b] = blocks[bi].push_back(all[b], b, kEndI);
        place[2 * b + 1] = blocks[bj].push_back(all[b], b, kEndJ);
      }
    }
    valid = true;
  }
  void set(std::size_t b, const Bond& bond) {
    blocks[static_cast<std::size_t>(bond.i) / block_size].bonds.set(static_cast<std::size_t>(place[2 * b]), bond);
    if (place[2 * b + 1] >= 0)
      blocks[static_cast<std::size_t>(bond.j) / block_size].bonds.set(static_cast<std::size_t>(place[2 * b + 1]), bond);
  }
};

// A flagged bond evaluated exactly (System::exact_bond): its loads and gap, unless it breaks.
struct ExactBond {
  BondLoads loads;
  double delta;
  BondEvent event;
  double nx, ny;
};

// One chunk's results of the forces part, in L1 until its scatter.
struct BondChunkForces {
  double force_x[kBondChunk], force_y[kBondChunk];  // on i (on j: opposite)
  double torque_i[kBondChunk], torque_j[kBondChunk];
  double delta[kBondChunk];  // gap
  BondState state[kBondChunk];
};

struct BondScratch {
  BondBlocks bonds;
  std::vector<BondEventRecord> events;  // all blocks' events of one pass
  std::vector<std::size_t> first_touching;  // System::detect_contacts: per task, its first touching candidate
};

// n and the gap of a bond from the separation r_j - r_i (image shift included); the contact
// directions are filled in by the caller. Shared by the forces part and the exact path, so both compute
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

// The forces part over bonds [begin, begin + count), into the out_* arrays (offset to begin already).
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

}  // namespace gel::detail
