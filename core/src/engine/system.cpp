// System: construction, observables, state access and the configuration (gel/system.hpp). The
// engine's other concepts have one file each in this folder.
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
// Construction

System::~System() = default;
System::System(System&&) noexcept = default;
System& System::operator=(System&&) noexcept = default;

System::System(const Configuration& config, const SimParams& params)
    : params_(params), bond_scratch_(std::make_unique<detail::BondScratch>()) {
  const std::size_t n = config.size();
  if (n == 0) throw InvalidArgument("configuration", "no particles");
  if (!(params_.dt > 0)) params_.dt = params_.dt_fraction * shortest_period(params_.bond);
  require_positive("integration.dt", params_.dt);
  require_positive("integration.skin", params_.skin);
  require_non_negative("integration.eta_factor", params_.eta_factor);
  if (params_.guard_interval <= 0) throw InvalidArgument("integration.guard_interval", "must be positive");
  if (params_.max_speed <= 0) params_.max_speed = 0.1 * kRadius / params_.dt;

  lx_ = config.lx;
  ly_ = config.ly;
  require_positive("configuration.lx", lx_);
  require_positive("configuration.ly", ly_);
  periodic_x_ = (params_.effects & kPeriodicX) != 0;
  periodic_y_ = config.periodic_y;
  if (config.has_walls() && !(params_.effects & kWalls))
    throw InvalidArgument("effects", "the configuration has walls but the 'walls' effect is off");

  x_ = config.x;
  y_ = config.y;
  orient_c_.resize(n);
  orient_s_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    orient_c_[i] = std::cos(config.theta[i]);
    orient_s_[i] = std::sin(config.theta[i]);
  }
  // A configuration without velocities is at rest.
  if (config.has_velocities()) {
    if (config.vx.size() != n || config.vy.size() != n || config.omega.size() != n)
      throw InvalidArgument("configuration.vx", "vx, vy and omega need one entry per particle (or none: at rest)");
    vx_ = config.vx;
    vy_ = config.vy;
    omega_ = config.omega;
  } else {
    vx_.assign(n, 0.0);
    vy_.assign(n, 0.0);
    omega_.assign(n, 0.0);
  }
  fx_.assign(n, 0.0);
  fy_.assign(n, 0.0);
  torque_.assign(n, 0.0);

  bonds_.reserve(config.bonds.size() + n);
  for (const BondRecord& record : config.bonds) {
    if (record.i < 0 || record.j < 0 || static_cast<std::size_t>(record.i) >= n ||
        static_cast<std::size_t>(record.j) >= n || record.i == record.j)
      throw InvalidArgument("configuration.bonds", "bond joins invalid particles");
    bonds_.push_back(Bond{record.i, record.j, record.bix, record.biy, record.bjx, record.bjy, 0.0, 0.0});
  }

  if (config.has_walls()) {
    walls_active_ = true;
    wall_bottom_ = config.wall_bottom;
    wall_top_ = config.wall_top;
    wall_.assign(n, kNoWall);
    for (std::size_t i = 0; i < n; ++i) {
      const std::int8_t side = config.wall.empty() ? std::int8_t{kNoWall} : config.wall[i];
      // A wall particle keeps the offset it stuck with, which may reach past the wall (it sticks
      // at the first look after it touched): only free particles must lie between the walls.
      if (side == kNoWall &&
          (y_[i] - kRadius < wall_bottom_ - params_.max_overlap || y_[i] + kRadius > wall_top_ + params_.max_overlap))
        throw InvalidArgument("configuration.y[" + std::to_string(i) + "]", "particle lies outside the walls");
      if (side != kNoWall) {
        wall_[i] = side;
        wall_members_.push_back(static_cast<std::int32_t>(i));
        wall_offset_.push_back(y_[i] - (side == kBottomWall ? wall_bottom_ : wall_top_));
      }
    }
  }

  rebuild_neighbours();
  // Reject what the overlap term cannot resolve: any bonded or touching pair overlapping
  // by more than the stability bound.
  auto check_pair = [&](std::int32_t i, std::int32_t j, double sx, double sy, const char* what) {
    const double dx = x_[j] + sx - x_[i], dy = y_[j] + sy - y_[i];
    const double gap = std::sqrt(dx * dx + dy * dy) - kDiameter;
    if (gap < -params_.max_overlap)
      throw InvalidArgument("configuration", std::string(what) + " particles " + std::to_string(i) + " and " +
                                                 std::to_string(j) + " overlap by " + number(-gap) +
                                                 " a, more than the overlap term can resolve (max_overlap " +
                                                 number(params_.max_overlap) + " a)");
  };
  for (const Bond& bond : bonds_) check_pair(bond.i, bond.j, bond.shift_x, bond.shift_y, "bonded");
  for (const Candidate& pair : candidates_) check_pair(pair.i, pair.j, pair.shift_x, pair.shift_y, "unbonded");
  compute_forces();
}

