// A bounded randomized test (a fuzz run of fixed length, so CI runs it under the sanitizers
// every time) of what every job and every gelsim run goes through first: the scene JSON parser,
// scene resolution and validation, and the engine parameters derived from the scene.
// Valid scenes are mutated (bytes changed, spans cut or repeated, numbers replaced by extreme
// ones, text cut short); each mutant must either be refused with InvalidArgument or resolve to
// a scene whose engine parameters are finite and positive. Anything else (another exception
// type, a crash, a sanitizer report) is a bug.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"

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

std::string mutate(std::string text, std::mt19937_64& random) {
  auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(random() % n); };
  static const std::vector<std::string> extremes = {"1e308", "-1e308", "1e-320", "-0", "0", "-1", "NaN", "\"Infinity\"",
                                                    "9223372036854775808", "-9223372036854775809", "4294967296", "1e9",
                                                    "\"\"", "null", "true", "[]", "{}", "\"quick\"", "0.5", "3"};
  const int edits = 1 + static_cast<int>(random() % 3);
  for (int edit = 0; edit < edits && !text.empty(); ++edit) {
    switch (random() % 6) {
      case 0: {  // one byte changed, often to JSON structure
        static const std::string alphabet = "{}[]\":,0123456789eE.-+ abcxyz_\\";
        text[pick(text.size())] = random() % 4 == 0 ? static_cast<char>(random() % 256) : alphabet[pick(alphabet.size())];
        break;
      }
      case 1: {  // a span cut out
        const std::size_t at = pick(text.size());
        text.erase(at, 1 + pick(16));
        break;
      }
      case 2: {  // a span repeated
        const std::size_t at = pick(text.size());
        text.insert(at, text.substr(at, 1 + pick(24)));
        break;
      }
      case 3: {  // a number replaced by an extreme value
        std::size_t at = pick(text.size());
        while (at < text.size() && !(std::isdigit(static_cast<unsigned char>(text[at])) || text[at] == '-')) ++at;
        std::size_t end = at;
        while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) || std::string(".eE+-").find(text[end]) != std::string::npos)) ++end;
        if (at < text.size()) text.replace(at, end - at, extremes[pick(extremes.size())]);
        break;
      }
      case 4:  // cut short
        text.resize(pick(text.size()));
        break;
      default: {  // a value after a colon replaced by any JSON value
        const std::size_t colon = text.find(':', pick(text.size()));
        if (colon == std::string::npos) break;
        std::size_t end = colon + 1;
        while (end < text.size() && text[end] != ',' && text[end] != '}') ++end;
        text.replace(colon + 1, end - colon - 1, " " + extremes[pick(extremes.size())]);
      }
    }
  }
  return text;
}

TEST(FuzzScene, MutatedScenesAreRefusedWithInvalidArgumentOrResolveToFiniteParameters) {
  const std::vector<std::string> seeds = seed_scenes();
  std::mt19937_64 random(20261203);
  int refused = 0, resolved = 0;
  for (int n = 0; n < kMutants; ++n) {
    const std::string text = mutate(seeds[static_cast<std::size_t>(random() % seeds.size())], random);
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

}  // namespace
}  // namespace gel
