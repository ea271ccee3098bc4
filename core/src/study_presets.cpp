#include <cctype>

#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/study.hpp"

namespace gel {
namespace {

constexpr int kMaxStudySeeds = 1000;

// An ensemble's scene: a scene preset, or (empty) the small validation gel of
// docs/quasistatic.md; the ensemble's name is its bond preset.
struct EnsembleDefinition {
  std::string_view name;
  std::string_view scene_preset;
};

struct PresetDefinition {
  std::string_view name;
  int seeds;
  std::string_view fidelity;
  std::vector<EnsembleDefinition> ensembles;
};

const std::vector<PresetDefinition>& definitions() {
  static const std::vector<PresetDefinition> presets = {
      {"paper", 10, "quasistatic", {{"bond1", "paper-bond1"}, {"bond2", "paper-bond2"}}},
      {"small", 10, "quasistatic", {{"bond1", ""}, {"bond2", ""}}},
      {"quick", 3, "paper", {{"bond1", "quick"}, {"bond2", "quick"}}},
  };
  return presets;
}

const PresetDefinition& find(std::string_view name) {
  for (const auto& preset : definitions())
    if (preset.name == name) return preset;
  std::string known;
  for (const auto& preset : definitions()) known += (known.empty() ? "" : ", ") + std::string(preset.name);
  throw InvalidArgument("preset", "unknown study preset " + quoted(std::string(name)) + " (known: " + known + ")");
}

}  // namespace

std::vector<std::string> study_preset_names() {
  std::vector<std::string> names;
  for (const auto& preset : definitions()) names.emplace_back(preset.name);
  return names;
}

std::string study_preset_fidelity(std::string_view name) { return std::string(find(name).fidelity); }

std::vector<StudyEnsembleSpec> study_preset(std::string_view name, const StudyPresetOptions& options) {
  const PresetDefinition& preset = find(name);
  if (options.seed_count < 0 || options.seed_count > kMaxStudySeeds)
    throw InvalidArgument("seed_count", "must be in 0..1000, got " + std::to_string(options.seed_count));
  const int seeds = options.seed_count > 0 ? options.seed_count : preset.seeds;
  const std::string fidelity = options.fidelity.empty() ? std::string(preset.fidelity) : options.fidelity;
  std::vector<StudyEnsembleSpec> out;
  for (const auto& [ensemble, scene_preset_name] : preset.ensembles) {
    StudyEnsembleSpec spec;
    spec.name = std::string(ensemble);
    if (scene_preset_name.empty()) {
      // The 1408-particle gel on which docs/quasistatic.md validated the quasi-static method
      // against the paper's protocol (150 x 250 a, 22 flocs of 64), for either bond set.
      spec.scene.mutable_generator()->set_lx(150);
      spec.scene.mutable_generator()->set_ly(250);
      spec.scene.mutable_generator()->set_n_floc(64);
      spec.scene.mutable_generator()->set_n_clusters(22);
    } else {
      spec.scene.set_preset(std::string(scene_preset_name));
    }
    spec.scene.set_name(std::string(name) + "/" + spec.name);
    spec.scene.mutable_compression()->set_fidelity(fidelity);
    // The quick scene is bond 1; its bond-2 ensemble overrides the bond law only.
    if (scene_preset_name.empty() || scene_preset_name == "quick") spec.scene.mutable_bond()->set_preset(spec.name);
    resolve_compression_scene(spec.scene);  // an unknown fidelity fails here, naming the field
    for (int s = 1; s <= seeds; ++s) spec.seeds.push_back(static_cast<std::uint64_t>(s));
    out.push_back(std::move(spec));
  }
  return out;
}

void validate_ensemble_name(const std::string& name, const std::string& field) {
  if (name.empty() || name.size() > 64)
    throw InvalidArgument(field, "must be 1-64 characters, got " + std::to_string(name.size()));
  for (const char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-'))
      throw InvalidArgument(field, "may hold only letters, digits, '_', '.' and '-': " + quoted(name));
  if (name == "." || name == "..") throw InvalidArgument(field, "must not be '.' or '..'");
}

}  // namespace gel
