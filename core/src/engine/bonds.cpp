// Bonds: creation on contact, geometry and energy, the thresholds (breaks and resets), and the
// bond-force loop (one thread or the pool, bond_kernels.hpp) with its exact path for flagged bonds.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "gel/bond_evaluator.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "system_internal.hpp"

namespace gel {
using namespace engine;

// ---------------------------------------------------------------------------------------
// Bonds

void System::create_bond(std::int32_t i, std::int32_t j, double shift_x, double shift_y) {
  const double dx = x_[j] + shift_x - x_[i], dy = y_[j] + shift_y - y_[i];
  const double r = std::sqrt(dx * dx + dy * dy);
  const double nx = dx / r, ny = dy / r;
  Bond bond{i, j, 0, 0, 0, 0, shift_x, shift_y};
  to_body(orient_c_[i], orient_s_[i], nx, ny, bond.bix, bond.biy);
  to_body(orient_c_[j], orient_s_[j], -nx, -ny, bond.bjx, bond.bjy);
  bonds_.push_back(bond);
  bond_scratch_->bonds.valid = false;
  ++events_.created;
  // The bond forms at delta <= 0 (the step overshoots contact by at most v dt), so it
  // starts with a little normal energy; the ledger keeps it to close the energy balance.
  const BondGeometry g{nx, ny, r - kDiameter, nx, ny, -nx, -ny};
  ledger_.created += gel::bond_energy(g, params_.bond, params_.effects).total();
}

void System::detect_contacts() {
  const double contact_sq = kDiameter * kDiameter;
  touching_.clear();
  for (std::size_t c = 0; c < candidates_.size();) {
    const Candidate& pair = candidates_[c];
    const double dx = x_[pair.j] + pair.shift_x - x_[pair.i];
    const double dy = y_[pair.j] + pair.shift_y - y_[pair.i];
    if (dx * dx + dy * dy <= contact_sq) [[unlikely]] {
      touching_.push_back(pair);
      candidates_[c] = candidates_.back();
      candidates_.pop_back();
    } else {
      ++c;
    }
  }
  if (touching_.empty()) [[likely]]
    return;
  // The candidate list follows the cell grid, whose cells are 2a + skin wide: bonds formed in one
  // step are appended in (i, j) order instead, so that the bond order (the order in which each
  // particle's forces are summed) does not depend on the skin.
  std::sort(touching_.begin(), touching_.end(),
            [](const Candidate& a, const Candidate& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  for (const Candidate& pair : touching_) create_bond(pair.i, pair.j, pair.shift_x, pair.shift_y);
}

BondGeometry System::geometry(const Bond& bond) const {
  const double dx = x_[bond.j] + bond.shift_x - x_[bond.i];
  const double dy = y_[bond.j] + bond.shift_y - y_[bond.i];
  const double r = std::sqrt(dx * dx + dy * dy);
  BondGeometry g{dx / r, dy / r, r - kDiameter, 0, 0, 0, 0};
  to_lab(orient_c_[bond.i], orient_s_[bond.i], bond.bix, bond.biy, g.xi_ix, g.xi_iy);
  to_lab(orient_c_[bond.j], orient_s_[bond.j], bond.bjx, bond.bjy, g.xi_jx, g.xi_jy);
  return g;
}

double System::bond_energy(const Bond& bond) const {
  return gel::bond_energy(geometry(bond), params_.bond, params_.effects).total();
}

double System::stored_energy() const {
  double total = 0;
  for (const Bond& bond : bonds_) total += bond_energy(bond);
  return total;
}

// Slow path of the bond loop, taken only for a bond past a threshold (the evaluator's
// threshold_event). Returns true when the bond broke (it is marked and contributes no force),
// false when it was reset.
bool System::handle_threshold(std::size_t b, BondEvent event, double nx, double ny) {
  Bond& bond = bonds_[b];
  const BondGeometry g = geometry(bond);
  const BondEnergy energy = gel::bond_energy(g, params_.bond, params_.effects);
  if (event == BondEvent::kBreak) {
    ledger_.dissipated += energy.total();
    ++events_.normal;
    if (bond_marked_.size() < bonds_.size()) bond_marked_.resize(bonds_.size(), 0);
    bond_marked_[b] = 1;
    return true;
  }
  // A reset re-records both contact points at the current line of centres: d = 0, phi = 0.
  if (event == BondEvent::kSlidingReset) ++events_.sliding;
  else ++events_.rolling;
  ledger_.dissipated += energy.sliding + energy.rolling;
  to_body(orient_c_[bond.i], orient_s_[bond.i], nx, ny, bond.bix, bond.biy);
  to_body(orient_c_[bond.j], orient_s_[bond.j], -nx, -ny, bond.bjx, bond.bjy);
  if (bond_scratch_->bonds.valid) bond_scratch_->bonds.set(b, bond);
  return false;
}

void System::remove_marked_bonds() {
  // Back to front, so that swap-removal never moves an unvisited marked bond.
  for (std::size_t b = bond_marked_.size(); b-- > 0;) {
    if (!bond_marked_[b]) continue;
    const Bond& bond = bonds_[b];
    // A broken pair may bond again when it touches again: it is a candidate from now on.
    if (params_.effects & kBondCreation) candidates_.push_back(Candidate{bond.i, bond.j, bond.shift_x, bond.shift_y});
    bonds_[b] = bonds_.back();
    bonds_.pop_back();
  }
  bond_marked_.clear();
  bond_scratch_->bonds.valid = false;
}

// Pass 2 of the bond loop (bond_kernels.hpp): one bond flagged by pass 1 evaluated exactly, with
// its thresholds, into the per-bond results. Returns true when the bond broke (it is marked and
// contributes no force).
template <unsigned kMask>
bool System::bond_force_exact(std::size_t b, double& min_delta) {
  using Evaluator = BondEvaluator<kMask & kBondEffectBits>;
  constexpr bool kCheckThresholds = (kMask & kThresholds) != 0;
  const BondLaw& law = params_.bond;
  detail::BondForceArrays& out = bond_scratch_->forces;
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
  if constexpr (kCheckThresholds) {
    const BondEvent event = threshold_event(f, law);
    if (event != BondEvent::kNone) {
      if (handle_threshold(b, event, g.nx, g.ny)) {
        out.state[b] = detail::BondForceArrays::kBroken;
        return true;
      }
      f.sliding_x = f.sliding_y = f.rolling_moment = 0.0;
    }
  }
  const BondLoads o = bond_loads(f, g);
  out.force_x[b] = o.force_x;
  out.force_y[b] = o.force_y;
  out.torque_i[b] = o.torque_i;
  out.torque_j[b] = o.torque_j;
  min_delta = std::min(min_delta, g.delta);
  return false;
}

// The three passes of bond_kernels.hpp. Every particle's force is the same sequence of additions
// (its bonds in bond order) for any number of threads, so results are bit-identical.
template <unsigned kMask>
void System::bond_forces() {
  constexpr unsigned kEffects = kMask & kBondEffectBits;
  constexpr bool kShift = (kMask & kShiftBit) != 0;
  constexpr bool kCheckThresholds = (kMask & kThresholds) != 0;
  const BondLaw law = params_.bond;
  detail::BondScratch& scratch = *bond_scratch_;
  detail::BondArrays& arrays = scratch.bonds;
  detail::BondForceArrays& forces = scratch.forces;
  const std::size_t bond_count = bonds_.size();
  if (!arrays.valid) arrays.assign(bonds_, size());
  if (forces.state.size() != bond_count) {
    for (auto* column : {&forces.force_x, &forces.force_y, &forces.torque_i, &forces.torque_j, &forces.delta})
      column->resize(bond_count);
    forces.state.resize(bond_count);
  }

  auto pass1 = [&](std::size_t begin, std::size_t count, double* out_fx, double* out_fy, double* out_ti, double* out_tj,
                   double* out_delta, detail::BondState* out_state) {
    detail::bond_chunk_forces<kEffects, kShift, kCheckThresholds>(arrays, begin, count, x_.data(), y_.data(),
                                                                  orient_c_.data(), orient_s_.data(), law, out_fx, out_fy,
                                                                  out_ti, out_tj, out_delta, out_state);
  };
  double min_delta = min_delta_;
  bool any_broken = false;
  const std::size_t n = size();

  if (!pool_) {
    // One thread: each chunk's passes back to back while its results are in L1, the sums as a
    // scatter in bond order, which adds to each particle in the same order as pass 3 would.
    std::fill(fx_.begin(), fx_.end(), 0.0);
    std::fill(fy_.begin(), fy_.end(), 0.0);
    std::fill(torque_.begin(), torque_.end(), 0.0);
    double* __restrict fx = fx_.data();
    double* __restrict fy = fy_.data();
    double* __restrict torque = torque_.data();
    // A separate minimum for the exact path, whose address is taken, keeps this one in a register.
    double exact_min_delta = min_delta;
    detail::BondChunkForces& chunk = scratch.chunk;
    for (std::size_t begin = 0; begin < bond_count; begin += detail::kBondChunk) {
      const std::size_t count = std::min(detail::kBondChunk, bond_count - begin);
      pass1(begin, count, chunk.force_x, chunk.force_y, chunk.torque_i, chunk.torque_j, chunk.delta, chunk.state);
      for (std::size_t k = 0; k < count; ++k) {
        if (chunk.state[k] == detail::BondForceArrays::kFlagged) [[unlikely]] {
          // Pass 2 writes into the all-bond arrays; this bond's results are read from there.
          const std::size_t b = begin + k;
          if (bond_force_exact<kMask>(b, exact_min_delta)) {
            any_broken = true;
            continue;
          }
          chunk.force_x[k] = forces.force_x[b];
          chunk.force_y[k] = forces.force_y[b];
          chunk.torque_i[k] = forces.torque_i[b];
          chunk.torque_j[k] = forces.torque_j[b];
        } else {
          min_delta = std::min(min_delta, chunk.delta[k]);
        }
        const std::int32_t i = arrays.i[begin + k], j = arrays.j[begin + k];
        fx[i] += chunk.force_x[k];
        fy[i] += chunk.force_y[k];
        fx[j] -= chunk.force_x[k];
        fy[j] -= chunk.force_y[k];
        torque[i] += chunk.torque_i[k];
        torque[j] += chunk.torque_j[k];
      }
    }
    min_delta_ = std::min(min_delta, exact_min_delta);
    if (any_broken) remove_marked_bonds();
    return;
  }

  // Several threads: bigger tasks than the one-thread chunks (fewer hand-outs, no L1 reuse to keep).
  constexpr std::size_t kTaskBonds = 8 * detail::kBondChunk;
  const std::size_t tasks = (bond_count + kTaskBonds - 1) / kTaskBonds;
  scratch.chunk_summaries.resize(tasks);
  parallel(tasks, [&](std::size_t chunk) {
    const std::size_t begin = chunk * kTaskBonds, count = std::min(kTaskBonds, bond_count - begin);
    pass1(begin, count, forces.force_x.data() + begin, forces.force_y.data() + begin, forces.torque_i.data() + begin,
          forces.torque_j.data() + begin, forces.delta.data() + begin, forces.state.data() + begin);
    scratch.chunk_summaries[chunk] = detail::summarise_chunk(forces, begin, count);
  });
  for (const detail::ChunkSummary& summary : scratch.chunk_summaries) min_delta = std::min(min_delta, summary.min_delta);
  // Pass 2 is serial (it may break bonds and reset springs) and visits the flagged bonds in bond
  // order; a task that flagged none is skipped whole, so the serial part no longer reads every
  // bond's state each step (8 bytes a bond; at 23 040 particles two threads gained 3-5 %).
  for (std::size_t chunk = 0; chunk < tasks; ++chunk) {
    if (!scratch.chunk_summaries[chunk].any_flagged) continue;
    const std::size_t begin = chunk * kTaskBonds, end = std::min(bond_count, begin + kTaskBonds);
    for (std::size_t b = begin; b < end; ++b)
      if (forces.state[b] == detail::BondForceArrays::kFlagged) any_broken |= bond_force_exact<kMask>(b, min_delta);
  }
  parallel((n + detail::kParticleBlock - 1) / detail::kParticleBlock, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock;
    detail::sum_bond_forces(arrays, forces, begin, std::min(n, begin + detail::kParticleBlock), fx_.data(), fy_.data(),
                            torque_.data());
  });
  min_delta_ = min_delta;
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
