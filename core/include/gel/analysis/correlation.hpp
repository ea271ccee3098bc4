#pragma once
// Density correlation C(r), fractal-dimension profile D_f(r) and the slope fit of ln C against
// ln r (MODEL.md "Structure analysis").
//
// C(d) = <rho(p) rho(p + d)> / <rho>^2 on the pixel field (density_field.hpp). The sum over p is
// an autocorrelation computed with FFTW (r2c / c2r, |F|^2): periodic along x; along y periodic
// when the field is, otherwise the field is zero-padded to at least 2 ny rows so that no pair
// wraps, and the sum for a vertical shift dy is divided by the number of pixel pairs that fit
// inside the region, nx (ny - |dy|): every pair inside the walls is counted exactly once, so the
// estimator has no bias from the finite height (the zero padding stands for "unknown", not for
// empty space). C = 1 means no correlation; C(0) = 1/<rho>.
//
// Radial average: bins of width `bin` (default: the pixel size) centred on r_k = k * bin; a
// shift d joins the bin of |d| and the bin's value pools the pairs, C_k = sum A(d) / sum n(d) /
// <rho>^2, and r_k reported is the pair-weighted mean |d| of the bin. Shifts up to r_max:
// half the periodic length in x, half the height (periodic or between walls) in y, whichever is
// smaller (default), so every direction contributes to every bin.
#include <optional>
#include <vector>

#include "gel/analysis/density_field.hpp"

namespace gel::analysis {

// The full two-dimensional correlation C(dx, dy) on the pixel lattice, before the radial
// average: what the radial C(r) is made of, and what a lattice test can check shift by shift.
struct CorrelationMap {
  int nx = 0, ny = 0;          // field size; shifts dx in (-nx, nx) wrap, |dy| < ny
  int rows = 0;                // rows of the (zero-padded) transform
  double hx = 0, hy = 0;
  bool periodic_y = false;
  double mean_density = 0;
  std::vector<double> products;  // sum_p rho(p) rho(p + d), [row * nx + col], d wrapped
  // Pixel pairs (p, p + d) inside the region for a vertical shift dy.
  double pairs(int dy) const;
  // C(d) for a shift of (dx, dy) pixels; dx any integer (periodic), |dy| < ny, or any dy
  // when periodic in y.
  double at(int dx, int dy) const;
};

CorrelationMap correlation_map(const DensityField& field);

struct Correlation {
  std::vector<double> r;      // [a]
  std::vector<double> c;      // C(r), dimensionless
  std::vector<double> pairs;  // pixel pairs pooled in the bin
  double mean_density = 0;    // <rho> of the field
  double pixel = 0;
};

struct CorrelationOptions {
  double bin = 0;      // radial bin width [a]; 0 = pixel size (max of hx, hy)
  double r_max = 0;    // 0 = min(L_x, H) / 2
};

Correlation density_correlation(const DensityField& field, const CorrelationOptions& options = {});
Correlation radial_average(const CorrelationMap& map, const CorrelationOptions& options = {});

// D_f(r) = d + d ln C / d ln r with d = 2: at each bin with r > 0 and C > 0, the slope of a
// least-squares line through the points (ln r, ln C) with |ln r' - ln r| <= half_window (at
// least 3 points; fewer: no value). Default half window 0.1 in ln r, i.e. a window of r e^{-0.1}
// .. r e^{0.1} (about +-10%), which at the default pixel holds >= 3 bins from r ~ 2.5 a up
// (bin / r <= 0.1): narrow enough to keep the floc and network scales apart.
inline constexpr double kDefaultDfHalfWindow = 0.1;
struct DfProfile {
  std::vector<double> r;
  std::vector<double> df;
};
DfProfile fractal_dimension_profile(const std::vector<double>& r, const std::vector<double>& c,
                                    double half_window = kDefaultDfHalfWindow, int dimension = 2);

// Least-squares line ln C = s ln r + b over the bins with rmin <= r <= rmax and C > 0:
// D_f = d + s and its standard error from the residual scatter, s_e = sqrt(RSS/(n-2) / Sxx).
// The bins are not independent (neighbouring shifts share pixels), so stderr measures how
// well a power law describes C over the range, not the seed-to-seed scatter (use an ensemble).
// Default range 2a..10a: beyond one particle diameter (inside it C follows the single-disk
// overlap) and below the floc size of the paper gels (64-particle flocs, R_g of order 10a).
inline constexpr double kDefaultFitRmin = 2.0;
inline constexpr double kDefaultFitRmax = 10.0;
struct DfFit {
  double df = 0;
  double stderr_ = 0;
  double rmin = 0, rmax = 0;
  int points = 0;
};
// Throws InvalidArgument ("fit_range") with fewer than 3 usable bins or rmin >= rmax.
DfFit fit_fractal_dimension(const std::vector<double>& r, const std::vector<double>& c,
                            double rmin = kDefaultFitRmin, double rmax = kDefaultFitRmax,
                            int dimension = 2);

}  // namespace gel::analysis
