// Structure analyses, fits, regimes and ensembles (docs/analysis.md), each checked
// against a result known in closed form: the lens area of two disks, a pixel-exact lattice, the
// two-point function of a Boolean model of disks, uncorrelated pixels, synthetic power laws,
// planted regime boundaries.
#include <cairo.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "gel/analysis/correlation.hpp"
#include "gel/analysis/curve_analysis.hpp"
#include "gel/analysis/density_field.hpp"
#include "gel/analysis/fits.hpp"
#include "gel/analysis/fluctuation.hpp"
#include "gel/analysis/pictures.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/structure.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"

#if defined(__SANITIZE_ADDRESS__)
// cairo's text drawing (snapshot titles) loads fontconfig, which keeps its font caches until the
// process ends by design; LeakSanitizer reports them. They are not ours: suppress them by
// library, nothing else.
extern "C" const char* __lsan_default_suppressions() { return "leak:libfontconfig.so\n"; }
#endif

namespace gel::analysis {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Overlap area of two unit disks whose centres are d apart.
double lens_area(double d) {
  if (d >= 2) return 0.0;
  return 2 * std::acos(d / 2) - 0.5 * d * std::sqrt(4 - d * d);
}

Configuration periodic_box(double lx, double ly) {
  Configuration c;
  c.lx = lx;
  c.ly = ly;
  c.periodic_y = true;
  return c;
}

// Value of C in the bin nearest to r.
double c_at(const Correlation& corr, double r) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < corr.r.size(); ++i)
    if (std::abs(corr.r[i] - r) < std::abs(corr.r[best] - r)) best = i;
  return corr.c[best];
}

Configuration quick_gel(std::uint64_t seed) {
  gel::v1::Generator g;
  g.set_preset("quick");
  g.set_seed(seed);
  return generate_gel(g);
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

TEST(Fluctuation, XiOfAGasIsSmallAndOfAClusteredConfigurationLarger) {
  // Same packing fraction: a uniform gas of disks and the same number of disks packed into
  // compact clumps of 40. The clumps fluctuate on the clump scale.
  const double L = 120;
  const int n = 550;  // phi ~ 0.12
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, L);
  Configuration gas = periodic_box(L, L), clumps = periodic_box(L, L);
  for (int i = 0; i < n; ++i) gas.add_particle(u(rng), u(rng));
  for (int placed = 0; placed < n;) {
    const double cx = u(rng), cy = u(rng);
    for (int i = -3; i <= 3 && placed < n; ++i)
      for (int j = -3; j <= 3 && placed < n; ++j)
        if (i * i + j * j <= 12) clumps.add_particle(cx + 2 * i, cy + 2 * j), ++placed;
  }
  const auto xi_gas = correlation_length(density_fluctuation(pixelise(gas)));
  const auto xi_clumps = correlation_length(density_fluctuation(pixelise(clumps)));
  ASSERT_TRUE(xi_gas.has_value());
  ASSERT_TRUE(xi_clumps.has_value());
  std::printf("xi gas %.2f a, clumps %.2f a\n", *xi_gas, *xi_clumps);
  EXPECT_LT(*xi_gas, 12.0);
  EXPECT_GT(*xi_clumps, 2 * *xi_gas);
}

TEST(Fluctuation, XiIsMissingWhenTheRatioNeverCrossesHalf) {
  // A full field has no fluctuation at all (below 0.5 from the start); a half-filled box
  // split in two halves has boxes that are all full or all empty (ratio 1 at every size).
  // Box sides 1, 2, 4, ... a (4, 8, 16, ... pixels) all divide the half width of 128 pixels.
  DensityField full;
  full.nx = full.ny = 256, full.hx = full.hy = 0.25, full.periodic_y = true;
  full.rho.assign(256 * 256, 1);
  EXPECT_FALSE(correlation_length(density_fluctuation(full)).has_value());
  DensityField halves = full;
  for (int iy = 0; iy < 256; ++iy)
    for (int ix = 128; ix < 256; ++ix) halves.rho[iy * 256 + ix] = 0;
  const DensityFluctuation f = density_fluctuation(halves, {1.0, 0, 2.0});
  EXPECT_EQ(f.l.size(), 6u);
  ASSERT_FALSE(f.ratio.empty());
  for (double v : f.ratio) EXPECT_NEAR(v, 1.0, 1e-12);
  EXPECT_FALSE(correlation_length(f).has_value());
  // An interpolated crossing lies between the bracketing sizes.
  DensityFluctuation synthetic{{1, 2, 4}, {2.0, 1.0, 0.25}, {100, 25, 4}};
  EXPECT_NEAR(*correlation_length(synthetic), 2 * std::sqrt(2.0), 1e-12);
}

