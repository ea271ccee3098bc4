// gelsim compress: stepwise uniaxial compression of a fractal gel (docs/compression.md).
//   gelsim compress --preset quick
//   gelsim compress --preset paper-bond1 --seed 1 --out runs/b1 --progress-file runs/b1/progress.jsonl
//   gelsim compress --resume runs/b1
//   gelsim compress --preset quick --seeds 1-8 --jobs 2 --out runs/ens   (an ensemble, members in parallel)
// Progress goes to stderr (a bar on a terminal, plain lines otherwise), the curve to stdout.
// Exit codes: 0 done, 2 invalid input, 3 numerical instability, 4 stopped by a signal
// (checkpointed: resume with --resume DIR).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "command_line.hpp"
#include "duration_text.hpp"
#include "gel/analysis/ensemble_statistic.hpp"
#include "gel/compression.hpp"
#include "gel/resources.hpp"
#include "gel/seed.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/progress_file.hpp"
#include "gel/run_directory.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void request_stop(int) { g_stop.store(true); }

struct CompressArgs {
  std::string preset;
  std::string scene_file;
  std::string config_file;
  std::optional<std::int64_t> gel_frame;  // of a GSD or extended XYZ --gel; default the last
  std::string bond;
  std::optional<std::uint64_t> seed;
  std::string fidelity;
  std::string out;
  std::optional<std::string> resume;
  bool overwrite = false;
  std::string progress_file;
  double progress_interval = 1.0;
  bool json = false;
  bool no_snapshots = false;
  bool estimate = false;
  // Protocol and integration overrides (0 / unset: preset or default).
  double phi_max = 0, w0 = 0, v_wall = 0, v_wall_v0 = 0, a = 0, b = 0, max_wait_time = 0, stress_floor = 0;
  double dt = 0, dt_fraction = 0, checkpoint_seconds = 0, adaptive_wall = 0, adaptive_drag_fraction = 0;
  std::optional<double> eta_factor;
  int steps = 0, profile_slices = 0;
  std::int64_t m_exam = 0;
  std::optional<bool> shortcut;
  std::string exam_ruptures, approach;
  double strain_step = 0, relax_tolerance = 0, relax_floor = 0, relax_dt_max = 0;
  double walk_dt_factor = 0, walk_dt_stress = 0, loaded_wall_factor = 0, loaded_wall_stress = 0;
  std::int64_t relax_max_iterations = 0;
  // Ensemble: members by seed, `jobs` at a time, each in out/seed_<seed>.
  std::string seeds;
  int jobs = 1;
  int threads = 0;  // 0: the scene's integration.threads, else 1
  // GSD trajectory: a frame every N engine steps, to OUT/trajectory.gsd unless named.
  std::int64_t trajectory_every = 0;
  std::string trajectory;
  // Thermo log: a CSV line of the state every N engine steps, to OUT/thermo.csv.
  std::int64_t thermo_every = 0;
};

// The thermo log of a run whose outputs go to `dir` (none without --thermo-every: the scene of a
// resumed run may still ask for one); throws when there is nowhere to put it.
std::string thermo_path(const CompressArgs& args, const std::string& dir) {
  if (args.thermo_every <= 0) return {};
  if (dir.empty()) throw gel::InvalidArgument("--thermo-every", "needs --out DIR: the log is written to DIR/thermo.csv");
  return gel::default_thermo_path(dir);
}

// The trajectory file of a run whose outputs go to `dir`; throws when there is nowhere to put it.
std::string trajectory_path(const CompressArgs& args, const std::string& dir) {
  if (args.trajectory_every <= 0) {
    if (!args.trajectory.empty()) throw gel::InvalidArgument("trajectory", "--trajectory needs --trajectory-every N (steps between frames)");
    return {};
  }
  if (!args.trajectory.empty()) return args.trajectory;
  if (dir.empty()) throw gel::InvalidArgument("trajectory", "--trajectory-every needs --out or --trajectory FILE.gsd");
  return gel::default_trajectory_path(dir);
}

