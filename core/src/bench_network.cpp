#include "gel/bench_network.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>
#include <vector>

#include "gel/errors.hpp"
#include "gel/units.hpp"

namespace gel {

Configuration random_network(int particles, std::uint64_t seed, double phi) {
  if (particles < 2) throw InvalidArgument("particles", "need at least 2 particles");
  if (!(phi > 0 && phi < 0.5)) throw InvalidArgument("phi", "must be in (0, 0.5)");
  Configuration config;
  const double area = kPi * kRadius * kRadius * particles / phi;
  config.lx = std::sqrt(area * 3.0 / 5.0);
  config.ly = area / config.lx;
  config.periodic_y = true;

  std::mt19937_64 rng(seed);
  auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };

  // Occupancy grid of cell size 2a for the overlap test.
  const int cells_x = static_cast<int>(config.lx / kDiameter), cells_y = static_cast<int>(config.ly / kDiameter);
  std::unordered_map<std::int64_t, std::vector<std::int32_t>> grid;
  auto key = [&](int cx, int cy) {
    cx = (cx % cells_x + cells_x) % cells_x;
    cy = (cy % cells_y + cells_y) % cells_y;
    return static_cast<std::int64_t>(cy) * cells_x + cx;
  };
  auto cell_of = [&](double px, double py, int& cx, int& cy) {
    cx = static_cast<int>(std::floor(px / config.lx * cells_x));
    cy = static_cast<int>(std::floor(py / config.ly * cells_y));
  };
  auto free_at = [&](double px, double py) {
    int cx, cy;
    cell_of(px, py, cx, cy);
    for (int oy = -1; oy <= 1; ++oy)
      for (int ox = -1; ox <= 1; ++ox) {
        auto it = grid.find(key(cx + ox, cy + oy));
        if (it == grid.end()) continue;
        for (std::int32_t j : it->second) {
          double dx = config.x[j] - px, dy = config.y[j] - py;
          dx -= config.lx * std::round(dx / config.lx);
          dy -= config.ly * std::round(dy / config.ly);
          if (dx * dx + dy * dy < kDiameter * kDiameter * (1.0 - 1e-9)) return false;
        }
      }
    return true;
  };
  auto place = [&](double px, double py) {
    px -= config.lx * std::floor(px / config.lx);
    py -= config.ly * std::floor(py / config.ly);
    const std::int32_t index = config.add_particle(px, py, 2.0 * kPi * uniform());
    int cx, cy;
    cell_of(px, py, cx, cy);
    grid[key(cx, cy)].push_back(index);
    return index;
  };

  place(config.lx * uniform(), config.ly * uniform());
  // Parents come from the last few particles; when the tip is boxed in, the window widens.
  const int recent = 6;
  int failures = 0, consecutive_failures = 0;
  while (static_cast<int>(config.size()) < particles) {
    const int count = static_cast<int>(config.size());
    const int window = std::min(count, recent * (1 + consecutive_failures / 8));
    const std::int32_t parent = count - 1 - static_cast<std::int32_t>(uniform() * window);
    const double angle = 2.0 * kPi * uniform();
    const double px = config.x[parent] + kDiameter * std::cos(angle);
    const double py = config.y[parent] + kDiameter * std::sin(angle);
    double wx = px - config.lx * std::floor(px / config.lx), wy = py - config.ly * std::floor(py / config.ly);
    if (!free_at(wx, wy)) {
      if (++failures > 1000 * particles) throw std::runtime_error("random_network: cannot place particles");
      ++consecutive_failures;
      continue;
    }
    consecutive_failures = 0;
    const std::int32_t child = place(px, py);
    config.add_bond_at_contact(parent, child);
  }
  return config;
}

}  // namespace gel
