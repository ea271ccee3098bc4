// The bond-force loop (bond_kernels.hpp): every block's owner computes the forces on its
// particles, on one thread or the pool, and the breaks and resets found meanwhile are applied
// after it, in bond order.
#include <algorithm>
#include <array>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

#include "gel/bond_evaluator.hpp"
#include "gel/system.hpp"
#include "system_internal.hpp"

namespace gel {
using namespace engine;

// The exact path: one flagged bond evaluated without the series, with its thresholds. It changes
// nothing (both owners of a bond that crosses blocks run it); the caller records the event.
template <unsigned kMask>
detail::ExactBond System::exact_bond(std::size_t b) const {
  using Evaluator = BondEvaluator<kMask & kBondEffectBits>;
  const BondLaw& law = params_.bond;
  const Bond& bond = bonds_[b];
  const std::int32_t i = bond.i, j = bond.j;
  double dx = x_[j] - x_[i], dy = y_[j] - y_[i];
  if constexpr ((kMask & kShiftBit) != 0) {
    dx += bond.shift_x;
    dy += bond.shift_y;
  }
  BondGeometry g = detail::line_of_centres(dx, dy);
  if constexpr (Evaluator::needs_contact_points()) {
    to_lab(orient_c_[i], orient_s_[i], bond.bix, bond.biy, g.xi_ix, g.xi_iy);
    to_lab(orient_c_[j], orient_s_[j], bond.bjx, bond.bjy, g.xi_jx, g.xi_jy);
  }
  BondForces f = Evaluator::evaluate(g, law);
  BondEvent event = BondEvent::kNone;
  if constexpr ((kMask & kThresholds) != 0) {
    event = threshold_event(f, law);
    if (event == BondEvent::kBreak) return {{}, g.delta, event, g.nx, g.ny};
    // A reset re-records the contact points (d = 0, phi = 0): no tangential load this step.
    if (event != BondEvent::kNone) f.sliding_x = f.sliding_y = f.rolling_moment = 0.0;
  }
  return {bond_loads(f, g), g.delta, event, g.nx, g.ny};
}

// One block: the forces on its particles from their bonds, summed in bond order. A particle of
// the block gets the same additions as a serial loop over all bonds would give it; the other end
// of a bond that crosses blocks is its own owner's.
template <unsigned kMask>
void System::block_bond_forces(detail::BondBlock& block) {
  constexpr unsigned kEffects = kMask & kBondEffectBits;
  constexpr bool kShift = (kMask & kShiftBit) != 0;
  constexpr bool kCheckThresholds = (kMask & kThresholds) != 0;
  std::fill(fx_.begin() + static_cast<std::ptrdiff_t>(block.begin), fx_.begin() + static_cast<std::ptrdiff_t>(block.end), 0.0);
  std::fill(fy_.begin() + static_cast<std::ptrdiff_t>(block.begin), fy_.begin() + static_cast<std::ptrdiff_t>(block.end), 0.0);
  std::fill(torque_.begin() + static_cast<std::ptrdiff_t>(block.begin),
            torque_.begin() + static_cast<std::ptrdiff_t>(block.end), 0.0);
  double* __restrict fx = fx_.data();
  double* __restrict fy = fy_.data();
  double* __restrict torque = torque_.data();
  const detail::BondArrays& arrays = block.bonds;
  const detail::BondEnds* ends = block.ends.data();
  block.events.clear();
  // A separate minimum for the exact path keeps this one in a register.
  double min_delta = std::numeric_limits<double>::infinity(), exact_min_delta = min_delta;
  detail::BondChunkForces chunk;  // on the stack: in L1, and each thread has its own
  const std::size_t entries = arrays.size();
  for (std::size_t begin = 0; begin < entries; begin += detail::kBondChunk) {
    const std::size_t count = std::min(detail::kBondChunk, entries - begin);
    detail::bond_chunk_forces<kEffects, kShift, kCheckThresholds>(
        arrays, begin, count, x_.data(), y_.data(), orient_c_.data(), orient_s_.data(), params_.bond, chunk.force_x,
        chunk.force_y, chunk.torque_i, chunk.torque_j, chunk.delta, chunk.state);
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t e = begin + k;
      if (chunk.state[k] == detail::kFlagged) [[unlikely]] {
        const std::int32_t b = block.bond[e];
        const detail::ExactBond exact = exact_bond<kMask>(static_cast<std::size_t>(b));
        // The block of i records the event, so that it is applied once.
        if (exact.event != BondEvent::kNone && (ends[e] & detail::kEndI))
          block.events.push_back({b, exact.event, exact.nx, exact.ny});
        if (exact.event == BondEvent::kBreak) continue;
        chunk.force_x[k] = exact.loads.force_x;
        chunk.force_y[k] = exact.loads.force_y;
        chunk.torque_i[k] = exact.loads.torque_i;
        chunk.torque_j[k] = exact.loads.torque_j;
        exact_min_delta = std::min(exact_min_delta, exact.delta);
      } else {
        min_delta = std::min(min_delta, chunk.delta[k]);
      }
      const std::int32_t i = arrays.i[e], j = arrays.j[e];
      if (ends[e] & detail::kEndI) {
        fx[i] += chunk.force_x[k];
        fy[i] += chunk.force_y[k];
        torque[i] += chunk.torque_i[k];
      }
      if (ends[e] & detail::kEndJ) {
        fx[j] -= chunk.force_x[k];
        fy[j] -= chunk.force_y[k];
        torque[j] += chunk.torque_j[k];
      }
    }
  }
  block.min_delta = std::min(min_delta, exact_min_delta);
}

// One block on one thread; blocks of kParticleBlock particles (the integrator's tasks, so that a
// thread's particles stay in its cache) on several.
template <unsigned kMask>
void System::bond_forces() {
  detail::BondBlocks& layout = bond_scratch_->bonds;
  const std::size_t n = size();
  const std::size_t block_size = pool_ ? detail::kParticleBlock : n;
  if (!layout.valid || layout.block_size != block_size) layout.assign(bonds_, n, block_size);
  parallel(layout.blocks.size(), [&](std::size_t k) { block_bond_forces<kMask>(layout.blocks[k]); });

  double min_delta = min_delta_;
  std::vector<detail::BondEventRecord>& events = bond_scratch_->events;
  events.clear();
  for (const detail::BondBlock& block : layout.blocks) {
    min_delta = std::min(min_delta, block.min_delta);
    events.insert(events.end(), block.events.begin(), block.events.end());
  }
  min_delta_ = min_delta;
  if (events.empty()) [[likely]]
    return;
  // Each block's events are in bond order, the blocks' lists are not: the ledger adds in bond order.
  std::sort(events.begin(), events.end(),
            [](const detail::BondEventRecord& a, const detail::BondEventRecord& b) { return a.bond < b.bond; });
  bool any_broken = false;
  for (const detail::BondEventRecord& event : events)
    any_broken |= handle_threshold(static_cast<std::size_t>(event.bond), event.event, event.nx, event.ny);
  if (any_broken) remove_marked_bonds();
}

void System::dispatch_bond_forces() {
  static constexpr auto table = []<std::size_t... kMasks>(std::index_sequence<kMasks...>) {
    return std::array<void (System::*)(), kBondVariants>{&System::bond_forces<kMasks>...};
  }(std::make_index_sequence<kBondVariants>{});
  const unsigned mask = (params_.effects & kBondEffectBits) | ((periodic_x_ || periodic_y_) ? kShiftBit : 0u);
  (this->*table[mask])();
}

}  // namespace gel
