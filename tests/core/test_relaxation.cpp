// FIRE relaxation (docs/quasistatic.md) against analytic equilibria. The bond constants are
// written out from MODEL.md's table (bond 1: k_N = k_S = 20 F0/a, k_R a^2 = 20 F0 a), not read
// back from the code, so a wrong preset fails here too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "gel/bending.hpp"
#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

constexpr double kBond1Stiffness = 20.0;  // k_N = k_S [F0/a] and k_R a^2 [F0 a] of bond 1
constexpr double kBond1Overlap = 8e4;     // C [F0/a^3]

SimParams bond1(unsigned effects) {
  SimParams params;
  params.bond = bond_preset("bond1");
  params.effects = effects;
  return params;
}

// Relaxes to convergence in chunks, recording the residual after each chunk.
RelaxState relax_fully(System& system, const RelaxOptions& options, std::vector<double>* residuals = nullptr,
                       std::int64_t max_iterations = 400000) {
  RelaxState state;
  while (!state.converged && !state.stalled && state.iterations < max_iterations) {
    system.relax(state, options, 50);
    if (residuals) residuals->push_back(state.residual);
  }
  return state;
}

// An 11-particle chain under the three-point load F (MODEL.md "Three-point bending").
System loaded_chain(const SimParams& params, double force) {
  System system(straight_chain(11), params);
  system.set_external_force(5, force, 0);
  system.set_external_force(0, -0.5 * force, 0);
  system.set_external_force(10, -0.5 * force, 0);
  return system;
}

TEST(Relaxation, ThreePointBendingReachesTheSpringChainDeflection) {
  // The joint at distance (2k+1)a from an end carries the moment (F/2)(2k+1)a and the shear F/2:
  // w = F [ (1 + 9 + 25 + 49 + 81) a^2 / (2 k_R a^2) + 5 / (2 k_S) ] for 11 particles.
  const double force = 0.02;
  System system = loaded_chain(bond1(bending_effects()), force);
  RelaxOptions options;
  options.force_tolerance = 1e-10;
  options.force_floor = 1e-13;
  std::vector<double> residuals;
  const RelaxState state = relax_fully(system, options, &residuals);
  ASSERT_TRUE(state.converged) << "residual " << state.residual << " after " << state.iterations;
  const double expected = force * (165.0 / (2 * kBond1Stiffness) + 5.0 / (2 * kBond1Stiffness));
  // Geometric nonlinearity is of order (w/L)^2 ~ 1e-4.
  EXPECT_NEAR(chain_deflection(system) / expected, 1.0, 2e-3);
  EXPECT_EQ(system.events().rolling + system.events().sliding + system.events().normal, 0);
  // At rest, and the residual fell by many orders of magnitude from the first chunk.
  EXPECT_EQ(system.max_speed(), 0.0);
  ASSERT_GE(residuals.size(), 1u);
  EXPECT_LT(residuals.back(), 1e-12);
  EXPECT_LE(system.residual_force(), 1e-12);
}

TEST(Relaxation, ResidualDecreasesAndResetsArePartOfThePath) {
  // Above the bending threshold (2/9 F0 for small deflections) rolling resets happen during the
  // relaxation; it still converges, and after unloading the chain stays bent (plastic).
  const double force = 0.35;
  System system = loaded_chain(bond1(bending_effects()), force);
  RelaxOptions options;
  options.force_tolerance = 1e-8;
  std::vector<double> residuals;
  RelaxState loaded = relax_fully(system, options, &residuals);
  ASSERT_TRUE(loaded.converged) << "residual " << loaded.residual;
  EXPECT_GT(system.events().rolling, 0);
  // The residual (sampled every 50 iterations) fell by orders of magnitude from its largest
  // value, resets on the way included.
  ASSERT_GE(residuals.size(), 3u);
  EXPECT_LT(residuals.back(), 1e-6 * *std::max_element(residuals.begin(), residuals.end()));
  system.clear_external_forces();
  const RelaxState unloaded = relax_fully(system, options);
  ASSERT_TRUE(unloaded.converged);
  EXPECT_GT(std::abs(chain_deflection(system)), 0.1);
}

TEST(Relaxation, LoadedChainBetweenWallsCarriesTheSeriesSpringStress) {
  // A vertical chain of n particles between the walls, compressed by Delta: the n - 1 bonds in
  // series are each compressed by delta = Delta / (n - 1) and carry F = k_N delta + C delta^3
  // (the cubic term is 6e-5 of the linear one here), and P = F / (2a L_x) on both walls.
  const int n = 9;
  const Configuration config = vertical_chain(n, 30);
  System system(config, bond1(kAllEffects & ~kBondCreation));
  system.install_walls();
  const double squeeze = 1e-3;
  system.affine_move_walls(system.wall_bottom() + 0.3 * squeeze, system.wall_top() - 0.7 * squeeze);
  RelaxOptions options;
  options.force_tolerance = 1e-9;
  const RelaxState state = relax_fully(system, options);
  ASSERT_TRUE(state.converged);
  const double delta = squeeze / (n - 1);
  const double force = kBond1Stiffness * delta + kBond1Overlap * delta * delta * delta;
  const double expected = force / (2.0 * kRadius * config.lx);
  const WallStress stress = system.wall_stress();
  EXPECT_NEAR(stress.p_top / expected, 1.0, 1e-6);
  EXPECT_NEAR(stress.p_bottom / expected, 1.0, 1e-6);
  // Stored energy of the springs, and the walls' work covers it (the minimizer only removes).
  const double stored = (n - 1) * (0.5 * kBond1Stiffness * delta * delta + 0.25 * kBond1Overlap * std::pow(delta, 4));
  EXPECT_NEAR(system.stored_energy() / stored, 1.0, 1e-5);
  EXPECT_GE(system.energy().wall_work, system.stored_energy() * (1 - 1e-9));
}

