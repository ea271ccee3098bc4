// The virial stress tensor (gel/virial_stress.hpp) against closed forms: single bonds in a
// periodic box, a chain pressed between the walls, the identity with the wall stress that holds
// in any state, and the rows of a small compression, where sigma_yy = -P at force balance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <tuple>

#include "gel/bond_evaluator.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "gel/virial_stress.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

constexpr double kBox = 40;                       // periodic box L_x = L_y [a]
constexpr double kVolume = kThickness * kBox * kBox;  // V = 2a L_x L_y
constexpr double kKNormal = 20.0, kKSliding = 20.0;   // bond 1 [F0/a]

// A bond from (x0, y0) at `angle` to the x axis, stretched by `stretch` along its line, in a
// periodic box: F_ij = k_N stretch n on i (pulls it towards j), r_ij = (2a + stretch) n.
System inclined_bond(double x0, double y0, double angle, double stretch) {
  Configuration config;
  config.lx = config.ly = kBox;
  const double nx = std::cos(angle), ny = std::sin(angle);
  config.add_particle(x0, y0);
  config.add_particle(x0 + kDiameter * nx, y0 + kDiameter * ny);
  config.add_bond_at_contact(0, 1);
  config.x[1] += stretch * nx;
  config.y[1] += stretch * ny;
  return System(config, bond1_params(kSprings | kPeriodicX));
}

TEST(VirialStress, AStretchedBondAlongYIsATensionRFOverV) {
  const double stretch = 0.02;  // F_N = 0.4 F0 < F_Nc
  const System system = inclined_bond(10, 9, kPi / 2, stretch);
  const VirialStress stress = virial_stress(system, 4);  // slices 10 a tall
  const double expected = (kDiameter + stretch) * kKNormal * stretch / kVolume;
  EXPECT_NEAR(stress.total.yy, expected, 1e-12 * expected);
  EXPECT_GT(stress.total.yy, 0.0) << "tension is positive";
  EXPECT_NEAR(stress.total.xx, 0.0, 1e-15);
  EXPECT_NEAR(stress.total.xy, 0.0, 1e-15);
  EXPECT_NEAR(stress.total.yx, 0.0, 1e-15);
  // The bond runs from y = 9 to 11.02: 1/2.02 of it in slice 0, 1.02/2.02 in slice 1, each
  // over a quarter of the volume.
  ASSERT_EQ(stress.slices.size(), 4u);
  const double length = kDiameter + stretch;
  EXPECT_NEAR(stress.slices[0].yy, 4 * expected * (1.0 / length), 1e-12 * expected);
  EXPECT_NEAR(stress.slices[1].yy, 4 * expected * ((length - 1.0) / length), 1e-12 * expected);
  EXPECT_EQ(stress.slices[2].yy, 0.0);
  EXPECT_EQ(stress.slices[3].yy, 0.0);
}

TEST(VirialStress, ACompressedBondIsNegative) {
  const double stretch = -0.01;  // in overlap: k_N delta + C delta^3
  const System system = inclined_bond(10, 10, 0.0, stretch);
  const double force = kKNormal * stretch + 8e4 * stretch * stretch * stretch;
  const double expected = (kDiameter + stretch) * force / kVolume;
  const VirialStress stress = virial_stress(system, 0);
  EXPECT_LT(stress.total.xx, 0.0);
  EXPECT_NEAR(stress.total.xx, expected, 1e-12 * std::abs(expected));
  EXPECT_NEAR(stress.total.yy, 0.0, 1e-15);
  EXPECT_TRUE(stress.slices.empty());
}

// A bond at 30 degrees carries r F n (x) n: principal axes along the bond, sigma_xy = sigma_yx.
TEST(VirialStress, AnInclinedBondHasSymmetricShear) {
  const double angle = kPi / 6, stretch = 0.03;
  const System system = inclined_bond(20, 20, angle, stretch);
  const double rf = (kDiameter + stretch) * kKNormal * stretch / kVolume;
  const StressTensor s = virial_stress(system, 0).total;
  EXPECT_NEAR(s.xx, rf * std::cos(angle) * std::cos(angle), 1e-12 * rf);
  EXPECT_NEAR(s.yy, rf * std::sin(angle) * std::sin(angle), 1e-12 * rf);
  EXPECT_NEAR(s.xy, rf * std::sin(angle) * std::cos(angle), 1e-12 * rf);
  EXPECT_NEAR(s.yx, s.xy, 1e-12 * rf);
  EXPECT_EQ(s.shear(), 0.5 * (s.xy + s.yx));
}

