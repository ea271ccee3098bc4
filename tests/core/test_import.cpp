// Configurations in from GSD and extended XYZ (gel/import.hpp) and the per-bond state and
// contact loads the exports write (gel/export.hpp). gelsim's own exports must come back bit for
// bit; foreign files are covered, with the files gsd.hoomd and ASE write, by tests/cli/test_import.sh.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>

#include "gel/bond_evaluator.hpp"
#include "gel/errors.hpp"
#include "gel/export.hpp"
#include "gel/generator.hpp"
#include "gel/import.hpp"
#include "gel/system.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

exporting::Frame frame_of(const Configuration& configuration) {
  exporting::Frame frame;
  frame.configuration = configuration;
  return frame;
}

class ImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("gel_import_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A tiny gel behind walls after some steps of compression: velocities, wall members and
  // contact points that are no longer along the line of centres.
  static Configuration moving_gel(std::int64_t steps) {
    const gel::v1::Scene scene = tiny_compression_scene("paper");
    System system(generate_gel(scene.generator()), bond1_params(kAllEffects));
    system.install_walls();
    system.set_wall_velocities(0.01, -0.01);
    system.run(steps);
    Configuration c = system.configuration();
    c.seed = 0xFEDCBA9876543210ULL;  // 64 bits: a double would lose the low ones
    return c;
  }

  static void expect_identical(const Configuration& a, const Configuration& b) {
    EXPECT_EQ(a.lx, b.lx);
    EXPECT_EQ(a.ly, b.ly);
    EXPECT_EQ(a.periodic_y, b.periodic_y);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.theta, b.theta);
    EXPECT_EQ(a.vx, b.vx);
    EXPECT_EQ(a.vy, b.vy);
    EXPECT_EQ(a.omega, b.omega);
    EXPECT_EQ(a.wall, b.wall);
    EXPECT_EQ(a.wall_bottom, b.wall_bottom);
    EXPECT_EQ(a.wall_top, b.wall_top);
    ASSERT_EQ(a.bonds.size(), b.bonds.size());
    for (std::size_t k = 0; k < a.bonds.size(); ++k) {
      const BondRecord &p = a.bonds[k], &q = b.bonds[k];
      EXPECT_TRUE(p.i == q.i && p.j == q.j && p.bix == q.bix && p.biy == q.biy && p.bjx == q.bjx && p.bjy == q.bjy) << "bond " << k;
    }
  }

  static std::string refusal(const std::string& file, std::int64_t frame = kLastFrame) {
    try {
      read_configuration(file, frame);
    } catch (const InvalidArgument& e) {
      return e.what();
    }
    return "accepted";
  }

  std::filesystem::path dir_;
};

TEST_F(ImportTest, GsdExportComesBackBitForBitFromAnyFrame) {
  const Configuration first = moving_gel(200), second = moving_gel(400);
  ASSERT_TRUE(first.has_walls() && first.has_velocities());
  ASSERT_NE(first.vx, second.vx);
  {
    const auto writer = exporting::open_writer(exporting::Format::kGsd, path("run.gsd"));
    for (const Configuration* c : {&first, &second}) {
      exporting::Frame frame;
      frame.configuration = *c;
      frame.bond_law = bond_preset("bond1");
      writer->append(frame);
    }
  }
  expect_identical(read_configuration(path("run.gsd"), 0), first);
  expect_identical(read_configuration(path("run.gsd"), 1), second);
  expect_identical(read_configuration(path("run.gsd")), second);  // the last by default
  expect_identical(read_configuration(path("run.gsd"), -2), first);
  EXPECT_EQ(read_configuration(path("run.gsd")).seed, second.seed);
  EXPECT_EQ(refusal(path("run.gsd"), 2),
            "frame: '" + path("run.gsd") + "' holds 2 frames (0 to 1, or -1 to -2 from the end): there is no frame 2");
  EXPECT_NE(refusal(path("run.gsd"), -3).find("there is no frame -3"), std::string::npos);
}

