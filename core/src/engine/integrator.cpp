// Integration: velocity Verlet with Stokes drag (integrator_kernels.hpp holds the loops), the
// force evaluation of one step, the time step and the threads.
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
#include "floating_point.hpp"

namespace gel {
using namespace engine;

detail::KickCoefficients System::kick_coefficients() const {
  const double dt = params_.dt;
  return {dt, 0.5 * dt / kMass, 0.5 * dt / kInertia, params_.drag_translation(), params_.drag_rotation()};
}

template <bool kDragOn>
void System::first_half_kick_and_drift() {
  const std::size_t n = size();
  const std::size_t blocks = (n + detail::kParticleBlock - 1) / detail::kParticleBlock;
  kick_totals_.resize(blocks);
  const detail::KickCoefficients k = kick_coefficients();
  parallel(blocks, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock, count = std::min(detail::kParticleBlock, n - begin);
    kick_totals_[block] = detail::kick_and_drift<kDragOn>(
        count, k, x_.data() + begin, y_.data() + begin, orient_c_.data() + begin, orient_s_.data() + begin,
        vx_.data() + begin, vy_.data() + begin, omega_.data() + begin, fx_.data() + begin, fy_.data() + begin,
        torque_.data() + begin);
  });
  // Blocks combined in order: the same sum for any number of threads.
  double max_speed_sq = 0, drag_power = 0;
  for (const detail::KickTotals& totals : kick_totals_) {
    max_speed_sq = std::max(max_speed_sq, totals.max_speed_sq);
    drag_power += totals.drag_power;
  }
  max_speed_sq_ = max_speed_sq;
  if constexpr (kDragOn) ledger_.drag += 0.5 * params_.dt * drag_power;
}

template <bool kDragOn>
void System::second_half_kick() {
  const std::size_t n = size();
  const std::size_t blocks = (n + detail::kParticleBlock - 1) / detail::kParticleBlock;
  kick_totals_.resize(blocks);
  const detail::KickCoefficients k = kick_coefficients();
  parallel(blocks, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock, count = std::min(detail::kParticleBlock, n - begin);
    kick_totals_[block].drag_power = detail::second_kick<kDragOn>(count, k, vx_.data() + begin, vy_.data() + begin,
                                                                  omega_.data() + begin, fx_.data() + begin,
                                                                  fy_.data() + begin, torque_.data() + begin);
  });
  double drag_power = 0;
  for (const detail::KickTotals& totals : kick_totals_) drag_power += totals.drag_power;
  if constexpr (kDragOn) ledger_.drag += 0.5 * params_.dt * drag_power;
}

void System::set_time_step(double dt) {
  require_positive("integration.dt", dt);
  if (dt == params_.dt) return;
  params_.max_speed *= params_.dt / dt;
  params_.dt = dt;
}

void System::set_threads(int threads) {
  if (threads < 1) throw InvalidArgument("threads", "must be >= 1");
  if (threads == this->threads()) return;
  pool_ = threads == 1 ? nullptr : std::make_unique<detail::WorkerPool>(threads);
}

int System::threads() const { return pool_ ? pool_->threads() : 1; }

void System::step() {
  const detail::FlushSubnormals flush_subnormals;
  if (!forces_valid_) compute_forces();
  const double dt = params_.dt;
  const bool drag = (params_.effects & kDrag) != 0;
  const double wall_power_before = wall_power_, external_power_before = external_power_;

  // Wall particles were given the wall's velocity and no force, so the kick leaves them on
  // the wall's path up to drag, which impose_wall_motion() removes again.
  if (drag)
    first_half_kick_and_drift<true>();
  else
    first_half_kick_and_drift<false>();
  if (!(max_speed_sq_ <= params_.max_speed * params_.max_speed)) [[unlikely]] check_stability();
  travel_ += std::sqrt(max_speed_sq_) * dt;

  if (walls_active_) {
    wall_bottom_ += wall_v_bottom_ * dt;
    wall_top_ += wall_v_top_ * dt;
    wall_travel_ += std::max(std::abs(wall_v_bottom_), std::abs(wall_v_top_)) * dt;
    impose_wall_motion();
  }
  find_new_contacts();

  compute_forces();
  if (drag)
    second_half_kick<true>();
  else
    second_half_kick<false>();
  if (walls_active_) {
    impose_wall_motion();
    // Drag on wall particles is the wall's business, not the network's.
    if (drag) {
      const double gamma = params_.drag_translation();
      for (const std::int32_t i : wall_members_) ledger_.drag -= dt * gamma * vy_[i] * vy_[i];
    }
    ledger_.wall_work += 0.5 * dt * (wall_power_before + wall_power_);
  }
  if (!external_.empty()) {
    double power = 0;
    for (const ExternalForce& load : external_) power += load.fx * vx_[load.i] + load.fy * vy_[load.i];
    ledger_.external_work += 0.5 * dt * (external_power_before + power);
    external_power_ = power;
  }
  time_ += dt;
  ++step_count_;
  if (step_count_ % params_.guard_interval == 0) check_stability();
}

void System::run(std::int64_t steps) {
  for (std::int64_t k = 0; k < steps; ++k) step();
}

void System::compute_forces() {
  const detail::FlushSubnormals flush_subnormals;
  dispatch_bond_forces();  // writes every particle's force and torque (from zero)
  if (!external_.empty()) apply_external_forces();
  if (walls_active_) collect_wall_forces();
  forces_valid_ = true;
}

}  // namespace gel
