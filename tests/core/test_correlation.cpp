// The two-point density correlation C(r) and the fractal dimension D_f from it (docs/analysis.md),
// each against a result known in closed form: the lens area of two disks, a pixel-exact lattice,
// the two-point function of a Boolean model of disks, uncorrelated pixels, a power law.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "gel/analysis/correlation.hpp"
#include "gel/analysis/density_field.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/units.hpp"
#include "analysis_samples.hpp"

namespace gel::analysis {
namespace {

// Overlap area of two unit disks whose centres are d apart.
double lens_area(double d) {
  if (d >= 2) return 0.0;
  return 2 * std::acos(d / 2) - 0.5 * d * std::sqrt(4 - d * d);
}

// Value of C in the bin nearest to r.
double c_at(const Correlation& corr, double r) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < corr.r.size(); ++i)
    if (std::abs(corr.r[i] - r) < std::abs(corr.r[best] - r)) best = i;
  return corr.c[best];
}

TEST(Correlation, SingleDiskIsTheLensArea) {
  // <rho(p) rho(p + d)> = lens(|d|) / A for one disk, so C(r) <rho>^2 A = lens(r).
  Configuration c = periodic_box(24, 24);
  c.add_particle(11.3, 12.6);  // off the pixel grid on purpose
  const DensityField field = pixelise(c, 0.125);
  EXPECT_NEAR(field.mean() * 24 * 24, kPi, 0.02);  // pixelised area of the disk
  const Correlation corr = density_correlation(field);
  const double scale = field.mean() * field.mean() * 24 * 24;
  EXPECT_NEAR(corr.c[0] * field.mean(), 1.0, 1e-12);  // C(0) = 1 / <rho>
  for (std::size_t i = 0; i < corr.r.size(); ++i) {
    SCOPED_TRACE(corr.r[i]);
    EXPECT_NEAR(corr.c[i] * scale, lens_area(corr.r[i]), 0.03);
  }
}

TEST(Correlation, PixelExactLatticeRepeatsAtLatticeVectors) {
  // Square lattice of spacing 4 a = 16 pixels: the field is exactly periodic on the lattice, so
  // C(R) = C(0) = 1/<rho> at every lattice vector, and C = 0 where no disk meets a shifted one.
  Configuration c = periodic_box(40, 40);
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) c.add_particle(2 + 4 * i, 2 + 4 * j);
  const DensityField field = pixelise(c, 0.25);
  const CorrelationMap map = correlation_map(field);
  const double c0 = map.at(0, 0);
  EXPECT_DOUBLE_EQ(c0, 1.0 / field.mean());
  EXPECT_DOUBLE_EQ(map.at(16, 0), c0);
  EXPECT_DOUBLE_EQ(map.at(0, 16), c0);
  EXPECT_DOUBLE_EQ(map.at(-16, 32), c0);
  EXPECT_DOUBLE_EQ(map.at(8, 8), 0.0);  // shift (2a, 2a): nearest centres 2.83 a apart
  // Sum over all shifts of the products is (sum rho)^2: the mean of C over shifts is 1.
  double sum = 0;
  for (double v : map.products) sum += v;
  const double solid = field.mean() * field.nx * field.ny;
  EXPECT_NEAR(sum, solid * solid, 1e-6 * solid * solid);
  // Radial average at the nearest-neighbour distance: the bin at r = 4 a holds the four lattice
  // shifts and a ring of others, so it lies strictly between 0 and C(0).
  const Correlation corr = radial_average(map);
  EXPECT_GT(c_at(corr, 4.0), 1.0);
  EXPECT_LT(c_at(corr, 4.0), c0);
}

TEST(Correlation, BooleanModelOfDisksMatchesItsTwoPointFunction) {
  // Disks at Poisson positions, overlaps allowed (a uniform ideal gas): a point is empty with
  // probability q = exp(-lambda pi), two points d apart are both empty with probability
  // exp(-lambda (2 pi - lens(d))), hence
  //   C(d) = (1 - 2 q + q^2 exp(lambda lens(d))) / (1 - q)^2, and C = 1 beyond 2a.
  const double L = 160, p = 0.25;
  const double lambda = -std::log(1 - p) / kPi;
  Configuration c = periodic_box(L, L);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, L);
  const int n = static_cast<int>(std::lround(lambda * L * L));
  for (int i = 0; i < n; ++i) c.add_particle(u(rng), u(rng));
  const Correlation corr = density_correlation(pixelise(c, 0.25));
  const double q = std::exp(-lambda * kPi);
  for (std::size_t i = 1; i < corr.r.size() && corr.r[i] < 8; ++i) {
    const double d = corr.r[i];
    const double expected = (1 - 2 * q + q * q * std::exp(lambda * lens_area(d))) / ((1 - q) * (1 - q));
    SCOPED_TRACE(d);
    EXPECT_NEAR(corr.c[i], expected, 0.05 * expected);
  }
}