TEST(Relaxation, OverlapPressedPairReachesTheCubicLawEquilibrium) {
  // k_N delta + C delta^3 = -F for a pair pressed by F = 50 F0 (C = 8e4 F0/a^3): deep in the
  // cubic range, where the contact is ~40x stiffer than k_N.
  System system(pair_along_x(0.0), bond1(kNormalSpring | kOverlapRepulsion));
  const double load = 50;
  system.set_external_force(0, load, 0);
  system.set_external_force(1, -load, 0);
  RelaxOptions options;
  options.force_tolerance = 1e-12;
  const RelaxState state = relax_fully(system, options);
  ASSERT_TRUE(state.converged);
  double expected = -0.08;
  for (int k = 0; k < 50; ++k) {
    const double f = kBond1Stiffness * expected + kBond1Overlap * std::pow(expected, 3) + load;
    expected -= f / (kBond1Stiffness + 3 * kBond1Overlap * expected * expected);
  }
  EXPECT_NEAR(system.x()[1] - system.x()[0] - kDiameter, expected, 1e-10);
}

TEST(Relaxation, UnloadedGelConvergesToZeroStressHonestly) {
  // A dilute gel between walls, compressed a little: it does not span, so the relaxed P is
  // zero up to the residual, and the relaxation says it converged rather than timing out.
  gel::v1::Generator generator;
  generator.set_lx(60);
  generator.set_ly(110);
  generator.set_n_floc(16);
  generator.set_n_clusters(16);
  generator.set_seed(2);
  System system(generate_gel(resolve_generator(generator)), bond1(kAllEffects));
  system.install_walls();
  const double height = system.wall_top() - system.wall_bottom();
  system.affine_move_walls(system.wall_bottom() + 0.01 * height, system.wall_top() - 0.01 * height);
  RelaxOptions options;
  const RelaxState state = relax_fully(system, options);
  ASSERT_TRUE(state.converged) << "residual " << state.residual;
  const WallStress stress = system.wall_stress();
  EXPECT_LT(std::abs(stress.p_top), 1e-6);
  EXPECT_LT(std::abs(stress.p_bottom), 1e-6);
}

TEST(Relaxation, StiffContactsStayStable) {
  // k_N a^2 / k_R = 1e3: the fastest mode is ~30x faster than the rolling one, and FIRE's
  // step is set by the fastest. It stays stable and reaches the analytic deflection to the
  // accuracy its residual allows (bending stiffness F/w ~ 0.24 F0/a: a residual of 1e-6 of
  // the mean bond force moves w by far less than 1e-3).
  SimParams params = bond1(bending_effects());
  params.bond.k_normal = 2e4;
  System system = loaded_chain(params, 0.02);
  RelaxOptions options;
  options.force_tolerance = 1e-6;
  // With FIRE's cap well above the stiff mode's stability limit the soft mode only creeps
  // (about 1e6 iterations at cap factor 10): the budget allows for a cap set too high.
  const RelaxState state = relax_fully(system, options, nullptr, 2000000);
  ASSERT_TRUE(state.converged) << "residual " << state.residual << " after " << state.iterations << " stalled "
                               << int(state.stalled) << " dt " << state.dt << " cap " << state.dt_max;
  const double expected = 0.02 * (165.0 / (2 * kBond1Stiffness) + 5.0 / (2 * kBond1Stiffness));
  EXPECT_NEAR(chain_deflection(system) / expected, 1.0, 2e-3);
}

// 160 particles (20 flocs of 8) in 60 x 60 with walls installed.
System gel_between_walls() {
  gel::v1::Generator generator;
  generator.set_lx(60);
  generator.set_ly(60);
  generator.set_n_floc(8);
  generator.set_n_clusters(20);
  generator.set_seed(5);
  System system(generate_gel(resolve_generator(generator)), bond1(kAllEffects));
  system.install_walls();
  return system;
}

TEST(Relaxation, IsDeterministic) {
  auto run = [] {
    System system = gel_between_walls();
    const double height = system.wall_top() - system.wall_bottom();
    system.affine_move_walls(system.wall_bottom() + 0.02 * height, system.wall_top() - 0.02 * height);
    RelaxOptions options;
    relax_fully(system, options, nullptr, 20000);
    return system.save_state();
  };
  EXPECT_EQ(run(), run());
}

TEST(Relaxation, AStrainStepThatCrushesContactsFailsLoudly) {
  // 20% of the gap in one affine step pushes neighbours half a radius into each other: the
  // stability guard stops the relaxation with a message, it does not return a curve row.
  System system = gel_between_walls();
  const double height = system.wall_top() - system.wall_bottom();
  RelaxState state;
  EXPECT_THROW(
      {
        system.affine_move_walls(system.wall_bottom() + 0.1 * height, system.wall_top() - 0.1 * height);
        system.relax(state, RelaxOptions{}, 20000);
      },
      StabilityError);
}

}  // namespace
}  // namespace gel
