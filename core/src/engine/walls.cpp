// The walls: installing them, particles sticking to them, their motion and the stress on them.
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
#include "bonded_group.hpp"
#include "floating_point.hpp"

namespace gel {
using namespace engine;

// ---------------------------------------------------------------------------------------
// Forces, walls, external loads

void System::collect_wall_forces() {
  WallStress stress;
  double power = 0;
  for (const std::int32_t i : wall_members_) {
    if (wall_[i] == kTopWall)
      stress.force_top += fy_[i];
    else
      stress.force_bottom += fy_[i];
    // Power that the wall, moving the particle, feeds into the bonds.
    power -= fx_[i] * vx_[i] + fy_[i] * vy_[i];
    // A wall particle moves with the wall: its bond forces are taken by the wall.
    fx_[i] = fy_[i] = torque_[i] = 0.0;
  }
  stress.p_top = stress.force_top / (kThickness * lx_);
  stress.p_bottom = -stress.force_bottom / (kThickness * lx_);
  stress.p = 0.5 * (stress.p_top + stress.p_bottom);
  wall_stress_ = stress;
  wall_power_ = power;
}

WallStress System::wall_stress() const { return wall_stress_; }

void System::impose_wall_motion() {
  for (std::size_t k = 0; k < wall_members_.size(); ++k) {
    const std::int32_t i = wall_members_[k];
    const bool top = wall_[i] == kTopWall;
    y_[i] = (top ? wall_top_ : wall_bottom_) + wall_offset_[k];
    vx_[i] = 0.0;
    vy_[i] = top ? wall_v_top_ : wall_v_bottom_;
    omega_[i] = 0.0;
  }
}

void System::attach(std::int32_t i, WallSide side) {
  // The particle's own motion is lost to the wall it sticks to.
  ledger_.absorbed_by_walls += 0.5 * kMass * (vx_[i] * vx_[i] + vy_[i] * vy_[i]) + 0.5 * kInertia * omega_[i] * omega_[i];
  wall_[i] = side;
  wall_members_.push_back(i);
  wall_offset_.push_back(y_[i] - (side == kTopWall ? wall_top_ : wall_bottom_));
  vx_[i] = 0.0;
  vy_[i] = side == kTopWall ? wall_v_top_ : wall_v_bottom_;
  omega_[i] = 0.0;
}

void System::attach_to_walls() {
  attaching_.clear();
  for (std::size_t c = 0; c < wall_candidates_.size();) {
    const std::int32_t i = wall_candidates_[c];
    if (y_[i] - kRadius <= wall_bottom_ || y_[i] + kRadius >= wall_top_) [[unlikely]] {
      attaching_.push_back(i);
      wall_candidates_[c] = wall_candidates_.back();
      wall_candidates_.pop_back();
    } else {
      ++c;
    }
  }
  if (attaching_.empty()) [[likely]]
    return;
  // In particle order, like the bonds above: the wall force is summed over wall_members_.
  std::sort(attaching_.begin(), attaching_.end());
  for (const std::int32_t i : attaching_) attach(i, y_[i] - kRadius <= wall_bottom_ ? kBottomWall : kTopWall);
}

void System::set_wall_velocities(double v_bottom, double v_top) {
  require_finite("v_bottom", v_bottom);
  require_finite("v_top", v_top);
  wall_v_bottom_ = v_bottom;
  wall_v_top_ = v_top;
  if (walls_active_) {
    impose_wall_motion();
    forces_valid_ = false;
  }
}

void System::install_walls() {
  if (walls_active_) throw std::logic_error("walls are already installed");
  if (!(params_.effects & kWalls)) throw InvalidArgument("effects", "walls need the 'walls' effect");
  // Into the box first, so that the bonds across y = 0 are those whose shift is not 0.
  wrap_into_box();
  rebuild_neighbours();
  if (periodic_y_) {
    for (std::size_t b = bonds_.size(); b-- > 0;) {
      if (bonds_[b].shift_y == 0.0) continue;
      ledger_.dissipated += bond_energy(bonds_[b]);
      bonds_[b] = bonds_.back();
      bonds_.pop_back();
      bond_scratch_->bonds.valid = false;
    }
  }
  periodic_y_ = false;
  walls_active_ = true;
  const auto [lo, hi] = std::minmax_element(y_.begin(), y_.end());
  wall_bottom_ = *lo - kRadius;
  wall_top_ = *hi + kRadius;
  wall_.assign(size(), kNoWall);
  wall_members_.clear();
  wall_offset_.clear();
  for (std::size_t i = 0; i < size(); ++i) {
    if (y_[i] - kRadius <= wall_bottom_) attach(static_cast<std::int32_t>(i), kBottomWall);
    else if (y_[i] + kRadius >= wall_top_) attach(static_cast<std::int32_t>(i), kTopWall);
  }
  rebuild_neighbours();
  forces_valid_ = false;
  compute_forces();
}

void System::translate_wall_group(WallSide side, double dy) {
  const detail::FlushSubnormals flush_subnormals;
  if (!walls_active_) throw std::logic_error("no walls");
  require_finite("dy", dy);
  // The group is every particle connected through bonds to the wall's particles, short of the
  // other wall's.
  const WallSide other = side == kTopWall ? kBottomWall : kTopWall;
  const std::vector<char> in_group = bonded_group(
      size(), bonds_, [&](std::size_t i) { return wall_[i] == side; }, [&](std::size_t i) { return wall_[i] == other; });
  for (std::size_t i = 0; i < size(); ++i)
    if (in_group[i] && wall_[i] == kNoWall) y_[i] += dy;
  if (side == kTopWall)
    wall_top_ += dy;
  else
    wall_bottom_ += dy;
  impose_wall_motion();
  rebuild_neighbours();
  forces_valid_ = false;
}

}  // namespace gel
