// gelctl submit: a compression job from a preset or a scene file, with overrides, seeds and
// labels; prints the job id on the first line, then optionally follows the job.
#include <cstdint>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "common.hpp"

namespace {

using gelctl::json;
using gelctl::UsageError;

struct SubmitArgs {
  std::string preset, scene_file, seeds_text, name, fidelity;
  std::vector<std::uint64_t> seed_list;
  std::vector<std::string> labels, sets;
  bool watch = false, json_output = false, rerun = false;
};

// "1,2,5-8" -> 1 2 5 6 7 8
std::vector<std::uint64_t> parse_seeds(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  std::stringstream in(text);
  std::string part;
  auto number = [](const std::string& digits) -> std::uint64_t {
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) {
      throw UsageError("--seeds: '" + digits + "' is not a non-negative integer");
    }
    return std::stoull(digits);
  };
  while (std::getline(in, part, ',')) {
    if (part.empty()) continue;
    auto dash = part.find('-');
    if (dash == std::string::npos) {
      seeds.push_back(number(part));
    } else {
      const auto first = number(part.substr(0, dash)), last = number(part.substr(dash + 1));
      if (last < first || last - first > 100000) throw UsageError("--seeds: bad range '" + part + "'");
      for (auto seed = first; seed <= last; ++seed) seeds.push_back(seed);
    }
  }
  if (seeds.empty()) throw UsageError("--seeds: no seed in '" + text + "'");
  return seeds;
}

// "compression.steps=4" into a JSON object (numbers, true/false and null bare; else strings).
void set_path(json& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw UsageError("--set: '" + assignment + "' is not field=value");
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  json value = json::parse(text, nullptr, false);
  if (value.is_discarded() || value.is_object() || value.is_array()) value = text;
  json* node = &root;
  std::stringstream in(path);
  std::string key;
  std::vector<std::string> keys;
  while (std::getline(in, key, '.')) keys.push_back(key);
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    if (!(*node)[keys[i]].is_object()) (*node)[keys[i]] = json::object();
    node = &(*node)[keys[i]];
  }
  (*node)[keys.back()] = value;
}

int run_submit(gelctl::Client& client, const SubmitArgs& args) {
  if (args.preset.empty() && args.scene_file.empty()) throw UsageError("submit: give --preset NAME or --scene FILE.json");
  gel::v1::SubmitJobRequest request;
  json scene = json::object();
  if (!args.scene_file.empty()) {
    scene = json::parse(gelctl::read_file(args.scene_file), nullptr, false);
    if (scene.is_discarded() || !scene.is_object()) {
      // Not ours to judge further: the server names the problem.
      request.set_scene_json(gelctl::read_file(args.scene_file));
    }
  } else {
    scene["preset"] = args.preset;
  }
  if (!request.scene_json().empty() && (!args.fidelity.empty() || !args.sets.empty())) {
    throw UsageError("--scene: " + args.scene_file + " is not a JSON object, cannot apply overrides");
  }
  if (request.scene_json().empty()) {
    if (!args.fidelity.empty()) set_path(scene, "compression.fidelity=" + args.fidelity);
    for (const auto& assignment : args.sets) set_path(scene, assignment);
    request.set_scene_json(scene.dump());
  }
  for (auto seed : args.seed_list) request.add_seeds(seed);
  if (!args.seeds_text.empty()) {
    for (auto seed : parse_seeds(args.seeds_text)) request.add_seeds(seed);
  }
  request.set_name(args.name);
  for (const auto& label : args.labels) {
    auto [key, value] = gelctl::split_label(label, "--label");
    (*request.mutable_labels())[key] = value;
  }
  request.set_rerun(args.rerun);
  gel::v1::SubmitJobResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().SubmitJob(context.get(), request, &response));
  std::cout << response.job_id() << std::endl;
  // The id stays the first line (scripts read it); the hit is said on stderr. geld has put this
  // submission's labels (and its name, if the job had none) on that job.
  if (response.cached())
    std::cerr << "gelctl: cache hit of " << response.job_id()
              << ": it already ran this scene with these seeds and this program; --rerun runs it again\n";
  if (args.json_output && !args.watch) std::cout << gelctl::job_json(response.job()).dump(2) << std::endl;
  if (args.watch) return gelctl::watch_job(client, response.job_id(), args.json_output);
  return gelctl::kExitSuccess;
}

const gelctl::Registrar submit_registrar{
    "submit", "Submit a compression job; prints its id on the first line", 10,
    [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<SubmitArgs>();
      auto* preset = sub.add_option("--preset", args->preset, "Scene preset: quick, paper-bond1, paper-bond2");
      auto* scene = sub.add_option("--scene", args->scene_file, "Scene JSON file (gel.v1.Scene)");
      preset->excludes(scene);
      sub.add_option("--seed", args->seed_list, "Seed (repeatable)");
      sub.add_option("--seeds", args->seeds_text, "Ensemble seeds: 1,2,3 or 1-10");
      sub.add_option("--name", args->name, "Job name");
      sub.add_option("--label", args->labels, "key=value (repeatable)");
      sub.add_option("--fidelity", args->fidelity, "compression.fidelity: fast, default, paper, quasistatic");
      sub.add_option("--set", args->sets, "Override a scene field: dotted.name=value (repeatable)");
      sub.add_flag("--watch,-w", args->watch, "Follow the job until it ends");
      sub.add_flag("--rerun", args->rerun, "Run even if a job with the same scene, seeds and program succeeded (run cache)");
      sub.add_flag("--json", args->json_output, "Print the job as JSON (and JSON lines while watching)");
      return [args](gelctl::Client& client) { return run_submit(client, *args); };
    }};

}  // namespace
