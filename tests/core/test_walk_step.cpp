// The walk step (docs/quasistatic.md "Walk step"): while the walls walk and carry little, the
// dynamics may take a longer step; every relaxation and every loaded walk keeps the scene's dt.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "compression_internal.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "gel/v1/checkpoint.pb.h"
#include "test_scenes.hpp"

namespace gel {
namespace {

gel::v1::Scene tiny_walk_scene(double walk_dt_factor, double walk_dt_stress) {
  gel::v1::Scene scene = tiny_compression_scene("quasistatic");
  scene.mutable_compression()->set_walk_dt_factor(walk_dt_factor);
  scene.mutable_compression()->set_loaded_wall_factor(1);  // the walk step alone
  if (walk_dt_stress > 0) scene.mutable_compression()->set_walk_dt_stress(walk_dt_stress);
  return scene;
}

void expect_invalid_walk(const gel::v1::Scene& scene, const std::string& field) {
  try {
    resolve_compression_scene(scene);
    ADD_FAILURE() << "no InvalidArgument for " << field;
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

TEST(WalkStep, PaperKeepsItsStepAndTheFactorIsBoundedByTheBondPeriod) {
  gel::v1::Scene paper;
  paper.set_preset("paper-bond1");
  paper.mutable_compression()->set_fidelity("paper");
  EXPECT_EQ(resolve_compression_scene(paper).compression().walk_dt_factor(), 1.0);
  EXPECT_EQ(resolve_compression_scene(paper).compression().walk_dt_stress(), 1e-2);
  gel::v1::Scene preset;
  preset.set_preset("paper-bond1");
  EXPECT_EQ(resolve_compression_scene(preset).compression().walk_dt_factor(), 4.0);
  // The preset's dt is 0.025 of the shortest bond period and the walk step at most 0.25 of it.
  expect_invalid_walk(tiny_walk_scene(10.5, 0), "compression.walk_dt_factor");
  expect_invalid_walk(tiny_walk_scene(0.5, 0), "compression.walk_dt_factor");
  expect_invalid_walk(tiny_walk_scene(std::nan(""), 0), "compression.walk_dt_factor");
  gel::v1::Scene negative = tiny_walk_scene(4, 0);
  negative.mutable_compression()->set_walk_dt_stress(-1);
  expect_invalid_walk(negative, "compression.walk_dt_stress");
  EXPECT_EQ(resolve_compression_scene(tiny_walk_scene(10, 0)).compression().walk_dt_factor(), 10.0);
  // A scene whose own dt is long gets the preset's factor only as far as the bound allows.
  gel::v1::Scene long_dt = tiny_walk_scene(0, 0);
  long_dt.mutable_integration()->set_dt_fraction(0.1);
  EXPECT_DOUBLE_EQ(resolve_compression_scene(long_dt).compression().walk_dt_factor(), 2.5);
  long_dt.mutable_integration()->set_dt_fraction(0.5);
  EXPECT_EQ(resolve_compression_scene(long_dt).compression().walk_dt_factor(), 1.0);
  // A scene resolved before the field existed keeps 0, which runs as the scene's dt.
  gel::v1::Scene stored = resolve_compression_scene(tiny_walk_scene(1, 0));
  stored.mutable_compression()->clear_walk_dt_factor();
  EXPECT_EQ(resolve_compression_scene(stored).compression().walk_dt_factor(), 0.0);
}

TEST(WalkStep, SetTimeStepKeepsTheGuardsDistancePerStep) {
  System system(pair_along_x(0.0), bond1_params(kSprings));
  const double dt = system.params().dt, distance = system.params().max_speed * dt;
  system.set_time_step(4 * dt);
  EXPECT_EQ(system.params().dt, 4 * dt);
  EXPECT_NEAR(system.params().max_speed * system.params().dt, distance, 1e-15 * distance);
  EXPECT_THROW(system.set_time_step(0), InvalidArgument);
}

TEST(WalkStep, FastestContactFrequencyIsGershgorinsBound) {
  // One bond at contact: each particle has one contact of stiffness k_N, so the bound is
  // sqrt((1 + sqrt 2) k_N / m); pressed by delta the cubic term adds 3 C delta^2.
  const SimParams params = bond1_params(kSprings);
  const double k_n = params.bond.k_normal, c = params.bond.overlap_coefficient;
  EXPECT_NEAR(System(pair_along_x(0.0), params).fastest_contact_frequency(), std::sqrt((1 + std::sqrt(2.0)) * k_n / kMass),
              1e-12);
  const double delta = -0.05;
  EXPECT_NEAR(System(pair_along_x(delta), params).fastest_contact_frequency(),
              std::sqrt((1 + std::sqrt(2.0)) * (k_n + 3 * c * delta * delta) / kMass), 1e-9);
  // Stretched, only k_N.
  EXPECT_NEAR(System(pair_along_x(0.01), params).fastest_contact_frequency(), std::sqrt((1 + std::sqrt(2.0)) * k_n / kMass),
              1e-12);
}

TEST(WalkStep, TheWalkTakesLongerStepsForTheSameTimeAndEveryRelaxationTheScenesStep) {
  // The same walk to the first target (the same wall distance at the same speed) in a quarter
  // of the steps; the simulated time of the walk agrees to within the last step of each.
  const CompressionResult plain = run_compression(tiny_walk_scene(1, 0), RunOptions{});
  const std::string dir = fresh_temp_path("walk_step");
  RunOptions options;
  options.out_dir = dir;
  options.write_snapshots = false;
  const CompressionResult walked = run_compression(tiny_walk_scene(4, 1e3), options);
  ASSERT_TRUE(plain.finished && walked.finished);
  const gel::v1::CurveRow &a = plain.curve.rows(1), &b = walked.curve.rows(1);
  const double dt = resolve_sim_params(resolve_compression_scene(tiny_walk_scene(1, 0))).dt;
  EXPECT_NEAR(b.sim_time(), a.sim_time(), 8 * dt);
  const double plain_walk = static_cast<double>(a.steps() - a.relax_iterations());
  const double long_walk = static_cast<double>(b.steps() - b.relax_iterations());
  // A quarter, up to the chunks that the stiffness cap held to a shorter step.
  EXPECT_GE(long_walk, plain_walk / 4 - 2) << "walk steps " << long_walk << " against " << plain_walk;
  EXPECT_LT(long_walk, 1.05 * plain_walk / 4) << "walk steps " << long_walk << " against " << plain_walk;
  // Every row is relaxed as before, and the run ends at the scene's own step: the relaxations
  // and the state a resumed run starts from never inherit the walk's.
  for (int k = 1; k < walked.curve.rows_size(); ++k) EXPECT_TRUE(walked.curve.rows(k).equilibrated()) << "k " << k;
  const std::string bytes = read_file(dir + "/checkpoint.bin");
  ASSERT_GT(bytes.size(), 16u);
  gel::v1::Checkpoint checkpoint;
  ASSERT_TRUE(checkpoint.ParseFromString(bytes.substr(8, bytes.size() - 16)));
  EXPECT_EQ(checkpoint.engine().dt(), dt);
  std::filesystem::remove_all(dir);
}

TEST(WalkStep, BelowTheStressOnlyAndNeverPastHalfOfVerletsLimit) {
  CompressionSettings settings;
  settings.walk_dt_factor = 4;
  settings.walk_dt_stress = 1e-3;
  const double dt = 0.01;
  int asked = 0;
  auto frequency = [&asked](double omega) {
    return [&asked, omega] {
      ++asked;
      return omega;
    };
  };
  // Unloaded, soft: the whole factor.
  EXPECT_EQ(walk_time_step(settings, dt, 5e-4, frequency(1.0)), 4 * dt);
  EXPECT_EQ(walk_time_step(settings, dt, -5e-4, frequency(1.0)), 4 * dt);
  EXPECT_EQ(walk_time_step(settings, dt, 0.0, frequency(0.0)), 4 * dt);  // no bonds at all
  // Stiff contacts: omega dt = 1 at most, and never below the scene's dt.
  EXPECT_DOUBLE_EQ(walk_time_step(settings, dt, 5e-4, frequency(50.0)), 1.0 / 50.0);
  EXPECT_EQ(walk_time_step(settings, dt, 5e-4, frequency(1e6)), dt);
  EXPECT_EQ(asked, 5);
  // Loaded (or not a number), or the factor off: dt, without the loop over the bonds.
  asked = 0;
  EXPECT_EQ(walk_time_step(settings, dt, 1e-3, frequency(1.0)), dt);
  EXPECT_EQ(walk_time_step(settings, dt, -2e-3, frequency(1.0)), dt);
  EXPECT_EQ(walk_time_step(settings, dt, std::nan(""), frequency(1.0)), dt);
  settings.walk_dt_factor = 1;
  EXPECT_EQ(walk_time_step(settings, dt, 0.0, frequency(1.0)), dt);
  EXPECT_EQ(asked, 0);
}

// Loaded walls (docs/quasistatic.md "Loaded walls"): at and above loaded_wall_stress the walls may
// move faster; below it, or with the factor off, at v_wall.
TEST(LoadedWalls, FasterOnlyAtAndAboveTheStress) {
  CompressionSettings settings;
  settings.walk_dt_stress = 1e-3;  // not the loaded walls' stress
  settings.loaded_wall_stress = 1e-2;
  const double v = 3e-4;
  EXPECT_EQ(loaded_wall_speed(settings, v, 5e-2), v);  // off by default
  settings.loaded_wall_factor = 2;
  EXPECT_EQ(loaded_wall_speed(settings, v, 5e-3), v);
  EXPECT_EQ(loaded_wall_speed(settings, v, -5e-3), v);
  EXPECT_EQ(loaded_wall_speed(settings, v, 1e-2), 2 * v);
  EXPECT_EQ(loaded_wall_speed(settings, v, -2e-2), 2 * v);
  EXPECT_EQ(loaded_wall_speed(settings, v, std::nan("")), v);  // the guard's business, not a reason to hurry
}

TEST(LoadedWalls, TheQuasistaticPresetSetsTwiceFromThreeHundredthsAndPaperNone) {
  gel::v1::Scene preset;
  preset.set_preset("paper-bond1");
  const gel::v1::Compression resolved = resolve_compression_scene(preset).compression();
  EXPECT_EQ(resolved.loaded_wall_factor(), 2.0);
  EXPECT_EQ(resolved.loaded_wall_stress(), 3e-2);
  EXPECT_EQ(resolved.walk_dt_stress(), 1e-2);  // the walk step keeps its own stress
  for (const char* fidelity : {"paper", "fast"}) {
    gel::v1::Scene other = preset;
    other.mutable_compression()->set_fidelity(fidelity);
    EXPECT_EQ(resolve_compression_scene(other).compression().loaded_wall_factor(), 0.0) << fidelity;
    EXPECT_EQ(compression_settings(resolve_compression_scene(other).compression()).loaded_wall_factor, 1.0) << fidelity;
  }
  // A changed fidelity derives the field again; an explicit 1 keeps the walls at v_wall.
  gel::v1::Scene changed = resolve_compression_scene(preset);
  changed.mutable_compression()->set_fidelity("paper");
  EXPECT_EQ(resolve_compression_scene(changed).compression().loaded_wall_factor(), 0.0);
  EXPECT_EQ(resolve_compression_scene(changed).compression().loaded_wall_stress(), 1e-2);
  gel::v1::Scene pinned = preset;
  pinned.mutable_compression()->set_loaded_wall_factor(1);
  EXPECT_EQ(resolve_compression_scene(pinned).compression().loaded_wall_factor(), 1.0);
  // A stored scene resolved before the field existed keeps 0 (off), as its job started.
  gel::v1::Scene stored = resolve_compression_scene(preset);
  stored.mutable_compression()->clear_loaded_wall_factor();
  EXPECT_EQ(resolve_compression_scene(stored).compression().loaded_wall_factor(), 0.0);
  // Walls already near the skin's limit get the factor only as far as it allows.
  // The fastest walls the skin allows (bisected), then walls at 0.7 of that speed.
  gel::v1::Scene fast_walls = tiny_compression_scene("quasistatic");
  auto allowed = [&fast_walls](double v_wall_v0) {
    fast_walls.mutable_compression()->set_v_wall_v0(v_wall_v0);
    try {
      resolve_compression_scene(fast_walls);
      return true;
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(e.field(), "compression.v_wall") << e.what();
      return false;
    }
  };
  double fastest = 1e-4, too_fast = 1e-4;
  while (allowed(too_fast) && too_fast < 1e6) too_fast *= 2;
  ASSERT_LT(too_fast, 1e6);
  fastest = too_fast / 2;
  for (int halving = 0; halving < 40; ++halving) (allowed(0.5 * (fastest + too_fast)) ? fastest : too_fast) = 0.5 * (fastest + too_fast);
  fast_walls.mutable_compression()->set_v_wall_v0(0.7 * fastest);
  const gel::v1::Compression near_limit = resolve_compression_scene(fast_walls).compression();
  EXPECT_NEAR(near_limit.loaded_wall_factor(), 1 / 0.7, 0.01);
  EXPECT_NEAR(near_limit.walk_dt_factor(), 1 / 0.7, 0.01);
  EXPECT_NO_THROW(run_compression(fast_walls, RunOptions{}).finished);
}

TEST(LoadedWalls, TheFactorIsChecked) {
  auto with_factor = [](double factor) {
    gel::v1::Scene scene = tiny_compression_scene("quasistatic");
    scene.mutable_compression()->set_loaded_wall_factor(factor);
    return scene;
  };
  EXPECT_EQ(compression_settings(resolve_compression_scene(with_factor(2)).compression()).loaded_wall_factor, 2.0);
  // The stress defaults to the preset's and may be given apart from it.
  EXPECT_EQ(resolve_compression_scene(with_factor(2)).compression().loaded_wall_stress(), 3e-2);
  gel::v1::Scene apart = with_factor(2);
  apart.mutable_compression()->set_loaded_wall_stress(5e-2);
  EXPECT_EQ(compression_settings(resolve_compression_scene(apart).compression()).loaded_wall_stress, 5e-2);
  EXPECT_EQ(compression_settings(resolve_compression_scene(apart).compression()).walk_dt_stress, 1e-2);
  apart.mutable_compression()->set_loaded_wall_stress(-1);
  expect_invalid_walk(apart, "compression.loaded_wall_stress");
  expect_invalid_walk(with_factor(0.5), "compression.loaded_wall_factor");
  expect_invalid_walk(with_factor(11), "compression.loaded_wall_factor");
  expect_invalid_walk(with_factor(std::nan("")), "compression.loaded_wall_factor");
}

TEST(LoadedWalls, TheLoadedWalkTakesHalfTheStepsAtTwiceTheSpeed) {
  // A stress threshold of ~zero makes every walk loaded once the walls touch the network; the
  // walls then cover each target's distance in half the steps at the same dt.
  auto scene = [](double factor) {
    gel::v1::Scene s = tiny_walk_scene(1, 0);
    s.mutable_compression()->set_loaded_wall_factor(factor);
    s.mutable_compression()->set_loaded_wall_stress(1e-12);
    return s;
  };
  const CompressionResult plain = run_compression(scene(1), RunOptions{});
  const CompressionResult fast = run_compression(scene(2), RunOptions{});
  ASSERT_TRUE(plain.finished && fast.finished);
  ASSERT_EQ(plain.curve.rows_size(), fast.curve.rows_size());
  const int last = plain.curve.rows_size() - 1;
  auto walk_steps = [last](const CompressionResult& run) {
    // From row 2 on (the first target's walk starts unloaded), without FIRE's iterations.
    double steps = 0;
    for (int k = 2; k <= last; ++k) {
      const gel::v1::CurveRow &row = run.curve.rows(k), &before = run.curve.rows(k - 1);
      steps += static_cast<double>((row.steps() - row.relax_iterations()) - before.steps());
    }
    return steps;
  };
  const double ratio = walk_steps(fast) / walk_steps(plain);
  EXPECT_GT(ratio, 0.45) << walk_steps(fast) << " against " << walk_steps(plain);
  EXPECT_LT(ratio, 0.55) << walk_steps(fast) << " against " << walk_steps(plain);
  for (int k = 1; k <= last; ++k) EXPECT_TRUE(fast.curve.rows(k).equilibrated()) << "k " << k;
}

}  // namespace
}  // namespace gel
