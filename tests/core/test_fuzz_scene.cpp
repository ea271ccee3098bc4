// A bounded randomized test (a fuzz run of fixed length, so CI runs it under the sanitizers
// every time) of what every job and every gelsim run goes through first: the scene JSON parser,
// scene resolution and validation, and the engine parameters derived from the scene.
// Valid scenes are mutated (bytes changed, spans cut or repeated, numbers replaced by extreme
// ones, text cut short); each mutant must either be refused with InvalidArgument or resolve to
// a scene whose engine parameters are finite and positive. Anything else (another exception
// type, a crash, a sanitizer report) is a bug.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"
#include "scene_mutator.hpp"

namespace gel {
namespace {

constexpr int kMutants = 30000;

std::vector<std::string> seed_scenes() {
  std::vector<std::string> scenes = {
      R"({"preset": "quick"})",
      R"({"preset": "paper-bond2", "compression": {"fidelity": "quasistatic", "steps": 5}, "effects": ["normal", "walls"]})",
      R"({"generator": {"lx": 40, "ly": 60, "n_floc": 8, "n_clusters": 10, "seed": "7"}, "bond": {"preset": "bond1"},
          "compression": {"fidelity": "fast", "phi_max": 0.5, "steps": 3, "m_exam": 200}, "integration": {"dt_fraction": 0.02}})",
  };
  // The fully resolved forms name every field, so mutations reach every validator.
  for (const char* preset : {"quick", "paper-bond1"}) {
    gel::v1::Scene scene;
    scene.set_preset(preset);
    scenes.push_back(scene_to_json(resolve_compression_scene(scene)));
  }
  return scenes;
}

TEST(FuzzScene, MutatedScenesAreRefusedWithInvalidArgumentOrResolveToFiniteParameters) {
  const std::vector<std::string> seeds = seed_scenes();
  std::mt19937_64 random(20261203);
  int refused = 0, resolved = 0;
  for (int n = 0; n < kMutants; ++n) {
    const std::string text = test::mutate_json(seeds[static_cast<std::size_t>(random() % seeds.size())], random);
    try {
      const gel::v1::Scene scene = resolve_compression_scene(scene_from_json(text));
      const SimParams params = resolve_sim_params(scene);
      ASSERT_TRUE(std::isfinite(params.dt) && params.dt > 0) << "dt " << params.dt << " from:\n" << text;
      ASSERT_TRUE(std::isfinite(params.eta_factor) && params.eta_factor >= 0) << "eta_factor " << params.eta_factor << " from:\n" << text;
      ASSERT_TRUE(std::isfinite(params.skin) && params.skin > 0) << "skin " << params.skin << " from:\n" << text;
      const auto& c = scene.compression();
      ASSERT_FALSE(compression_targets(0.12, c.w0(), c.phi_max(), c.steps()).empty()) << text;
      ++resolved;
    } catch (const InvalidArgument&) {
      ++refused;
    } catch (const std::exception& e) {
      FAIL() << "not an InvalidArgument: " << e.what() << "\nfrom:\n" << text;
    }
  }
  // Both outcomes must occur, or the mutations are not exercising the validators.
  EXPECT_GT(refused, kMutants / 4);
  EXPECT_GT(resolved, kMutants / 50);
  std::printf("%d mutants: %d refused, %d resolved\n", kMutants, refused, resolved);
}

TEST(FuzzScene, WhatAUserWroteIsRefusedNamingAFieldInTheProductsWords) {
  // A --scene file or a job's scene_json is checked (require_json_message) before protobuf's
  // parser, whose own words ("invalid value", "Cannot find field", "Unexpected token") name no
  // field a user could act on: none of them may come through.
  const std::vector<std::string> seeds = seed_scenes();
  std::mt19937_64 random(20261207);
  int refused = 0;
  for (int n = 0; n < kMutants; ++n) {
    const std::string text = test::mutate_json(seeds[static_cast<std::size_t>(random() % seeds.size())], random);
    try {
      require_json_message("scene", text, *gel::v1::Scene::descriptor());
      (void)scene_from_json(text);
    } catch (const InvalidArgument& e) {
      ++refused;
      const std::string message = e.what();
      for (const char* internal : {"INVALID_ARGUMENT:", "TYPE_", "Cannot find field", "Unexpected", "invalid value", "json.exception"})
        ASSERT_EQ(message.find(internal), std::string::npos) << message << "\nfrom:\n" << text;
      for (const char c : e.field())
        ASSERT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '[' || c == ']')
            << "not a field name: " << message;
    }
  }
  EXPECT_GT(refused, kMutants / 4);
}

}  // namespace
}  // namespace gel