TEST_F(ImportTest, GsdOfAGelWithoutWallsOrVelocitiesComesBackAsIs) {
  const Configuration gel = generate_gel(tiny_compression_scene("paper").generator());
  ASSERT_FALSE(gel.has_walls() || gel.has_velocities());
  exporting::open_writer(exporting::Format::kGsd, path("gel.gsd"))->append(frame_of(gel));
  const Configuration back = read_configuration(path("gel.gsd"));
  EXPECT_TRUE(back.periodic_y);
  // At rest either way: the writer stores zeros, which the engine starts from as it would from none.
  EXPECT_EQ(back.vx, std::vector<double>(gel.size(), 0.0));
  Configuration expected = gel;
  expected.vx = expected.vy = expected.omega = std::vector<double>(gel.size(), 0.0);
  expect_identical(back, expected);
}

TEST_F(ImportTest, ExtendedXyzExportComesBackBitForBit) {
  // XYZ holds positions, theta, walls and the box; no bonds and no velocities.
  Configuration c = moving_gel(300);
  c.bonds.clear();
  c.vx.clear();
  c.vy.clear();
  c.omega.clear();
  {
    const auto writer = exporting::open_writer(exporting::Format::kExtendedXyz, path("run.xyz"));
    Configuration earlier = c;
    earlier.x[0] += 0.5;
    writer->append(frame_of(earlier));
    writer->append(frame_of(c));
  }
  expect_identical(read_configuration(path("run.xyz")), c);
  EXPECT_EQ(read_configuration(path("run.xyz"), 0).x[0], c.x[0] + 0.5);
  // A gel with bonds loses them in XYZ: refused, not read as a gel that falls apart.
  const Configuration bonded = moving_gel(10);
  exporting::open_writer(exporting::Format::kExtendedXyz, path("bonded.xyz"))->append(frame_of(bonded));
  EXPECT_NE(refusal(path("bonded.xyz")).find("it records " + std::to_string(bonded.bonds.size()) +
                                              " bonds, which extended XYZ does not hold: start from the GSD export"),
            std::string::npos)
      << refusal(path("bonded.xyz"));
}

TEST_F(ImportTest, ExtendedXyzThatIsNoFlatGelIsRefusedNamingWhy) {
  const auto write = [&](const std::string& comment, const std::string& particle) {
    std::ofstream(path("f.xyz")) << "1\n" << comment << "\n" << particle << "\n";
    return refusal(path("f.xyz"));
  };
  const std::string flat = R"(Lattice="20 0 0 0 30 0 0 0 0" Properties=species:S:1:pos:R:3 pbc="T T F")";
  EXPECT_EQ(write(flat, "X 1 2 0"), "accepted");
  EXPECT_NE(write(R"(Properties=species:S:1:pos:R:3)", "X 1 2 0").find("no Lattice"), std::string::npos);
  EXPECT_NE(write(R"(Lattice="20 0 0 0 30 0 0 0 40" Properties=species:S:1:pos:R:3)", "X 1 2 0").find("a 3D box, periodic in z"),
            std::string::npos);
  EXPECT_NE(write(R"(Lattice="20 0 0 5 30 0 0 0 0" Properties=species:S:1:pos:R:3 pbc="T T F")", "X 1 2 0").find("sheared"),
            std::string::npos);
  EXPECT_NE(write(flat, "X 1 2 0.5").find("particle 0 lies out of the plane (z = 0.5)"), std::string::npos);
  EXPECT_NE(write(R"(Lattice="20 0 0 0 30 0 0 0 0" Properties=species:S:1:pos:R:3:radius:R:1 pbc="T T F")", "X 1 2 0 0.5")
                .find("has radius 0.5: gelsim's particles are disks of radius 1"),
            std::string::npos);
  EXPECT_NE(write(R"(Lattice="20 0 0 0 30 0 0 0 0" Properties=species:S:1:pos:R:3:wall:I:1 pbc="T F F")", "X 1 2 0 1")
                .find("no wall positions"),
            std::string::npos);
  EXPECT_NE(write(flat, "X 1 two 0").find("particle 0's y is 'two', not a finite number"), std::string::npos);
}

TEST_F(ImportTest, GsdThatIsNotGsdIsRefused) {
  std::ofstream(path("noise.gsd")) << "not a gsd file at all, but long enough to hold a header of 256 bytes" << std::string(300, 'x');
  EXPECT_NE(refusal(path("noise.gsd")).find("not a GSD file"), std::string::npos);
  std::ofstream(path("x.vtu")) << "<VTKFile/>";
  EXPECT_NE(refusal(path("x.vtu")).find("VTK files are written for viewing and not read back"), std::string::npos);
  EXPECT_NE(refusal(path("absent.gsd")).find("cannot open"), std::string::npos);
}

