// Stage 1 of the gel generator: reaction-limited hierarchical cluster-cluster aggregation of
// one floc (see generator.hpp for the scheme and why it samples contacts uniformly).
//
// Layout: the floc's particles live in one set of arrays, and at level k the clusters are the
// consecutive index ranges [m 2^k, (m+1) 2^k), each centred on its own centre of mass. A join
// merges two neighbouring ranges in place, so no cluster is ever copied, and particles that
// are close in index are close in the hierarchy, hence in space (used to find overlaps early).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "generator_internal.hpp"

namespace gel::detail {
namespace {

constexpr double kContact = 2.0;  // 2a

// Uniform grid over the bounding box of a set of points, cell width >= 2a + tolerance, so
// every point within contact of a query lies in the 3 x 3 cells around it. Counting sort.
class FreeGrid {
 public:
  void build(const double* x, const double* y, std::size_t n, double cell) {
    cell_ = cell;
    min_x_ = *std::min_element(x, x + n);
    min_y_ = *std::min_element(y, y + n);
    const double max_x = *std::max_element(x, x + n);
    const double max_y = *std::max_element(y, y + n);
    nx_ = static_cast<int>((max_x - min_x_) / cell_) + 1;
    ny_ = static_cast<int>((max_y - min_y_) / cell_) + 1;
    start_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
    items_.resize(n);
    cell_of_.resize(n);
    for (std::size_t p = 0; p < n; ++p) {
      cell_of_[p] = index(cell_x(x[p]), cell_y(y[p]));
      ++start_[cell_of_[p] + 1];
    }
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    fill_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t p = 0; p < n; ++p) items_[fill_[cell_of_[p]]++] = static_cast<std::int32_t>(p);
  }

  // Calls f(p) for every stored point in the 3 x 3 cells around (px, py); stops and returns
  // true as soon as f returns true.
  template <class F>
  bool any_near(double px, double py, F&& f) const {
    const int cx = cell_x(px), cy = cell_y(py);
    if (cx < -1 || cy < -1 || cx > nx_ || cy > ny_) return false;
    for (int gy = std::max(cy - 1, 0); gy <= std::min(cy + 1, ny_ - 1); ++gy)
      for (int gx = std::max(cx - 1, 0); gx <= std::min(cx + 1, nx_ - 1); ++gx) {
        const std::size_t c = index(gx, gy);
        for (std::int32_t k = start_[c]; k < start_[c + 1]; ++k)
          if (f(items_[k])) return true;
      }
    return false;
  }

 private:
  // Far-away points give large magnitudes; clamp before converting so the cast is defined.
  int cell_x(double px) const { return static_cast<int>(std::floor(std::clamp((px - min_x_) / cell_, -2.0, nx_ + 1.0))); }
  int cell_y(double py) const { return static_cast<int>(std::floor(std::clamp((py - min_y_) / cell_, -2.0, ny_ + 1.0))); }
  std::size_t index(int gx, int gy) const { return static_cast<std::size_t>(gy) * nx_ + gx; }

