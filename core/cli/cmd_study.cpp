// gelsim study: a built-in study (gel/study.hpp) run locally and analysed.
//   gelsim study --preset paper --out runs/paper --jobs 2          (run, resume, analyse)
//   gelsim study --preset quick --seeds 2 --out runs/q --fidelity fast
//   gelsim study --out runs/paper --analyse-only                   (analysis of what finished)
//   gelsim study --file study.json --out runs/mine                (explicit ensembles)
//   gelsim study --list-presets
// Members of every ensemble share one work list, `--jobs` at a time, each in
// OUT/<ensemble>/seed_<seed>; a finished member is never run again and an interrupted one
// resumes from its checkpoint, so the same command continues a study. The analysis
// (gel::analysis::analyse_study) goes to OUT/study_analysis.json, and each finished member's
// structure numbers to its structure.json: with curve.json, all that the analysis needs, so a
// study directory without checkpoints and snapshots is still a complete, resumable study.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "gel/analysis/study_analysis.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/seed.hpp"
#include "gel/study.hpp"

namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_study_stop{false};
extern "C" void request_study_stop(int) { g_study_stop.store(true); }

struct StudyArgs {
  std::string preset = "paper";
  std::string file;  // explicit ensembles instead of a preset
  std::string out;
  std::string fidelity;
  int seeds = 0;
  int jobs = 1;
  int bootstrap_samples = 1000;
  bool analyse_only = false, list_presets = false, no_structure = false, include_unequilibrated = false;
};

struct Member {
  std::string ensemble;
  gel::v1::Scene scene;  // resolved, with the member's seed
  std::uint64_t seed = 0;
  std::string dir;
};

bool finished_run(const std::string& dir) {
  if (!fs::exists(fs::path(dir) / "curve.json")) return false;
  const gel::v1::Curve curve = gel::read_curve(dir);
  return curve.rows_size() > 0 && curve.rows(curve.rows_size() - 1).k() == curve.scene().compression().steps();
}

// The member's structure numbers beside its curve (OUT/<ensemble>/seed_<seed>/structure.json),
// so that the study can be analysed again, and archived, without its snapshots.
void write_member_structure(const std::string& dir, const gel::v1::Curve& curve) {
  const gel::analysis::StructureOptions options;  // the analysis's own (StudyAnalysisOptions::structure)
  if (gel::analysis::read_member_structure(dir, curve, options)) return;
  const gel::analysis::MemberStructure structure = gel::analysis::member_structure(dir, curve, options);
  const fs::path path = fs::path(dir) / gel::analysis::kMemberStructureFile;
  const fs::path partial = fs::path(dir) / (std::string(gel::analysis::kMemberStructureFile) + ".partial");
  std::ofstream(partial) << gel::analysis::to_json(structure, curve).dump(1) << "\n";
  fs::rename(partial, path);
}

// {"ensembles": [{"name": "bond1", "scene": {...}, "seeds": [1, 2, 3]}, ...]}: the shape of the
// study.json that a study directory keeps. Seeds may be left out when --seeds N is given.
std::vector<gel::StudyEnsembleSpec> read_study_file(const StudyArgs& args) {
  if (!args.fidelity.empty()) throw gel::InvalidArgument("--fidelity", "applies to a preset; set it in each scene of --file");
  nlohmann::json study;
  try {
    study = nlohmann::json::parse(gel::read_file(args.file));
  } catch (const nlohmann::json::exception& e) {
    throw gel::InvalidArgument("--file", args.file + " is not JSON: " + e.what());
  }
  if (!study.contains("ensembles") || !study.at("ensembles").is_array() || study.at("ensembles").empty())
    throw gel::InvalidArgument("--file", "needs a non-empty \"ensembles\" list");
  std::vector<gel::StudyEnsembleSpec> ensembles;
  for (std::size_t e = 0; e < study.at("ensembles").size(); ++e) {
    const nlohmann::json& entry = study.at("ensembles")[e];
    const std::string field = "--file: ensembles[" + std::to_string(e) + "]";
    gel::StudyEnsembleSpec spec;
    spec.name = entry.value("name", std::string());
    gel::validate_ensemble_name(spec.name, field + ".name");
    for (const auto& other : ensembles)
      if (other.name == spec.name) throw gel::InvalidArgument(field + ".name", "'" + spec.name + "' appears twice");
    if (!entry.contains("scene") || !entry.at("scene").is_object()) throw gel::InvalidArgument(field + ".scene", "missing");
    gel::require_json_message(field + ".scene", entry.at("scene").dump(), *gel::v1::Scene::descriptor());
    spec.scene = gel::scene_from_json(entry.at("scene").dump());
    if (entry.contains("seeds")) {
      if (!entry.at("seeds").is_array()) throw gel::InvalidArgument(field + ".seeds", "must be a list of seeds");
      // As JSON text, so that -1 is refused rather than wrapped to 2^64-1.
      for (const nlohmann::json& seed : entry.at("seeds")) spec.seeds.push_back(gel::parse_seed(field + ".seeds", seed.dump()));
    }
    if (spec.seeds.empty())
      for (int s = 1; s <= args.seeds; ++s) spec.seeds.push_back(static_cast<std::uint64_t>(s));
    if (spec.seeds.empty()) throw gel::InvalidArgument(field + ".seeds", "none given (list them, or give --seeds N)");
    ensembles.push_back(std::move(spec));
  }
  return ensembles;
}

