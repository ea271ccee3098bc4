// The virial stress tensor (gel/virial_stress.hpp): the evaluator of one bond's virial and the
// loop that sums it over the box and shares it among the slices.
#include "gel/virial_stress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "gel/bond_evaluator.hpp"
#include "gel/units.hpp"

namespace gel {
namespace {

void add(StressTensor& to, const StressTensor& c, double weight) {
  to.xx += weight * c.xx;
  to.xy += weight * c.xy;
  to.yx += weight * c.yx;
  to.yy += weight * c.yy;
}

// Slices of [bottom, bottom + height), periodic or bounded by walls.
struct Slabs {
  double bottom, height, width;
  int count;
  bool periodic;
  std::vector<StressTensor>& sums;

  int index(double slab) const {
    // Clamped as doubles before the cast: a float-to-int conversion out of range is undefined.
    if (periodic) {
      const double wrapped = slab - count * std::floor(slab / count);
      return static_cast<int>(std::clamp(wrapped, 0.0, count - 1.0));
    }
    return static_cast<int>(std::clamp(slab, 0.0, count - 1.0));
  }

  // Shares c among the slices by the length of the segment from ya to yb inside each one.
  void deposit(double ya, double yb, const StressTensor& c) {
    if (count <= 0) return;
    if (ya > yb) std::swap(ya, yb);
    if (periodic) {
      const double shift = height * std::floor((ya - bottom) / height);
      ya -= shift, yb -= shift;
    } else {
      // A particle pressed a little past a wall: its piece beyond it goes to the end slice.
      ya = std::clamp(ya, bottom, bottom + height);
      yb = std::clamp(yb, bottom, bottom + height);
    }
    const double length = yb - ya;
    const double first = std::floor((ya - bottom) / width), last = std::floor((yb - bottom) / width);
    if (!(length > 0.0) || first == last) {
      add(sums[static_cast<std::size_t>(index(first))], c, 1.0);
      return;
    }
    // A bond spans a few slices at most: its length is about 2a.
    for (double s = first; s <= last; s += 1.0) {
      const double piece = std::min(yb, bottom + (s + 1) * width) - std::max(ya, bottom + s * width);
      if (piece > 0.0) add(sums[static_cast<std::size_t>(index(s))], c, piece / length);
    }
  }
};

// The evaluator: r_ij (x) F_ij of one bond, r_ij = (2a + delta) n.
StressTensor bond_virial(const BondGeometry& g, const BondLoads& f) {
  const double r = kDiameter + g.delta;
  const double rx = r * g.nx, ry = r * g.ny;
  return {rx * f.force_x, rx * f.force_y, ry * f.force_x, ry * f.force_y};
}

}  // namespace

VirialStress virial_stress(const System& system, int slices) {
  const bool walls = system.has_walls();
  const double bottom = walls ? system.wall_bottom() : 0.0;
  const double height = walls ? system.wall_top() - system.wall_bottom() : system.ly();
  VirialStress result;
  result.slices.assign(static_cast<std::size_t>(std::max(slices, 0)), StressTensor{});
  Slabs slabs{bottom, height, height / std::max(slices, 1), slices, !walls, result.slices};

  StressTensor sum;
  const auto& y = system.y();
  const BondLaw& law = system.params().bond;
  const unsigned effects = system.params().effects;
  const std::vector<Bond>& bonds = system.bonds();
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    const BondGeometry g = system.bond_geometry(b);
    const BondLoads f = bond_loads(evaluate_bond(g, law, effects), g);
    const StressTensor c = bond_virial(g, f);
    add(sum, c, 1.0);
    const double yi = y[static_cast<std::size_t>(bonds[b].i)];
    slabs.deposit(yi, yi + (kDiameter + g.delta) * g.ny, c);
    // The walls hold their particles against the bond's force on them: a link from the particle
    // to the wall's plane that carries that force.
    for (const auto& [p, sign] : {std::pair{bonds[b].i, 1.0}, std::pair{bonds[b].j, -1.0}}) {
      const std::int8_t side = system.wall_side(static_cast<std::size_t>(p));
      if (side == kNoWall) continue;
      const double yp = y[static_cast<std::size_t>(p)];
      const double wall = side == kTopWall ? system.wall_top() : system.wall_bottom();
      const double dy = yp - wall;
      const StressTensor link{0.0, 0.0, dy * sign * f.force_x, dy * sign * f.force_y};
      add(sum, link, 1.0);
      slabs.deposit(yp, wall, link);
    }
  }
  const double volume = kThickness * system.lx() * height;
  add(result.total, sum, 1.0 / volume);
  const double slice_volume = volume / std::max(slices, 1);
  for (StressTensor& slice : result.slices) {
    const StressTensor raw = slice;
    slice = StressTensor{};
    add(slice, raw, 1.0 / slice_volume);
  }
  return result;
}

}  // namespace gel
