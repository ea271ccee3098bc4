// Hard cases: each must stay numerically stable with a checked outcome, or stop with the
// engine's documented StabilityError. (Longer stress runs: gelsim bench and compress.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "gel/bench_network.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

SimParams params_for(const char* preset, unsigned effects) {
  SimParams params;
  params.bond = bond_preset(preset);
  params.effects = effects;
  params.dt = params.dt_fraction * shortest_period(params.bond);
  return params;
}

TEST(HardCases, TimeStepAtTheVerletLimitRunsAndJustBeyondStops) {
  // A pair on its normal spring is one oscillator, omega = sqrt(2 k_N/m); velocity Verlet is
  // stable for omega dt < 2 and grows by |lambda| ~ 1 + sqrt(8 eps) per step beyond it.
  SimParams params = params_for("bond1", kNormalSpring);
  const double limit = 2.0 / std::sqrt(2.0 * params.bond.k_normal / kMass);
  params.dt = 0.98 * limit;
  System stable(pair_along_x(0.01), params);
  double largest_gap = 0;
  for (int k = 0; k < 20000; ++k) {
    stable.step();
    const double dx = stable.x()[1] - stable.x()[0];
    largest_gap = std::max(largest_gap, std::abs(dx - kDiameter));
  }
  // Near the limit Verlet's amplitude in position is inflated by 1/sqrt(1 - (omega dt/2)^2)
  // ~ 5 at 0.98 of the limit, but stays bounded.
  EXPECT_LT(largest_gap, 0.1);

  params.dt = 1.02 * limit;
  System unstable(pair_along_x(0.01), params);
  EXPECT_THROW(unstable.run(20000), StabilityError);
}

// A particle in a hexagon of six neighbours, every contact compressed by `overlap`.
Configuration pressed_hexagon(double overlap) {
  Configuration config;
  config.lx = config.ly = 40;
  config.periodic_y = false;
  const double r = kDiameter - overlap;
  config.add_particle(20, 20);
  for (int c = 0; c < 6; ++c) config.add_particle(20 + r * std::cos(c * kPi / 3), 20 + r * std::sin(c * kPi / 3));
  for (int c = 1; c <= 6; ++c) {
    config.add_bond_at_contact(0, c);
    config.add_bond_at_contact(c, c % 6 + 1);  // neighbours on the hexagon are 2a - overlap apart too
  }
  return config;
}

TEST(HardCases, ManyStiffContactsOnOneParticleStopTheRunWhereOneAloneWouldNot) {
  // Each contact at overlap 0.1 a has k_c = k_N + 3 C delta^2. With dt set so that one contact's
  // pair mode sits at omega dt = 1 (stable), the centre particle carries six of them: its
  // Gershgorin bound (1 + sqrt 2) 6 k_c / m gives omega dt = 2.7 > 2, and the guard must say so
  // at its first check instead of letting the mode grow.
  constexpr double kOverlap = 0.1;
  SimParams params = params_for("bond1", kNormalSpring | kOverlapRepulsion);
  const double k_contact = params.bond.k_normal + 3 * params.bond.overlap_coefficient * kOverlap * kOverlap;
  params.dt = 1.0 / std::sqrt(2.0 * k_contact / kMass);
  // Held in place: each outer particle is pushed out by the centre and, radially by the same
  // amount in sum, by its two hexagon neighbours; a load of twice the contact force holds it.
  const double contact_force = params.bond.k_normal * kOverlap + params.bond.overlap_coefficient * std::pow(kOverlap, 3);
  auto hold = [&](System& system) {
    for (int c = 0; c < 6; ++c)
      system.set_external_force(c + 1, -2 * contact_force * std::cos(c * kPi / 3), -2 * contact_force * std::sin(c * kPi / 3));
  };
  System unstable(pressed_hexagon(kOverlap), params);
  hold(unstable);
  try {
    unstable.run(params.guard_interval);
    ADD_FAILURE() << "no StabilityError within one guard interval";
  } catch (const StabilityError& error) {
    EXPECT_NE(std::string(error.what()).find("the contacts of particle 0"), std::string::npos) << error.what();
  }
  // Where the bound is 1.9 the same scene passes four checks. (Not many more: a particle pressed
  // from six sides is a buckling, physically unstable equilibrium that roundoff starts.)
  params.dt = 1.9 / std::sqrt((1 + std::sqrt(2.0)) * 6 * k_contact / kMass);
  System stable(pressed_hexagon(kOverlap), params);
  hold(stable);
  EXPECT_NO_THROW(stable.run(4 * params.guard_interval));
}

TEST(HardCases, OverlapInTheCubicRangeSettlesAtTheAnalyticOverlap) {
  // Two particles pressed together by 50 F0 settle where k_N delta + C delta^3 = -50 (delta < 0),
  // deep in the cubic term's range (|delta| ~ 0.085 a vs delta_c = 0.05 a).
  const double load = 50.0;
  SimParams params = params_for("bond1", kNormalSpring | kOverlapRepulsion | kDrag);
  System system(pair_along_x(0.0), params);
  system.set_external_force(0, load, 0);
  system.set_external_force(1, -load, 0);
  system.run(20000);
  // Newton on k delta + C delta^3 + F = 0.
  double expected = -0.08;
  for (int k = 0; k < 50; ++k) {
    const double f = params.bond.k_normal * expected + params.bond.overlap_coefficient * std::pow(expected, 3) + load;
    const double df = params.bond.k_normal + 3 * params.bond.overlap_coefficient * expected * expected;
    expected -= f / df;
  }
  const double gap = system.x()[1] - system.x()[0] - kDiameter;
  EXPECT_NEAR(gap, expected, 1e-9);
  EXPECT_LT(system.max_speed(), 1e-9);
}