// A fresh run's --out: refused when an earlier run is there (its trajectory, snapshots past the
// new last row and plots would stay beside the new curve, read as one run), cleared with
// --overwrite.
void prepare_out_dir(const CompressArgs& args) {
  if (args.resume) {
    if (args.overwrite) throw gel::InvalidArgument("--overwrite", "starts the run afresh, --resume continues it: give one of them");
    return;
  }
  if (args.out.empty()) {
    if (args.overwrite) throw gel::InvalidArgument("--overwrite", "needs --out DIR, the run directory to clear");
    return;
  }
  auto joined = [](const std::vector<std::string>& names) {
    std::string text;
    for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
    return text;
  };
  if (args.overwrite) {
    const std::string removed = joined(gel::clear_earlier_run(args.out));
    if (!removed.empty()) std::cerr << "gelsim: --overwrite: removed the earlier run's " << removed << " from " << args.out << "\n";
    return;
  }
  if (const std::string found = joined(gel::earlier_run_outputs(args.out)); !found.empty())
    throw gel::InvalidArgument("--out", "'" + args.out + "' holds an earlier run (" + found + "): continue it with --resume " +
                                            args.out + ", replace it with --overwrite, or choose another --out");
}

gel::v1::Scene build_scene(const CompressArgs& args) {
  gel::v1::Scene scene;
  if (!args.scene_file.empty()) {
    const std::string text = gel::read_file(args.scene_file);
    scene = gel::scene_from_json(text);
  }
  if (!args.preset.empty()) scene.set_preset(args.preset);
  if (scene.preset().empty() && args.scene_file.empty() && args.config_file.empty()) scene.set_preset("quick");
  if (!args.bond.empty()) scene.mutable_bond()->set_preset(args.bond);
  if (args.seed) scene.mutable_generator()->set_seed(*args.seed);
  // In the scene, so that the run's record says so and --resume goes on logging without the flag.
  if (args.thermo_every > 0) scene.mutable_output()->set_thermo_every(args.thermo_every);
  gel::v1::Compression* c = scene.mutable_compression();
  if (!args.fidelity.empty()) c->set_fidelity(args.fidelity);
  if (args.phi_max != 0) c->set_phi_max(args.phi_max);
  if (args.w0 != 0) c->set_w0(args.w0);
  if (args.steps != 0) c->set_steps(args.steps);
  if (args.v_wall != 0) c->set_v_wall(args.v_wall);
  if (args.v_wall_v0 != 0) c->set_v_wall_v0(args.v_wall_v0);
  if (args.m_exam != 0) c->set_m_exam(args.m_exam);
  if (args.a != 0) c->set_a_tolerance(args.a);
  if (args.b != 0) c->set_b_tolerance(args.b);
  if (args.max_wait_time != 0) c->set_max_wait_time(args.max_wait_time);
  if (args.stress_floor != 0) c->set_stress_floor(args.stress_floor);
  if (args.shortcut) c->set_approach_shortcut(*args.shortcut);
  if (args.adaptive_wall != 0) c->set_adaptive_wall_max_factor(args.adaptive_wall);
  if (args.adaptive_drag_fraction != 0) c->set_adaptive_wall_drag_fraction(args.adaptive_drag_fraction);
  if (args.profile_slices != 0) c->set_profile_slices(args.profile_slices);
  if (args.checkpoint_seconds != 0) c->set_checkpoint_seconds(args.checkpoint_seconds);
  if (!args.exam_ruptures.empty()) c->set_exam_ruptures(args.exam_ruptures);
  if (args.strain_step != 0) c->set_quasistatic_strain_step(args.strain_step);
  if (!args.approach.empty()) c->set_quasistatic_approach(args.approach);
  if (args.relax_tolerance != 0) c->set_relax_force_tolerance(args.relax_tolerance);
  if (args.relax_floor != 0) c->set_relax_force_floor(args.relax_floor);
  if (args.relax_dt_max != 0) c->set_relax_dt_max_factor(args.relax_dt_max);
  if (args.walk_dt_factor != 0) c->set_walk_dt_factor(args.walk_dt_factor);
  if (args.walk_dt_stress != 0) c->set_walk_dt_stress(args.walk_dt_stress);
  if (args.loaded_wall_factor != 0) c->set_loaded_wall_factor(args.loaded_wall_factor);
  if (args.loaded_wall_stress != 0) c->set_loaded_wall_stress(args.loaded_wall_stress);
  if (args.relax_max_iterations != 0) c->set_relax_max_iterations(args.relax_max_iterations);
  if (args.dt != 0) scene.mutable_integration()->set_dt(args.dt);
  if (args.dt_fraction != 0) scene.mutable_integration()->set_dt_fraction(args.dt_fraction);
  if (args.eta_factor) scene.mutable_integration()->set_eta_factor(*args.eta_factor);
  return scene;
}