TEST(Profile, DiskSlicesAreExactAndPeriodicImagesCount) {
  Configuration c = periodic_box(20, 20);
  for (int i = 0; i < 10; ++i) c.add_particle(1 + 2 * i, 5.0);  // a row on the line y = 5
  c.add_particle(3, 0.0);                                       // half of it across y = 0
  const PackingProfile p = packing_profile(c, 20);
  ASSERT_EQ(p.phi.size(), 20u);
  const double half_disk_in_unit_slice = kPi / 2;  // slice [5, 6] holds half of each disk
  EXPECT_NEAR(p.phi[4], 10 * half_disk_in_unit_slice / 20, 1e-12);
  EXPECT_NEAR(p.phi[5], 10 * half_disk_in_unit_slice / 20, 1e-12);
  EXPECT_NEAR(p.phi[0], half_disk_in_unit_slice / 20, 1e-12);
  EXPECT_NEAR(p.phi[19], half_disk_in_unit_slice / 20, 1e-12);
  double total = 0;
  for (double v : p.phi) total += v * 20 * p.slice;
  EXPECT_NEAR(total, 11 * kPi, 1e-9);
}

TEST(Fits, PowerLawRecoversExactAndNoisyExponentsWithHonestErrors) {
  std::vector<double> phi, p;
  for (int k = 0; k < 15; ++k) phi.push_back(0.12 * std::pow(1.1, k)), p.push_back(0.7 * std::pow(phi.back(), 3.4));
  const PowerLawFit exact = fit_power_law(phi, p, 0, 1);
  EXPECT_NEAR(exact.exponent, 3.4, 1e-12);
  EXPECT_NEAR(exact.prefactor, 0.7, 1e-12);
  EXPECT_EQ(exact.points, 15);
  // 400 noisy data sets (5 % log-normal scatter): the spread of the estimates matches the
  // reported standard error, and the mean is unbiased.
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0, 0.05);
  double sum = 0, sum2 = 0, reported = 0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> noisy = p;
    for (double& v : noisy) v *= std::exp(noise(rng));
    const PowerLawFit f = fit_power_law(phi, noisy, 0, 1);
    sum += f.exponent, sum2 += f.exponent * f.exponent, reported += f.exponent_stderr;
  }
  const double mean = sum / trials, spread = std::sqrt(sum2 / trials - mean * mean);
  EXPECT_NEAR(mean, 3.4, 3 * spread / std::sqrt(trials));
  EXPECT_NEAR(reported / trials / spread, 1.0, 0.15);
  // The range selects points.
  EXPECT_EQ(fit_power_law(phi, p, 0.2, 0.4).points, 7);  // k = 6 .. 12
  EXPECT_THROW(fit_power_law(phi, p, 0.9, 1.0), InvalidArgument);
}

TEST(Fits, GelPointFitRecoversPhiGAndExponent) {
  std::vector<double> phi, p;
  for (int k = 0; k < 16; ++k) phi.push_back(0.10 * std::pow(1.12, k)), p.push_back(2.0 * std::pow(phi.back() - 0.07, 2.5));
  const GelPointFit exact = fit_gel_point(phi, p, 0, 1);
  EXPECT_TRUE(exact.converged);
  EXPECT_NEAR(exact.phi_g, 0.07, 1e-6);
  EXPECT_NEAR(exact.exponent, 2.5, 1e-5);
  EXPECT_NEAR(exact.prefactor, 2.0, 1e-4);
  EXPECT_FALSE(exact.phi_g_at_bound);
  // A pure power law (phi_g = 0) puts phi_g on its lower bound and recovers the exponent.
  std::vector<double> pure;
  for (double x : phi) pure.push_back(0.5 * std::pow(x, 3.0));
  const GelPointFit at_zero = fit_gel_point(phi, pure, 0, 1);
  EXPECT_GE(at_zero.phi_g, 0.0);
  EXPECT_LT(at_zero.phi_g, 1e-6);
  EXPECT_TRUE(at_zero.phi_g_at_bound);
  EXPECT_NEAR(at_zero.exponent, 3.0, 1e-4);
  // One JSON name for the flag, the study analysis's (gel_point.at_bound).
  EXPECT_EQ(to_json(at_zero).at("at_bound"), true);
  EXPECT_FALSE(to_json(at_zero).contains("phi_g_at_bound"));
  EXPECT_EQ(to_json(exact).at("at_bound"), false);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.02);
  std::vector<double> noisy = p;
  for (double& v : noisy) v *= std::exp(noise(rng));
  const GelPointFit f = fit_gel_point(phi, noisy, 0, 1);
  EXPECT_LT(std::abs(f.phi_g - 0.07), std::max(3 * f.phi_g_stderr, 0.003));
  EXPECT_LT(std::abs(f.exponent - 2.5), std::max(3 * f.exponent_stderr, 0.05));
  EXPECT_GT(f.phi_g_stderr, 0);
  EXPECT_LT(f.phi_g, phi[0]);
}