// The exported bond state is MODEL.md's: counter-rotating a bonded pair is pure rolling
// (d = 0, phi = -2 alpha here), co-rotating it pure sliding (phi = 0, |d| = 2a sin alpha).
TEST(BondStateExport, RollingAndSlidingOfATurnedPairAreModelMd) {
  const BondLaw law = bond_preset("bond1");
  const double alpha = 0.01, gap = 0.02;
  const Configuration rolling = bonded_pair(gap, alpha, -alpha);
  const exporting::BondState r = exporting::bond_state(rolling, &law, kAllEffects);
  ASSERT_EQ(r.gap.size(), 1u);
  EXPECT_NEAR(r.gap[0], gap, 1e-15);
  EXPECT_NEAR(r.bending[0], -2 * alpha, 1e-15);
  EXPECT_NEAR(std::hypot(r.sliding_x[0], r.sliding_y[0]), 0.0, 1e-15);
  EXPECT_NEAR(r.normal_force[0], law.k_normal * gap, 1e-13);
  EXPECT_NEAR(r.rolling_moment[0], law.k_rolling * -2 * alpha, 1e-13);
  EXPECT_NEAR(r.contact_ix[0], std::cos(alpha), 1e-15);
  EXPECT_NEAR(r.contact_iy[0], std::sin(alpha), 1e-15);
  EXPECT_NEAR(r.contact_jx[0], -std::cos(alpha), 1e-15);
  EXPECT_NEAR(r.contact_jy[0], std::sin(alpha), 1e-15);
  const exporting::BondState s = exporting::bond_state(bonded_pair(0, alpha, alpha), &law, kAllEffects);
  EXPECT_NEAR(s.bending[0], 0.0, 1e-15);
  EXPECT_NEAR(s.sliding_x[0], 0.0, 1e-15);
  EXPECT_NEAR(s.sliding_y[0], -2 * kRadius * std::sin(alpha), 1e-15);
  EXPECT_NEAR(s.sliding_force_y[0], law.k_sliding * -2 * kRadius * std::sin(alpha), 1e-13);
  // Without a law: the geometry only.
  const exporting::BondState geometry = exporting::bond_state(rolling, nullptr, kAllEffects);
  EXPECT_FALSE(geometry.with_forces);
  EXPECT_TRUE(geometry.normal_force.empty());
  EXPECT_EQ(geometry.bending, r.bending);
}

// The exported contact loads are the engine's: equal on every free particle (up to the order
// of the sums), and they cancel over the whole system (Newton's third law).
TEST(BondStateExport, ContactLoadsAreTheEnginesForces) {
  const gel::v1::Scene scene = tiny_compression_scene("paper");
  const SimParams params = bond1_params(kAllEffects & ~kDrag);
  System system(generate_gel(scene.generator()), params);
  system.install_walls();
  system.set_wall_velocities(0.01, -0.01);
  system.run(300);
  system.compute_forces();
  const Configuration c = system.configuration();
  const exporting::BondState state = exporting::bond_state(c, &params.bond, params.effects);
  const exporting::ParticleLoads loads = exporting::particle_loads(c, state);
  double scale = 0, sum_x = 0, sum_y = 0;
  for (std::size_t b = 0; b < state.normal_force.size(); ++b) scale = std::max(scale, std::abs(state.normal_force[b]));
  ASSERT_GT(scale, 1e-6);
  std::size_t free = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    sum_x += loads.fx[i];
    sum_y += loads.fy[i];
    if (system.wall_side(i) != kNoWall) continue;
    ++free;
    EXPECT_NEAR(loads.fx[i], system.fx()[i], 1e-12 * scale) << i;
    EXPECT_NEAR(loads.fy[i], system.fy()[i], 1e-12 * scale) << i;
    EXPECT_NEAR(loads.torque[i], system.torque()[i], 1e-12 * scale) << i;
  }
  EXPECT_GT(free, c.size() / 2);
  EXPECT_NEAR(sum_x, 0.0, 1e-12 * scale * c.size());
  EXPECT_NEAR(sum_y, 0.0, 1e-12 * scale * c.size());
}

}  // namespace
}  // namespace gel
