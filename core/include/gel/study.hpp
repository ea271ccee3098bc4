#pragma once
// Built-in studies: named sets of ensembles (a scene and its seeds each), shared by
// `gelsim study` (local runs) and geld's SubmitStudy, so that a study preset means the same
// runs wherever it is submitted.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "gel/v1/scene.pb.h"

namespace gel {

struct StudyEnsembleSpec {
  std::string name;              // "bond1"
  gel::v1::Scene scene;          // unresolved: a scene preset and the overrides
  std::vector<std::uint64_t> seeds;
};

struct StudyPresetOptions {
  int seed_count = 0;            // 0: the preset's
  std::string fidelity;          // "": the preset's
};

// "paper": the published study (Seto et al. 2013): bond 1 and bond 2 gels at paper size
//   (scene presets paper-bond1, paper-bond2), 10 seeds each, fidelity quasistatic: the
//   quasi-static method reproduced the paper protocol's ensemble means (docs/quasistatic.md)
//   at a fraction of its cost.
// "small": both bonds on the 1408-particle gel (150 x 250 a, 22 flocs of 64) on which
//   docs/quasistatic.md validated the quasi-static method, 10 seeds, fidelity quasistatic: a
//   few minutes a run, for a first look at the observables and their scatter.
// "quick": both bonds on the quick scene, 3 seeds each, about a minute on one core: for
//   trying the study machinery, not for science.
// Throws InvalidArgument ("preset", "seed_count", "fidelity").
std::vector<StudyEnsembleSpec> study_preset(std::string_view name, const StudyPresetOptions& options = {});
std::vector<std::string> study_preset_names();
std::string study_preset_fidelity(std::string_view name);  // the preset's own fidelity

// Checks an ensemble name: 1-64 characters of [A-Za-z0-9_.-] (it names a directory of
// `gelsim study` and a job label). Throws InvalidArgument (field).
void validate_ensemble_name(const std::string& name, const std::string& field);

}  // namespace gel