// A curve with planted regimes: intervals 0-4 store more than they dissipate, 5-9 dissipate by
// rolling only, 10-14 break and slide too; interval 7 carries a stray burst of sliding.
gel::v1::Curve planted_curve() {
  gel::v1::Curve curve;
  curve.set_particles(1000);
  double stored = 0, dissipated = 0;
  long normal = 0, sliding = 0, rolling = 0;
  for (int k = 0; k <= 15; ++k) {
    if (k > 0) {
      const int i = k - 1;
      if (i < 5) stored += 10, dissipated += 1, rolling += 2;
      else if (i < 10) stored += 1, dissipated += 10, rolling += 50, sliding += (i == 7 ? 10 : 0);
      else stored += 1, dissipated += 30, rolling += 50, sliding += 20, normal += 10;
    }
    auto* row = curve.add_rows();
    row->set_k(k);
    row->set_phi(0.12 * std::pow(1.1, k));
    row->set_target_phi(row->phi());
    row->set_p(std::pow(row->phi(), 3));
    row->set_equilibrated(true);
    row->set_spans(true);
    row->set_stored_energy(stored);
    row->set_dissipated_energy(dissipated);
    row->mutable_ruptures()->set_normal(normal);
    row->mutable_ruptures()->set_sliding(sliding);
    row->mutable_ruptures()->set_rolling(rolling);
  }
  return curve;
}

TEST(Regimes, PlantedBoundariesAreFound) {
  const gel::v1::Curve curve = planted_curve();
  const auto increments = curve_increments(curve);
  ASSERT_EQ(increments.size(), 15u);
  EXPECT_NEAR(increments[12].gamma_normal, 10 / (1000 * std::log(1.1)), 1e-12);
  EXPECT_NEAR(increments[12].gamma_rolling, 50 / (1000 * std::log(1.1)), 1e-12);
  EXPECT_NEAR(increments[0].stored_rate, 10 / std::log(1.1), 1e-9);
  const RegimeSplit split = split_regimes(increments);
  EXPECT_EQ(split.label[7], Regime::kMultiModePlastic);  // the stray burst
  EXPECT_EQ(split.disagreements, 1);
  ASSERT_TRUE(split.single_mode_start_phi && split.multi_mode_start_phi);
  EXPECT_NEAR(*split.single_mode_start_phi, curve.rows(5).phi(), 1e-12);
  EXPECT_NEAR(*split.multi_mode_start_phi, curve.rows(10).phi(), 1e-12);
  // A purely elastic curve has no boundary.
  gel::v1::Curve elastic = curve;
  while (elastic.rows_size() > 5) elastic.mutable_rows()->RemoveLast();
  const RegimeSplit none = split_regimes(curve_increments(elastic));
  EXPECT_FALSE(none.single_mode_start_phi.has_value());
  EXPECT_FALSE(none.multi_mode_start_phi.has_value());
  EXPECT_FALSE(none.range[1].has_value());
}

