// gelsim bend: the three-point bending scene, or the bisection for its plastic threshold.
#include <cmath>
#include <iostream>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "command_line.hpp"
#include "gel/bending.hpp"
#include "gel/errors.hpp"

namespace {

struct BendArgs {
  std::string bond = "bond1";
  int chain = 11;
  double force = 0.1;
  double dt_fraction = 0;
  double eta_factor = -1;
  double max_time = 20000;
  bool json = false;
  bool find_threshold = false;
  double low = 0.01, high = 1.0, resolution = 1e-4;
};

gel::SimParams bend_params(const BendArgs& args) {
  gel::v1::Scene scene;
  scene.mutable_bond()->set_preset(args.bond);
  if (args.dt_fraction > 0) scene.mutable_integration()->set_dt_fraction(args.dt_fraction);
  if (args.eta_factor >= 0) scene.mutable_integration()->set_eta_factor(args.eta_factor);
  gel::SimParams params = gel::resolve_sim_params(scene);
  params.effects = gel::bending_effects();
  return params;
}

nlohmann::json to_json(const gel::BendingResult& r, double force) {
  return {{"force", force},
          {"recovered", r.recovered},
          {"max_deflection", r.max_deflection},
          {"loaded_deflection", r.loaded_deflection},
          {"residual_deflection", r.residual_deflection},
          {"loaded_equilibrium", r.loaded_equilibrium},
          {"unloaded_equilibrium", r.unloaded_equilibrium},
          {"events", {{"normal", r.events.normal}, {"sliding", r.events.sliding}, {"rolling", r.events.rolling}, {"created", r.events.created}}},
          {"sim_time", r.sim_time},
          {"steps", r.steps}};
}

int run_bend(const BendArgs& args) {
  const gel::SimParams params = bend_params(args);
  gel::BendingOptions options;
  options.chain = args.chain;
  options.max_time = args.max_time;
  if (args.find_threshold) {
    // Bisection on F_ex between a force that recovers and one that leaves the chain bent.
    double low = args.low, high = args.high;
    auto recovers = [&](double force) {
      options.force = force;
      return gel::run_bending(params, options).recovered;
    };
    if (!recovers(low)) throw gel::InvalidArgument("--low", "the chain does not recover at the lower bracket");
    if (recovers(high)) throw gel::InvalidArgument("--high", "the chain still recovers at the upper bracket");
    int evaluations = 2;
    while (high - low > args.resolution) {
      const double middle = 0.5 * (low + high);
      (recovers(middle) ? low : high) = middle;
      ++evaluations;
    }
    nlohmann::json out = {{"bond", args.bond}, {"chain", args.chain}, {"threshold_force", 0.5 * (low + high)},
                          {"bracket", {low, high}}, {"evaluations", evaluations}};
    if (args.json)
      std::cout << out.dump() << "\n";
    else
      std::cout << "bending threshold F_ex = " << 0.5 * (low + high) << " F0 (between " << low << " and " << high << ")\n";
    return 0;
  }
  options.force = args.force;
  const gel::BendingResult result = gel::run_bending(params, options);
  if (args.json) {
    std::cout << to_json(result, args.force).dump() << "\n";
  } else {
    std::cout << (result.recovered ? "elastic: the chain recovered" : "plastic: the chain stays bent") << "\n"
              << "max deflection under load  " << result.max_deflection << " a\n"
              << "residual deflection        " << result.residual_deflection << " a\n"
              << "events: normal " << result.events.normal << ", sliding " << result.events.sliding << ", rolling "
              << result.events.rolling << ", created " << result.events.created << "\n";
  }
  return 0;
}

gelsim::Registrar bend_command("bend", "three-point bending of a straight chain", [](CLI::App& sub) {
  auto args = std::make_shared<BendArgs>();
  sub.add_option("--bond", args->bond, "bond preset (bond1, bond2)");
  sub.add_option("--chain", args->chain, "particles in the chain (odd)")->check(CLI::Range(3, 10001));
  sub.add_option("--force", args->force, "F_ex on the middle particle [F0]")->check(gel::cli::positive(args->force));
  sub.add_option("--dt-fraction", args->dt_fraction, "time step as a fraction of the shortest period")
      ->check(gel::cli::positive(args->dt_fraction));
  sub.add_option("--eta-factor", args->eta_factor, "viscosity in units of eta_cd (default 0.1)")
      ->check(gel::cli::non_negative(args->eta_factor));
  sub.add_option("--max-time", args->max_time, "time allowed per phase [t0]")->check(gel::cli::positive(args->max_time));
  sub.add_flag("--json", args->json, "print one JSON object");
  sub.add_flag("--find-threshold", args->find_threshold, "bisect for the force where the chain stops recovering");
  sub.add_option("--low", args->low, "lower bracket for --find-threshold")->check(gel::cli::positive(args->low));
  sub.add_option("--high", args->high, "upper bracket for --find-threshold")->check(gel::cli::positive(args->high));
  sub.add_option("--resolution", args->resolution, "bracket width to stop at")->check(gel::cli::positive(args->resolution));
  return [args] { return run_bend(*args); };
});

}  // namespace
