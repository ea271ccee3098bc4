// The fits of P(phi) (docs/analysis.md): a power law and the gel-point law on synthetic data with
// known exponents, exact and with noise whose spread the reported errors must match.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "gel/analysis/fits.hpp"
#include "gel/analysis/run_analysis.hpp"  // to_json of a fit
#include "gel/errors.hpp"
#include "analysis_samples.hpp"

namespace gel::analysis {
namespace {

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

}  // namespace
}  // namespace gel::analysis
