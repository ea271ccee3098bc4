// One test per rule of MODEL.md that a wrong model could otherwise break unseen: each sets up the
// smallest scene where the rule alone decides the outcome and compares with the value MODEL.md
// gives, written out here from the specification's numbers (bond 1: k_N = k_S = 20 F0/a,
// k_R a^2 = 20 F0 a, C = 8e4 F0/a^3, F_Nc = F_Sc = 1 F0, M_Rc = 1 F0 a; paper protocol: A = 1e-2,
// B = 1e-3). Each was checked by breaking its rule in the code and watching it fail; the commit
// that added a test names the break it catches.
#include <gtest/gtest.h>

#include <cmath>

#include "gel/bond_evaluator.hpp"
#include "gel/compression.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

constexpr double kModelKNormal = 20.0;   // bond 1, F0/a
constexpr double kModelKSliding = 20.0;  // F0/a
constexpr double kModelOverlap = 8e4;    // C, F0/a^3
constexpr double kModelA = 1e-2;         // paper protocol, both bonds
constexpr double kModelB = 1e-3;         // paper protocol, bond 1

// F_N . n of MODEL.md: k_N delta + C theta(-delta) delta^3.
double model_normal_force(double delta) {
  return kModelKNormal * delta + (delta < 0 ? kModelOverlap * delta * delta * delta : 0.0);
}
// Its energy: k_N delta^2 / 2 + C theta(-delta) delta^4 / 4.
double model_normal_energy(double delta) {
  return 0.5 * kModelKNormal * delta * delta + (delta < 0 ? 0.25 * kModelOverlap * std::pow(delta, 4) : 0.0);
}

// ---------------------------------------------------------------------------------------
// Walls: P = (P_top + P_bot) / 2, P_top = F_wall,top / (2a L_x), P_bot = -F_wall,bot / (2a L_x).

// A particle stuck to one wall, bonded to a free particle that presses on it by an overlap of
// 0.01 a; nothing touches the other wall. Returns the system after its first force evaluation.
System one_wall_loaded(WallSide side) {
  Configuration config;
  config.lx = 20;
  config.ly = 40;
  config.periodic_y = false;
  config.wall_bottom = 0;
  config.wall_top = 30;
  const bool bottom = side == kBottomWall;
  config.add_particle(10, bottom ? 1.0 : 29.0);  // on its wall
  config.add_particle(10, bottom ? 3.0 : 27.0);  // free, at contact
  config.add_bond_at_contact(0, 1);
  config.y[1] += bottom ? -0.01 : 0.01;  // pressed into the wall particle by 0.01 a
  config.wall = {side, kNoWall};
  return System(config, bond1_params(kSprings | kWalls | kPeriodicX));
}

// The pressed pair pushes the loaded wall's particle into its wall with F_N (n points from it to
// the free particle, away from the wall): that wall's stress is -F_N / (2a L_x), the other's 0.
void expect_p_is_half_the_loaded_walls_stress(WallSide side) {
  const System system = one_wall_loaded(side);
  const WallStress stress = system.wall_stress();
  const double delta = std::abs(system.y()[1] - system.y()[0]) - kDiameter;
  const double expected = -model_normal_force(delta) / (kThickness * 20.0);
  ASSERT_GT(expected, 0.0);
  const double loaded = side == kBottomWall ? stress.p_bottom : stress.p_top;
  const double other = side == kBottomWall ? stress.p_top : stress.p_bottom;
  EXPECT_NEAR(loaded, expected, 1e-12 * expected);
  EXPECT_EQ(other, 0.0);
  EXPECT_EQ(stress.p, 0.5 * loaded);
}

TEST(ModelRules, ALoadOnTheBottomWallOnlyGivesHalfItsStressAsP) { expect_p_is_half_the_loaded_walls_stress(kBottomWall); }

TEST(ModelRules, ALoadOnTheTopWallOnlyGivesHalfItsStressAsP) { expect_p_is_half_the_loaded_walls_stress(kTopWall); }

// ---------------------------------------------------------------------------------------
// Bond creation happens only with the 'creation' effect, in the dynamics and in FIRE.

// Two free particles 1 a apart approaching at 0.1 a/t0, run until they would overlap by 0.1 a
// if nothing stopped them.
struct Approach {
  std::size_t bonds;
  std::int64_t created;
  double gap;  // at the end
};
Approach approach(unsigned effects) {
  Configuration config;
  config.lx = config.ly = 30;
  config.add_particle(10, 10, 0.3);
  config.add_particle(13, 10, -1.1);
  System system(config, bond1_params(effects));
  system.set_velocity(0, 0.05, 0, 0);
  system.set_velocity(1, -0.05, 0, 0);
  while (system.time() < 11.0) system.step();
  return {system.bonds().size(), system.events().created, pair_gap(system)};
}