// ---------------------------------------------------------------------------------------
// Observables and state

double System::theta(std::size_t i) const { return std::atan2(orient_s_[i], orient_c_[i]); }

double System::kinetic_energy() const {
  double energy = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;
    energy += 0.5 * kMass * (vx_[i] * vx_[i] + vy_[i] * vy_[i]) + 0.5 * kInertia * omega_[i] * omega_[i];
  }
  return energy;
}

double System::max_speed() const {
  double speed_sq = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;
    speed_sq = std::max({speed_sq, vx_[i] * vx_[i] + vy_[i] * vy_[i], kRadius * kRadius * omega_[i] * omega_[i]});
  }
  return std::sqrt(speed_sq);
}

double System::mean_contact_number() const { return 2.0 * static_cast<double>(bonds_.size()) / static_cast<double>(size()); }

double System::packing_fraction() const {
  const double height = walls_active_ ? wall_top_ - wall_bottom_ : ly_;
  return kPi * kRadius * kRadius * static_cast<double>(size()) / (lx_ * height);
}

void System::set_velocity(std::int32_t i, double vx, double vy, double omega) {
  vx_[i] = vx;
  vy_[i] = vy;
  omega_[i] = omega;
  forces_valid_ = false;
}

void System::set_position(std::int32_t i, double x, double y) {
  x_[i] = x;
  y_[i] = y;
  rebuild_neighbours();
  forces_valid_ = false;
}

void System::set_orientation(std::int32_t i, double theta) {
  orient_c_[i] = std::cos(theta);
  orient_s_[i] = std::sin(theta);
  forces_valid_ = false;
}

namespace {
void wrap_into(std::vector<double>& coordinates, double length) {
  for (double& c : coordinates) c -= length * std::floor(c / length);
}
}  // namespace

void System::wrap_into_box() {
  if (periodic_x_) wrap_into(x_, lx_);
  if (periodic_y_) wrap_into(y_, ly_);
}

Configuration System::configuration() const {
  Configuration config;
  config.lx = lx_;
  config.ly = ly_;
  config.periodic_y = periodic_y_;
  config.x = x_;
  config.y = y_;
  if (periodic_x_) wrap_into(config.x, lx_);
  if (periodic_y_) wrap_into(config.y, ly_);
  config.theta.resize(size());
  for (std::size_t i = 0; i < size(); ++i) config.theta[i] = theta(i);
  config.vx = vx_;
  config.vy = vy_;
  config.omega = omega_;
  config.bonds.reserve(bonds_.size());
  for (const Bond& bond : bonds_)
    config.bonds.push_back(BondRecord{bond.i, bond.j, bond.bix, bond.biy, bond.bjx, bond.bjy});
  if (walls_active_) {
    config.wall = wall_;
    config.wall_bottom = wall_bottom_;
    config.wall_top = wall_top_;
  }
  return config;
}

}  // namespace gel