std::string progress_text(const gel::v1::Progress& p) {
  // Quasi-static runs also show the relaxation converging.
  char relaxation[96] = "";
  if (p.phase() == "relaxing" || (p.phase() == "compressing" && p.relax_iterations() > 0))
    std::snprintf(relaxation, sizeof relaxation, "  residual %.2e (target %.2e) after %lld it", p.residual_force(),
                  p.residual_target(), static_cast<long long>(p.relax_iterations()));
  char buffer[320];
  std::snprintf(buffer, sizeof buffer, "%-11s k %d/%d  phi %.4f -> %.4f  P %.3e%s  breaks %lld  resets %lld  elapsed %s  ETA %s",
                p.phase().c_str(), p.k(), p.k_total(), p.phi(), p.target_phi(), p.p(), relaxation,
                static_cast<long long>(p.events().normal()),
                static_cast<long long>(p.events().sliding() + p.events().rolling()),
                gel::duration_text(p.elapsed_seconds()).c_str(), gel::duration_text(p.remaining_seconds()).c_str());
  return buffer;
}

void print_table(const gel::v1::Curve& curve) {
  std::printf("%3s %9s %12s %12s %12s %7s %8s %8s %8s %8s %3s\n", "k", "phi", "P_y[P0]", "P_top", "P_bot", "z",
              "normal", "sliding", "rolling", "created", "eq");
  for (const auto& r : curve.rows())
    std::printf("%3d %9.5f %12.5e %12.5e %12.5e %7.4f %8lld %8lld %8lld %8lld %3s\n", r.k(), r.phi(), r.p(), r.p_top(),
                r.p_bot(), r.contact_number(), static_cast<long long>(r.ruptures().normal()),
                static_cast<long long>(r.ruptures().sliding()), static_cast<long long>(r.ruptures().rolling()),
                static_cast<long long>(r.ruptures().created()), r.equilibrated() ? "yes" : "no");
  if (curve.rows_size() > 0)
    std::printf("wall time %.2f s, %lld steps, %d particles\n", curve.rows(curve.rows_size() - 1).wall_seconds(),
                static_cast<long long>(curve.rows(curve.rows_size() - 1).steps()), curve.particles());
}

// --- Ensembles: --seeds 1-10 --jobs N ------------------------------------------------------

// "1-10", "1,3,7-9": the seeds in the order given, each once.
std::vector<std::uint64_t> parse_seeds(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t dash = item.find('-');
    try {
      std::size_t used = 0;
      const std::uint64_t first = std::stoull(item.substr(0, dash), &used);
      if (used != item.substr(0, dash).size()) throw std::invalid_argument("trailing characters");
      std::uint64_t last = first;
      if (dash != std::string::npos) {
        last = std::stoull(item.substr(dash + 1), &used);
        if (used != item.size() - dash - 1) throw std::invalid_argument("trailing characters");
      }
      gel::require_seed("--seeds", first);
      gel::require_seed("--seeds", last);
      if (last < first) throw gel::InvalidArgument("--seeds", "range '" + item + "' runs backwards");
      if (last - first >= 10000 || seeds.size() + (last - first) >= 10000)
        throw gel::InvalidArgument("--seeds", "more than 10000 seeds");
      for (std::uint64_t seed = first; seed <= last; ++seed)
        if (std::find(seeds.begin(), seeds.end(), seed) == seeds.end()) seeds.push_back(seed);
    } catch (const gel::InvalidArgument&) {
      throw;  // a logic_error too, and already says what is wrong
    } catch (const std::logic_error&) {
      throw gel::InvalidArgument("--seeds", "'" + item + "' is not a seed or a range A-B (e.g. --seeds 1-10 or 1,4,7-9)");
    }
    start = comma + 1;
  }
  return seeds;
}

std::string member_dir(const std::string& out, std::uint64_t seed) {
  return (std::filesystem::path(out) / ("seed_" + std::to_string(seed))).string();
}

struct MemberOutcome {
  std::uint64_t seed = 0;
  gel::CompressionResult result;
  int exit_code = 0;  // as a single run's
  std::string error;
};

