// gelsim bench: particle-steps per second of the step loop on the benchmark network, with all
// effects or with a subset. Speed is measured here, never in unit tests.
#include <algorithm>
#include <chrono>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "command_line.hpp"
#include "gel/bench_network.hpp"
#include "gel/errors.hpp"
#include "gel/system.hpp"

namespace {

struct BenchArgs {
  int particles = 5760;
  std::string bond = "bond1";
  std::vector<std::string> effects;
  bool subsets = false;
  double min_seconds = 2.0;
  double v_wall = 0.01;
  double skin = 0;  // 0: the scene default
  std::uint64_t seed = 1;
  bool json = false;
  int repeat = 1;
  std::vector<int> threads{1};
};

nlohmann::json bench_once(const BenchArgs& args, unsigned effects, int threads) {
  gel::v1::Scene scene;
  scene.mutable_bond()->set_preset(args.bond);
  gel::SimParams params = gel::resolve_sim_params(scene);
  params.effects = effects;
  if (args.skin > 0) params.skin = args.skin;
  gel::System system(gel::random_network(args.particles, args.seed), params);
  system.set_threads(threads);
  if (effects & gel::kWalls) {
    system.install_walls();
    system.set_wall_velocities(args.v_wall, -args.v_wall);
  }
  system.run(200);  // warm caches and let the first contacts form
  using clock = std::chrono::steady_clock;
  std::int64_t steps = 0;
  const auto start = clock::now();
  double seconds = 0;
  std::int64_t chunk = 100;
  while (seconds < args.min_seconds) {
    system.run(chunk);
    steps += chunk;
    seconds = std::chrono::duration<double>(clock::now() - start).count();
    if (seconds < 0.1 * args.min_seconds) chunk *= 2;
  }
  const double rate = static_cast<double>(steps) * static_cast<double>(system.size()) / seconds;
  const auto& events = system.events();
  return {{"particles", system.size()},
          {"bonds", system.bonds().size()},
          {"effects", gel::effect_names(effects)},
          {"steps", steps},
          {"seconds", seconds},
          {"particle_steps_per_second", rate},
          {"threads", threads},
          {"dt", system.params().dt},
          {"neighbour_rebuilds", system.neighbour_rebuilds()},
          {"events", {{"normal", events.normal}, {"sliding", events.sliding}, {"rolling", events.rolling}, {"created", events.created}}}};
}

int run_bench(const BenchArgs& args) {
  std::vector<std::pair<std::string, unsigned>> runs;
  if (args.subsets) {
    using namespace gel;
    runs = {{"all", kAllEffects},
            {"no thresholds", kAllEffects & ~kThresholds},
            {"no creation", kAllEffects & ~kBondCreation},
            {"no drag", kAllEffects & ~kDrag},
            {"no rolling, no sliding", kAllEffects & ~(kRolling | kSliding)},
            {"normal springs only", kNormalSpring | kPeriodicX | kWalls}};
  } else {
    runs = {{"selected", gel::parse_effects(args.effects)}};
  }
  nlohmann::json results = nlohmann::json::array();
  for (const auto& [base_label, effects] : runs)
  for (const int threads : args.threads) {
    const std::string label = args.threads.size() > 1 ? base_label + ", " + std::to_string(threads) + " threads" : base_label;
    // The machine is noisy: with --repeat N the rate reported is the median of N measurements
    // (all of them are listed).
    std::vector<nlohmann::json> trials;
    for (int r = 0; r < args.repeat; ++r) trials.push_back(bench_once(args, effects, threads));
    std::vector<double> rates;
    for (const auto& t : trials) rates.push_back(t["particle_steps_per_second"].get<double>());
    std::vector<double> sorted = rates;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t mid = sorted.size() / 2;
    const double median = sorted.size() % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
    nlohmann::json result = trials[0];
    result["particle_steps_per_second"] = median;
    if (args.repeat > 1) {
      result["repeats"] = args.repeat;
      result["particle_steps_per_second_all"] = rates;
    }
    result["label"] = label;
    if (!args.json)
      std::cerr << label << ": " << result["particle_steps_per_second"].get<double>() / 1e6 << " M particle-steps/s ("
                << result["steps"] << " steps, " << result["seconds"].get<double>() << " s)\n";
    results.push_back(result);
  }
  if (args.json)
    std::cout << (results.size() == 1 ? results[0] : nlohmann::json{{"runs", results}}).dump() << "\n";
  else
    std::cout << results.dump(2) << "\n";
  return 0;
}

gelsim::Registrar bench_command("bench", "speed of the step loop (particle-steps per second)", [](CLI::App& sub) {
  auto args = std::make_shared<BenchArgs>();
  sub.add_option("--particles", args->particles, "particles in the network")->check(CLI::Range(2, 100000000));
  sub.add_option("--bond", args->bond, "bond preset (bond1, bond2)");
  sub.add_option("--effects", args->effects, "effects to switch on (default: all)")->delimiter(',');
  sub.add_flag("--subsets", args->subsets, "run all effects and a set of subsets");
  sub.add_option("--min-seconds", args->min_seconds, "time to run each measurement")
      ->check(gel::cli::positive(args->min_seconds));
  sub.add_option("--v-wall", args->v_wall, "wall speed during the benchmark [a/t0]")
      ->check(gel::cli::non_negative(args->v_wall));
  sub.add_option("--skin", args->skin, "neighbour-list skin [a] (default: the scene default)")
      ->check(gel::cli::positive(args->skin));
  sub.add_option("--seed", args->seed, "seed of the network, 1 to 2^63-1")->check(gelsim::seed_validator());
  sub.add_flag("--json", args->json, "print one JSON object");
  sub.add_option("--threads", args->threads, "engine threads; several (1,2,4): a scaling table")
      ->delimiter(',')
      ->check(CLI::Range(1, 1024));
  sub.add_option("--repeat", args->repeat, "measure N times and report the median (default 1)")->check(CLI::Range(1, 100));
  return [args] { return run_bench(*args); };
});

}  // namespace
