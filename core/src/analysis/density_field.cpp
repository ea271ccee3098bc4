#include "gel/analysis/density_field.hpp"

#include <cmath>
#include <numeric>

#include "gel/errors.hpp"

namespace gel::analysis {

double DensityField::mean() const {
  if (rho.empty()) return 0.0;
  const std::size_t solid = std::accumulate(rho.begin(), rho.end(), std::size_t{0});
  return static_cast<double>(solid) / static_cast<double>(rho.size());
}

DensityField pixelise(const Configuration& config, double pixel) {
  if (!(std::isfinite(pixel) && pixel > 0)) throw InvalidArgument("pixel", "pixel size must be > 0");
  const double height = config.height();
  if (!(config.lx > 0 && height > 0)) throw InvalidArgument("configuration", "box has no positive size");
  DensityField field;
  field.nx = std::max(1, static_cast<int>(std::lround(config.lx / pixel)));
  field.ny = std::max(1, static_cast<int>(std::lround(height / pixel)));
  if (static_cast<double>(field.nx) * field.ny > static_cast<double>(1 << 28))
    throw InvalidArgument("pixel", "pixel size too small for this box (more than 2^28 pixels)");
  field.hx = config.lx / field.nx;
  field.hy = height / field.ny;
  field.y0 = config.has_walls() ? config.wall_bottom : 0.0;
  field.periodic_y = config.periodic_y && !config.has_walls();
  field.rho.assign(static_cast<std::size_t>(field.nx) * field.ny, 0);

  // Pixel (ix, iy) is solid when its centre lies inside a disk. Columns are taken modulo nx, so
  // a disk that crosses the periodic x boundary is drawn on both sides; rows likewise when y
  // is periodic, and clipped at the walls (or the open box) otherwise.
  constexpr double kRadius = 1.0;
  for (std::size_t p = 0; p < config.size(); ++p) {
    const double px = config.x[p], py = config.y[p] - field.y0;
    const int iy_lo = static_cast<int>(std::floor((py - kRadius) / field.hy - 0.5));
    const int iy_hi = static_cast<int>(std::ceil((py + kRadius) / field.hy - 0.5));
    const int ix_lo = static_cast<int>(std::floor((px - kRadius) / field.hx - 0.5));
    const int ix_hi = static_cast<int>(std::ceil((px + kRadius) / field.hx - 0.5));
    for (int iy = iy_lo; iy <= iy_hi; ++iy) {
      int row = iy;
      if (field.periodic_y) {
        row = ((iy % field.ny) + field.ny) % field.ny;
      } else if (iy < 0 || iy >= field.ny) {
        continue;
      }
      const double dy = (iy + 0.5) * field.hy - py;
      if (dy * dy > kRadius * kRadius) continue;
      unsigned char* line = field.rho.data() + static_cast<std::size_t>(row) * field.nx;
      for (int ix = ix_lo; ix <= ix_hi; ++ix) {
        const double dx = (ix + 0.5) * field.hx - px;
        if (dx * dx + dy * dy > kRadius * kRadius) continue;
        line[((ix % field.nx) + field.nx) % field.nx] = 1;
      }
    }
  }
  return field;
}

}  // namespace gel::analysis
