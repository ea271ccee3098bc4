#pragma once
// Shared by the engine's source files (System's members are defined one concept per file):
// the bond loop's template mask, frame rotations, number formatting for error messages, and
// System::parallel, the one place that runs a task over the worker pool or inline; and the
// loop kernels and scratch types that System's members hold.
#include <cstddef>
#include <sstream>
#include <string>

#include "gel/effects.hpp"
#include "gel/system.hpp"
#include "bond_kernels.hpp"
#include "integrator_kernels.hpp"
#include "rotation.hpp"
#include "worker_pool.hpp"

namespace gel::engine {

// Bit of the bond-loop template mask that says the box is periodic, so bonds carry an image
// shift. Bits 0-4 are the bond effects of effects.hpp.
constexpr unsigned kShiftBit = 1u << 5;
constexpr unsigned kBondEffectBits = kNormalSpring | kOverlapRepulsion | kSliding | kRolling | kThresholds;
constexpr std::size_t kBondVariants = 64;

// Body-frame vector b rotated into the lab frame by R(theta) = [[c, -s], [s, c]].
inline void to_lab(double c, double s, double bx, double by, double& lx, double& ly) {
  lx = c * bx - s * by;
  ly = s * bx + c * by;
}

// Lab vector v into the body frame: R(-theta) v.
inline void to_body(double c, double s, double vx, double vy, double& bx, double& by) {
  bx = c * vx + s * vy;
  by = -s * vx + c * vy;
}

inline std::string number(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

}  // namespace gel::engine

namespace gel {

template <class Task>
void System::parallel(std::size_t tasks, Task&& task) {
  if (pool_)
    pool_->run(tasks, task);
  else
    for (std::size_t t = 0; t < tasks; ++t) task(t);
}

}  // namespace gel