TEST(ModelRules, ParticlesThatMeetBondOnlyWithTheCreationEffectInTheDynamics) {
  const unsigned dynamics = kAllEffects & ~(kWalls | kDrag);
  const Approach with = approach(dynamics);
  EXPECT_EQ(with.bonds, 1u);
  EXPECT_EQ(with.created, 1);
  const Approach without = approach(dynamics & ~kBondCreation);
  EXPECT_LT(without.gap, -0.05) << "the pair never came into contact";
  EXPECT_EQ(without.bonds, 0u);
  EXPECT_EQ(without.created, 0);
}

// A pair stretched by 0.04 a (below delta_c = 0.05 a) relaxes to contact; on the way its first
// particle moves 0.02 a along x and comes within 2a of a third, unbonded particle C.
struct RelaxedTriple {
  std::size_t bonds;
  std::int64_t created;
  double distance_to_c;  // first particle to C, after relaxation
};
RelaxedTriple relax_triple(unsigned effects) {
  Configuration config;
  config.lx = config.ly = 40;
  config.periodic_y = false;
  config.add_particle(10, 10);
  config.add_particle(12, 10);
  config.add_bond_at_contact(0, 1);
  config.x[1] += 0.04;
  config.add_particle(11, 11.74);  // 2.0069 a from particle 0 now, 1.9970 a from where it ends
  System system(config, bond1_params(effects));
  EXPECT_EQ(system.bonds().size(), 1u);
  RelaxState state;
  EXPECT_TRUE(system.relax(state, RelaxOptions{}, 100000));
  const double dx = system.x()[2] - system.x()[0], dy = system.y()[2] - system.y()[0];
  return {system.bonds().size(), system.events().created, std::sqrt(dx * dx + dy * dy)};
}

TEST(ModelRules, ParticlesThatMeetBondOnlyWithTheCreationEffectInFire) {
  const unsigned springs = kSprings | kThresholds;
  const RelaxedTriple without = relax_triple(springs);
  EXPECT_LT(without.distance_to_c, kDiameter - 1e-3) << "the relaxation never brought C into contact";
  EXPECT_EQ(without.bonds, 1u);
  EXPECT_EQ(without.created, 0);
  const RelaxedTriple with = relax_triple(springs | kBondCreation);
  EXPECT_EQ(with.bonds, 2u);
  EXPECT_EQ(with.created, 1);
}

// ---------------------------------------------------------------------------------------
// FIRE converges on torques too: a pure rolling pre-strain (counter-rotation, d = 0, so every
// force is zero) must relax to zero bending angle.

TEST(ModelRules, FireRelaxesAPureRollingPreStrainToZeroAngle) {
  const double alpha = 0.01;  // phi = -asin(sin 2 alpha) = -0.02 rad, below phi_c = 0.05
  System system(bonded_pair(0.0, alpha, -alpha), bond1_params(kSprings | kThresholds));
  auto bending = [&] {
    const Bond& bond = system.bonds().at(0);
    const double ci = std::cos(system.theta(0)), si = std::sin(system.theta(0));
    const double cj = std::cos(system.theta(1)), sj = std::sin(system.theta(1));
    const double xi_ix = ci * bond.bix - si * bond.biy, xi_iy = si * bond.bix + ci * bond.biy;
    const double xi_jx = cj * bond.bjx - sj * bond.bjy, xi_jy = sj * bond.bjx + cj * bond.bjy;
    return -std::asin(xi_ix * xi_jy - xi_iy * xi_jx);
  };
  ASSERT_NEAR(bending(), -2 * alpha, 1e-12);
  ASSERT_NEAR(std::hypot(system.fx()[0], system.fy()[0]), 0.0, 1e-12);  // no force: only torque
  RelaxState state;
  ASSERT_TRUE(system.relax(state, RelaxOptions{}, 100000));
  EXPECT_GT(state.iterations, 0);
  // Converged at |T|/a below the 1e-9 F0 floor: |phi| = |T| / (k_R a^2) below 5e-11.
  EXPECT_LT(std::abs(bending()), 1e-9);
  EXPECT_EQ(system.events().rolling, 0);
}

// ---------------------------------------------------------------------------------------
// The equilibrium test (paper, bond 1: A = 1e-2, B = 1e-3): |P_top - P_bot| / P < A,
// |P - P'| / P < B with P = (P_top + P_bot) / 2, and no rupture since P'.

