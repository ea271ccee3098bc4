// What the compression protocol measures on the engine (compression_observables.hpp).
#include "compression_observables.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "engine/bonded_group.hpp"
#include "gel/errors.hpp"
#include "gel/units.hpp"
#include "gel/virial_stress.hpp"

namespace gel {
namespace {

// Area of the unit disk below the line at height t from its centre (t clamped to [-1, 1]).
double disk_area_below(double t) {
  t = std::clamp(t / kRadius, -1.0, 1.0);
  return kRadius * kRadius * (std::acos(-t) + t * std::sqrt(1.0 - t * t));
}

}  // namespace

// The exact area of each disk inside each slice, over the slice area.
std::vector<double> phi_profile(const System& system, int slices) {
  const double bottom = system.wall_bottom(), top = system.wall_top();
  const double width = (top - bottom) / slices;
  std::vector<double> area(static_cast<std::size_t>(slices), 0.0);
  const auto& y = system.y();
  for (std::size_t i = 0; i < system.size(); ++i) {
    // Clamped as doubles before the cast: a float-to-int conversion out of range (or of a NaN)
    // is undefined behaviour, and a particle far outside the walls must not cause it.
    auto slice_of = [&](double yy) {
      const double index = std::floor((yy - bottom) / width);
      return static_cast<int>(std::clamp(std::isnan(index) ? 0.0 : index, 0.0, static_cast<double>(slices - 1)));
    };
    const int first = slice_of(y[i] - kRadius);
    const int last = slice_of(y[i] + kRadius);
    for (int s = first; s <= last; ++s) {
      const double lower = s == 0 ? -std::numeric_limits<double>::infinity() : bottom + s * width;
      const double upper = s == slices - 1 ? std::numeric_limits<double>::infinity() : bottom + (s + 1) * width;
      area[s] += disk_area_below(upper - y[i]) - disk_area_below(lower - y[i]);
    }
  }
  std::vector<double> phi(area.size());
  for (std::size_t s = 0; s < area.size(); ++s) phi[s] = area[s] / (system.lx() * width);
  return phi;
}

gel::v1::Stress stress_record(const System& system, int slices) {
  const VirialStress stress = virial_stress(system, slices);
  gel::v1::Stress record;
  record.set_xx(stress.total.xx);
  record.set_yy(stress.total.yy);
  record.set_xy(stress.total.shear());
  for (const StressTensor& slice : stress.slices) {
    record.add_xx_profile(slice.xx);
    record.add_yy_profile(slice.yy);
    record.add_xy_profile(slice.shear());
  }
  return record;
}

void require_finite_state(const char* what, double value) {
  if (!std::isfinite(value))
    throw StabilityError(std::string("compression: ") + what + " is not finite (" + std::to_string(value) + ")");
}

// --- Approach shortcut (MODEL.md: translate the group attached to one wall rigidly until the
// network first spans) ------------------------------------------------------------------------

std::vector<char> top_wall_group(const System& system) {
  return bonded_group(
      system.size(), system.bonds(), [&](std::size_t i) { return system.wall_side(i) == kTopWall; },
      [](std::size_t) { return false; });
}

bool group_touches_bottom_wall(const System& system, const std::vector<char>& group) {
  for (std::size_t i = 0; i < system.size(); ++i)
    if (group[i] && system.wall_side(i) == kBottomWall) return true;
  return false;
}

bool network_spans(const System& system) { return group_touches_bottom_wall(system, top_wall_group(system)); }

double distance_to_first_contact(const System& system, const std::vector<char>& group) {
  const auto& x = system.x();
  const auto& y = system.y();
  const double lx = system.lx();
  double distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < system.size(); ++i) {
    if (!group[i]) continue;
    distance = std::min(distance, y[i] - kRadius - system.wall_bottom());
    for (std::size_t j = 0; j < system.size(); ++j) {
      if (group[j] || y[j] > y[i]) continue;
      double dx = x[j] - x[i];
      dx -= lx * std::round(dx / lx);
      if (std::abs(dx) >= kDiameter) continue;
      distance = std::min(distance, y[i] - y[j] - std::sqrt(kDiameter * kDiameter - dx * dx));
    }
  }
  return std::max(distance, 0.0);
}

}  // namespace gel