// What this invocation did with the members, for the summary.
struct StudyOutcome {
  std::atomic<int> ran{0}, already_finished{0};
  std::mutex mutex;
  std::vector<std::string> failed;  // "bond1 seed 3"
  void add_failure(const std::string& name) {
    std::lock_guard lock(mutex);
    failed.push_back(name);
  }
};

// "value [lo, hi]" of an estimate of the study analysis (95 % bootstrap interval), "-" without one.
std::string estimate_text(const nlohmann::json& estimate) {
  if (!estimate.is_object() || !estimate.value("value", nlohmann::json()).is_number()) return "-";
  char text[96];
  if (estimate.value("lo", nlohmann::json()).is_number() && estimate.value("hi", nlohmann::json()).is_number())
    std::snprintf(text, sizeof text, "%.3g [%.3g, %.3g]", estimate.at("value").get<double>(), estimate.at("lo").get<double>(),
                  estimate.at("hi").get<double>());
  else
    std::snprintf(text, sizeof text, "%.3g", estimate.at("value").get<double>());
  return text;
}

// The end of a study: its members, each ensemble's headline numbers (docs/study_analysis.md), and
// where the analysis and the figures are, on stdout.
void print_study_summary(const StudyArgs& args, std::size_t members, std::size_t finished, const StudyOutcome& outcome,
                         const nlohmann::json& analysis, const std::string& path) {
  std::printf("members: %zu of %zu finished", finished, members);
  if (!args.analyse_only) std::printf(" (%d run now, %d already done)", outcome.ran.load(), outcome.already_finished.load());
  if (!outcome.failed.empty()) {
    std::vector<std::string> failed = outcome.failed;
    std::sort(failed.begin(), failed.end());
    std::string names;
    for (const auto& name : failed) names += (names.empty() ? "" : ", ") + name;
    std::printf(", %zu failed (%s: their errors are above)", failed.size(), names.c_str());
  }
  std::printf("\n");
  const double confidence = analysis.value("confidence", 0.95);
  for (const nlohmann::json& ensemble : analysis.at("ensembles")) {
    const std::string name = ensemble.at("name").get<std::string>();
    std::printf("%s: %d seeds (%.0f %% bootstrap intervals over seeds)\n", name.c_str(), ensemble.at("members").get<int>(),
                100 * confidence);
    const nlohmann::json& power_law = ensemble.at("power_law");
    const nlohmann::json& all = power_law.value("all", nlohmann::json());
    if (all.is_object())
      std::printf("  lambda (P_y ~ phi^lambda, phi %.3g-%.3g): %s\n", all.at("phi_min").get<double>(),
                  all.at("phi_max").get<double>(), estimate_text(all.at("exponent")).c_str());
    else
      std::printf("  lambda: not fitted (%s)\n", power_law.value("all_error", std::string("no fit")).c_str());
    const nlohmann::json& regimes = ensemble.at("regimes");
    std::printf("  elastic -> plastic at phi %s, single -> multi-mode at phi %s\n",
                estimate_text(regimes.value("elastic_to_plastic_phi", nlohmann::json())).c_str(),
                estimate_text(regimes.value("single_to_multi_mode_phi", nlohmann::json())).c_str());
    const nlohmann::json& gel_point = ensemble.at("gel_point");
    if (gel_point.value("at_bound", false))
      std::printf("  gel point: not determined (the fit put phi_g at its bound)\n");
    else if (gel_point.contains("phi_g"))
      std::printf("  gel point: phi_g %s\n", estimate_text(gel_point.at("phi_g")).c_str());
    else
      std::printf("  gel point: not fitted (%s)\n", gel_point.value("error", std::string("no fit")).c_str());
    const std::string folder = (fs::path(args.out) / name).string();
    std::printf("  figures: gelsim plot %s  (draws them into %s/plots)\n", folder.c_str(), folder.c_str());
  }
  std::printf("analysis (every observable, every row): %s\n", path.c_str());
}