gel::v1::Compression paper_bond1_protocol() {
  gel::v1::Scene scene = scene_preset("paper-bond1");
  scene.mutable_compression()->set_fidelity("paper");
  const gel::v1::Compression c = resolve_compression_scene(scene).compression();
  EXPECT_EQ(c.a_tolerance(), kModelA);
  EXPECT_EQ(c.b_tolerance(), kModelB);
  return c;
}

EquilibriumSample balanced(double p, double previous_p) {
  EquilibriumSample sample;
  sample.p_top = sample.p_bot = p;
  sample.previous_p = previous_p;
  sample.max_speed = 1.0;  // above the stress floor speed is not a criterion
  return sample;
}

TEST(ModelRules, TheDriftTestIsRelativeToPNotToThePreviousP) {
  const gel::v1::Compression c = paper_bond1_protocol();
  // |P - P'| / P and |P - P'| / P' on opposite sides of B: d / 1 < B < d / (1 - d).
  const double below = kModelB / (1 + 0.5 * kModelB);
  ASSERT_LT(below / 1.0, kModelB);
  ASSERT_GT(below / (1.0 - below), kModelB);
  EXPECT_TRUE(equilibrium_reached(balanced(1.0, 1.0 - below), c));
  // And the mirror: d / 1 > B > d / (1 + d).
  const double above = kModelB / (1 - 0.5 * kModelB);
  ASSERT_GT(above / 1.0, kModelB);
  ASSERT_LT(above / (1.0 + above), kModelB);
  EXPECT_FALSE(equilibrium_reached(balanced(1.0, 1.0 + above), c));
}

TEST(ModelRules, TheBalanceTestUsesAAndTheDriftTestUsesB) {
  const gel::v1::Compression c = paper_bond1_protocol();
  // Unbalanced by half of A (five times B), steady: at equilibrium.
  EquilibriumSample unbalanced = balanced(1.0, 1.0);
  unbalanced.p_top = 1.0 + 0.25 * kModelA;
  unbalanced.p_bot = 1.0 - 0.25 * kModelA;
  EXPECT_TRUE(equilibrium_reached(unbalanced, c));
  // Balanced but drifting by half of A (five times B): not at equilibrium.
  EXPECT_FALSE(equilibrium_reached(balanced(1.0, 1.0 - 0.5 * kModelA), c));
}

TEST(ModelRules, TheEquilibriumTestTakesPAsTheMeanOfBothWalls) {
  const gel::v1::Compression c = paper_bond1_protocol();
  // P_top and P_bot 0.8 A apart around P = P' = 1: the mean has not moved, though each wall
  // alone is 4 B from P'.
  EquilibriumSample sample = balanced(1.0, 1.0);
  sample.p_top = 1.0 + 0.4 * kModelA;
  sample.p_bot = 1.0 - 0.4 * kModelA;
  EXPECT_TRUE(equilibrium_reached(sample, c));
  // The mirror: the bottom wall still at P', the top wall 3 B above it: the mean moved 1.5 B.
  sample.p_bot = 1.0;
  sample.p_top = 1.0 + 3 * kModelB;
  EXPECT_FALSE(equilibrium_reached(sample, c));
  // The top wall at P', the bottom wall 1.6 B below it: the mean moved 0.8 B.
  sample.p_top = 1.0;
  sample.p_bot = 1.0 - 1.6 * kModelB;
  EXPECT_TRUE(equilibrium_reached(sample, c));
}

TEST(ModelRules, EveryRuptureModeCountsInTheEquilibriumTest) {
  EventCounts events;
  events.normal = 2;
  events.sliding = 3;
  events.rolling = 5;
  events.created = 7;  // a new bond is not a rupture
  EXPECT_EQ(exam_ruptures(events, true), 10);
  EXPECT_EQ(exam_ruptures(events, false), 2);
  // One of each mode alone changes the count, with every option's rule.
  for (int mode = 0; mode < 3; ++mode) {
    EventCounts one;
    (mode == 0 ? one.normal : mode == 1 ? one.sliding : one.rolling) = 1;
    EXPECT_EQ(exam_ruptures(one, true), 1) << "mode " << mode;
    EXPECT_EQ(exam_ruptures(one, false), mode == 0 ? 1 : 0) << "mode " << mode;
  }
  // The scene option: "all" is the default (MODEL.md), "normal" the old rule.
  gel::v1::Compression c = paper_bond1_protocol();
  EXPECT_EQ(c.exam_ruptures(), "all");
  EXPECT_EQ(exam_ruptures(events, c), 10);
  gel::v1::Scene scene = scene_preset("paper-bond1");
  scene.mutable_compression()->set_exam_ruptures("normal");
  EXPECT_EQ(exam_ruptures(events, resolve_compression_scene(scene).compression()), 2);
}

