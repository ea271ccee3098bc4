// The density fluctuation and its correlation length xi, and the packing profile phi(y)
// (docs/analysis.md): a gas against clumps, fields that never cross one half, exact disk slices.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "gel/analysis/density_field.hpp"
#include "gel/analysis/fluctuation.hpp"
#include "gel/configuration.hpp"
#include "gel/units.hpp"
#include "analysis_samples.hpp"

namespace gel::analysis {
namespace {

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

}  // namespace
}  // namespace gel::analysis
