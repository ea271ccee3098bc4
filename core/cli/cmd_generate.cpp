// gelsim generate: makes a fractal gel (MODEL.md "Initial configuration") and writes it.
//   gelsim generate --lx 300 --ly 500 --n-floc 64 --n-clusters 90 --seed 1 --out gel.json [--json]
//   gelsim generate --preset paper-bond1 --seed 7 --out gel.json
// Explicit options override the preset's values. Without --out nothing is written.
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "gel/configuration.hpp"
#include "gel/generator.hpp"

namespace {

struct GenerateOptions {
  std::string preset;
  double lx = 0, ly = 0;
  int n_floc = 0, n_clusters = 0;
  std::uint64_t seed = 1;
  double walk_step = 0, contact_tolerance = 0;
  int max_attempts = 0;
  std::string out;
  bool json = false;
};

// NaN (no fit possible) prints as null.
nlohmann::json number(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr); }

int run_generate(const GenerateOptions& o) {
  gel::v1::Generator request;
  request.set_preset(o.preset);
  request.set_lx(o.lx);
  request.set_ly(o.ly);
  request.set_n_floc(o.n_floc);
  request.set_n_clusters(o.n_clusters);
  request.set_seed(o.seed);
  request.set_walk_step(o.walk_step);
  request.set_contact_tolerance(o.contact_tolerance);
  request.set_max_attempts(o.max_attempts);
  gel::GeneratorSummary summary;
  const gel::Configuration config = gel::generate_gel(request, &summary);
  if (!o.out.empty()) gel::write_configuration(config, o.out);

  nlohmann::json j;
  j["particles"] = summary.particles;
  j["phi"] = summary.phi;
  j["bonds"] = summary.bonds;
  j["mean_contact_number"] = summary.mean_contact_number;
  j["floc_fractal_dimension"] = number(summary.floc_fractal_dimension);
  j["floc_fractal_dimension_stderr"] = number(summary.floc_fractal_dimension_stderr);
  j["seconds"] = summary.seconds;
  j["walk_moves"] = summary.walk_moves;
  j["seed"] = config.seed;
  j["lx"] = config.lx;
  j["ly"] = config.ly;
  j["n_floc"] = config.generator.n_floc();
  j["n_clusters"] = config.generator.n_clusters();
  j["preset"] = config.generator.preset();
  j["out"] = o.out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.out);
  if (o.json) {
    std::cout << j.dump() << "\n";
  } else {
    std::cout << "particles                 " << summary.particles << "\n"
              << "box                       " << config.lx << " x " << config.ly << "\n"
              << "phi                       " << summary.phi << "\n"
              << "bonds                     " << summary.bonds << "\n"
              << "mean contact number       " << summary.mean_contact_number << "\n"
              << "floc fractal dimension    " << summary.floc_fractal_dimension << " +- "
              << summary.floc_fractal_dimension_stderr << "\n"
              << "random-walk moves         " << summary.walk_moves << "\n"
              << "seconds                   " << summary.seconds << "\n";
    if (!o.out.empty()) std::cout << "written                   " << o.out << "\n";
  }
  return 0;
}

const gelsim::Registrar registrar{
    "generate", "Generate a fractal gel: hierarchical reaction-limited flocs joined by random walks",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<GenerateOptions>();
      sub.add_option("--preset", o->preset, "paper-bond1 (300x500, 64x90), paper-bond2 (200x500, 64x60), quick (60x110, 16x16)");
      sub.add_option("--lx", o->lx, "box width [a]");
      sub.add_option("--ly", o->ly, "box height [a]");
      sub.add_option("--n-floc", o->n_floc, "particles per floc (power of two)");
      sub.add_option("--n-clusters", o->n_clusters, "number of flocs");
      sub.add_option("--seed", o->seed, "random seed, 1 to 2^63-1 (default 1)")->check(gelsim::seed_validator());
      sub.add_option("--walk-step", o->walk_step, "random-walk step [a] (default 1)");
      sub.add_option("--contact-tolerance", o->contact_tolerance, "gap below which particles are bonded [a] (default 1e-9)");
      sub.add_option("--max-attempts", o->max_attempts, "placement attempts per floc (default 10000)");
      sub.add_option("--out", o->out, "configuration file (.json: JSON, else binary protobuf)");
      sub.add_flag("--json", o->json, "print the summary as one JSON object");
      return [o] { return run_generate(*o); };
    }};

}  // namespace
