#pragma once
// The pixelised solid phase of a configuration (MODEL.md "Structure analysis"): rho = 1 on pixels
// whose centre lies inside a particle (radius a = 1), 0 elsewhere. It is the common input of the
// density correlation C(r) and of the box-density fluctuations.
//
// Region: x in [0, L_x) (periodic); y between the walls [wall_bottom, wall_top] when the
// configuration has walls, else [0, L_y) (periodic when periodic_y, an open box otherwise).
// Pixels: nx = max(1, round(L_x / pixel)) columns of width L_x / nx, so the grid tiles the periodic
// length exactly; along a periodic y likewise; between walls ny = max(1, round(H / pixel)).
// Particle images across the periodic boundaries are drawn.
#include <cstddef>
#include <vector>

#include "gel/configuration.hpp"

namespace gel::analysis {

inline constexpr double kDefaultPixel = 0.25;  // [a]: 8 pixels per diameter

struct DensityField {
  int nx = 0, ny = 0;
  double hx = 0, hy = 0;       // pixel width and height [a]
  double y0 = 0;               // y of the lower edge of row 0
  bool periodic_y = false;
  std::vector<unsigned char> rho;  // row-major: rho[iy * nx + ix]
  double mean() const;         // <rho>: fraction of solid pixels
  unsigned char at(int ix, int iy) const { return rho[static_cast<std::size_t>(iy) * nx + ix]; }
};

// Throws InvalidArgument ("pixel") unless pixel > 0 and the grid stays below 2^28 pixels, and
// ("configuration") when the box has no positive size.
DensityField pixelise(const Configuration& config, double pixel = kDefaultPixel);

}  // namespace gel::analysis
