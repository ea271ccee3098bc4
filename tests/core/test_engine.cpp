// Engine tests against analytic solutions and conservation laws (MODEL.md). Tolerances are
// stated where they are set: velocity Verlet has O((omega dt)^2) phase and energy errors, so
// with omega dt ~ 0.07 (dt_fraction 0.025 of bond1) relative errors of ~1e-3 are expected.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gel/bench_network.hpp"
#include "gel/bond_evaluator.hpp"
#include "gel/bending.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "same_bits.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

TEST(Engine, BondedPairOscillatesAtTheNormalSpringFrequency) {
  SimParams params = bond1_params(kNormalSpring);
  System system(bonded_pair(0.01), params);
  // Relative coordinate: (m/2) delta'' = -k_N delta, omega = sqrt(2 k_N / m).
  const double omega = std::sqrt(2.0 * params.bond.k_normal / kMass);
  const double expected_period = 2.0 * kPi / omega;
  // Time between the first and the eleventh downward zero crossing, interpolated.
  std::vector<double> crossings;
  double previous = pair_gap(system), previous_time = 0;
  // Eleven crossings take about 10 periods = 10 / (dt_fraction = 0.025) = 400 steps per period;
  // the cap fails a broken spring instead of looping for ever.
  for (int step = 0; crossings.size() < 11; ++step) {
    ASSERT_LT(step, 100000) << "only " << crossings.size() << " zero crossings";
    system.step();
    const double gap = pair_gap(system);
    if (previous > 0 && gap <= 0)
      crossings.push_back(previous_time + (system.time() - previous_time) * previous / (previous - gap));
    previous = gap;
    previous_time = system.time();
  }
  const double period = (crossings.back() - crossings.front()) / 10.0;
  // Verlet's frequency error is (omega dt)^2/24 ~ 2e-4 here.
  EXPECT_NEAR(period / expected_period, 1.0, 1e-3);
}

TEST(Engine, DragAtEtaCdCriticallyDampsTheRollingStiffness) {
  // eta_cd makes the translational drag 2 sqrt(k_R m): the critical damping of a mass m on the
  // rolling stiffness k_R/a^2. A pair whose normal spring is k_R/(2a^2) has exactly that mode
  // in its relative coordinate ((m/2) delta'' + (gamma/2) delta' + k delta = 0), so at
  // eta = eta_cd the gap relaxes as (1 + w t) e^(-w t), w = sqrt(k_R/m), without overshoot.
  SimParams params = bond1_params(kNormalSpring | kDrag);
  params.bond.k_normal = 0.5 * params.bond.k_rolling;
  params.eta_factor = 1.0;
  const double gap0 = 0.01;
  System critical(bonded_pair(gap0), params);
  const double w = std::sqrt(params.bond.k_rolling / kMass);
  double worst = 0, min_gap = gap0;
  for (int k = 0; k < 2000; ++k) {
    critical.step();
    const double t = critical.time();
    worst = std::max(worst, std::abs(pair_gap(critical) - gap0 * (1 + w * t) * std::exp(-w * t)));
    min_gap = std::min(min_gap, pair_gap(critical));
  }
  EXPECT_LT(worst, 5e-3 * gap0);  // O((w dt)^2) with w dt = 0.05
  EXPECT_GT(min_gap, -1e-6 * gap0);

  // Just under critical, the gap must overshoot through zero; just over, it must not.
  params.eta_factor = 0.8;
  System under(bonded_pair(gap0), params);
  double under_min = gap0;
  for (int k = 0; k < 3000; ++k) {
    under.step();
    under_min = std::min(under_min, pair_gap(under));
  }
  EXPECT_LT(under_min, -1e-4 * gap0);
}

TEST(Engine, RigidRotationOfAPairGivesNoSlidingAndNoBending) {
  const double alpha = 0.3;
  Configuration config = bonded_pair(0.0);
  // Rotate positions about the pair's centre and both orientations by alpha.
  const double cx = 0.5 * (config.x[0] + config.x[1]), cy = config.y[0];
  for (int i = 0; i < 2; ++i) {
    const double dx = config.x[i] - cx, dy = config.y[i] - cy;
    config.x[i] = cx + std::cos(alpha) * dx - std::sin(alpha) * dy;
    config.y[i] = cy + std::sin(alpha) * dx + std::cos(alpha) * dy;
    config.theta[i] += alpha;
  }
  System system(config, bond1_params(kSprings));
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(system.fx()[i], 0.0, 1e-12);
    EXPECT_NEAR(system.fy()[i], 0.0, 1e-12);
    EXPECT_NEAR(system.torque()[i], 0.0, 1e-12);
  }
  EXPECT_NEAR(system.stored_energy(), 0.0, 1e-24);
}