// Mean, standard deviation and equilibrated count of P per target, by the product's one ensemble
// statistic (gel/analysis/ensemble_statistic.hpp: over the members that reached the row; the full
// analysis of an ensemble is `gelsim analyze-run OUT`).
nlohmann::json ensemble_summary(const std::vector<MemberOutcome>& members) {
  std::vector<const gel::v1::Curve*> curves;
  for (const auto& m : members) curves.push_back(&m.result.curve);
  const auto phi = gel::analysis::ensemble_statistic(curves, [](const gel::v1::CurveRow& row) { return row.phi(); });
  const auto p = gel::analysis::ensemble_statistic(curves, [](const gel::v1::CurveRow& row) { return row.p(); });
  std::map<int, int> equilibrated;  // members whose row k is at equilibrium
  for (const auto* curve : curves)
    for (const auto& row : curve->rows()) equilibrated[row.k()] += row.equilibrated() ? 1 : 0;
  nlohmann::json rows = nlohmann::json::array();
  for (std::size_t r = 0; r < p.size(); ++r)
    rows.push_back({{"k", p[r].k}, {"phi", phi[r].mean}, {"P_mean", p[r].mean}, {"P_std", p[r].std}, {"members", p[r].n},
                    {"equilibrated", equilibrated[p[r].k]}});
  return rows;
}

