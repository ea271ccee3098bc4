// External forces on single particles (three-point bending), with their work in the ledger.
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

void System::apply_external_forces() {
  double power = 0;
  for (const ExternalForce& load : external_) {
    fx_[load.i] += load.fx;
    fy_[load.i] += load.fy;
    power += load.fx * vx_[load.i] + load.fy * vy_[load.i];
  }
  external_power_ = power;
}

void System::set_external_force(std::int32_t i, double fx, double fy) {
  if (i < 0 || static_cast<std::size_t>(i) >= size()) throw InvalidArgument("particle", "no such particle");
  require_finite("force.x", fx);
  require_finite("force.y", fy);
  for (ExternalForce& load : external_)
    if (load.i == i) {
      load.fx = fx;
      load.fy = fy;
      forces_valid_ = false;
      return;
    }
  external_.push_back(ExternalForce{i, fx, fy});
  forces_valid_ = false;
}

void System::clear_external_forces() {
  external_.clear();
  external_power_ = 0;
  forces_valid_ = false;
}

}  // namespace gel