TEST(Engine, CounterRotationIsPureRolling) {
  const double alpha = 0.01;  // bending angle phi = -2 alpha, below phi_c
  System system(bonded_pair(0.0, alpha, -alpha), bond1_params(kSprings));
  const BondLaw law = bond_preset("bond1");
  // No sliding force: the net force on each particle vanishes.
  EXPECT_NEAR(system.fx()[0], 0.0, 1e-12);
  EXPECT_NEAR(system.fy()[0], 0.0, 1e-12);
  // M_R = k_R a^2 phi on i, -M_R on j.
  const double phi = -std::asin(std::sin(2 * alpha));
  EXPECT_NEAR(system.torque()[0], law.k_rolling * phi, 1e-12);
  EXPECT_NEAR(system.torque()[1], -law.k_rolling * phi, 1e-12);
  EXPECT_NEAR(system.stored_energy(), 0.5 * law.k_rolling * phi * phi, 1e-14);
}

TEST(Engine, CoRotationIsPureSliding) {
  const double alpha = 0.01;
  System system(bonded_pair(0.0, alpha, alpha), bond1_params(kSprings));
  const BondLaw law = bond_preset("bond1");
  // d = -2 a sin(alpha) t (t = e_y here): F_T on i = k_S d, on j opposite; torques equal.
  const double d = -2.0 * kRadius * std::sin(alpha);
  EXPECT_NEAR(system.fx()[0], 0.0, 1e-12);
  EXPECT_NEAR(system.fy()[0], law.k_sliding * d, 1e-12);
  EXPECT_NEAR(system.fy()[1], -law.k_sliding * d, 1e-12);
  EXPECT_NEAR(system.torque()[0], system.torque()[1], 1e-12);
  EXPECT_NEAR(system.torque()[0], kRadius * law.k_sliding * d, 1e-12);
  EXPECT_NEAR(system.stored_energy(), 0.5 * law.k_sliding * d * d, 1e-14);
}

// Largest deviation of the total energy from its start over a run of fixed duration.
double energy_drift(double dt, double duration) {
  // Normal, overlap and rolling forces derive exactly from the bond energy; the sliding law
  // F_T = k_S d is only the small-strain gradient of k_S |d|^2/2, so it is left out here.
  SimParams params = bond1_params(kNormalSpring | kOverlapRepulsion | kRolling | kPeriodicX);
  params.dt = dt;
  System system(random_network(60, 3), params);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> thermal(0.0, 0.05);
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(system.size()); ++i)
    system.set_velocity(i, thermal(rng), thermal(rng), thermal(rng));
  auto total = [&] { return system.kinetic_energy() + system.stored_energy(); };
  const double start = total();
  double worst = 0;
  const auto steps = static_cast<std::int64_t>(std::llround(duration / dt));
  for (std::int64_t k = 0; k < steps; ++k) {
    system.step();
    worst = std::max(worst, std::abs(total() - start));
  }
  return worst / start;
}

TEST(Engine, EnergyIsConservedToSecondOrderInTheTimeStep) {
  const double dt = 0.02;
  const double coarse = energy_drift(dt, 20.0);
  const double fine = energy_drift(dt / 2, 20.0);
  EXPECT_LT(coarse, 1e-2);
  // Halving dt divides a second-order error by 4 (3 to 5.5 allows for the fluctuation).
  EXPECT_GT(coarse / fine, 3.0);
  EXPECT_LT(coarse / fine, 5.5);
}

TEST(Engine, SlowPullBreaksTheBondAtTheCriticalForce) {
  SimParams params = bond1_params(kSprings | kThresholds | kDrag);
  System system(bonded_pair(0.0), params);
  const double rate = 1e-4;  // F0 per t0: quasi-static against the relaxation time ~1 t0
  double force_at_break = -1;
  while (system.events().normal == 0 && system.time() < 2e4) {
    const double force = rate * system.time();
    system.set_external_force(0, -force, 0);
    system.set_external_force(1, force, 0);
    system.step();
    if (system.events().normal > 0) force_at_break = force;
  }
  ASSERT_EQ(system.events().normal, 1);
  EXPECT_TRUE(system.bonds().empty());
  // The bond force lags the load by about rate * relaxation time, and the load grows by
  // rate * dt per step.
  EXPECT_NEAR(force_at_break, params.bond.f_normal_critical, 2e-3);
}