int run_ensemble(const CompressArgs& args) {
  const bool resuming = args.resume.has_value();
  const std::string out = resuming ? (args.resume->empty() ? args.out : *args.resume) : args.out;
  if (out.empty()) throw gel::InvalidArgument("--out", "an ensemble needs a directory (--out DIR): each member runs in DIR/seed_<seed>");
  if (args.jobs < 0) throw gel::InvalidArgument("--jobs", "must be 0 (one per core) or positive");
  if (!args.trajectory.empty())
    throw gel::InvalidArgument("--trajectory", "members of an ensemble write DIR/seed_<seed>/trajectory.gsd each: leave --trajectory out");
  const std::filesystem::path manifest = std::filesystem::path(out) / "ensemble.json";
  std::vector<std::uint64_t> seeds;
  gel::v1::Scene scene;
  if (resuming) {
    const nlohmann::json stored = nlohmann::json::parse(gel::read_file(manifest.string()));
    seeds = stored.at("seeds").get<std::vector<std::uint64_t>>();
  } else {
    seeds = parse_seeds(args.seeds);
    scene = gel::resolve_compression_scene(build_scene(args));  // invalid input fails before any member starts
    std::filesystem::create_directories(out);
    std::ofstream(manifest) << nlohmann::json{{"seeds", seeds}, {"scene", nlohmann::json::parse(gel::scene_to_json(scene))}}.dump(1)
                            << "\n";
  }
  const int jobs = std::min<int>(static_cast<int>(seeds.size()),
                                 args.jobs > 0 ? args.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));

  gel::ProgressFile progress_file(args.progress_file);
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
  std::mutex print_mutex;
  auto print = [&](const std::string& line) {
    std::lock_guard lock(print_mutex);
    std::cerr << line << '\n';
  };
  print("ensemble of " + std::to_string(seeds.size()) + " members, " + std::to_string(jobs) + " at a time, in " + out);

  std::vector<MemberOutcome> outcomes(seeds.size());
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t index = next++; index < seeds.size(); index = next++) {
      MemberOutcome& outcome = outcomes[index];
      const std::uint64_t seed = outcome.seed = seeds[index];
      const std::string prefix = "[seed " + std::to_string(seed) + "] ";
      gel::RunOptions options;
      options.out_dir = member_dir(out, seed);
      options.stop = &g_stop;
      options.progress_interval_seconds = std::max(args.progress_interval, 1.0);
      options.write_snapshots = !args.no_snapshots;
      options.threads = args.threads;
      options.trajectory_every = args.trajectory_every;
      options.trajectory_path = trajectory_path(args, options.out_dir);
      options.thermo_every = args.thermo_every;
      options.thermo_path = thermo_path(args, options.out_dir);
      options.on_progress = [&, seed, prefix](const gel::v1::Progress& p) {
        progress_file.progress(p, seed);
        print(prefix + progress_text(p));
      };
      options.on_row = [&, seed, prefix](const gel::v1::CurveRow& row) {
        progress_file.row(row, seed);
        print(prefix + "equilibrium k " + std::to_string(row.k()) + ": phi " + std::to_string(row.phi()) + "  P " +
              std::to_string(row.p()) + (row.equilibrated() ? "" : "  (NOT equilibrated)"));
      };
      try {
        if (gel::has_checkpoint(options.out_dir)) {
          outcome.result = gel::resume_compression(options);
        } else {
          gel::v1::Scene member_scene = resuming ? gel::scene_from_json(nlohmann::json::parse(gel::read_file(manifest.string())).at("scene").dump())
                                                 : scene;
          member_scene.mutable_generator()->set_seed(seed);
          std::filesystem::create_directories(options.out_dir);
          outcome.result = gel::run_compression(member_scene, options);
        }
        if (outcome.result.stopped) outcome.exit_code = 4;
      } catch (const gel::InvalidArgument& e) {
        outcome.exit_code = 2;
        outcome.error = e.what();
        progress_file.failed(gel::RunFailure::kInvalidArgument, e.what(), e.field(), seed);
      } catch (const gel::StabilityError& e) {
        outcome.exit_code = 3;
        outcome.error = e.what();
        progress_file.failed(gel::RunFailure::kInstability, e.what(), "", seed);
      } catch (const std::exception& e) {
        outcome.exit_code = 1;
        outcome.error = e.what();
        progress_file.failed(gel::RunFailure::kError, e.what(), "", seed);
      }
      if (!outcome.error.empty()) {
        print(prefix + "failed: " + outcome.error);
      } else if (outcome.result.finished) {
        progress_file.done(options.out_dir, outcome.result.curve.rows_size(), seed);
        print(prefix + "done");
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < jobs; ++t) threads.emplace_back(worker);
  for (auto& thread : threads) thread.join();

  int exit_code = 0;
  for (const auto& outcome : outcomes) exit_code = std::max(exit_code, outcome.exit_code);
  if (std::any_of(outcomes.begin(), outcomes.end(), [](const MemberOutcome& m) { return m.exit_code == 4; })) {
    progress_file.stopped(out);
    std::cerr << "gelsim: stopped; resume with --resume " << out << "\n";
    return 4;
  }
  const nlohmann::json summary = ensemble_summary(outcomes);
  if (args.json) {
    nlohmann::json members = nlohmann::json::array();
    for (const auto& m : outcomes)
      members.push_back({{"seed", m.seed}, {"error", m.error}, {"curve", gel::curve_to_json(m.result.curve)}});
    std::cout << nlohmann::json{{"seeds", seeds}, {"summary", summary}, {"ensemble_rule", gel::analysis::kEnsembleRule},
                                {"members", members}}
                     .dump()
              << "\n";
  } else {
    std::printf("%3s %9s %12s %12s %8s %4s\n", "k", "phi", "P_mean[P0]", "P_std", "members", "eq");
    for (const auto& row : summary)
      std::printf("%3d %9.5f %12.5e %12.5e %8d %4d\n", row["k"].get<int>(), row["phi"].get<double>(),
                  row["P_mean"].get<double>(), row["P_std"].get<double>(), row["members"].get<int>(),
                  row["equilibrated"].get<int>());
    std::printf("P_mean, P_std: %s\n", gel::analysis::kEnsembleRule);
    std::printf("members in %s/seed_<seed>; full analysis: gelsim analyze-run %s; pictures: gelsim plot %s\n", out.c_str(),
                out.c_str(), out.c_str());
  }
  return exit_code;
}

