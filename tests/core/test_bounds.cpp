// Every numeric field of a scene is bounded to a range the model can run in (docs/api.md
// "Budgets and bounds"): each bound is tested at its edge (accepted) and just past it (refused,
// naming the field), and every text of a scene is capped. Before these bounds a finite but absurd
// value (skin 1e300, walk_step 1e-300, checkpoint_seconds 1e-300) was accepted and took the
// machine's memory, a worker, or 30x the run time.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/resources.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"

namespace gel {
namespace {

using Change = std::function<void(gel::v1::Scene&)>;

gel::v1::Scene quick_with(const Change& change) {
  gel::v1::Scene scene = scene_preset("quick");
  change(scene);
  return scene;
}

void expect_accepted(const Change& change, const std::string& what) {
  EXPECT_NO_THROW(resolve_compression_scene(quick_with(change))) << what;
}

void expect_refused(const Change& change, const std::string& field, const std::string& what) {
  try {
    resolve_compression_scene(quick_with(change));
    ADD_FAILURE() << what << ": accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << what << ": " << e.what();
  }
}

// A field's edge: `at` is accepted, `past` refused naming `field`.
void expect_edge(const std::string& field, const std::function<void(gel::v1::Scene&, double)>& set, double at, double past) {
  expect_accepted([&](gel::v1::Scene& s) { set(s, at); }, field + " = " + std::to_string(at));
  expect_refused([&](gel::v1::Scene& s) { set(s, past); }, field, field + " = " + std::to_string(past));
}

TEST(Bounds, IntegrationFieldsAtTheirEdges) {
  auto integration = [](gel::v1::Scene& s) { return s.mutable_integration(); };
  const auto skin = [&](gel::v1::Scene& s, double v) { integration(s)->set_skin(v); };
  expect_edge("integration.skin", skin, 2.0, std::nextafter(2.0, 3.0));
  expect_refused([&](gel::v1::Scene& s) { skin(s, 1e300); }, "integration.skin", "skin 1e300");
  const auto fraction = [&](gel::v1::Scene& s, double v) { integration(s)->set_dt_fraction(v); };
  expect_edge("integration.dt_fraction", fraction, 1e-4, 0.99e-4);
  expect_edge("integration.dt_fraction", fraction, 1.0, 1.0001);
  const double period = shortest_period(bond_preset("bond1"));
  const auto dt = [&](gel::v1::Scene& s, double v) { integration(s)->set_dt(v); };
  expect_edge("integration.dt", dt, 1e-4 * period, 0.99e-4 * period);
  expect_edge("integration.dt", dt, 1.0 * period, 1.0001 * period);
  const auto guard = [&](gel::v1::Scene& s, double v) { integration(s)->set_guard_interval(static_cast<int>(v)); };
  expect_edge("integration.guard_interval", guard, 1e6, 1e6 + 1);
  const auto overlap = [&](gel::v1::Scene& s, double v) { integration(s)->set_max_overlap(v); };
  expect_edge("integration.max_overlap", overlap, 1.0, 1.0001);
}

TEST(Bounds, TheDragStaysWithinTheExplicitHalfKicksStability) {
  // MODEL.md: 6 pi eta a = eta_factor 2 sqrt(k_R m) (k_R a^2 = 20 F0 a for bond 1) and
  // 8 pi eta a^3 = (4/3) a^2 6 pi eta a; the first half kick takes it explicitly, stable while
  // (dt / 2) gamma_R / I <= 1 with I = 2/5 m a^2 and dt = 0.025 of the shortest period.
  const double dt = 0.025 * shortest_period(bond_preset("bond1"));
  const double gamma_rotation_per_eta_factor = (4.0 / 3.0) * 2.0 * std::sqrt(20.0);
  const double largest = 0.4 / (0.5 * dt * gamma_rotation_per_eta_factor);
  EXPECT_GT(largest, 10 * 0.1) << "the reference drag 0.1 must be far inside";
  const auto eta = [](gel::v1::Scene& s, double v) { s.mutable_integration()->set_eta_factor(v); };
  expect_edge("integration.eta_factor", eta, 0.999 * largest, 1.001 * largest);
  expect_accepted([&](gel::v1::Scene& s) { eta(s, 0.0); }, "no drag");
  expect_refused([&](gel::v1::Scene& s) { eta(s, 1e300); }, "integration.eta_factor", "eta 1e300");
}

TEST(Bounds, GeneratorAndProtocolFieldsAtTheirEdges) {
  const auto walk = [](gel::v1::Scene& s, double v) { s.mutable_generator()->set_walk_step(v); };
  expect_edge("generator.walk_step", walk, 0.1, 0.0999);
  expect_edge("generator.walk_step", walk, 2.0, 2.0001);
  expect_refused([&](gel::v1::Scene& s) { walk(s, 1e-300); }, "generator.walk_step", "walk step 1e-300");
  const auto attempts = [](gel::v1::Scene& s, double v) { s.mutable_generator()->set_max_attempts(static_cast<int>(v)); };
  expect_edge("generator.max_attempts", attempts, 1e7, 1e7 + 1);
  const auto checkpoint = [](gel::v1::Scene& s, double v) { s.mutable_compression()->set_checkpoint_seconds(v); };
  expect_edge("compression.checkpoint_seconds", checkpoint, 0.1, 0.0999);
  expect_edge("compression.checkpoint_seconds", checkpoint, 86400, 86401);
  expect_refused([&](gel::v1::Scene& s) { checkpoint(s, 1e-300); }, "compression.checkpoint_seconds", "1e-300 s");
  // At most 1000 equilibrium tests of m_exam steps per target (quick: m_exam 10^4, bond 1's dt).
  const double exam_time = 1e4 * 0.025 * shortest_period(bond_preset("bond1"));
  const auto wait = [](gel::v1::Scene& s, double v) { s.mutable_compression()->set_max_wait_time(v); };
  expect_edge("compression.max_wait_time", wait, 999.999 * exam_time, 1000.001 * exam_time);
  const auto iterations = [](gel::v1::Scene& s, double v) {
    s.mutable_compression()->set_relax_max_iterations(static_cast<std::int64_t>(v));
  };
  expect_edge("compression.relax_max_iterations", iterations, 1e9, 1e9 + 1);
}

TEST(Bounds, EveryTextOfASceneIsCapped) {
  expect_accepted([](gel::v1::Scene& s) { s.set_name(std::string(256, 'n')); }, "name of 256 bytes");
  expect_refused([](gel::v1::Scene& s) { s.set_name(std::string(257, 'n')); }, "name", "name of 257 bytes");
  expect_refused([](gel::v1::Scene& s) { s.mutable_compression()->set_fidelity(std::string(100000, 'f')); },
                 "compression.fidelity", "a long fidelity");
  expect_refused(
      [](gel::v1::Scene& s) {
        for (int i = 0; i < 65; ++i) s.add_effects("normal");
      },
      "effects", "65 effects");
  // An unknown value is quoted cut short, with its length, so the message stays small.
  try {
    resolve_compression_scene(quick_with([](gel::v1::Scene& s) { s.mutable_compression()->set_fidelity(std::string(200, 'f')); }));
    ADD_FAILURE() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "compression.fidelity");
    EXPECT_LT(std::string(e.what()).size(), 200u) << e.what();
    EXPECT_NE(std::string(e.what()).find("(200 bytes)"), std::string::npos) << e.what();
  }
}

TEST(Bounds, QuotedAndTruncatedTextStaysValidUtf8) {
  EXPECT_EQ(quoted("short"), "'short'");
  // "é" is two bytes: a cut at byte 4 of "aéé" (5 bytes) must not split the second one.
  EXPECT_EQ(quoted("a\xc3\xa9\xc3\xa9", 5), "'a\xc3\xa9\xc3\xa9'");
  EXPECT_EQ(quoted("a\xc3\xa9\xc3\xa9", 4), "'a\xc3\xa9...' (5 bytes)");
  EXPECT_EQ(truncated("a\xc3\xa9\xc3\xa9", 2), "a... (5 bytes in all)");
  EXPECT_EQ(truncated("abc", 3), "abc");
}

// The estimate of gel/resources.hpp against the counts it is built from.
const double kDensestPacking = kPi / (2 * std::sqrt(3.0));  // hexagonal disks
TEST(Resources, TheEstimateIsBuiltFromTheDensestPacking) {
  const gel::v1::Scene scene = resolve_compression_scene(scene_preset("paper-bond1"));
  const ResourceEstimate e = estimate_resources(scene);
  EXPECT_EQ(e.particles, 5760);
  // At the densest packing (0.9069) a disk has at most floor(0.9069 * 3^2 - 1) = 7 contacts.
  EXPECT_EQ(e.bonds, 7 * 5760 / 2);
  // Centres within 2a + skin (0.3 a): 0.9069 * 3.3^2 - 1 = 8.876 per particle, halved.
  EXPECT_NEAR(static_cast<double>(e.neighbour_pairs), 0.5 * 5760 * (kDensestPacking * 3.3 * 3.3 - 1), 1.0);
  EXPECT_EQ(e.rows, 18);
  // The walls walk from L_y to the height of phi_max: L_y (1 - phi_0 / phi_max) / (2 v_wall dt'),
  // dt' = 4 dt the longest walk step of the preset (a lower bound).
  const double phi0 = kPi * 5760 / (300.0 * 500.0);
  const SimParams params = resolve_sim_params(scene);
  ASSERT_EQ(scene.compression().walk_dt_factor(), 4.0);
  const double walk = 500.0 * (1 - phi0 / 0.74) / (2 * scene.compression().v_wall() * 4 * params.dt);
  EXPECT_NEAR(static_cast<double>(e.steps), walk, 1.0);  // quasistatic: no exams counted
  EXPECT_DOUBLE_EQ(e.particle_steps, 5760.0 * static_cast<double>(e.steps));
  EXPECT_EQ(e.memory_driver, "generator");
  // A wider skin holds more pairs; a trajectory takes disk; no snapshots take less.
  gel::v1::Scene wide = scene;
  wide.mutable_integration()->set_skin(2.0);
  const ResourceEstimate w = estimate_resources(wide);
  EXPECT_NEAR(static_cast<double>(w.neighbour_pairs), 0.5 * 5760 * (kDensestPacking * 25 - 1), 1.0);
  EXPECT_GT(w.memory_bytes, e.memory_bytes);
  gel::v1::Scene traced = scene;
  traced.mutable_output()->set_trajectory_every(100);
  const ResourceEstimate t = estimate_resources(traced);
  EXPECT_GT(t.disk_bytes, 10 * e.disk_bytes);
  EXPECT_EQ(t.disk_driver, "output.trajectory_every");
  EXPECT_LT(estimate_resources(scene, false).disk_bytes, e.disk_bytes);
}

}  // namespace
}  // namespace gel