TEST(Engine, ResetMovesStoredTangentialEnergyToDissipated) {
  const BondLaw law = bond_preset("bond1");
  const double alpha = 0.04;  // counter-rotation: phi = -0.08 rad, M_R = 1.6 > M_Rc = 1
  System system(bonded_pair(0.0, alpha, -alpha), bond1_params(kSprings | kThresholds));
  const double phi = 2 * alpha;
  const double released = 0.5 * law.k_rolling * phi * phi;  // phi = -asin(sin 2 alpha)
  EXPECT_EQ(system.events().rolling, 1);
  EXPECT_EQ(system.events().sliding, 0);
  EXPECT_EQ(system.bonds().size(), 1u);
  EXPECT_NEAR(system.energy().dissipated, released, 1e-12);
  EXPECT_NEAR(system.stored_energy(), 0.0, 1e-20);
  EXPECT_NEAR(system.torque()[0], 0.0, 1e-12);
}

TEST(Engine, PeriodicImagesAcrossXGiveTheSameForces) {
  const unsigned effects = kSprings | kPeriodicX;
  Configuration inside = bonded_pair(0.003, 0.01, -0.02);
  inside.periodic_y = true;
  inside.y[1] += 0.4;  // an oblique bond
  Configuration wrapped = inside;
  // Shift the pair so it straddles x = 0: particle 0 just left of L_x, particle 1 across.
  const double shift = inside.lx - inside.x[0] - 0.7;
  for (double& x : wrapped.x) x = std::fmod(x + shift, wrapped.lx);
  ASSERT_LT(wrapped.x[1], wrapped.x[0]);
  System a(inside, bond1_params(effects)), b(wrapped, bond1_params(effects));
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(a.fx()[i], b.fx()[i], 1e-12);
    EXPECT_NEAR(a.fy()[i], b.fy()[i], 1e-12);
    EXPECT_NEAR(a.torque()[i], b.torque()[i], 1e-12);
  }
  EXPECT_NEAR(a.stored_energy(), b.stored_energy(), 1e-14);
}

TEST(Engine, AParticleTouchingAWallMovesWithItFromThenOn) {
  Configuration config;
  config.lx = 20;
  config.ly = 20;
  config.periodic_y = true;
  config.add_particle(5, 2, 0);   // lowest: the bottom wall starts touching it
  config.add_particle(10, 12, 0);  // highest: the top wall
  config.add_particle(15, 5, 0);  // free, 2 a above the bottom wall
  System system(config, bond1_params(kAllEffects));
  system.install_walls();
  ASSERT_EQ(system.wall_side(0), kBottomWall);
  ASSERT_EQ(system.wall_side(1), kTopWall);
  ASSERT_EQ(system.wall_side(2), kNoWall);
  const double v = 0.05;
  system.set_wall_velocities(v, 0.0);
  while (system.wall_side(2) == kNoWall && system.time() < 200) system.step();
  ASSERT_EQ(system.wall_side(2), kBottomWall);
  const double offset = system.y()[2] - system.wall_bottom();
  EXPECT_NEAR(offset, kRadius, v * system.params().dt + 1e-12);
  const double x_attached = system.x()[2];
  system.run(500);
  EXPECT_NEAR(system.y()[2] - system.wall_bottom(), offset, 1e-12);
  EXPECT_EQ(system.x()[2], x_attached);
  EXPECT_DOUBLE_EQ(system.vy()[2], v);
  EXPECT_EQ(system.omega()[2], 0.0);
}

TEST(Engine, ContactCreatesABondAtTheLineOfCentres) {
  Configuration config;
  config.lx = config.ly = 30;
  config.add_particle(10, 10, 0.3);
  config.add_particle(13, 10, -1.1);
  // No drag, so the approach speed stays 0.1 a/t0 and the overshoot past contact is v dt.
  System system(config, bond1_params(kAllEffects & ~(kWalls | kDrag)));
  system.set_velocity(0, 0.05, 0, 0);
  system.set_velocity(1, -0.05, 0, 0);
  while (system.bonds().empty() && system.time() < 100) system.step();
  ASSERT_EQ(system.bonds().size(), 1u);
  EXPECT_EQ(system.events().created, 1);
  EXPECT_LE(pair_gap(system), 0.0);
  EXPECT_GT(pair_gap(system), -0.1 * system.params().dt - 1e-12);
  // At formation xi_ij = n: the contact point of particle 0 points at particle 1.
  const Bond& bond = system.bonds()[0];
  const double theta0 = system.theta(bond.i);
  EXPECT_NEAR(std::cos(theta0) * bond.bix - std::sin(theta0) * bond.biy, bond.i == 0 ? 1.0 : -1.0, 1e-9);
  EXPECT_GE(system.energy().created, 0.0);
}

