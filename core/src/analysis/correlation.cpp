#include "gel/analysis/correlation.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <mutex>

#include "gel/errors.hpp"

namespace gel::analysis {
namespace {

// FFTW's planner is not thread-safe (only fftw_execute is); the service may analyse several
// configurations at once.
std::mutex& fftw_planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};

// Smallest n >= minimum whose prime factors are 2, 3, 5 and 7: FFTW is fastest on those.
int fft_friendly_size(int minimum) {
  for (int n = std::max(1, minimum);; ++n) {
    int m = n;
    for (int f : {2, 3, 5, 7})
      while (m % f == 0) m /= f;
    if (m == 1) return n;
  }
}

}  // namespace

double CorrelationMap::pairs(int dy) const {
  if (periodic_y) return static_cast<double>(nx) * ny;
  const int rows_left = ny - std::abs(dy);
  return rows_left > 0 ? static_cast<double>(nx) * rows_left : 0.0;
}

double CorrelationMap::at(int dx, int dy) const {
  const int col = ((dx % nx) + nx) % nx;
  if (periodic_y) dy = ((dy % ny) + ny) % ny;
  const double n = pairs(dy);
  if (n <= 0 || mean_density <= 0) return 0.0;
  const int row = ((dy % rows) + rows) % rows;
  return products[static_cast<std::size_t>(row) * nx + col] / n / (mean_density * mean_density);
}

CorrelationMap correlation_map(const DensityField& field) {
  if (field.nx <= 0 || field.ny <= 0) throw InvalidArgument("field", "empty density field");
  CorrelationMap map;
  map.nx = field.nx;
  map.ny = field.ny;
  map.hx = field.hx;
  map.hy = field.hy;
  map.periodic_y = field.periodic_y;
  map.mean_density = field.mean();
  // Between walls, zero rows below and above make the circular correlation a linear one: a
  // shift |dy| <= ny - 1 never wraps a row back into the region when rows >= 2 ny - 1.
  map.rows = field.periodic_y ? field.ny : fft_friendly_size(2 * field.ny - 1);
  const int nx = field.nx, rows = map.rows, half = nx / 2 + 1;
  const std::size_t real_size = static_cast<std::size_t>(rows) * nx;
  const std::size_t complex_size = static_cast<std::size_t>(rows) * half;

  std::unique_ptr<double, FftwFree> real(static_cast<double*>(fftw_malloc(sizeof(double) * real_size)));
  std::unique_ptr<fftw_complex, FftwFree> spectrum(
      static_cast<fftw_complex*>(fftw_malloc(sizeof(fftw_complex) * complex_size)));
  if (!real || !spectrum) throw std::bad_alloc();
  fftw_plan forward, backward;
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    // FFTW_ESTIMATE: planning by measurement would cost more than the one transform we do.
    forward = fftw_plan_dft_r2c_2d(rows, nx, real.get(), spectrum.get(), FFTW_ESTIMATE);
    backward = fftw_plan_dft_c2r_2d(rows, nx, spectrum.get(), real.get(), FFTW_ESTIMATE);
  }
  std::fill(real.get(), real.get() + real_size, 0.0);
  for (std::size_t i = 0; i < field.rho.size(); ++i) real.get()[i] = field.rho[i];
  fftw_execute(forward);
  // Wiener-Khinchin: the autocorrelation is the inverse transform of |F|^2.
  for (std::size_t i = 0; i < complex_size; ++i) {
    fftw_complex& z = spectrum.get()[i];
    z[0] = z[0] * z[0] + z[1] * z[1];
    z[1] = 0.0;
  }
  fftw_execute(backward);
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    fftw_destroy_plan(forward);
    fftw_destroy_plan(backward);
  }
  // FFTW's transforms are unnormalised: forward then backward multiplies by rows * nx. The
  // products are sums of 0/1 values, so rounding removes the transform's round-off.
  const double scale = 1.0 / static_cast<double>(real_size);
  map.products.resize(real_size);
  for (std::size_t i = 0; i < real_size; ++i) map.products[i] = std::round(real.get()[i] * scale);
  return map;
}

