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
#include <atomic>
#include <chrono>
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
        if (finished_run(member.dir)) continue;
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
            print(prefix + "done in " + std::to_string(static_cast<int>(seconds)) + " s");
          }
        } catch (const gel::StabilityError& e) {
          print(prefix + "failed: " + e.what());
          worst = std::max(worst.load(), 3);
        } catch (const std::exception& e) {
          print(prefix + "failed: " + e.what());
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
  std::cout << path << "\n";
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