int run_study(const StudyArgs& args) {
  if (args.list_presets) {
    for (const std::string& name : gel::study_preset_names()) {
      std::cout << name << " (fidelity " << gel::study_preset_fidelity(name) << "):";
      for (const auto& ensemble : gel::study_preset(name)) std::cout << " " << ensemble.name << " x" << ensemble.seeds.size();
      std::cout << "\n";
    }
    return 0;
  }
  if (args.out.empty()) throw gel::InvalidArgument("--out", "a study needs a directory (--out DIR)");
  const fs::path manifest = fs::path(args.out) / "study.json";
  std::vector<gel::StudyEnsembleSpec> ensembles;
  if (fs::exists(manifest)) {
    // The study that was started here goes on: the options of the first run hold.
    const nlohmann::json stored = nlohmann::json::parse(std::ifstream(manifest));
    for (const auto& entry : stored.at("ensembles")) {
      gel::StudyEnsembleSpec spec;
      spec.name = entry.at("name").get<std::string>();
      spec.scene = gel::scene_from_json(entry.at("scene").dump());
      spec.seeds = entry.at("seeds").get<std::vector<std::uint64_t>>();
      ensembles.push_back(std::move(spec));
    }
  } else {
    if (args.analyse_only) throw gel::InvalidArgument("--out", args.out + " holds no study (study.json)");
    ensembles = args.file.empty() ? gel::study_preset(args.preset, {args.seeds, args.fidelity}) : read_study_file(args);
    nlohmann::json stored = {{"preset", args.file.empty() ? args.preset : ""}, {"ensembles", nlohmann::json::array()}};
    for (auto& spec : ensembles) {
      spec.scene = gel::resolve_compression_scene(spec.scene);
      stored["ensembles"].push_back(
          {{"name", spec.name}, {"scene", nlohmann::json::parse(gel::scene_to_json(spec.scene))}, {"seeds", spec.seeds}});
    }
    fs::create_directories(args.out);
    std::ofstream(manifest) << stored.dump(1) << "\n";
  }

  std::vector<Member> members;
  for (const auto& spec : ensembles)
    for (const std::uint64_t seed : spec.seeds) {
      Member member{spec.name, spec.scene, seed, (fs::path(args.out) / spec.name / ("seed_" + std::to_string(seed))).string()};
      member.scene.mutable_generator()->set_seed(seed);
      members.push_back(std::move(member));
    }

  std::mutex print_mutex;
  auto print = [&](const std::string& line) {
    std::lock_guard lock(print_mutex);
    std::cerr << line << std::endl;
  };
  int exit_code = 0;
  StudyOutcome outcome;
  if (!args.analyse_only) {
    std::signal(SIGINT, request_study_stop);
    std::signal(SIGTERM, request_study_stop);
    const int jobs = std::max(1, std::min(args.jobs > 0 ? args.jobs : static_cast<int>(std::thread::hardware_concurrency()),
                                          static_cast<int>(members.size())));
    print("study of " + std::to_string(ensembles.size()) + " ensembles, " + std::to_string(members.size()) + " runs, " +
          std::to_string(jobs) + " at a time, in " + args.out);
    std::atomic<std::size_t> next{0};
    std::atomic<int> worst{0};
    auto worker = [&] {
      for (std::size_t index = next++; index < members.size() && !g_study_stop; index = next++) {
        const Member& member = members[index];
        const std::string prefix = "[" + member.ensemble + " seed " + std::to_string(member.seed) + "] ";
        if (finished_run(member.dir)) {
          ++outcome.already_finished;
          continue;
        }
        gel::RunOptions options;
        options.out_dir = member.dir;
        options.stop = &g_study_stop;
        options.progress_interval_seconds = 30;
        options.on_row = [&, prefix](const gel::v1::CurveRow& row) {
          print(prefix + "k " + std::to_string(row.k()) + "  phi " + std::to_string(row.phi()) + "  P " +
                std::to_string(row.p()) + (row.equilibrated() ? "" : "  (not equilibrated)"));
        };
        const auto start = std::chrono::steady_clock::now();
        try {
          fs::create_directories(member.dir);
          const gel::CompressionResult result = gel::has_checkpoint(member.dir) ? gel::resume_compression(options)
                                                                                : gel::run_compression(member.scene, options);
          const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          if (result.stopped) {
            worst = std::max(worst.load(), 4);
          } else {
            ++outcome.ran;
            print(prefix + "done in " + std::to_string(static_cast<int>(seconds)) + " s");
          }
        } catch (const gel::StabilityError& e) {
          print(prefix + "failed: " + e.what());
          outcome.add_failure(member.ensemble + " seed " + std::to_string(member.seed));
          worst = std::max(worst.load(), 3);
        } catch (const std::exception& e) {
          print(prefix + "failed: " + e.what());
          outcome.add_failure(member.ensemble + " seed " + std::to_string(member.seed));
          worst = std::max(worst.load(), 1);
        }
      }
    };
    std::vector<std::thread> threads;
    for (int t = 0; t < jobs; ++t) threads.emplace_back(worker);
    for (auto& thread : threads) thread.join();
    exit_code = worst.load();
    if (g_study_stop) {
      std::cerr << "gelsim: stopped; the same command resumes the study\n";
      return 4;
    }
  }

  // The analysis of every ensemble over its finished members.
  std::vector<gel::analysis::StudyEnsembleInput> inputs;
  for (const auto& spec : ensembles) {
    gel::analysis::StudyEnsembleInput input;
    input.name = spec.name;
    for (const Member& member : members) {
      if (member.ensemble != spec.name || !finished_run(member.dir)) continue;
      input.curves.push_back(gel::read_curve(member.dir));
      input.seeds.push_back(member.seed);
      input.dirs.push_back(member.dir);
    }
    if (!args.no_structure)
      for (std::size_t m = 0; m < input.curves.size(); ++m) write_member_structure(input.dirs[m], input.curves[m]);
    if (input.curves.empty()) {
      print("ensemble " + spec.name + ": no finished member, left out of the analysis");
      continue;
    }
    if (input.curves.size() < spec.seeds.size())
      print("ensemble " + spec.name + ": " + std::to_string(input.curves.size()) + " of " +
            std::to_string(spec.seeds.size()) + " members finished; the analysis uses those");
    inputs.push_back(std::move(input));
  }
  if (inputs.empty()) throw gel::InvalidArgument("--out", "no finished run to analyse in " + args.out);
  gel::analysis::StudyAnalysisOptions options;
  options.bootstrap_samples = args.bootstrap_samples;
  options.structures = !args.no_structure;
  options.include_unequilibrated = args.include_unequilibrated;
  const nlohmann::json analysis = gel::analysis::to_json(gel::analysis::analyse_study(inputs, options));
  const std::string path = (fs::path(args.out) / "study_analysis.json").string();
  std::ofstream(path) << analysis.dump(1) << "\n";
  std::size_t finished = 0;
  for (const auto& input : inputs) finished += input.curves.size();
  print_study_summary(args, members.size(), finished, outcome, analysis, path);
  return exit_code;
}

