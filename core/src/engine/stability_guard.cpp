// The stability guard: a NaN, a blown-up overlap, a runaway speed or contacts stiffened past
// Verlet's limit stop the run with a StabilityError that says what and where.
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
// Stability guard

void System::stability_failure(const std::string& what) const {
  throw StabilityError("step " + std::to_string(step_count_) + " (t = " + number(time_) + "): " + what +
                       "; dt = " + number(params_.dt) + " (reduce integration.dt_fraction or the load)");
}

double System::bond_gap(const Bond& bond) const {
  const double dx = x_[bond.j] + bond.shift_x - x_[bond.i], dy = y_[bond.j] + bond.shift_y - y_[bond.i];
  return std::sqrt(dx * dx + dy * dy) - kDiameter;
}

void System::check_stability() {
  const std::size_t n = size();
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i)
    sum += x_[i] + y_[i] + vx_[i] + vy_[i] + omega_[i] + fx_[i] + fy_[i] + torque_[i] + orient_c_[i];
  if (!std::isfinite(sum)) {
    const std::array<std::pair<const char*, const std::vector<double>*>, 9> fields{{
        {"x", &x_}, {"y", &y_}, {"vx", &vx_}, {"vy", &vy_}, {"omega", &omega_},
        {"fx", &fx_}, {"fy", &fy_}, {"torque", &torque_}, {"orientation", &orient_c_}}};
    for (std::size_t i = 0; i < n; ++i)
      for (const auto& [name, values] : fields)
        if (!std::isfinite((*values)[i]))
          stability_failure("particle " + std::to_string(i) + " has non-finite " + name + " = " + number((*values)[i]));
    stability_failure("state values overflow (sum of state is " + number(sum) + ")");
  }
  const double limit_sq = params_.max_speed * params_.max_speed;
  for (std::size_t i = 0; i < n; ++i) {
    const double speed_sq = std::max(vx_[i] * vx_[i] + vy_[i] * vy_[i], kRadius * kRadius * omega_[i] * omega_[i]);
    if (!(speed_sq <= limit_sq))
      stability_failure("particle " + std::to_string(i) + " moves at " + number(std::sqrt(speed_sq)) +
                        " a/t0, beyond the bound max_speed = " + number(params_.max_speed) + " a/t0");
  }
  if (min_delta_ < -params_.max_overlap) {
    for (std::size_t b = 0; b < bonds_.size(); ++b) {
      const Bond& bond = bonds_[b];
      const double gap = bond_gap(bond);
      if (gap < -params_.max_overlap)
        stability_failure("bond " + std::to_string(b) + " (particles " + std::to_string(bond.i) + "-" +
                          std::to_string(bond.j) + ") overlaps by " + number(-gap) + " a, beyond max_overlap = " +
                          number(params_.max_overlap) + " a");
    }
  }
  if (params_.effects & kOverlapRepulsion) check_contact_stiffness();
  min_delta_ = 0;
}

// The cubic term stiffens a compressed contact to k_c = k_N + 3 C delta^2, and velocity Verlet
// is unstable once omega dt > 2 for the stiffest mode. A particle pressed by several contacts
// is stiffer than any one of them. Gershgorin's bound on the dynamical matrix (a row of particle
// i holds k_c n n^T on the diagonal and -k_c n n^T off it, and n_x^2 + |n_x n_y| <= (1 + sqrt 2)/2)
// gives omega^2 <= max_i (1 + sqrt 2) sum_{c at i} k_c / m. The sum is taken only when the most
// compressed contact could reach the limit with seven such contacts (the most a disk has at
// small overlaps), so that an ordinary step pays nothing for it.
namespace {
constexpr double kGershgorinFactor = 2.414213562373095;  // 1 + sqrt 2
}

double System::contact_stiffness(double delta) const {
  const BondLaw& law = params_.bond;
  const double overlap = std::min(delta, 0.0);
  return law.k_normal + 3.0 * law.overlap_coefficient * overlap * overlap;
}

std::vector<double> System::summed_contact_stiffness() const {
  std::vector<double> summed(size(), 0.0);
  for (const Bond& bond : bonds_) {
    const double k = contact_stiffness(bond_gap(bond));
    summed[bond.i] += k;
    summed[bond.j] += k;
  }
  return summed;
}

double System::fastest_contact_frequency() const {
  const std::vector<double> summed = summed_contact_stiffness();
  double largest = 0;
  for (std::size_t i = 0; i < size(); ++i)
    if (wall_side(i) == kNoWall) largest = std::max(largest, summed[i]);  // wall particles are not integrated
  return std::sqrt(kGershgorinFactor * largest / kMass);
}

void System::check_contact_stiffness() {
  if (std::sqrt(kGershgorinFactor * 7.0 * contact_stiffness(min_delta_) / kMass) * params_.dt <= 2.0) return;
  const std::vector<double> summed = summed_contact_stiffness();
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;  // moved with its wall, not integrated
    const double omega_dt = std::sqrt(kGershgorinFactor * summed[i] / kMass) * params_.dt;
    if (omega_dt > 2.0)
      stability_failure("the contacts of particle " + std::to_string(i) + " (most compressed overlap " + number(-min_delta_) +
                        " a) stiffen it to " + number(summed[i]) + " F0/a: omega dt = " + number(omega_dt) +
                        " exceeds the Verlet limit 2");
  }
}

}  // namespace gel