// ---------------------------------------------------------------------------------------
// Breaks: only tension breaks a bond, and a break releases all of the bond's energy.

TEST(ModelRules, AStretchedPairThatBreaksDissipatesItsWholeElasticEnergy) {
  const double delta = 0.06;  // F_N = 1.2 F0 > F_Nc
  {
    System system(pair_along_x(delta), bond1_params(kSprings | kThresholds));
    ASSERT_EQ(system.events().normal, 1);
    EXPECT_TRUE(system.bonds().empty());
    EXPECT_NEAR(system.energy().dissipated, model_normal_energy(delta), 1e-14);
    EXPECT_EQ(system.stored_energy(), 0.0);
  }
  {
    // With a sliding pre-strain below F_Sc (co-rotation by alpha: |d| = 2a sin alpha, phi = 0),
    // the sliding energy goes too.
    const double alpha = 0.01;
    System system(bonded_pair(delta, alpha, alpha), bond1_params(kSprings | kThresholds));
    ASSERT_EQ(system.events().normal, 1);
    const double d = 2 * std::sin(alpha);
    EXPECT_NEAR(system.energy().dissipated, model_normal_energy(delta) + 0.5 * kModelKSliding * d * d, 1e-14);
  }
}

TEST(ModelRules, TheEvaluatorsThresholdEventIsABreakInTensionElseTheLargerTangentialExcess) {
  // Bond 1 (MODEL.md): F_Nc = 1 F0, F_Sc = 1 F0, M_Rc = k_R a^2 phi_c = 20 x 0.05 = 1 F0 a.
  const BondLaw law = bond_preset("bond1");
  auto forces = [](double normal, double sliding_x, double sliding_y, double moment) {
    BondForces f;
    f.normal_force = normal;
    f.sliding_x = sliding_x;
    f.sliding_y = sliding_y;
    f.rolling_moment = moment;
    return f;
  };
  EXPECT_EQ(threshold_event(forces(0.99, 0.6, 0.79, -0.99), law), BondEvent::kNone);  // |F_T| = 0.99
  EXPECT_FALSE(exceeds_a_threshold(forces(0.99, 0.6, 0.79, -0.99), law));
  EXPECT_EQ(threshold_event(forces(1.01, 0, 0, 0), law), BondEvent::kBreak);
  EXPECT_EQ(threshold_event(forces(-50, 0, 0, 0), law), BondEvent::kNone);  // pressed: never breaks
  // Past every threshold at once, the break wins.
  EXPECT_EQ(threshold_event(forces(1.01, 3, 0, 3), law), BondEvent::kBreak);
  // Both tangential thresholds: the larger factor decides, sliding on a tie.
  EXPECT_EQ(threshold_event(forces(0, 0.9, 0.9, 1.2), law), BondEvent::kSlidingReset);  // 1.273 against 1.2
  EXPECT_EQ(threshold_event(forces(0, 0.9, 0.9, -1.3), law), BondEvent::kRollingReset);
  EXPECT_EQ(threshold_event(forces(0, 1.5, 0, 1.5), law), BondEvent::kSlidingReset);
  EXPECT_EQ(threshold_event(forces(0, 0, 0, 1.01), law), BondEvent::kRollingReset);
  // The loads: F_N n + F_T on i, and a n x F_T on both with +-M_R.
  BondGeometry g{};
  g.nx = 0.6;
  g.ny = 0.8;
  const BondLoads loads = bond_loads(forces(2, 0.8, -0.6, 0.5), g);
  EXPECT_DOUBLE_EQ(loads.force_x, 2 * 0.6 + 0.8);
  EXPECT_DOUBLE_EQ(loads.force_y, 2 * 0.8 - 0.6);
  const double sliding_torque = kRadius * (0.6 * -0.6 - 0.8 * 0.8);  // -1 a F0
  EXPECT_DOUBLE_EQ(loads.torque_i, 0.5 + sliding_torque);
  EXPECT_DOUBLE_EQ(loads.torque_j, -0.5 + sliding_torque);
}

