// The neighbour list: a cell list of the unbonded pairs within 2a + skin and of the free
// particles within a + skin of a wall, rebuilt when some particle may have moved skin/2.
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
// Neighbour search: a cell list builds the unbonded pairs within 2a + skin; they are the only
// candidates for new bonds until some particle may have moved skin/2.

// Positions are never wrapped back into the periodic box during a run (only the cell index
// and the configuration written out wrap them): a wrap at each rebuild would make the rounding of
// every later bond vector depend on when the rebuilds happen, i.e. on the skin.
void System::rebuild_neighbours() {
  const std::size_t n = size();
  for (Bond& bond : bonds_) {
    bond.shift_x = periodic_x_ ? -lx_ * std::round((x_[bond.j] - x_[bond.i]) / lx_) : 0.0;
    bond.shift_y = periodic_y_ ? -ly_ * std::round((y_[bond.j] - y_[bond.i]) / ly_) : 0.0;
  }
  bond_scratch_->bonds.valid = false;

  // Bonded partners, to leave bonded pairs out of the candidates.
  std::vector<std::int32_t> degree(n + 1, 0);
  for (const Bond& bond : bonds_) {
    ++degree[bond.i + 1];
    ++degree[bond.j + 1];
  }
  for (std::size_t i = 0; i < n; ++i) degree[i + 1] += degree[i];
  std::vector<std::int32_t> partners(degree[n]);
  {
    std::vector<std::int32_t> fill(degree.begin(), degree.end() - 1);
    for (const Bond& bond : bonds_) {
      partners[fill[bond.i]++] = bond.j;
      partners[fill[bond.j]++] = bond.i;
    }
  }
  auto bonded = [&](std::int32_t i, std::int32_t j) {
    for (std::int32_t k = degree[i]; k < degree[i + 1]; ++k)
      if (partners[k] == j) return true;
    return false;
  };

  const double cutoff = kDiameter + params_.skin;
  double x_min = 0, x_span = lx_, y_min = 0, y_span = ly_;
  if (!periodic_x_) {
    const auto [lo, hi] = std::minmax_element(x_.begin(), x_.end());
    x_min = *lo;
    x_span = *hi - *lo + 1e-9;
  }
  if (!periodic_y_) {
    const auto [lo, hi] = std::minmax_element(y_.begin(), y_.end());
    y_min = *lo;
    y_span = *hi - *lo + 1e-9;
  }
  const int cells_x = std::max(1, static_cast<int>(x_span / cutoff));
  const int cells_y = std::max(1, static_cast<int>(y_span / cutoff));
  const double cell_w = x_span / cells_x, cell_h = y_span / cells_y;
  auto cell_index = [&](std::size_t i) {
    const double xi = periodic_x_ ? x_[i] - lx_ * std::floor(x_[i] / lx_) : x_[i];
    const double yi = periodic_y_ ? y_[i] - ly_ * std::floor(y_[i] / ly_) : y_[i];
    int cx = static_cast<int>((xi - x_min) / cell_w);
    int cy = static_cast<int>((yi - y_min) / cell_h);
    cx = std::clamp(cx, 0, cells_x - 1);
    cy = std::clamp(cy, 0, cells_y - 1);
    return cy * cells_x + cx;
  };
  const int cell_count = cells_x * cells_y;
  std::vector<std::int32_t> cell_start(cell_count + 1, 0), cell_of(n), members(n);
  for (std::size_t i = 0; i < n; ++i) {
    cell_of[i] = cell_index(i);
    ++cell_start[cell_of[i] + 1];
  }
  for (int c = 0; c < cell_count; ++c) cell_start[c + 1] += cell_start[c];
  {
    std::vector<std::int32_t> fill(cell_start.begin(), cell_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) members[fill[cell_of[i]]++] = static_cast<std::int32_t>(i);
  }

  candidates_.clear();
  const double cutoff_sq = cutoff * cutoff;
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      // The distinct neighbour cells (a small periodic grid would otherwise repeat them).
      std::array<int, 9> neighbours{};
      int count = 0;
      for (int oy = -1; oy <= 1; ++oy) {
        int ny = cy + oy;
        if (ny < 0 || ny >= cells_y) {
          if (!periodic_y_) continue;
          ny = (ny + cells_y) % cells_y;
        }
        for (int ox = -1; ox <= 1; ++ox) {
          int nx = cx + ox;
          if (nx < 0 || nx >= cells_x) {
            if (!periodic_x_) continue;
            nx = (nx + cells_x) % cells_x;
          }
          const int c = ny * cells_x + nx;
          if (std::find(neighbours.begin(), neighbours.begin() + count, c) == neighbours.begin() + count)
            neighbours[count++] = c;
        }
      }
      const int home = cy * cells_x + cx;
      for (std::int32_t a = cell_start[home]; a < cell_start[home + 1]; ++a) {
        const std::int32_t i = members[a];
        for (int k = 0; k < count; ++k) {
          const int c = neighbours[k];
          for (std::int32_t b = cell_start[c]; b < cell_start[c + 1]; ++b) {
            const std::int32_t j = members[b];
            if (j <= i) continue;
            double dx = x_[j] - x_[i], dy = y_[j] - y_[i];
            const double sx = periodic_x_ ? -lx_ * std::round(dx / lx_) : 0.0;
            const double sy = periodic_y_ ? -ly_ * std::round(dy / ly_) : 0.0;
            dx += sx;
            dy += sy;
            if (dx * dx + dy * dy >= cutoff_sq) continue;
            if (bonded(i, j)) continue;
            candidates_.push_back(Candidate{i, j, sx, sy});
          }
        }
      }
    }
  }

  wall_candidates_.clear();
  if (walls_active_) {
    for (std::size_t i = 0; i < n; ++i) {
      if (wall_[i] != kNoWall) continue;
      if (y_[i] - kRadius < wall_bottom_ + params_.skin || y_[i] + kRadius > wall_top_ - params_.skin)
        wall_candidates_.push_back(static_cast<std::int32_t>(i));
    }
  }
  travel_ = 0;
  wall_travel_ = 0;
  ++rebuilds_;
}

void System::maybe_rebuild() {
  // Two particles approach each other by at most 2 travel_, a particle and a wall by
  // travel_ + wall_travel_: both stay below the skin while this sum is below skin/2.
  if (travel_ + wall_travel_ > 0.5 * params_.skin) rebuild_neighbours();
}

// After the particles moved (a step, a FIRE iteration, a rigid jump): the neighbour list rebuilt
// if some particle may have moved skin/2, the touching pairs bonded, the particles that reached a
// wall stuck to it.
void System::find_new_contacts() {
  maybe_rebuild();
  if (params_.effects & kBondCreation) detect_contacts();
  if (walls_active_) attach_to_walls();
}

}  // namespace gel