// Co-rotating a pair along x by theta is pure sliding (MODEL.md "Check"): d = -2a sin(theta) e_y,
// F_T = k_S d on i, no normal force. The shear force acts on the face normal to x:
// sigma_xy = 2a F_T,y / V, sigma_yx = 0 (the pair is not in torque balance: the bond's torques
// a n x F_T hold the couple), so the reported symmetric shear is half of it.
TEST(VirialStress, ASlidingPairCarriesShearOnTheFaceNormalToIt) {
  const double theta = 0.01;  // |F_T| = 0.4 F0 < F_Sc
  Configuration config = bonded_pair(0.0, theta, theta);
  config.periodic_y = true;
  config.lx = config.ly = kBox;
  const System system(config, bond1_params(kSprings | kPeriodicX));
  const double force_y = kKSliding * (-2.0 * kRadius * std::sin(theta));
  const StressTensor s = virial_stress(system, 0).total;
  EXPECT_NEAR(s.xy, kDiameter * force_y / kVolume, 1e-12 * std::abs(force_y) / kVolume);
  EXPECT_NEAR(s.yx, 0.0, 1e-15);
  EXPECT_NEAR(s.xx, 0.0, 1e-15);
  EXPECT_NEAR(s.yy, 0.0, 1e-15);
  EXPECT_NEAR(s.shear(), 0.5 * kDiameter * force_y / kVolume, 1e-12 * std::abs(force_y) / kVolume);
}

// A vertical chain pressed evenly between the walls: every free particle is at force balance, so
// sigma_yy = -P in the whole box and in every slice, and nothing else.
TEST(VirialStress, AChainPressedBetweenTheWallsHasSigmaYyMinusPInEverySlice) {
  const int n = 7;
  const double squeeze = 0.004;  // each gap -0.004 a
  Configuration config;
  config.lx = 20;
  config.ly = 40;
  config.periodic_y = false;
  for (int k = 0; k < n; ++k) config.add_particle(5, 3 + kDiameter * k);
  for (int k = 0; k + 1 < n; ++k) config.add_bond_at_contact(k, k + 1);
  for (int k = 0; k < n; ++k) config.y[k] = 3 + (kDiameter - squeeze) * k;
  config.wall_bottom = config.y[0] - kRadius;
  config.wall_top = config.y[n - 1] + kRadius;
  config.wall.assign(n, kNoWall);
  config.wall[0] = kBottomWall;
  config.wall[n - 1] = kTopWall;
  System system(config, bond1_params(kSprings | kWalls | kPeriodicX));
  system.compute_forces();
  const WallStress walls = system.wall_stress();
  ASSERT_GT(walls.p, 0.0);
  EXPECT_NEAR(walls.p_top, walls.p_bottom, 1e-12 * walls.p);
  const double force = -(kKNormal * -squeeze + 8e4 * std::pow(-squeeze, 3));  // the push of each contact
  EXPECT_NEAR(walls.p, force / (kThickness * config.lx), 1e-12 * walls.p);
  const VirialStress stress = virial_stress(system, 5);
  EXPECT_NEAR(stress.total.yy, -walls.p, 1e-12 * walls.p);
  EXPECT_NEAR(stress.total.xx, 0.0, 1e-15);
  EXPECT_NEAR(stress.total.shear(), 0.0, 1e-15);
  for (std::size_t s = 0; s < stress.slices.size(); ++s)
    EXPECT_NEAR(stress.slices[s].yy, -walls.p, 1e-12 * walls.p) << "slice " << s;
}

