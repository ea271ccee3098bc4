// Quasi-static pieces of the engine (docs/quasistatic.md): the affine strain step of the walls
// and FIRE relaxation to mechanical equilibrium with all bond physics on.
//
// FIRE 2.0 (Bitzek et al., PRL 97, 170201, 2006; Guenole et al., Comput. Mater. Sci. 175,
// 109584, 2020) with semi-implicit Euler, on the generalised velocity (v_x, v_y, a omega) of
// every free particle and the generalised force (F_x, F_y, T/a), so that F.v is the power of
// forces and torques together. Wall particles have zero force and velocity and drop out.
#include <algorithm>
#include <cmath>

#include "gel/bond_evaluator.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "fire_kernels.hpp"
#include "gel/units.hpp"
#include "rotation.hpp"
#include "floating_point.hpp"

namespace gel {

namespace {

// FIRE 2.0's published constants (Guenole et al. 2020, table 1).
constexpr std::int64_t kDelaySteps = 20;      // N_delay
constexpr std::int64_t kMaxUphillSteps = 2000; // N_negative^max
constexpr double kIncrease = 1.1;             // f_inc
constexpr double kDecrease = 0.5;             // f_dec
constexpr double kAlphaStart = 0.25;          // alpha_start
constexpr double kAlphaShrink = 0.99;         // f_alpha
constexpr double kDtMinFactor = 0.02;         // dt_min / dt_max
constexpr double kCapShrink = 0.9;            // dt_max after an uphill step taken at dt_max

// The mean bond force is a bond loop: refreshed this often (and whenever the residual looks
// converged), so its cost stays a few percent of the force loop.
constexpr std::int64_t kScaleInterval = 64;

}  // namespace

void System::affine_move_walls(double new_bottom, double new_top) {
  const detail::FlushSubnormals flush_subnormals;
  if (!walls_active_) throw std::logic_error("no walls");
  require_finite("wall_bottom", new_bottom);
  require_finite("wall_top", new_top);
  if (!(new_top > new_bottom)) throw InvalidArgument("walls", "the top wall must stay above the bottom wall");
  if (!forces_valid_) compute_forces();
  const double stored_before = stored_energy(), dissipated_before = ledger_.dissipated;
  const double centre_old = 0.5 * (wall_bottom_ + wall_top_), centre_new = 0.5 * (new_bottom + new_top);
  const double scale = (new_top - new_bottom) / (wall_top_ - wall_bottom_);

  double largest = std::max(std::abs(new_bottom - wall_bottom_), std::abs(new_top - wall_top_));
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_[i] != kNoWall) continue;
    const double moved = centre_new + (y_[i] - centre_old) * scale;
    largest = std::max(largest, std::abs(moved - y_[i]));
    y_[i] = moved;
  }
  wall_bottom_ = new_bottom;
  wall_top_ = new_top;
  wall_v_bottom_ = wall_v_top_ = 0.0;
  impose_wall_motion();
  travel_ += largest;
  find_new_contacts();
  compute_forces();
  // The move is instantaneous: its work is the change of stored energy plus what the
  // thresholds it crossed released (they trip in the force evaluation above).
  ledger_.wall_work += stored_energy() - stored_before + (ledger_.dissipated - dissipated_before);
}

void System::update_contacts() {
  const detail::FlushSubnormals flush_subnormals;
  find_new_contacts();
  compute_forces();
}

double System::residual_force() const {
  double largest_sq = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;
    const double t = torque_[i] / kRadius;
    largest_sq = std::max({largest_sq, fx_[i] * fx_[i] + fy_[i] * fy_[i], t * t});
  }
  return std::sqrt(largest_sq);
}

double System::mean_bond_force() const {
  if (bonds_.empty()) return 0.0;
  double total = 0;
  for (const Bond& bond : bonds_) {
    const BondGeometry g = geometry(bond);
    const BondForces f = evaluate_bond(g, params_.bond, params_.effects);
    const double fx = f.normal_force * g.nx + f.sliding_x, fy = f.normal_force * g.ny + f.sliding_y;
    total += std::sqrt(fx * fx + fy * fy);
  }
  return total / static_cast<double>(bonds_.size());
}