  double cell_ = 1, min_x_ = 0, min_y_ = 0;
  int nx_ = 0, ny_ = 0;
  std::vector<std::int32_t> start_, fill_, items_;
  std::vector<std::size_t> cell_of_;
};

// Rotates particles [begin, end) about the origin by the unit vector (c, s), positions and
// orientations alike (a rigid rotation of the cluster).
void rotate(Floc& f, std::size_t begin, std::size_t end, double c, double s) {
  for (std::size_t p = begin; p < end; ++p) {
    const double x = f.x[p], y = f.y[p];
    f.x[p] = c * x - s * y;
    f.y[p] = s * x + c * y;
    const double oc = f.c[p], os = f.s[p];
    f.c[p] = c * oc - s * os;
    f.s[p] = s * oc + c * os;
  }
}

// Moves the centre of mass of [begin, end) to the origin; returns the radius of gyration.
double recentre(Floc& f, std::size_t begin, std::size_t end) {
  double sx = 0, sy = 0;
  for (std::size_t p = begin; p < end; ++p) {
    sx += f.x[p];
    sy += f.y[p];
  }
  const double n = static_cast<double>(end - begin);
  const double cx = sx / n, cy = sy / n;
  double r2 = 0;
  for (std::size_t p = begin; p < end; ++p) {
    f.x[p] -= cx;
    f.y[p] -= cy;
    r2 += f.x[p] * f.x[p] + f.y[p] * f.y[p];
  }
  return std::sqrt(r2 / n);
}

// Joins cluster A = [a0, a0 + s) and B = [a0 + s, a0 + 2 s); returns the new cluster's Rg.
double join(Floc& f, std::size_t a0, std::size_t s, double tolerance, Random& rng, FreeGrid& grid) {
  const std::size_t b0 = a0 + s;
  double c, sn;
  rng.direction(c, sn);
  rotate(f, a0, b0, c, sn);
  rng.direction(c, sn);
  rotate(f, b0, b0 + s, c, sn);
  grid.build(f.x.data() + a0, f.y.data() + a0, s, kContact + 2.0 * tolerance);
  const double overlap2 = (kContact - tolerance) * (kContact - tolerance);
  const double* ax = f.x.data() + a0;
  const double* ay = f.y.data() + a0;

  // Attempts until the contact is accepted. Acceptance is the fraction of (i, j, psi) that is
  // free of overlap, at least of order (perimeter / s^2), so the cap is never reached in
  // practice; it only turns a logic error into an exception instead of a hang.
  const std::int64_t max_trials = 1000000000;
  for (std::int64_t trial = 0; trial < max_trials; ++trial) {
    const std::size_t i = a0 + rng.below(s);
    const std::size_t j = b0 + rng.below(s);
    double ux, uy;
    rng.direction(ux, uy);
    const double ox = f.x[i] + kContact * ux - f.x[j];
    const double oy = f.y[i] + kContact * uy - f.y[j];
    auto overlaps = [&](std::size_t q) {
      const double px = f.x[q] + ox, py = f.y[q] + oy;
      return grid.any_near(px, py, [&](std::int32_t r) {
        const double dx = px - ax[r], dy = py - ay[r];
        return dx * dx + dy * dy < overlap2;
      });
    };
    // B's particles outward from j in index order: hierarchy neighbours of j first, which is
    // where an overlap, if any, most likely is.
    bool rejected = overlaps(j);
    for (std::size_t k = 1; !rejected && k < s; ++k) {
      if (j >= b0 + k && overlaps(j - k)) rejected = true;
      if (!rejected && j + k < b0 + s && overlaps(j + k)) rejected = true;
    }
    if (rejected) continue;
    for (std::size_t q = b0; q < b0 + s; ++q) {
      f.x[q] += ox;
      f.y[q] += oy;
    }
    return recentre(f, a0, b0 + s);
  }
  throw std::runtime_error("floc aggregation: no overlap-free contact found for clusters of size " +
                           std::to_string(s) + " (internal error)");
}

}  // namespace

Floc aggregate_floc(int n, std::uint64_t seed, double tolerance) {
  Random rng(seed);
  Floc f;
  const std::size_t count = static_cast<std::size_t>(n);
  f.x.assign(count, 0.0);
  f.y.assign(count, 0.0);
  f.c.assign(count, 1.0);
  f.s.assign(count, 0.0);
  FreeGrid grid;
  for (std::size_t s = 1; s < count; s *= 2) {
    double rg_sum = 0;
    for (std::size_t a0 = 0; a0 < count; a0 += 2 * s) rg_sum += join(f, a0, s, tolerance, rng, grid);
    f.size_rg.emplace_back(static_cast<double>(2 * s), rg_sum / static_cast<double>(count / (2 * s)));
  }
  // Rounding of the repeated rotations leaves |(c, s)| = 1 to a few ulps; renormalise.
  for (std::size_t p = 0; p < count; ++p) {
    const double norm = std::sqrt(f.c[p] * f.c[p] + f.s[p] * f.s[p]);
    f.c[p] /= norm;
    f.s[p] /= norm;
  }
  return f;
}

std::vector<std::pair<std::int32_t, std::int32_t>> touching_pairs_free(const std::vector<double>& x,
                                                                       const std::vector<double>& y,
                                                                       double tolerance) {
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  if (x.empty()) return pairs;
  FreeGrid grid;
  grid.build(x.data(), y.data(), x.size(), kContact + 2.0 * tolerance);
  const double touch2 = (kContact + tolerance) * (kContact + tolerance);
  for (std::size_t p = 0; p < x.size(); ++p)
    grid.any_near(x[p], y[p], [&](std::int32_t q) {
      if (static_cast<std::size_t>(q) > p) {
        const double dx = x[q] - x[p], dy = y[q] - y[p];
        if (dx * dx + dy * dy < touch2) pairs.emplace_back(static_cast<std::int32_t>(p), q);
      }
      return false;
    });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace gel::detail