TEST(Engine, BendingRecoversUnderASmallForceAndStaysBentUnderALargeOne) {
  SimParams params = bond1_params(bending_effects());
  BendingOptions options;
  options.force = 0.15;
  const BendingResult elastic = run_bending(params, options);
  EXPECT_TRUE(elastic.recovered);
  EXPECT_EQ(elastic.events.rolling, 0);
  EXPECT_GT(elastic.max_deflection, 0.3);
  options.force = 0.35;
  const BendingResult plastic = run_bending(params, options);
  EXPECT_FALSE(plastic.recovered);
  EXPECT_GT(plastic.events.rolling, 0);
  EXPECT_GT(std::abs(plastic.residual_deflection), 0.1);
}

TEST(Engine, SmallBendingDeflectionMatchesTheSpringChainFormula) {
  // A chain of 2k bonds under three-point loading: the joint at distance (2k+1)a from an
  // end carries the moment (F/2)(2k+1)a and the shear F/2. Summing rolling rotations times
  // lever arms and sliding offsets over the 5 joints of each half (11 particles):
  // w = F [ (1 + 9 + 25 + 49 + 81) a^2 / (2 k_R a^2) + 5 / (2 k_S) ].
  SimParams params = bond1_params(bending_effects());
  BendingOptions options;
  options.force = 0.02;
  const BendingResult result = run_bending(params, options);
  const double expected = options.force * (165.0 / (2 * params.bond.k_rolling) + 5.0 / (2 * params.bond.k_sliding));
  // Geometric nonlinearity is of order (w/L)^2 ~ 1e-4; the equilibrium tolerance is 1e-7.
  EXPECT_NEAR(result.loaded_deflection / expected, 1.0, 2e-3);
}

TEST(Engine, StabilityGuardStopsATooLargeTimeStep) {
  SimParams params = bond1_params(kAllEffects & ~kWalls);
  params.dt = 2.5 * shortest_period(params.bond);  // far beyond the Verlet limit
  System system(random_network(100, 5), params);
  for (std::int32_t i = 0; i < 100; ++i) system.set_velocity(i, 0.01 * (i % 7), -0.01 * (i % 5), 0.0);
  try {
    system.run(10000);
    FAIL() << "the run should have stopped";
  } catch (const StabilityError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("step "), std::string::npos) << message;
    EXPECT_TRUE(message.find("particle") != std::string::npos || message.find("bond") != std::string::npos) << message;
  }
}

TEST(Engine, TurningAnEffectOffChangesOnlyWhatItShould) {
  Configuration config = random_network(200, 11);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> turn(-0.02, 0.02);
  for (double& theta : config.theta) theta += turn(rng);
  const unsigned all = kSprings | kPeriodicX;
  System reference(config, bond1_params(all));
  System no_rolling(config, bond1_params(all & ~kRolling));
  System no_sliding(config, bond1_params(all & ~kSliding));
  double torque_change = 0, sliding_force_change = 0;
  for (std::size_t i = 0; i < config.size(); ++i) {
    // Rolling acts only through moments: forces are untouched.
    EXPECT_EQ(reference.fx()[i], no_rolling.fx()[i]);
    EXPECT_EQ(reference.fy()[i], no_rolling.fy()[i]);
    torque_change += std::abs(reference.torque()[i] - no_rolling.torque()[i]);
    sliding_force_change += std::abs(reference.fx()[i] - no_sliding.fx()[i]);
  }
  EXPECT_GT(torque_change, 1e-3);
  EXPECT_GT(sliding_force_change, 1e-3);
  // The sliding law alone accounts for the difference in stored energy.
  EXPECT_GT(reference.stored_energy(), no_sliding.stored_energy());
}

TEST(Engine, SavedStateResumesBitForBit) {
  SimParams params = bond1_params(kAllEffects);
  System original(random_network(300, 2), params);
  original.install_walls();
  original.set_wall_velocities(0.02, -0.02);
  original.run(300);
  System resumed = System::load_state(original.save_state());
  original.run(700);
  resumed.run(700);
  EXPECT_EQ(original.x(), resumed.x());
  EXPECT_EQ(original.vy(), resumed.vy());
  EXPECT_EQ(original.bonds().size(), resumed.bonds().size());
  EXPECT_EQ(original.energy().dissipated, resumed.energy().dissipated);
  EXPECT_EQ(original.wall_stress().p, resumed.wall_stress().p);
}