// gel/virial_stress.hpp: sigma_yy = -(P_top + P_bot)/2 - (1/V) sum_free (y_p - y_centre) F_p,y
// in any state, here a gel mid-way through a compression (walls moving, particles not at
// balance, bonds across the periodic x boundary). The slices average to the whole.
TEST(VirialStress, MatchesTheWallStressThroughTheFreeParticlesForcesInAnyState) {
  const gel::v1::Scene scene = resolve_compression_scene(tiny_compression_scene("paper"));
  System system(generate_gel(scene.generator()), resolve_sim_params(scene));
  system.install_walls();
  system.set_wall_velocities(0.02, -0.02);
  system.run(6000);
  const WallStress walls = system.wall_stress();
  ASSERT_GT(std::abs(walls.p), 1e-4) << "the walls should carry load by now";
  const double centre = 0.5 * (system.wall_bottom() + system.wall_top());
  const double volume = kThickness * system.lx() * (system.wall_top() - system.wall_bottom());
  double free_moment = 0, scale = 0;
  for (std::size_t p = 0; p < system.size(); ++p) {
    if (system.wall_side(p) != kNoWall) continue;
    free_moment += (system.y()[p] - centre) * system.fy()[p];
    scale += std::abs((system.y()[p] - centre) * system.fy()[p]);
  }
  ASSERT_GT(scale / volume, 1e-3 * std::abs(walls.p)) << "the free particles should be off balance";
  const VirialStress stress = virial_stress(system, 20);
  const double expected = -walls.p - free_moment / volume;
  // Rounding: the sums run over a few hundred terms of size scale/N.
  EXPECT_NEAR(stress.total.yy, expected, 1e-12 * (scale / volume + std::abs(walls.p)));
  StressTensor mean;
  for (const StressTensor& slice : stress.slices) {
    mean.xx += slice.xx / 20, mean.yy += slice.yy / 20, mean.xy += slice.xy / 20, mean.yx += slice.yx / 20;
  }
  const double size = std::abs(stress.total.xx) + std::abs(stress.total.yy);
  EXPECT_NEAR(mean.xx, stress.total.xx, 1e-12 * size);
  EXPECT_NEAR(mean.yy, stress.total.yy, 1e-12 * size);
  EXPECT_NEAR(mean.xy, stress.total.xy, 1e-12 * size);
  EXPECT_NEAR(mean.yx, stress.total.yx, 1e-12 * size);
}

// A small quasi-static compression: at every relaxed row sigma_yy = -P within what the
// residual force allows (the identity above with |F_p| <= residual), in the whole box and in every
// slice; the kinetic part left out is nil; the row holds the stress of its snapshot.
TEST(VirialStress, AnEquilibratedRowHasSigmaYyEqualToMinusP) {
  const std::string dir = fresh_temp_path("virial");
  RunOptions options;
  options.out_dir = dir;
  const CompressionResult result = run_compression(tiny_compression_scene("quasistatic"), options);
  ASSERT_TRUE(result.finished);
  const gel::v1::Scene& scene = result.curve.scene();
  int checked = 0;
  for (const gel::v1::CurveRow& row : result.curve.rows()) {
    ASSERT_TRUE(row.has_stress());
    const gel::v1::Stress& s = row.stress();
    ASSERT_EQ(s.yy_profile_size(), row.phi_profile_size());
    const Configuration snapshot = read_configuration(dir + "/" + row.snapshot());
    const double height = snapshot.wall_top - snapshot.wall_bottom;
    const double volume = kThickness * snapshot.lx * height;
    // The kinetic part -(1/V) sum m v v is at most 2 E_kin / V.
    EXPECT_LE(2 * row.kinetic_energy() / volume, 1e-9 * std::max(std::abs(row.p()), 1e-6));
    // The row is the virial stress of its configuration (the snapshot stores theta, so the
    // orientations come back within an ulp).
    const System again(snapshot, resolve_sim_params(scene));
    const VirialStress recomputed = virial_stress(again, row.phi_profile_size());
    const double size = std::abs(s.xx()) + std::abs(s.yy()) + 1e-12;
    EXPECT_NEAR(recomputed.total.yy, s.yy(), 1e-9 * size);
    EXPECT_NEAR(recomputed.total.xx, s.xx(), 1e-9 * size);
    EXPECT_NEAR(recomputed.total.shear(), s.xy(), 1e-9 * size);
    if (row.k() == 0 || !row.equilibrated() || !row.spans()) continue;
    ++checked;
    std::size_t free_particles = 0;
    for (const std::int8_t side : snapshot.wall) free_particles += side == kNoWall;
    const double unbalanced = static_cast<double>(free_particles) * row.residual_force();
    const double p = 0.5 * (row.p_top() + row.p_bot());
    EXPECT_LE(std::abs(s.yy() + p), unbalanced * 0.5 * height / volume)
        << "k " << row.k() << ": sigma_yy " << s.yy() << " P " << p;
    // Every slice: the force through any plane is the walls' force up to the free particles'
    // residuals and the walls' difference.
    for (int k = 0; k < s.yy_profile_size(); ++k)
      EXPECT_LE(std::abs(s.yy_profile(k) + p),
                0.5 * std::abs(row.p_top() - row.p_bot()) + unbalanced / (kThickness * snapshot.lx))
          << "k " << row.k() << " slice " << k;
    EXPECT_LT(s.yy(), 0.0) << "compressed along y";
    // sigma_xy - sigma_yx is the net couple on the particles: at torque balance of the free
    // particles, the couples the sticky walls hold (moments of the bond loads on each wall
    // particle about its point on the wall) plus the bonds' sum delta (n x F_T), which the
    // model's torque arm a (not r/2) leaves over. Checked with the torques of bond_loads, not the
    // virial's r x F.
    const BondLaw& law = again.params().bond;
    double wall_couples = 0, arm_excess = 0;
    for (std::size_t b = 0; b < again.bonds().size(); ++b) {
      const BondGeometry g = again.bond_geometry(b);
      const BondLoads f = bond_loads(evaluate_bond(g, law, again.params().effects), g);
      arm_excess += g.delta / kDiameter * (f.torque_i + f.torque_j);
      const Bond& bond = again.bonds()[b];
      for (const auto& [p, sign, torque] : {std::tuple{bond.i, 1.0, f.torque_i}, std::tuple{bond.j, -1.0, f.torque_j}}) {
        const std::int8_t side = again.wall_side(static_cast<std::size_t>(p));
        if (side == kNoWall) continue;
        const double dy = again.y()[static_cast<std::size_t>(p)] - (side == kTopWall ? snapshot.wall_top : snapshot.wall_bottom);
        wall_couples += torque - dy * sign * f.force_x;
      }
    }
    const VirialStress exact = virial_stress(again, 0);
    EXPECT_NEAR(volume * (exact.total.xy - exact.total.yx), wall_couples + arm_excess,
                static_cast<double>(free_particles) * kRadius * row.residual_force())
        << "k " << row.k();
  }
  EXPECT_GE(checked, 2);
  std::filesystem::remove_all(dir);
}