TEST(HardCases, TinyStressOnAChainSpanningTheWalls) {
  // A straight vertical chain of n particles between the walls, compressed by 1e-7 a: the
  // n - 1 normal springs in series carry F = k_N 1e-7 / (n - 1), and P = F / (2a L_x) ~ 1e-9.
  const int n = 9;
  const Configuration config = vertical_chain(n, 30);
  SimParams params = params_for("bond1", kAllEffects & ~kBondCreation);
  System system(config, params);
  system.install_walls();
  const double squeeze = 1e-7;
  system.translate_wall_group(kTopWall, -squeeze);
  system.set_wall_velocities(0, 0);
  system.run(40000);
  const double force = params.bond.k_normal * squeeze / (n - 1);
  const double expected = force / (kThickness * config.lx);
  const WallStress stress = system.wall_stress();
  EXPECT_NEAR(stress.p_top / expected, 1.0, 1e-4);
  EXPECT_NEAR(stress.p_bottom / expected, 1.0, 1e-4);
}

TEST(HardCases, ExtremeStiffnessRatiosStayStableAndBalanceEnergy) {
  for (const double ratio : {1e-3, 1e3}) {
    SimParams params = params_for("bond1", kAllEffects & ~(kWalls | kThresholds));
    params.bond.k_normal = ratio * params.bond.k_rolling;  // k_N a^2 / k_R
    params.dt = params.dt_fraction * shortest_period(params.bond);
    System system(random_network(150, 21), params);
    std::mt19937_64 rng(5);
    std::normal_distribution<double> kick(0.0, 0.02);
    for (std::int32_t i = 0; i < 150; ++i) system.set_velocity(i, kick(rng), kick(rng), kick(rng));
    const double start = system.kinetic_energy() + system.stored_energy();
    ASSERT_NO_THROW(system.run(5000)) << "k_N/k_R = " << ratio;
    const EnergyLedger& e = system.energy();
    const double now = system.kinetic_energy() + system.stored_energy() + e.drag + e.dissipated - e.created;
    // Drag is integrated by the trapezoidal rule: O(dt^2) relative error.
    EXPECT_NEAR(now / start, 1.0, 2e-2) << "k_N/k_R = " << ratio;
  }
}

TEST(HardCases, ParticlesExactlyOnThePeriodicBoundary) {
  // One particle at x = 0 and one at x = L_x - 2a touch across the boundary; a particle at
  // x = L_x is the same point as x = 0.
  Configuration config;
  config.lx = 20;
  config.ly = 20;
  config.add_particle(0.0, 10);
  config.add_particle(config.lx - kDiameter, 10);
  config.add_particle(config.lx, 4);
  SimParams params = params_for("bond1", kAllEffects & ~kWalls);
  System system(config, params);
  system.run(10);
  ASSERT_EQ(system.bonds().size(), 1u);
  EXPECT_EQ(system.events().created, 1);
  for (std::size_t i = 0; i < system.size(); ++i) {
    EXPECT_TRUE(std::isfinite(system.x()[i]));
    EXPECT_GE(system.x()[i], -1e-6);
    EXPECT_LT(system.x()[i], config.lx + 1e-6);
  }
  EXPECT_LT(system.stored_energy(), 1e-6);
}

TEST(HardCases, AWallTouchingManyParticlesAtOnce) {
  // A whole row at the same height sticks to the bottom wall in the same step.
  Configuration config;
  config.lx = 60;
  config.ly = 40;
  for (int k = 0; k < 30; ++k) config.add_particle(1 + kDiameter * k, 3);
  for (int k = 0; k + 1 < 30; ++k) config.add_bond_at_contact(k, k + 1);
  config.add_bond_at_contact(29, 0);  // closes the row across the periodic boundary
  config.add_particle(30, 20);
  System system(config, params_for("bond1", kAllEffects));
  system.install_walls();
  int stuck = 0;
  for (std::size_t i = 0; i < 30; ++i) stuck += system.wall_side(i) == kBottomWall;
  EXPECT_EQ(stuck, 30);
  system.set_wall_velocities(0.05, -0.05);
  system.run(2000);
  for (std::size_t i = 0; i < 30; ++i) EXPECT_NEAR(system.y()[i] - system.wall_bottom(), kRadius, 1e-12);
  EXPECT_LT(system.stored_energy(), 1e-20);  // the row moves rigidly: no strain
}

TEST(HardCases, Bond2CompressedBeyondPhi08StaysFiniteWithBoundedOverlap) {
  SimParams params = params_for("bond2", kAllEffects);
  System system(random_network(200, 13), params);
  system.install_walls();
  const double v = 0.05;
  system.set_wall_velocities(v, -v);
  const double target = 0.8;
  // The walls close the box at 2 v per unit time; the cap fails walls that stopped moving.
  for (int chunk = 0; system.packing_fraction() < target; ++chunk) {
    ASSERT_LT(chunk, 10000) << "phi stuck at " << system.packing_fraction();
    ASSERT_NO_THROW(system.run(500));
  }
  system.set_wall_velocities(0, 0);
  system.run(20000);
  double worst_overlap = 0;
  for (const Bond& bond : system.bonds()) {
    const double dx = system.x()[bond.j] + bond.shift_x - system.x()[bond.i];
    const double dy = system.y()[bond.j] + bond.shift_y - system.y()[bond.i];
    worst_overlap = std::max(worst_overlap, kDiameter - std::sqrt(dx * dx + dy * dy));
  }
  EXPECT_GT(system.packing_fraction(), target);
  EXPECT_LT(worst_overlap, params.max_overlap);
  EXPECT_TRUE(std::isfinite(system.wall_stress().p));
  EXPECT_GT(system.wall_stress().p, 0.0);
}

}  // namespace
}  // namespace gel