bool System::relax(RelaxState& state, const RelaxOptions& options, std::int64_t max_iterations) {
  const detail::FlushSubnormals flush_subnormals;
  require_positive("relaxation.force_tolerance", options.force_tolerance);
  require_positive("relaxation.dt_max_factor", options.dt_max_factor);
  require_positive("relaxation.max_step", options.max_step);
  const std::size_t n = size();
  // Equilibrium does not depend on the masses, so FIRE may use its own: a rotational inertia
  // that slows the rotation against the sliding and rolling springs (bond 1's fastest mode,
  // 2.2x faster than stretching) to the stretching frequency lets every step be longer.
  const BondLaw& law = params_.bond;
  const double inertia =
      std::max(kInertia, kMass * (law.k_sliding * kRadius * kRadius + law.k_rolling) / std::max(law.k_normal, law.k_sliding));
  const double step_gain = shortest_period(law, inertia) / shortest_period(law);
  const double dt_max_start = options.dt_max_factor * step_gain * params_.dt;
  if (wall_v_bottom_ != 0.0 || wall_v_top_ != 0.0) set_wall_velocities(0.0, 0.0);
  if (!forces_valid_) compute_forces();
  if (state.converged || state.stalled) return state.converged;
  if (state.dt == 0.0) {
    // From rest, with the dynamics' own step.
    state = RelaxState{};
    state.dt = step_gain * params_.dt;
    state.dt_max = dt_max_start;
    state.alpha = kAlphaStart;
    state.tolerance_factor = 1.0;
    std::fill(vx_.begin(), vx_.end(), 0.0);
    std::fill(vy_.begin(), vy_.end(), 0.0);
    std::fill(omega_.begin(), omega_.end(), 0.0);
    if (walls_active_) impose_wall_motion();
  }
  const double inv_m = 1.0 / kMass, inv_rot = kRadius * kRadius / inertia;  // for (v, a omega) and (F, T/a)
  const double max_step = std::min(options.max_step, 0.1 * kRadius);

  auto converged_now = [&](double residual, std::int64_t iteration) {
    const double tolerance = options.force_tolerance * state.tolerance_factor;
    if (residual > options.force_floor && iteration % kScaleInterval != 0 && residual > tolerance * state.force_scale)
      return false;
    state.force_scale = mean_bond_force();
    if (residual > std::max(tolerance * state.force_scale, options.force_floor)) return false;
    const WallStress stress = wall_stress_;
    if (std::abs(stress.p) < options.stress_floor) return true;
    if (std::abs(stress.p_top - stress.p_bottom) <= options.a_tolerance * std::abs(stress.p)) return true;
    // Balanced particles but unbalanced walls: the residuals add up along the network, so
    // ask each particle for less.
    state.tolerance_factor *= 0.5;
    return false;
  };

  for (std::int64_t it = 0; it < max_iterations; ++it) {
    // One pass: power, norms, and the residual of the current forces.
    double power = 0, v_sq = 0, f_sq = 0, fv_over_m = 0, f_sq_over_m2 = 0, residual_sq = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double t = torque_[i] / kRadius, w = kRadius * omega_[i];
      power += fx_[i] * vx_[i] + fy_[i] * vy_[i] + t * w;
      v_sq += vx_[i] * vx_[i] + vy_[i] * vy_[i] + w * w;
      const double f_lin = fx_[i] * fx_[i] + fy_[i] * fy_[i];
      f_sq += f_lin + t * t;
      fv_over_m += (fx_[i] * vx_[i] + fy_[i] * vy_[i]) * inv_m + t * w * inv_rot;
      f_sq_over_m2 += f_lin * inv_m * inv_m + t * t * inv_rot * inv_rot;
      residual_sq = std::max({residual_sq, f_lin, t * t});
    }
    state.residual = std::sqrt(residual_sq);
    if (!std::isfinite(state.residual)) check_stability();
    if (converged_now(state.residual, state.iterations)) {
      state.converged = true;
      break;
    }

    const double dt_min = kDtMinFactor * state.dt_max;
    if (power > 0) {
      ++state.n_positive;
      state.n_negative = 0;
      if (state.n_positive > kDelaySteps) {
        state.dt = std::min(state.dt * kIncrease, state.dt_max);
        state.alpha *= kAlphaShrink;
      }
    } else {
      state.n_positive = 0;
      ++state.n_negative;
      if (state.n_negative > kMaxUphillSteps) {
        state.stalled = true;
        break;
      }
      // Going uphill at the largest step is, more often than not, the step passing the
      // stability limit of the stiffest mode (which grows with coordination and overlap):
      // lower the cap a little each time, down to the dynamics' own step.
      if (state.dt >= state.dt_max) state.dt_max = std::max(kCapShrink * state.dt_max, step_gain * params_.dt);
      if (state.iterations >= kDelaySteps) {
        state.dt = std::max(state.dt * kDecrease, dt_min);
        state.alpha = kAlphaStart;
      }
      // Step back half a step and stop (FIRE 2.0's correction of the overshoot).
      const double back = -0.5 * state.dt;
      for (std::size_t i = 0; i < n; ++i) {
        x_[i] += back * vx_[i];
        y_[i] += back * vy_[i];
        rotate_small(orient_c_[i], orient_s_[i], back * omega_[i]);
        vx_[i] = vy_[i] = omega_[i] = 0.0;
      }
      v_sq = fv_over_m = 0;
      travel_ += 0.5 * max_step;
    }

    // Semi-implicit Euler with FIRE's mixing: v <- (1-alpha)(v + dt F/m) + alpha |v'| F/|F|.
    const double dt = state.dt;
    const double v_new_sq = v_sq + 2 * dt * fv_over_m + dt * dt * f_sq_over_m2;
    const double mix = f_sq > 0 ? state.alpha * std::sqrt(std::max(v_new_sq, 0.0) / f_sq) : 0.0;
    const double keep = 1.0 - state.alpha;
    const detail::FireMixing mixing{dt, keep, mix, inv_m, inv_rot, max_step};
    const double largest_sq = detail::fire_update(n, mixing, x_.data(), y_.data(), orient_c_.data(), orient_s_.data(),
                                                  vx_.data(), vy_.data(), omega_.data(), fx_.data(), fy_.data(),
                                                  torque_.data());
    if (walls_active_) impose_wall_motion();
    travel_ += std::sqrt(largest_sq);
    find_new_contacts();
    compute_forces();
    ++state.iterations;
    ++step_count_;
    if (step_count_ % params_.guard_interval == 0) check_stability();
  }
  if (state.converged) {
    // Equilibrium is at rest.
    std::fill(vx_.begin(), vx_.end(), 0.0);
    std::fill(vy_.begin(), vy_.end(), 0.0);
    std::fill(omega_.begin(), omega_.end(), 0.0);
    if (walls_active_) impose_wall_motion();
  }
  return state.converged;
}

}  // namespace gel