TEST(ModelRules, APairPressedHarderThanTheBreakingForceStaysBonded) {
  const double delta = -0.1;  // F_N = -2 - 80 = -82 F0: |F_N| is 82 F_Nc, but it pushes
  ASSERT_LT(model_normal_force(delta), -50.0);
  {
    System system(pair_along_x(delta), bond1_params(kSprings | kThresholds));
    EXPECT_EQ(system.bonds().size(), 1u);
    EXPECT_EQ(system.events().normal, 0);
    EXPECT_EQ(system.events().sliding, 0);
    EXPECT_EQ(system.events().rolling, 0);
    EXPECT_NEAR(system.fx()[0], model_normal_force(delta), 1e-12 * 82);
  }
  {
    // Pressed and past the sliding threshold (co-rotation by 0.04: |F_T| = 1.6 F0): a reset.
    System system(bonded_pair(delta, 0.04, 0.04), bond1_params(kSprings | kThresholds));
    EXPECT_EQ(system.bonds().size(), 1u);
    EXPECT_EQ(system.events().normal, 0);
    EXPECT_EQ(system.events().sliding, 1);
  }
}

// ---------------------------------------------------------------------------------------
// The normal law: the cubic term acts in overlap only, in the force and in the energy.

TEST(ModelRules, TheOverlapTermActsInCompressionOnly) {
  const BondLaw law = bond_preset("bond1");
  for (const double delta : {0.03, 0.001, -0.001, -0.03}) {
    SCOPED_TRACE(delta);
    // The evaluator alone.
    const BondGeometry g{1, 0, delta, 1, 0, -1, 0};
    const BondForces f = BondEvaluator<kNormalSpring | kOverlapRepulsion>::evaluate(g, law);
    EXPECT_NEAR(f.normal_force, model_normal_force(delta), 1e-14);
    EXPECT_NEAR(bond_energy(g, law, kNormalSpring | kOverlapRepulsion).total(), model_normal_energy(delta), 1e-16);
    // And the engine: the force on particle 0 is F_N n with n = e_x.
    const System system(pair_along_x(delta), bond1_params(kNormalSpring | kOverlapRepulsion));
    const double engine_delta = pair_gap(system);
    EXPECT_NEAR(system.fx()[0], model_normal_force(engine_delta), 1e-13);
    EXPECT_NEAR(system.fx()[1], -model_normal_force(engine_delta), 1e-13);
    EXPECT_NEAR(system.stored_energy(), model_normal_energy(engine_delta), 1e-15);
  }
}

// ---------------------------------------------------------------------------------------
// A new bond records xi_ij = n on i and xi_ji = -n on j, so it starts with d = 0 and phi = 0.

TEST(ModelRules, ANewBondRecordsBothContactPointsOnTheLineOfCentres) {
  Configuration config;
  config.lx = config.ly = 30;
  config.add_particle(10, 10, 0.3);
  config.add_particle(12.6, 11.5, -1.1);  // an oblique approach, both particles turned
  System system(config, bond1_params(kAllEffects & ~(kWalls | kDrag)));
  const double dx0 = 2.6, dy0 = 1.5, r0 = std::hypot(dx0, dy0), speed = 0.05;
  system.set_velocity(0, speed * dx0 / r0, speed * dy0 / r0, 0);
  system.set_velocity(1, -speed * dx0 / r0, -speed * dy0 / r0, 0);
  while (system.bonds().empty() && system.time() < 100) system.step();
  ASSERT_EQ(system.bonds().size(), 1u);
  const Bond& bond = system.bonds()[0];
  ASSERT_EQ(bond.i, 0);
  const double dx = system.x()[1] - system.x()[0], dy = system.y()[1] - system.y()[0], r = std::hypot(dx, dy);
  const double nx = dx / r, ny = dy / r;
  const double ci = std::cos(system.theta(0)), si = std::sin(system.theta(0));
  const double cj = std::cos(system.theta(1)), sj = std::sin(system.theta(1));
  EXPECT_NEAR(ci * bond.bix - si * bond.biy, nx, 1e-12);
  EXPECT_NEAR(si * bond.bix + ci * bond.biy, ny, 1e-12);
  EXPECT_NEAR(cj * bond.bjx - sj * bond.bjy, -nx, 1e-12);
  EXPECT_NEAR(sj * bond.bjx + cj * bond.bjy, -ny, 1e-12);
  // d = 0 and phi = 0: no torque on either particle, and only normal energy stored.
  EXPECT_NEAR(system.torque()[0], 0.0, 1e-12);
  EXPECT_NEAR(system.torque()[1], 0.0, 1e-12);
  EXPECT_NEAR(system.stored_energy(), model_normal_energy(r - kDiameter), 1e-15);
}

}  // namespace
}  // namespace gel