TEST(Ensemble, MeanAndStdOfTwoKnownCurves) {
  gel::v1::Curve a = planted_curve(), b = planted_curve();
  for (int k = 0; k < b.rows_size(); ++k) {
    a.mutable_rows(k)->set_p(1.0 + k);
    b.mutable_rows(k)->set_p(3.0 + k);
    a.mutable_rows(k)->add_phi_profile(0.1), a.mutable_rows(k)->add_phi_profile(0.2);
    b.mutable_rows(k)->add_phi_profile(0.3), b.mutable_rows(k)->add_phi_profile(0.2);
  }
  b.mutable_rows()->RemoveLast();  // members of unequal length: the shorter one sets the rows
  const CurveEnsemble e = curve_ensemble({a, b});
  EXPECT_EQ(e.members, 2);
  const MeanStd& p = e.rows.at("P");
  ASSERT_EQ(p.mean.size(), 15u);
  for (int k = 0; k < 15; ++k) {
    EXPECT_DOUBLE_EQ(p.mean[k], 2.0 + k);
    EXPECT_NEAR(p.std[k], std::sqrt(2.0), 1e-12);
  }
  EXPECT_NEAR(e.phi_profile[3].mean[0], 0.2, 1e-12);
  EXPECT_NEAR(e.phi_profile[3].std[0], std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(e.phi_profile[3].std[1], 0.0, 1e-12);
  EXPECT_EQ(e.intervals.at("gamma_rolling").mean.size(), 14u);
  const OptionalMeanStd xi = mean_std(std::vector<std::optional<double>>{4.0, std::nullopt, 6.0});
  EXPECT_EQ(xi.missing, 1);
  EXPECT_DOUBLE_EQ(*xi.mean, 5.0);
  EXPECT_NEAR(*xi.std, std::sqrt(2.0), 1e-12);
  gel::v1::Curve other = planted_curve();
  other.mutable_rows(2)->set_k(7);
  EXPECT_THROW(curve_ensemble({a, other}), InvalidArgument);
}

std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("gel_analysis_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

// Colour of device pixel (x, y) of a PNG, as 0..255 per channel.
struct Pixel {
  int r, g, b;
};
Pixel png_pixel(cairo_surface_t* image, int x, int y) {
  const unsigned char* data = cairo_image_surface_get_data(image);
  const int stride = cairo_image_surface_get_stride(image);
  const auto word = *reinterpret_cast<const std::uint32_t*>(data + y * stride + 4 * x);
  return {static_cast<int>((word >> 16) & 255), static_cast<int>((word >> 8) & 255), static_cast<int>(word & 255)};
}
void expect_colour(const Pixel& p, const Rgb& c) {
  EXPECT_NEAR(p.r, 255 * c.r, 2);
  EXPECT_NEAR(p.g, 255 * c.g, 2);
  EXPECT_NEAR(p.b, 255 * c.b, 2);
}

TEST(Pictures, SnapshotHasTheBoxSizeAndParticlesWhereTheyAre) {
  // 40 a x 20 a between walls at y = 0 and 20: with one radius of margin above and below the
  // drawn region is 40 x 22 a, 400 px wide at size 400 (10 px per a), y pointing up.
  Configuration c;
  c.lx = 40, c.ly = 20, c.periodic_y = false;
  c.add_particle(10, 10);                       // free, unbonded
  c.add_particle(30, 1);                        // on the bottom wall
  c.add_particle(20, 15), c.add_particle(22, 15);
  c.add_bond_at_contact(2, 3);
  c.wall = {kNoWall, kBottomWall, kNoWall, kNoWall};
  c.wall_bottom = 0, c.wall_top = 20;
  const std::string dir = temp_dir("snapshot");
  const std::string png = dir + "/s.png", svg = dir + "/s.svg";
  render_snapshot(c, png, {400, true, 3.0, ""});
  cairo_surface_t* image = cairo_image_surface_create_from_png(png.c_str());
  ASSERT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
  EXPECT_EQ(cairo_image_surface_get_width(image), 400);
  EXPECT_EQ(cairo_image_surface_get_height(image), 220);
  auto device = [](double x, double y) { return std::pair<int, int>(static_cast<int>(x * 10), static_cast<int>((21 - y) * 10)); };
  auto [fx, fy] = device(10, 10);
  expect_colour(png_pixel(image, fx, fy), kParticleColour);
  auto [wx, wy] = device(30, 1);
  expect_colour(png_pixel(image, wx, wy), kWallParticleColour);
  auto [bx, by] = device(21, 15);  // the contact point, on the bond line
  expect_colour(png_pixel(image, bx, by), kBondColour);
  auto [ex, ey] = device(5, 5);    // empty space
  const Pixel empty = png_pixel(image, ex, ey);
  EXPECT_EQ(empty.r + empty.g + empty.b, 3 * 255);
  cairo_surface_destroy(image);
  render_snapshot(c, svg);
  std::ifstream in(svg);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("<svg"), std::string::npos);
  EXPECT_THROW(render_snapshot(c, dir + "/s.jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, GnuplotDrawsALogLogPlot) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.title = "test";
  f.log_x = f.log_y = true;
  f.width = 320, f.height = 240;
  PlotSeries s{"data", {0.1, 0.2, 0.4}, {1, 8, 64}, {0.1, 0.5, 3}, "linespoints"};
  f.series.push_back(s);
  f.series.push_back({"skipped on log axes", {0.1, 0.2}, {-1, 0}, {}, "lines"});
  f.vertical_lines.push_back({0.3, "boundary"});
  const std::string dir = temp_dir("plot");
  render_plot(f, dir + "/p.png");
  cairo_surface_t* image = cairo_image_surface_create_from_png((dir + "/p.png").c_str());
  ASSERT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
  EXPECT_EQ(cairo_image_surface_get_width(image), 320);
  EXPECT_EQ(cairo_image_surface_get_height(image), 240);
  int dark = 0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      const Pixel p = png_pixel(image, x, y);
      dark += p.r + p.g + p.b < 300;
    }
  EXPECT_GT(dark, 200);  // axes, text and the curve
  cairo_surface_destroy(image);
  EXPECT_TRUE(std::filesystem::exists(dir + "/gnuplot/p.gp"));
  std::filesystem::remove_all(dir);
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Pictures, SnapshotHasAScaleBarAndWritesPdf) {
  // An empty periodic 40 a x 20 a box, 10 px per a (400 x 200 px): the bar (5 a, a fifth of
  // the width rounded down to 1, 2 or 5 a) lies in the bottom-right corner.
  Configuration c;
  c.lx = 40, c.ly = 20;
  const std::string dir = temp_dir("scale_bar");
  auto dark_pixels_bottom_right = [&](bool scale_bar) {
    SnapshotStyle style;
    style.size = 400;
    style.scale_bar = scale_bar;
    render_snapshot(c, dir + "/s.png", style);
    cairo_surface_t* image = cairo_image_surface_create_from_png((dir + "/s.png").c_str());
    EXPECT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS);
    int dark = 0, dark_run = 0, longest_run = 0;
    for (int y = 150; y < 200; ++y) {
      dark_run = 0;
      for (int x = 200; x < 400; ++x) {
        const Pixel p = png_pixel(image, x, y);
        const bool is_dark = p.r + p.g + p.b < 100;
        dark += is_dark;
        dark_run = is_dark ? dark_run + 1 : 0;
        longest_run = std::max(longest_run, dark_run);
      }
    }
    cairo_surface_destroy(image);
    return std::pair<int, int>(dark, longest_run);
  };
  const auto [with_bar, bar_length] = dark_pixels_bottom_right(true);
  EXPECT_GT(with_bar, 100);
  EXPECT_NEAR(bar_length, 50, 2);  // 5 a at 10 px per a
  EXPECT_EQ(dark_pixels_bottom_right(false).first, 0);
  render_snapshot(c, dir + "/s.pdf");
  EXPECT_EQ(file_text(dir + "/s.pdf").substr(0, 5), "%PDF-");
  EXPECT_EQ(picture_format_of_path("A.PDF"), PictureFormat::pdf);
  EXPECT_THROW(parse_picture_format("jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, PlotScriptIsForAPaperAndRunsWhereverItIsCopied) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.title = "what the figure shows";
  f.x_label = "{/:Italic φ}";
  f.y_label = "{/:Italic P}_y  [{/:Italic F}_0/{/:Italic a}^2]";
  f.log_x = f.log_y = true;
  f.width = 320, f.height = 240;
  // Falling from the upper left: the key belongs in the upper right. The first bar reaches
  // below zero, which a log axis cannot show: it must end at the axis' bottom.
  f.series.push_back({"{/:Italic P}_y", {0.1, 0.2, 0.4}, {64, 8, 1}, {70, 0.5, 0.2}, "linespoints"});
  f.series.push_back({"{/:Italic P}_y ∝ {/:Italic φ}^{−3}", {0.1, 0.4}, {64, 1}, {}, "lines", true});
  const std::string dir = temp_dir("paper_plot");
  render_plot(f, dir + "/p.png");
  const std::string script = file_text(dir + "/gnuplot/p.gp");
  EXPECT_EQ(script.find("set title"), std::string::npos);
  EXPECT_EQ(script.find(dir), std::string::npos) << "absolute path in the kept script";
  EXPECT_EQ(script.find("noenhanced"), std::string::npos);
  EXPECT_NE(script.find("set key inside top right"), std::string::npos) << script;
  EXPECT_NE(script.find("set format y \"%g\""), std::string::npos);
  EXPECT_NE(script.find("using 1:2:3:4 with yerrorlines"), std::string::npos);
  // The bar's lower end: at the bottom of the y range, not left out.
  double y_lo = 0, y_hi = 0;
  ASSERT_EQ(std::sscanf(script.c_str() + script.find("set yrange ["), "set yrange [%lf:%lf]", &y_lo, &y_hi), 2);
  std::istringstream data(file_text(dir + "/gnuplot/p.dat"));
  std::string line;
  while (std::getline(data, line) && (line.empty() || line[0] == '#')) {
  }
  double x = 0, y = 0, low = 0, high = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "%lf %lf %lf %lf", &x, &y, &low, &high), 4) << line;
  EXPECT_EQ(y, 64);
  EXPECT_EQ(low, y_lo);
  EXPECT_GT(low, 0);
  EXPECT_EQ(high, 134);

  // The kept folder copied elsewhere redraws the picture there.
  const std::string copy = dir + "/copied";
  std::filesystem::create_directories(copy + "/gnuplot");
  for (const char* name : {"p.gp", "p.dat"}) std::filesystem::copy_file(dir + "/gnuplot/" + name, copy + "/gnuplot/" + name);
  ASSERT_EQ(std::system(("cd '" + copy + "/gnuplot' && gnuplot p.gp 2>/dev/null").c_str()), 0);
  EXPECT_GT(std::filesystem::file_size(copy + "/p.png"), 1000u);

  render_plot(f, dir + "/p.pdf");
  EXPECT_EQ(file_text(dir + "/p.pdf").substr(0, 5), "%PDF-");
  EXPECT_NE(file_text(dir + "/gnuplot/p_pdf.gp").find("set terminal pdfcairo"), std::string::npos);
  EXPECT_THROW(render_plot(f, dir + "/p.jpg"), InvalidArgument);
  std::filesystem::remove_all(dir);
}

TEST(Pictures, KeyLeavesThePlotAreaWhenDataFillEveryCorner) {
  if (find_gnuplot().empty()) GTEST_SKIP() << "gnuplot is not installed";
  PlotFigure f;
  f.width = 320, f.height = 240;
  f.series.push_back({"zigzag", {0, 1, 2, 3, 4}, {0, 1, 0, 1, 0}, {}, "lines"});
  f.series.push_back({"zagzig", {0, 1, 2, 3, 4}, {1, 0, 1, 0, 1}, {}, "lines"});
  const std::string dir = temp_dir("key_outside");
  render_plot(f, dir + "/k.svg");
  const std::string script = file_text(dir + "/gnuplot/k_svg.gp");
  EXPECT_EQ(script.find("set key inside"), std::string::npos) << script;
  EXPECT_NE(script.find("set key outside"), std::string::npos) << script;
  EXPECT_NE(file_text(dir + "/k.svg").find("<svg"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(Structure, AnalysisOfAGeneratedGelHasEveryPart) {
  const Configuration gel = quick_gel(1);
  const StructureAnalysis a = analyse_structure(gel);
  EXPECT_NEAR(a.phi, gel.packing_fraction(), 1e-15);
  ASSERT_TRUE(a.df_fit.has_value());
  EXPECT_GT(a.df_fit->df, 1.3);
  EXPECT_LT(a.df_fit->df, 1.8);
  EXPECT_FALSE(a.df_profile.r.empty());
  EXPECT_EQ(a.profile.phi.size(), 20u);
  const nlohmann::json j = to_json(a);
  for (const char* key : {"phi", "correlation", "fractal_dimension_profile", "fractal_dimension_fit", "xi_05"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["correlation"]["r"].size(), j["correlation"]["C"].size());
}

TEST(RunAnalysis, FitsLeaveOutRowsThatAreNotAnEquilibriumYieldStress) {
  // Rows 1-3 stopped at the wait limit with P ten times the law, row 4 did not span: a fit
  // over them would not return the planted exponent. Flagged, they stay out of it.
  gel::v1::Curve curve = planted_curve();
  for (int k : {1, 2, 3}) {
    curve.mutable_rows(k)->set_p(10 * curve.rows(k).p());
    curve.mutable_rows(k)->set_equilibrated(false);
  }
  curve.mutable_rows(4)->set_p(10 * curve.rows(4).p());
  curve.mutable_rows(4)->set_spans(false);
  const CurveAnalysis a = analyse_curves({curve}, RunAnalysisOptions{});
  ASSERT_TRUE(a.power_law.has_value());
  EXPECT_NEAR(a.power_law->exponent, 3.0, 1e-9);
  // Every left-out row is named with its reason, and the fit states the range it really used.
  ASSERT_EQ(a.excluded_rows.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.excluded_rows[i].k, i + 1);
    EXPECT_EQ(a.excluded_rows[i].reason, "not equilibrated");
  }
  EXPECT_EQ(a.excluded_rows[3].reason, "network does not span");
  EXPECT_EQ(a.fit_rows.front(), 5);
  EXPECT_DOUBLE_EQ(a.power_law->x_min, curve.rows(5).phi());
  EXPECT_DOUBLE_EQ(a.power_law->x_max, curve.rows(curve.rows_size() - 1).phi());
  EXPECT_EQ(a.power_law->points, curve.rows_size() - 5);
  EXPECT_FALSE(a.mean_curve.rows(1).equilibrated());
  EXPECT_TRUE(a.mean_curve.rows(5).equilibrated());
  // The regime split skips the intervals that touch a left-out row (rows 0-5: 5 intervals).
  ASSERT_EQ(a.increment_trusted.size(), a.increments.size());
  EXPECT_EQ(std::count(a.increment_trusted.begin(), a.increment_trusted.end(), false), 5);
  EXPECT_EQ(a.regimes.assigned.size(), a.increments.size() - 5);
  const nlohmann::json j = to_json(a);
  EXPECT_EQ(j["excluded_rows"].size(), 4u);
  EXPECT_TRUE(j["regimes"]["intervals"][0]["regime"].is_null());
  // Asked for explicitly, the unequilibrated rows come back; the one that does not span stays out.
  RunAnalysisOptions include;
  include.include_unequilibrated = true;
  const CurveAnalysis included = analyse_curves({curve}, include);
  ASSERT_EQ(included.excluded_rows.size(), 1u);
  EXPECT_EQ(included.excluded_rows[0].k, 4);
  ASSERT_TRUE(included.power_law.has_value());
  EXPECT_LT(included.power_law->exponent, 2.9);
  // Two members, one of them wait-limited at row 2: the row is out, and the reason counts members.
  gel::v1::Curve clean = planted_curve(), limited = planted_curve();
  limited.mutable_rows(2)->set_equilibrated(false);
  const CurveAnalysis pair = analyse_curves({clean, limited}, RunAnalysisOptions{});
  ASSERT_EQ(pair.excluded_rows.size(), 1u);
  EXPECT_EQ(pair.excluded_rows[0].reason, "not equilibrated in 1 of 2 members");
  // The same rows trusted: the fit is visibly off.
  for (int k : {1, 2, 3}) curve.mutable_rows(k)->set_equilibrated(true);
  curve.mutable_rows(4)->set_spans(true);
  const CurveAnalysis biased = analyse_curves({curve}, RunAnalysisOptions{});
  ASSERT_TRUE(biased.power_law.has_value());
  EXPECT_LT(biased.power_law->exponent, 2.5);
}

TEST(Fits, PointsWithNonPositiveStressAreCountedNotHidden) {
  // P = phi^2 on 6 points, two of them zero or negative (a row at rest under noise): the fit
  // keeps the planted law, says it left 2 points out, and reports the range of the points used.
  const std::vector<double> phi = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  std::vector<double> p;
  for (double x : phi) p.push_back(x * x);
  p[0] = 0.0, p[5] = -1e-3;
  const PowerLawFit fit = fit_power_law(phi, p, 0.0, 1.0);
  EXPECT_NEAR(fit.exponent, 2.0, 1e-12);
  EXPECT_EQ(fit.points, 4);
  EXPECT_EQ(fit.dropped, 2);
  EXPECT_DOUBLE_EQ(fit.x_min, 0.2);
  EXPECT_DOUBLE_EQ(fit.x_max, 0.5);
  EXPECT_DOUBLE_EQ(fit.requested_min, 0.0);
  EXPECT_DOUBLE_EQ(fit.requested_max, 1.0);
}

TEST(CurveJson, CarriesTheModelsEnergyUnit) {
  // E0 = k_R a^2 phi_c^2 / 2 with k_R a^2 = 20 F0 a and phi_c = 0.05 (MODEL.md, both bond sets):
  // 0.025 F0 a, written as a number here rather than computed from the code's tables.
  for (const char* preset : {"bond1", "bond2"}) {
    gel::v1::Curve curve = planted_curve();
    curve.mutable_scene()->mutable_bond()->set_preset(preset);
    const nlohmann::json j = curve_to_json(curve);
    ASSERT_TRUE(j.contains("E0")) << preset;
    EXPECT_NEAR(j["E0"].get<double>(), 0.025, 1e-15) << preset;
  }
}

TEST(CurveAnalysisJson, EnergyIncrementsAlsoInTheModelsUnit) {
  // MODEL.md gives the increments dE / d ln phi in E0 = 0.025 F0 a: each interval's rates in F0 a
  // divided by that number (written here, not read from the code), for both bond sets.
  for (const char* preset : {"bond1", "bond2"}) {
    gel::v1::Curve curve = planted_curve();
    curve.mutable_scene()->mutable_bond()->set_preset(preset);
    const nlohmann::json j = to_json(analyse_curves({curve}, RunAnalysisOptions{}));
    EXPECT_NEAR(j.at("E0").get<double>(), 0.025, 1e-15) << preset;
    const auto& intervals = j.at("regimes").at("intervals");
    ASSERT_FALSE(intervals.empty());
    for (const auto& interval : intervals) {
      EXPECT_NEAR(interval.at("stored_rate_E0").get<double>(), interval.at("stored_rate").get<double>() / 0.025, 1e-9);
      EXPECT_NEAR(interval.at("dissipated_rate_E0").get<double>(), interval.at("dissipated_rate").get<double>() / 0.025, 1e-9);
    }
  }
  // Without a rolling spring there is no E0: no such fields rather than a division by zero.
  gel::v1::Curve plain = planted_curve();
  plain.mutable_scene()->clear_bond();
  const nlohmann::json j = to_json(analyse_curves({plain}, RunAnalysisOptions{}));
  EXPECT_TRUE(j.at("E0").is_null());
  for (const auto& interval : j.at("regimes").at("intervals")) EXPECT_FALSE(interval.contains("stored_rate_E0"));
}

TEST(Ensemble, ProfilesOnDifferentRadiiAreAveragedAtEqualR) {
  // Two members sample the same line C(r) = 2 + 3r on shifted radii. Element by element their
  // mean would be 3/2 too high in every bin; interpolated onto common radii it is the line
  // itself with zero spread, over the range both cover.
  const std::vector<std::vector<double>> radii = {{0.0, 1.0, 2.0, 3.0, 4.0}, {0.5, 1.5, 2.5, 3.5}};
  std::vector<std::vector<double>> values;
  for (const auto& r : radii) {
    std::vector<double> v;
    for (double x : r) v.push_back(2 + 3 * x);
    values.push_back(v);
  }
  std::vector<double> grid;
  const MeanStd m = mean_on_common_radii(radii, values, grid);
  EXPECT_EQ(grid, (std::vector<double>{1.0, 2.0, 3.0}));
  ASSERT_EQ(m.mean.size(), 3u);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    EXPECT_NEAR(m.mean[i], 2 + 3 * grid[i], 1e-12);
    EXPECT_NEAR(m.std[i], 0.0, 1e-12);
  }
}

TEST(RunAnalysis, DirectoryWithCurveAndSnapshotsGivesFitsStructureAndPictures) {
  // A run directory as the compression writes it: curve.json plus snapshots/k_NNN.pb named in
  // the rows. Two members (the same curve twice) make an ensemble with zero spread.
  const std::string dir = temp_dir("run");
  gel::v1::Curve curve = planted_curve();
  std::filesystem::create_directories(dir + "/snapshots");
  const Configuration gel = quick_gel(2);
  for (int k : {0, 15}) {
    char name[32];
    std::snprintf(name, sizeof name, "snapshots/k_%03d.pb", k);
    write_configuration(gel, dir + "/" + name);
    curve.mutable_rows(k)->set_snapshot(name);
  }
  write_curve(curve, dir);
  const RunAnalysis run = analyse_runs({dir, dir});
  ASSERT_TRUE(run.curve.power_law.has_value());
  EXPECT_NEAR(run.curve.power_law->exponent, 3.0, 1e-9);  // planted P = phi^3
  EXPECT_NEAR(run.curve.power_law->prefactor, 1.0, 1e-9);
  ASSERT_TRUE(run.curve.regimes.multi_mode_start_phi.has_value());
  EXPECT_NEAR(*run.curve.regimes.multi_mode_start_phi, curve.rows(10).phi(), 1e-12);
  ASSERT_EQ(run.structure.size(), 2u);
  EXPECT_EQ(run.structure[0].snapshots.size(), 2u);
  ASSERT_TRUE(run.structure[0].df_fit.mean.has_value());
  EXPECT_NEAR(*run.structure[0].df_fit.std, 0.0, 1e-12);
  const nlohmann::json j = to_json(run);
  EXPECT_EQ(j["structure"].size(), 2u);
  EXPECT_TRUE(j["regimes"].contains("multi_mode_start_phi"));
  if (!find_gnuplot().empty()) {
    PictureOptions options;
    options.plot_width = 300, options.plot_height = 220, options.snapshot_size = 200;
    const auto written = render_run_pictures(run, dir + "/plots", options);
    EXPECT_EQ(written.size(), 8u + 2u);  // 8 plots, 2 snapshots
    for (const auto& path : written) EXPECT_GT(std::filesystem::file_size(path), 1000u) << path;
    options.format = "pdf";
    options.snapshots = false;
    for (const auto& path : render_run_pictures(run, dir + "/plots", options)) {
      EXPECT_EQ(std::filesystem::path(path).extension(), ".pdf");
      EXPECT_EQ(file_text(path).substr(0, 5), "%PDF-") << path;
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel::analysis