// Threads change who computes what, never the order of any sum (bond_kernels.hpp), so runs are
// bit-identical for any number of threads, and a run may change its number midway. The scene is
// large enough for several bond chunks and particle blocks, and compressed fast enough that bonds
// break, reset and form while it runs (the exact path and the rebuilt incidence lists).
TEST(Engine, AnyNumberOfThreadsGivesTheSameBits) {
  SimParams params = bond1_params(kAllEffects);
  auto run = [&](const std::vector<int>& threads_per_segment) {
    System system(random_network(1500, 4), params);
    system.install_walls();
    system.set_wall_velocities(0.05, -0.05);
    for (const int threads : threads_per_segment) {
      system.set_threads(threads);
      system.run(600);
    }
    return system;
  };
  const System serial = run({1, 1, 1});
  ASSERT_GT(serial.events().normal + serial.events().sliding + serial.events().rolling, 0);
  ASSERT_GT(serial.events().created, 0);
  for (const auto& segments : std::vector<std::vector<int>>{{2, 2, 2}, {3, 1, 2}}) {
    expect_same_bits(run(segments), serial);
  }
  System system(random_network(10, 1), params);
  EXPECT_THROW(system.set_threads(0), InvalidArgument);
}

TEST(Engine, WallCompressionBalancesEnergy) {
  // Stored + dissipated + kinetic + drag + absorbed = wall work + energy of formation,
  // up to the trapezoidal quadrature of the wall work and drag: O(dt^2) per unit time.
  SimParams params = bond1_params(kAllEffects);
  System system(random_network(400, 9), params);
  system.install_walls();
  system.set_wall_velocities(0.02, -0.02);
  system.run(20000);
  const EnergyLedger& e = system.energy();
  const double input = e.wall_work + e.created;
  const double accounted = system.stored_energy() + e.dissipated + system.kinetic_energy() + e.drag + e.absorbed_by_walls;
  ASSERT_GT(input, 1e-3);
  EXPECT_NEAR(accounted / input, 1.0, 1e-2);
}

TEST(Engine, InvalidParametersAreRejectedByName) {
  gel::v1::Scene scene;
  scene.mutable_bond()->set_preset("bond1");
  scene.mutable_bond()->set_k_normal(-3);
  try {
    resolve_sim_params(scene);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "bond.k_normal");
  }
  scene.mutable_bond()->set_k_normal(std::nan(""));
  EXPECT_THROW(resolve_sim_params(scene), InvalidArgument);
  scene.mutable_bond()->set_k_normal(0);
  scene.add_effects("gravity");
  try {
    resolve_sim_params(scene);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "effects");
  }
  // Two particles overlapping by more than the overlap term can resolve.
  Configuration config;
  config.lx = config.ly = 20;
  config.add_particle(5, 5);
  config.add_particle(5.8, 5);
  try {
    System system(config, bond1_params(kAllEffects & ~kWalls));
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "configuration");
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos);
  }
}

TEST(Engine, BenchNetworkIsConnectedWithAboutTwoBondsPerParticle) {
  const Configuration config = random_network(2000, 4);
  EXPECT_NEAR(config.packing_fraction(), 0.12, 1e-9);
  EXPECT_NEAR(config.mean_contact_number(), 2.0, 0.01);  // a tree: N - 1 bonds
  std::vector<int> component(config.size(), -1);
  std::vector<std::vector<int>> adjacency(config.size());
  for (const BondRecord& bond : config.bonds) {
    adjacency[bond.i].push_back(bond.j);
    adjacency[bond.j].push_back(bond.i);
  }
  std::vector<int> stack{0};
  component[0] = 0;
  std::size_t reached = 1;
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    for (int j : adjacency[i])
      if (component[j] < 0) {
        component[j] = 0;
        ++reached;
        stack.push_back(j);
      }
  }
  EXPECT_EQ(reached, config.size());
}

}  // namespace
}  // namespace gel

namespace gel {
namespace {
TEST(Engine, BendingAngleSeriesMatchesAsin) {
  // The short series must agree with std::asin to rounding (a few ulp) on both sides of its
  // cut-off, so the fast path never changes the physics.
  for (double x = -0.2; x <= 0.2; x += 1.0 / 4096) {
    const double reference = -std::asin(x);
    EXPECT_NEAR(bending_angle(x), reference, 4e-16 * std::max(std::abs(reference), 1e-300)) << "x = " << x;
  }
}
}  // namespace
}  // namespace gel