int run_compress(const CompressArgs& args) {
  if (args.estimate) {
    // What one member will hold and cost (geld admits jobs by the same estimate).
    if (!args.config_file.empty()) throw gel::InvalidArgument("--estimate", "estimates a generated gel's run: leave out --gel");
    gel::v1::Scene scene = gel::resolve_compression_scene(build_scene(args));
    if (args.trajectory_every > 0) scene.mutable_output()->set_trajectory_every(args.trajectory_every);
    const gel::ResourceEstimate e = gel::estimate_resources(scene, !args.no_snapshots);
    const nlohmann::json out{{"particles", e.particles}, {"bonds_at_most", e.bonds}, {"neighbour_pairs_at_most", e.neighbour_pairs},
                             {"rows", e.rows}, {"memory_bytes", e.memory_bytes + gel::kProgramBytes},
                             {"memory", gel::format_bytes(static_cast<double>(e.memory_bytes + gel::kProgramBytes))},
                             {"disk_bytes", e.disk_bytes}, {"disk", gel::format_bytes(static_cast<double>(e.disk_bytes))},
                             {"steps_at_least", e.steps}, {"particle_steps_at_least", e.particle_steps}};
    std::cout << out.dump(2) << '\n';
    return 0;
  }
  prepare_out_dir(args);
  if (!args.seeds.empty()) {
    if (args.seed) throw gel::InvalidArgument("--seeds", "give --seed (one run) or --seeds (an ensemble), not both");
    if (!args.config_file.empty()) throw gel::InvalidArgument("--seeds", "an ensemble generates its gels: --gel is for one run");
    return run_ensemble(args);
  }
  if (args.resume) {
    const std::string dir = args.resume->empty() ? args.out : *args.resume;
    if (!dir.empty() && std::filesystem::exists(std::filesystem::path(dir) / "ensemble.json")) return run_ensemble(args);
  }
  gel::ProgressFile progress_file(args.progress_file);
  const bool terminal = isatty(STDERR_FILENO) != 0;
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);

  gel::RunOptions options;
  options.out_dir = args.resume ? (args.resume->empty() ? args.out : *args.resume) : args.out;
  options.stop = &g_stop;
  options.progress_interval_seconds = args.progress_interval;
  options.write_snapshots = !args.no_snapshots;
  options.threads = args.threads;
  options.trajectory_every = args.trajectory_every;
  options.trajectory_path = trajectory_path(args, options.out_dir);
  options.thermo_every = args.thermo_every;
  options.thermo_path = thermo_path(args, options.out_dir);
  options.on_progress = [&](const gel::v1::Progress& p) {
    progress_file.progress(p);
    if (terminal)
      std::cerr << '\r' << progress_text(p) << "\033[K" << std::flush;
    else
      std::cerr << progress_text(p) << '\n';
  };
  options.on_row = [&](const gel::v1::CurveRow& row) {
    progress_file.row(row);
    if (terminal) std::cerr << '\r' << "\033[K";
    std::cerr << "equilibrium k " << row.k() << ": phi " << row.phi() << "  P " << row.p()
              << (row.relax_iterations() > 0 ? "  residual " + std::to_string(row.residual_force()) + " F0" : "")
              << (row.spans() ? "" : "  (network does not span the walls)")
              << (row.equilibrated() ? "" : "  (NOT equilibrated: wait or iteration limit reached)") << '\n';
  };

  gel::CompressionResult result;
  try {
    if (args.resume) {
      if (options.out_dir.empty()) throw gel::InvalidArgument("--resume", "needs a run directory (--resume DIR)");
      result = gel::resume_compression(options);
      if (result.resumed_from_previous_checkpoint)
        std::cerr << "gelsim: the last checkpoint was unusable (" << result.checkpoint_problem << "); went on from the one before it\n";
    } else {
      std::optional<gel::Configuration> initial;
      if (args.gel_frame && args.config_file.empty()) throw gel::InvalidArgument("--gel-frame", "picks a frame of the --gel file: give --gel FILE");
      if (!args.config_file.empty()) initial = gel::read_configuration(args.config_file, args.gel_frame.value_or(gel::kLastFrame));
      const gel::v1::Scene scene = build_scene(args);
      if (options.out_dir.empty()) {
        // Said before the run rather than found out after it; a scene that is refused is refused first.
        (void)gel::resolve_compression_scene(scene);
        std::cerr << "gelsim: no --out DIR: the curve is printed at the end, and no curve.json, snapshot or checkpoint is "
                     "written (the run cannot be resumed)\n";
      }
      result = gel::run_compression(scene, options, initial ? &*initial : nullptr);
    }
  } catch (const gel::InvalidArgument& e) {
    progress_file.failed(gel::RunFailure::kInvalidArgument, e.what(), e.field());
    throw;
  } catch (const gel::StabilityError& e) {
    progress_file.failed(gel::RunFailure::kInstability, e.what());
    throw;
  } catch (const std::exception& e) {
    progress_file.failed(gel::RunFailure::kError, e.what());
    throw;
  }
  if (terminal) std::cerr << '\n';
  if (result.stopped) {
    progress_file.stopped(options.out_dir, result.curve.rows_size());
    const bool resumable = !options.out_dir.empty() && gel::has_checkpoint(options.out_dir);
    std::cerr << "gelsim: stopped"
              << (resumable ? "; resume with --resume " + options.out_dir
                            : " before the gel was generated (nothing to resume: run the same command again)")
              << "\n";
    return 4;
  }
  progress_file.done(options.out_dir, result.curve.rows_size());
  if (args.json)
    std::cout << gel::curve_to_json(result.curve).dump() << "\n";
  else
    print_table(result.curve);
  return 0;
}