Correlation radial_average(const CorrelationMap& map, const CorrelationOptions& options) {
  const double pixel = std::max(map.hx, map.hy);
  const double bin = options.bin > 0 ? options.bin : pixel;
  const double height = map.ny * map.hy, width = map.nx * map.hx;
  const double r_max = options.r_max > 0 ? options.r_max : 0.5 * std::min(width, height);
  const int bins = static_cast<int>(std::floor(r_max / bin + 0.5)) + 1;
  std::vector<double> sum_products(bins, 0.0), sum_pairs(bins, 0.0), sum_r(bins, 0.0);

  const int dx_max = std::min(map.nx / 2, static_cast<int>(std::floor(r_max / map.hx)));
  const int dy_max = std::min(map.periodic_y ? map.ny / 2 : map.ny - 1, static_cast<int>(std::floor(r_max / map.hy)));
  for (int dy = -dy_max; dy <= dy_max; ++dy) {
    // A periodic field of even height has dy = +-ny/2 as one shift: count it once.
    if (map.periodic_y && map.ny % 2 == 0 && dy == -map.ny / 2) continue;
    const double n = map.pairs(dy);
    if (n <= 0) continue;
    const int row = ((dy % map.rows) + map.rows) % map.rows;
    const double* line = map.products.data() + static_cast<std::size_t>(row) * map.nx;
    for (int dx = -dx_max; dx <= dx_max; ++dx) {
      if (map.nx % 2 == 0 && dx == -map.nx / 2) continue;
      const double r = std::hypot(dx * map.hx, dy * map.hy);
      if (r > r_max) continue;
      const int k = static_cast<int>(std::floor(r / bin + 0.5));
      if (k >= bins) continue;
      sum_products[k] += line[((dx % map.nx) + map.nx) % map.nx];
      sum_pairs[k] += n;
      sum_r[k] += r * n;
    }
  }
  Correlation result;
  result.mean_density = map.mean_density;
  result.pixel = pixel;
  const double norm = map.mean_density * map.mean_density;
  for (int k = 0; k < bins; ++k) {
    if (sum_pairs[k] <= 0) continue;
    result.r.push_back(sum_r[k] / sum_pairs[k]);
    result.c.push_back(norm > 0 ? sum_products[k] / sum_pairs[k] / norm : 0.0);
    result.pairs.push_back(sum_pairs[k]);
  }
  return result;
}

Correlation density_correlation(const DensityField& field, const CorrelationOptions& options) {
  return radial_average(correlation_map(field), options);
}

namespace {

// Least-squares line through (x_i, y_i); returns false with fewer than 2 distinct x.
bool line_fit(const std::vector<double>& x, const std::vector<double>& y, double& slope, double& intercept,
              double& slope_stderr) {
  const std::size_t n = x.size();
  if (n < 2) return false;
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) mx += x[i], my += y[i];
  mx /= n, my /= n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n; ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  if (!(sxx > 0)) return false;
  slope = sxy / sxx;
  intercept = my - slope * mx;
  double rss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = y[i] - intercept - slope * x[i];
    rss += e * e;
  }
  slope_stderr = n > 2 ? std::sqrt(rss / static_cast<double>(n - 2) / sxx) : std::nan("");
  return true;
}

}  // namespace

DfProfile fractal_dimension_profile(const std::vector<double>& r, const std::vector<double>& c, double half_window,
                                    int dimension) {
  if (r.size() != c.size()) throw InvalidArgument("correlation", "r and C differ in length");
  if (!(half_window > 0)) throw InvalidArgument("half_window", "must be > 0");
  std::vector<double> log_r, log_c;
  for (std::size_t i = 0; i < r.size(); ++i)
    if (r[i] > 0 && c[i] > 0) log_r.push_back(std::log(r[i])), log_c.push_back(std::log(c[i]));
  DfProfile profile;
  std::vector<double> wx, wy;
  for (std::size_t i = 0; i < log_r.size(); ++i) {
    wx.clear(), wy.clear();
    for (std::size_t j = 0; j < log_r.size(); ++j)
      if (std::abs(log_r[j] - log_r[i]) <= half_window) wx.push_back(log_r[j]), wy.push_back(log_c[j]);
    double slope, intercept, stderr_slope;
    if (wx.size() < 3 || !line_fit(wx, wy, slope, intercept, stderr_slope)) continue;
    profile.r.push_back(std::exp(log_r[i]));
    profile.df.push_back(dimension + slope);
  }
  return profile;
}

DfFit fit_fractal_dimension(const std::vector<double>& r, const std::vector<double>& c, double rmin, double rmax,
                            int dimension) {
  if (!(rmin < rmax)) throw InvalidArgument("fit_range", "rmin must be below rmax");
  std::vector<double> x, y;
  for (std::size_t i = 0; i < r.size() && i < c.size(); ++i)
    if (r[i] >= rmin && r[i] <= rmax && r[i] > 0 && c[i] > 0) x.push_back(std::log(r[i])), y.push_back(std::log(c[i]));
  if (x.size() < 3) throw InvalidArgument("fit_range", "fewer than 3 correlation bins with C > 0 in the fit range");
  double slope, intercept, slope_stderr;
  if (!line_fit(x, y, slope, intercept, slope_stderr))
    throw InvalidArgument("fit_range", "the bins in the fit range have a single radius");
  DfFit fit;
  fit.df = dimension + slope;
  fit.stderr_ = slope_stderr;
  fit.rmin = rmin;
  fit.rmax = rmax;
  fit.points = static_cast<int>(x.size());
  return fit;
}

}  // namespace gel::analysis