DensityField random_pixels(int nx, int ny, double fill, bool periodic_y, std::uint64_t seed) {
  DensityField f;
  f.nx = nx, f.ny = ny, f.hx = f.hy = 0.25, f.periodic_y = periodic_y;
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution solid(fill);
  for (int i = 0; i < nx * ny; ++i) f.rho.push_back(solid(rng) ? 1 : 0);
  return f;
}

TEST(Correlation, UncorrelatedPixelsGiveOneAlsoBetweenWalls) {
  // Between walls the pairs per vertical shift shrink as ny - |dy|; dividing by that count
  // leaves no bias, so C stays 1 out to the largest shift (a bias would show up as a trend).
  for (bool periodic : {true, false}) {
    SCOPED_TRACE(periodic ? "periodic" : "walls");
    const DensityField f = random_pixels(400, 300, 0.3, periodic, 11);
    const Correlation corr = density_correlation(f);
    EXPECT_NEAR(corr.c[0], 1 / f.mean(), 1e-12);
    for (std::size_t i = 1; i < corr.r.size(); ++i) EXPECT_NEAR(corr.c[i], 1.0, 0.03) << corr.r[i];
    // A structureless field is space-filling: D_f = 2.
    const DfProfile df = fractal_dimension_profile(corr.r, corr.c);
    for (std::size_t i = 0; i < df.r.size(); ++i) {
      if (df.r[i] > 5) {
        EXPECT_NEAR(df.df[i], 2.0, 0.1) << df.r[i];
      }
    }
  }
}

TEST(Correlation, PixelSizeChangesCOnlyBelowAParticleDiameter) {
  // The default pixel (a/4) against one twice as fine on the same gel: beyond r = 2a the radial
  // C(r) agrees within 3 %, and so does the fitted D_f within 0.03.
  const Configuration gel = quick_gel(3);
  const Correlation coarse = density_correlation(pixelise(gel, kDefaultPixel));
  const Correlation fine = density_correlation(pixelise(gel, kDefaultPixel / 2), {kDefaultPixel, 0});
  ASSERT_EQ(coarse.r.size(), fine.r.size());
  for (std::size_t i = 0; i < coarse.r.size(); ++i) {
    if (coarse.r[i] >= 2 && coarse.r[i] <= 20) {
      EXPECT_NEAR(fine.c[i] / coarse.c[i], 1.0, 0.03) << coarse.r[i];
    }
  }
  const DfFit a = fit_fractal_dimension(coarse.r, coarse.c);
  const DfFit b = fit_fractal_dimension(fine.r, fine.c);
  EXPECT_NEAR(a.df, b.df, 0.03);
  EXPECT_GT(a.df, 1.3);
  EXPECT_LT(a.df, 1.9);
}

TEST(FractalDimension, PowerLawCorrelationReturnsItsExponent) {
  std::vector<double> r, c;
  for (double x = 1; x < 60; x += 0.25) r.push_back(x), c.push_back(3.0 * std::pow(x, -(2 - 1.6)));
  const DfProfile df = fractal_dimension_profile(r, c);
  ASSERT_GT(df.r.size(), 100u);
  for (double v : df.df) EXPECT_NEAR(v, 1.6, 1e-10);
  const DfFit fit = fit_fractal_dimension(r, c, 2, 10);
  EXPECT_NEAR(fit.df, 1.6, 1e-12);
  EXPECT_LT(fit.stderr_, 1e-10);
  EXPECT_EQ(fit.points, 33);
  EXPECT_THROW(fit_fractal_dimension(r, c, 10, 2), InvalidArgument);
  EXPECT_THROW(fit_fractal_dimension(r, c, 100, 200), InvalidArgument);
}

}  // namespace
}  // namespace gel::analysis