gelsim::Registrar study_command("study", "a built-in study (e.g. the paper's): run, resume and analyse", [](CLI::App& sub) {
  auto args = std::make_shared<StudyArgs>();
  sub.add_option("--preset", args->preset, "built-in study (paper, small, quick; default paper)");
  sub.add_option("--file", args->file, "explicit ensembles: {\"ensembles\": [{\"name\", \"scene\", \"seeds\"}]} (instead of --preset)");
  sub.add_option("--out", args->out, "directory of the study: OUT/<ensemble>/seed_<seed>, OUT/study_analysis.json");
  sub.add_option("--seeds", args->seeds, "seeds 1..N per ensemble (default: the preset's)")->check(CLI::Range(1, 1000));
  sub.add_option("--fidelity", args->fidelity, "the preset's fidelity (fast, default, paper, quasistatic)");
  sub.add_option("--jobs", args->jobs, "runs at a time (0: one per core)")->check(CLI::Range(0, 4096));
  sub.add_option("--bootstrap-samples", args->bootstrap_samples, "bootstrap resamples of the analysis")
      ->check(CLI::Range(1, 100000));
  sub.add_flag("--analyse-only,--analyze-only", args->analyse_only, "only the analysis of the runs that finished");
  sub.add_flag("--no-structure", args->no_structure, "leave out the snapshot analyses (xi, D_f)");
  sub.add_flag("--include-unequilibrated", args->include_unequilibrated, "also fit spanning rows that did not equilibrate");
  sub.add_flag("--list-presets", args->list_presets, "the built-in studies");
  return [args] { return run_study(*args); };
});

}  // namespace
