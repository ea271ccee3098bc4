#include "gel/analysis/fluctuation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gel/errors.hpp"

namespace gel::analysis {

DensityFluctuation density_fluctuation(const DensityField& field, const FluctuationOptions& options) {
  if (!(options.l_min > 0)) throw InvalidArgument("fluctuation.l_min", "must be > 0");
  if (!(options.factor > 1)) throw InvalidArgument("fluctuation.factor", "must be > 1");
  const int nx = field.nx, ny = field.ny;
  // Summed-area table: any box's solid count in O(1).
  std::vector<std::int64_t> sat(static_cast<std::size_t>(nx + 1) * (ny + 1), 0);
  for (int iy = 0; iy < ny; ++iy)
    for (int ix = 0; ix < nx; ++ix)
      sat[static_cast<std::size_t>(iy + 1) * (nx + 1) + ix + 1] = field.at(ix, iy) +
                                                                  sat[static_cast<std::size_t>(iy) * (nx + 1) + ix + 1] +
                                                                  sat[static_cast<std::size_t>(iy + 1) * (nx + 1) + ix] -
                                                                  sat[static_cast<std::size_t>(iy) * (nx + 1) + ix];
  auto count = [&](int x0, int y0, int x1, int y1) {
    return sat[static_cast<std::size_t>(y1) * (nx + 1) + x1] - sat[static_cast<std::size_t>(y0) * (nx + 1) + x1] -
           sat[static_cast<std::size_t>(y1) * (nx + 1) + x0] + sat[static_cast<std::size_t>(y0) * (nx + 1) + x0];
  };
  const double l_max = options.l_max > 0 ? options.l_max : 0.5 * std::min(nx * field.hx, ny * field.hy);
  DensityFluctuation result;
  int last_mx = 0, last_my = 0;
  for (double l = options.l_min; l <= l_max * (1 + 1e-12); l *= options.factor) {
    const int mx = std::max(1, static_cast<int>(std::lround(l / field.hx)));
    const int my = std::max(1, static_cast<int>(std::lround(l / field.hy)));
    if (mx == last_mx && my == last_my) continue;
    last_mx = mx, last_my = my;
    const int cols = nx / mx, rows = ny / my;
    if (cols * rows < 2) break;
    double sum = 0, sum2 = 0;
    const double area = static_cast<double>(mx) * my;
    for (int by = 0; by < rows; ++by)
      for (int bx = 0; bx < cols; ++bx) {
        const double density = count(bx * mx, by * my, (bx + 1) * mx, (by + 1) * my) / area;
        sum += density, sum2 += density * density;
      }
    const int boxes = cols * rows;
    const double mean = sum / boxes;
    const double variance = std::max(0.0, sum2 / boxes - mean * mean);
    if (!(mean > 0)) continue;
    result.l.push_back(std::sqrt(mx * field.hx * my * field.hy));
    result.ratio.push_back(std::sqrt(variance) / mean);
    result.boxes.push_back(boxes);
  }
  return result;
}

std::optional<double> correlation_length(const DensityFluctuation& f, double level) {
  if (f.l.empty() || !(f.ratio[0] >= level)) return std::nullopt;
  for (std::size_t k = 0; k + 1 < f.l.size(); ++k) {
    if (f.ratio[k] >= level && f.ratio[k + 1] < level) {
      if (!(f.ratio[k + 1] > 0)) return f.l[k + 1];
      const double x0 = std::log(f.l[k]), x1 = std::log(f.l[k + 1]);
      const double y0 = std::log(f.ratio[k]), y1 = std::log(f.ratio[k + 1]);
      const double t = (std::log(level) - y0) / (y1 - y0);
      return std::exp(x0 + t * (x1 - x0));
    }
  }
  return std::nullopt;
}

namespace {
// Area of the unit disk between heights -1 <= t0 <= t1 <= 1 measured from its centre:
// integral of 2 sqrt(1 - s^2) ds.
double disk_strip_area(double t0, double t1) {
  auto primitive = [](double t) {
    t = std::clamp(t, -1.0, 1.0);
    return t * std::sqrt(1 - t * t) + std::asin(t);
  };
  return t1 > t0 ? primitive(t1) - primitive(t0) : 0.0;
}
}  // namespace

PackingProfile packing_profile(const Configuration& config, int slices) {
  if (slices < 1) throw InvalidArgument("profile_slices", "must be >= 1");
  const double height = config.height();
  if (!(config.lx > 0 && height > 0)) throw InvalidArgument("configuration", "box has no positive size");
  const double bottom = config.has_walls() ? config.wall_bottom : 0.0;
  const bool periodic = config.periodic_y && !config.has_walls();
  PackingProfile profile;
  profile.slice = height / slices;
  std::vector<double> area(slices, 0.0);
  for (std::size_t p = 0; p < config.size(); ++p) {
    const double yc = config.y[p] - bottom;
    for (int image = periodic ? -1 : 0; image <= (periodic ? 1 : 0); ++image) {
      const double y = yc + image * height;
      const int lo = std::max(0, static_cast<int>(std::floor((y - 1) / profile.slice)));
      const int hi = std::min(slices - 1, static_cast<int>(std::floor((y + 1) / profile.slice)));
      for (int s = lo; s <= hi; ++s) area[s] += disk_strip_area(s * profile.slice - y, (s + 1) * profile.slice - y);
    }
  }
  for (int s = 0; s < slices; ++s) {
    profile.y.push_back(bottom + (s + 0.5) * profile.slice);
    profile.phi.push_back(area[s] / (config.lx * profile.slice));
  }
  return profile;
}

}  // namespace gel::analysis