gelsim::Registrar compress_command("compress", "stepwise uniaxial compression of a fractal gel", [](CLI::App& sub) {
  auto args = std::make_shared<CompressArgs>();
  sub.add_option("--preset", args->preset, "scene preset: quick (default), paper-bond1, paper-bond2");
  sub.add_option("--scene", args->scene_file, "scene JSON (gel.v1.Scene); options below override it");
  // --gel: --config means a daemon configuration file in geld; the old name still works here.
  sub.add_option("--gel,--config", args->config_file,
                 "start from this gel instead of generating one: a configuration file (.json, .pb), a GSD frame (.gsd) or an "
                 "extended XYZ frame (.xyz) (docs/gelsim.md \"Data in\")");
  sub.add_option("--gel-frame", args->gel_frame, "the frame of a GSD or XYZ --gel: 0, 1, ... or -1, -2, ... from the end (default: the last)");
  sub.add_option("--bond", args->bond, "bond preset: bond1, bond2");
  sub.add_option("--seed", args->seed, "generator seed, 1 to 2^63-1 (a negative number is refused, not wrapped)")
      ->check(gelsim::seed_validator());
  sub.add_option("--seeds", args->seeds, "an ensemble: seeds 1-10 or 1,4,7-9, each member in OUT/seed_<seed>");
  sub.add_option("--threads", args->threads,
                 "engine threads per run (results are bit-identical for any number; default: the scene's integration.threads, else 1)")
      ->check(CLI::Range(1, 1024));
  sub.add_option("--jobs", args->jobs, "ensemble members run at a time (0: one per core; default 1)")
      ->check(gel::cli::non_negative(args->jobs));
  sub.add_option("--fidelity", args->fidelity, "default (= quasistatic: FIRE relaxation at each target), paper (MODEL.md reference values) or fast (biased, for exploring)");
  sub.add_option("--out", args->out, "run directory: curve.json/csv, profiles.csv, snapshots/, checkpoint.bin");
  sub.add_option("--resume", args->resume, "continue the run in DIR (default: --out) from its checkpoint")->expected(0, 1);
  sub.add_flag("--overwrite", args->overwrite,
               "replace an earlier run in --out: remove its outputs first (only where gelsim wrote its checkpoint, "
               "curve.json or ensemble.json); without it a used --out is refused");
  sub.add_option("--progress-file", args->progress_file, "append one JSON line per progress message and row");
  sub.add_option("--progress-interval", args->progress_interval, "seconds between progress messages")
      ->check(gel::cli::non_negative(args->progress_interval));
  sub.add_flag("--json", args->json, "print the curve as one JSON object (curve.json's format)");
  sub.add_flag("--no-snapshots", args->no_snapshots, "write no configuration snapshots");
  sub.add_flag("--estimate", args->estimate,
               "print what one run will hold and cost (memory and disk at most, steps at least) and exit without running");
  sub.add_option("--trajectory-every", args->trajectory_every,
                 "write a GSD trajectory frame every N engine steps (OVITO, gsd.hoomd; README \"Data out\")")
      ->check(gel::cli::positive(args->trajectory_every));
  sub.add_option("--trajectory", args->trajectory, "the trajectory file (default OUT/trajectory.gsd; not with --seeds)");
  sub.add_option("--thermo-every", args->thermo_every,
                 "append a CSV line of the state (step, time, phi, P_top, P_bot, energies, ruptures) to OUT/thermo.csv "
                 "every N engine steps, flushed at once (docs/compression.md \"Thermo log\")")
      ->check(gel::cli::positive(args->thermo_every));
  sub.add_option("--phi-max", args->phi_max, "last target packing fraction");
  sub.add_option("--steps", args->steps, "k', the number of targets (at least 1; leave it out for the preset's)")
      ->check(CLI::Validator(
          [](std::string& value) {
            // 0 meant "the preset's" without saying so: refused, as leaving the flag out says that.
            char* end = nullptr;
            const long long steps = std::strtoll(value.c_str(), &end, 10);
            return end && *end == '\0' && steps >= 1 ? std::string()
                                                      : "must be a whole number >= 1 (leave it out for the preset's), got " + value;
          },
          "INT"));
  sub.add_option("--w0", args->w0, "phi_1 = w0 phi_0");
  sub.add_option("--v-wall", args->v_wall, "wall speed, each wall [a/t0]");
  sub.add_option("--v-wall-v0", args->v_wall_v0, "wall speed in units of v0 = a sqrt(k_R/m)");
  sub.add_option("--m-exam", args->m_exam, "steps between equilibrium tests");
  sub.add_option("--A", args->a, "tolerance of |P_top - P_bot|/P");
  sub.add_option("--B", args->b, "tolerance of |P - P'|/P");
  sub.add_option("--max-wait-time", args->max_wait_time, "longest wait for equilibrium per target [t0]");
  sub.add_option("--stress-floor", args->stress_floor, "P below which a step is stress-free [F0/a^2]");
  sub.add_option("--shortcut", args->shortcut, "approach shortcut until the network spans (true/false)");
  sub.add_option("--adaptive-wall", args->adaptive_wall,
                 "adaptive wall: let the walls run up to this multiple of v_wall while quasi-static (1 = off)");
  sub.add_option("--adaptive-drag-fraction", args->adaptive_drag_fraction,
                 "adaptive wall: share of the wall work that drag may take before the walls slow (default 0.05)\n"
                 "(with neither option, the fidelity preset decides: off in every preset)");
  sub.add_option("--exam-ruptures", args->exam_ruptures,
                 "ruptures the equilibrium test's third criterion counts: all (default) or normal");
  sub.add_option("--approach", args->approach,
                 "quasistatic: how the walls reach a target: walls (the dynamics' wall motion, default), affine, "
                 "or walls-then-affine (walls until a relaxed row spans, affine steps after)");
  sub.add_option("--strain-step", args->strain_step, "quasistatic, affine: largest d ln(phi) per step (default 0.005)");
  sub.add_option("--relax-tolerance", args->relax_tolerance,
                 "quasistatic: residual force and torque/a per particle over the mean bond force (default 1e-4)");
  sub.add_option("--relax-floor", args->relax_floor, "quasistatic: residual that always counts as relaxed [F0] (default stress floor x a^2)");
  sub.add_option("--relax-dt-max", args->relax_dt_max, "quasistatic: FIRE's largest step over the dynamics' dt, times FIRE's inertia gain (default 3)");
  sub.add_option("--walk-dt-factor", args->walk_dt_factor, "the walls' walk takes this x dt while they carry less than --walk-dt-stress (1 = off; default: the fidelity's)");
  sub.add_option("--walk-dt-stress", args->walk_dt_stress, "wall stress below which the walk takes the longer step [F0/a^2] (default 1e-2)");
  sub.add_option("--loaded-wall-factor", args->loaded_wall_factor, "the walls move at this x v_wall while they carry --loaded-wall-stress or more (quasistatic/default: 2; paper, fast: off; 1 = off)");
  sub.add_option("--loaded-wall-stress", args->loaded_wall_stress, "wall stress from which the walls move at --loaded-wall-factor [F0/a^2] (quasistatic/default: 3e-2; otherwise --walk-dt-stress)");
  sub.add_option("--relax-max-iterations", args->relax_max_iterations, "quasistatic: FIRE iterations per strain step (default 1e6)");
  sub.add_option("--profile-slices", args->profile_slices, "slices of the phi(y) profile");
  sub.add_option("--checkpoint-seconds", args->checkpoint_seconds, "wall-clock seconds between checkpoints");
  sub.add_option("--eta-factor", args->eta_factor, "viscosity in units of eta_cd (default 0.1)");
  sub.add_option("--dt", args->dt, "time step [t0]");
  sub.add_option("--dt-fraction", args->dt_fraction, "time step as a fraction of the shortest period");
  return [args] { return run_compress(*args); };
});

}  // namespace
