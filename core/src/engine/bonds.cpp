// Bonds: creation on contact, geometry and energy, the thresholds (breaks and resets). The
// bond-force loop is bond_loop.cpp.
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

namespace {
constexpr std::size_t kCandidateBlock = 1024;  // candidates per task of detect_contacts (several threads)
}  // namespace

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
  auto touches = [&](const Candidate& pair) {
    const double dx = x_[pair.j] + pair.shift_x - x_[pair.i];
    const double dy = y_[pair.j] + pair.shift_y - y_[pair.i];
    return dx * dx + dy * dy <= contact_sq;
  };
  // A pair touches in few steps: the threads look for the first one, and the list is changed on
  // one thread, from there on, only when there is one (as a serial scan would, for any T).
  const std::size_t count = candidates_.size();
  const std::size_t block = pool_ ? kCandidateBlock : std::max<std::size_t>(count, 1);
  std::vector<std::size_t>& first = bond_scratch_->first_touching;
  first.assign((count + block - 1) / block, count);
  parallel(first.size(), [&](std::size_t t) {
    const std::size_t end = std::min(count, (t + 1) * block);
    for (std::size_t c = t * block; c < end; ++c)
      if (touches(candidates_[c])) [[unlikely]] {
        first[t] = c;
        return;
      }
  });
  std::size_t from = count;
  for (const std::size_t c : first) from = std::min(from, c);
  if (from == count) [[likely]]
    return;
  touching_.clear();
  for (std::size_t c = from; c < candidates_.size();) {
    const Candidate& pair = candidates_[c];
    if (touches(pair)) {
      touching_.push_back(pair);
      candidates_[c] = candidates_.back();
      candidates_.pop_back();
    } else {
      ++c;
    }
  }
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

// A bond past a threshold (the evaluator's threshold_event), found by the bond loop's exact path
// and applied after it in bond order (so the ledger's sum is the same for any number of threads).
// Returns true when the bond broke (it is marked; it contributed no force), false when it was
// reset.
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

}  // namespace gel