// Curves written before the stress was read back without one (not a zero stress), and their
// CSV cells stay empty; a row's stress goes through curve.json exactly; a broken one is named.
TEST(VirialStress, CurveFilesCarryItAndOldRowsHaveNone) {
  gel::v1::CurveRow row;
  row.set_k(1);
  row.set_p(0.5);
  gel::v1::Stress* s = row.mutable_stress();
  s->set_xx(-0.1);
  s->set_yy(-0.5);
  s->set_xy(1.0 / 3.0);
  for (const double v : {-0.4, -0.6}) s->add_yy_profile(v), s->add_xx_profile(v / 5), s->add_xy_profile(v / 7);
  nlohmann::json json = curve_row_to_json(row);
  const gel::v1::CurveRow back = curve_row_from_json(json);
  ASSERT_TRUE(back.has_stress());
  EXPECT_EQ(back.stress().SerializeAsString(), row.stress().SerializeAsString());
  EXPECT_EQ(curve_csv_row(row).substr(curve_csv_row(row).rfind(",-0.1,")), ",-0.1,-0.5,0.3333333333333333");

  json.erase("stress");
  const gel::v1::CurveRow old = curve_row_from_json(json);
  EXPECT_FALSE(old.has_stress());
  const std::string cells = curve_csv_row(old);
  EXPECT_EQ(cells.substr(cells.size() - 3), ",,,");
  // Same number of columns as the header either way.
  const auto columns = [](const std::string& line) { return std::count(line.begin(), line.end(), ','); };
  EXPECT_EQ(columns(cells), columns(curve_csv_header()));
  gel::v1::Curve curve;
  *curve.add_rows() = row;
  *curve.add_rows() = old;
  const std::string profiles = profiles_to_csv(curve);
  EXPECT_NE(profiles.find("sigma_yy_1 [F0/a^2]"), std::string::npos) << profiles;
  std::istringstream lines(profiles);
  std::string header, first, second;
  std::getline(lines, header), std::getline(lines, first), std::getline(lines, second);
  EXPECT_EQ(columns(first), columns(header));
  EXPECT_EQ(columns(second), columns(header));

  json["stress"] = {{"xx", 0.0}, {"yy", "high"}, {"xy", 0.0}};
  try {
    curve_row_from_json(json);
    ADD_FAILURE() << "a stress that is not a number was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("rows.stress.yy"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace gel
