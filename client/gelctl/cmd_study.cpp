// gelctl study: studies, named sets of ensembles run as one unit (SubmitStudy and friends):
//   gelctl study submit --preset paper [--seeds N] [--fidelity F] [--watch]
//   gelctl study list | show ID | watch ID | cancel ID | analysis ID [--json]
#include <chrono>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <google/protobuf/util/json_util.h>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "common.hpp"
#include "proto_json.hpp"

namespace {

using gelctl::json;

struct StudyArgs {
  // submit
  std::string preset, fidelity, name, study_file;
  int seeds = 0;
  std::vector<std::string> labels;
  bool rerun = false, watch = false;
  // show, watch, cancel, analysis
  std::string study_id;
  bool json_output = false;
  bool include_unequilibrated = false, partial = false;
  int bootstrap_samples = 0;
  int page_size = 50;
};

std::string number_or_dash(const json& value) {
  return value.is_number() ? gelctl::format_number(value.get<double>()) : "-";
}

void print_study(const gel::v1::Study& study) {
  std::cout << study.id() << ": " << gelctl::state_name(study.state()) << "  name '" << study.name() << "'"
            << (study.preset().empty() ? "" : "  preset " + study.preset())
            << (study.fidelity().empty() ? "" : "  fidelity " + study.fidelity()) << "  created "
            << gelctl::format_unix_ms(study.created_unix_ms()) << "\n";
  if (!study.error().empty()) std::cout << "  error: " << study.error() << "\n";
  std::cout << "  " << std::left << std::setw(12) << "ENSEMBLE" << std::setw(14) << "JOB" << std::setw(11) << "STATE"
            << std::setw(10) << "MEMBERS" << std::setw(7) << "ROWS" << "" << std::right << "\n";
  for (const gel::v1::StudyJob& job : study.jobs()) {
    std::cout << "  " << std::left << std::setw(12) << job.ensemble() << std::setw(14) << job.job_id() << std::setw(11)
              << gelctl::state_name(job.state()) << std::setw(10)
              << (std::to_string(job.members_finished()) + "/" + std::to_string(job.members())) << std::setw(7)
              << job.rows() << (job.cached() ? "(from the run cache)" : "") << std::right << "\n";
  }
}

int watch_study(gelctl::Client& client, const std::string& study_id, bool json_lines) {
  gel::v1::WatchStudyRequest request;
  request.set_study_id(study_id);
  auto context = client.context(false);
  auto reader = client.stub().WatchStudy(context.get(), request);
  gel::v1::StudyUpdate update;
  gel::v1::JobState state = gel::v1::JOB_STATE_UNSPECIFIED;
  auto last_progress = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  while (reader->Read(&update)) {
    if (update.has_study()) state = update.study().state();
    if (json_lines) {
      std::cout << gel::message_to_json(update, false).dump() << std::endl;
      continue;
    }
    if (update.has_study() && !update.has_update()) {
      print_study(update.study());
      continue;
    }
    const gel::v1::JobUpdate& job_update = update.update();
    const std::string tag = "[" + update.ensemble() + "] ";
    using Kind = gel::v1::JobUpdate;
    switch (job_update.kind()) {
      case Kind::STATE:
        std::cout << tag << update.job_id() << ": " << gelctl::state_name(job_update.job().state())
                  << (job_update.job().error().empty() ? "" : ": " + job_update.job().error()) << std::endl;
        if (update.has_study())
          std::cout << "study " << update.study().id() << ": " << gelctl::state_name(update.study().state()) << std::endl;
        break;
      case Kind::ROW:
        std::cout << tag << "seed " << job_update.seed() << "  k " << job_update.row().k() << "  phi "
                  << gelctl::format_number(job_update.row().phi(), 5) << "  P "
                  << gelctl::format_number(job_update.row().p(), 5)
                  << (job_update.row().equilibrated() ? "" : "  (not equilibrated)") << std::endl;
        break;
      case Kind::PROGRESS: {
        // One line every 5 s at most, whichever ensemble it is from.
        const auto now = std::chrono::steady_clock::now();
        if (now - last_progress < std::chrono::seconds(5)) break;
        last_progress = now;
        const auto& progress = job_update.progress();
        std::cout << tag << "seed " << job_update.seed() << "  " << progress.phase() << "  step " << progress.k() << "/"
                  << progress.k_total() << "  phi " << gelctl::format_number(progress.phi(), 4) << "  elapsed "
                  << gelctl::format_duration(progress.elapsed_seconds()) << std::endl;
        break;
      }
      case Kind::LOG:
        std::cout << tag << "log: " << job_update.message() << std::endl;
        break;
      default:
        break;
    }
  }
  gelctl::throw_if_failed(reader->Finish());
  if (state == gel::v1::JOB_STATE_SUCCEEDED || !gelctl::is_terminal(state)) return gelctl::kExitSuccess;
  return gelctl::kExitJobUnsuccessful;
}

int run_submit(gelctl::Client& client, const StudyArgs& args) {
  gel::v1::SubmitStudyRequest request;
  if (!args.study_file.empty()) {
    // A study written out: gel.v1.SubmitStudyRequest in JSON (its ensembles and their scenes).
    const std::string text = gelctl::read_file(args.study_file);
    if (const gel::JsonProblem problem = gel::json_problem(text, *gel::v1::SubmitStudyRequest::descriptor()))
      throw gelctl::UsageError("--file: " + args.study_file + ": " + (problem.field.empty() ? "" : problem.field + ": ") +
                               problem.message);
    const auto status = google::protobuf::util::JsonStringToMessage(text, &request);
    if (!status.ok())
      throw gelctl::UsageError("--file: " + args.study_file + " is not a gel.v1.SubmitStudyRequest in JSON: " +
                               std::string(status.message()));
  }
  if (!args.preset.empty()) request.set_preset(args.preset);
  if (!args.fidelity.empty()) request.set_fidelity(args.fidelity);
  if (!args.name.empty()) request.set_name(args.name);
  if (request.name().empty()) request.set_name(request.preset());
  if (args.seeds > 0) request.set_seed_count(static_cast<std::uint32_t>(args.seeds));
  for (const std::string& label : args.labels) {
    const auto [key, value] = gelctl::split_label(label, "--label");
    (*request.mutable_labels())[key] = value;
  }
  request.set_rerun(args.rerun);
  gel::v1::SubmitStudyResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().SubmitStudy(context.get(), request, &response));
  std::cout << response.study_id() << "\n";
  if (args.json_output) {
    std::cout << gel::message_to_json(response.study(), false).dump() << "\n";
  } else {
    print_study(response.study());
  }
  return args.watch ? watch_study(client, response.study_id(), args.json_output) : gelctl::kExitSuccess;
}

int run_list(gelctl::Client& client, const StudyArgs& args) {
  gel::v1::ListStudiesRequest request;
  request.set_page_size(args.page_size);
  gel::v1::ListStudiesResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().ListStudies(context.get(), request, &response));
  if (args.json_output) {
    json out = json::array();
    for (const auto& study : response.studies()) out.push_back(gel::message_to_json(study, false));
    std::cout << out.dump() << "\n";
    return gelctl::kExitSuccess;
  }
  if (response.studies_size() > 0)
    std::cout << std::left << std::setw(16) << "ID" << std::setw(11) << "STATE" << std::setw(20) << "NAME" << std::setw(10)
              << "ENSEMBLES" << "CREATED" << std::right << "\n";
  for (const auto& study : response.studies())
    std::cout << std::left << std::setw(16) << study.id() << std::setw(11) << gelctl::state_name(study.state())
              << std::setw(20) << (study.name().empty() ? "-" : study.name()) << std::setw(10) << study.jobs_size()
              << gelctl::format_unix_ms(study.created_unix_ms()) << std::right << "\n";
  if (!response.next_page_token().empty()) std::cout << "more studies: raise --page-size\n";
  return gelctl::kExitSuccess;
}

int run_show(gelctl::Client& client, const StudyArgs& args) {
  gel::v1::GetStudyRequest request;
  request.set_study_id(args.study_id);
  gel::v1::Study study;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().GetStudy(context.get(), request, &study));
  if (args.json_output) {
    std::cout << gel::message_to_json(study, false).dump() << "\n";
  } else {
    print_study(study);
  }
  return gelctl::kExitSuccess;
}

int run_cancel(gelctl::Client& client, const StudyArgs& args) {
  gel::v1::CancelStudyRequest request;
  request.set_study_id(args.study_id);
  gel::v1::Study study;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().CancelStudy(context.get(), request, &study));
  print_study(study);
  return gelctl::kExitSuccess;
}

std::string estimate_text(const json& estimate) {
  if (!estimate.is_object()) return "-";
  std::string text = number_or_dash(estimate.value("value", json()));
  if (estimate.value("lo", json()).is_number())
    text += " [" + number_or_dash(estimate.at("lo")) + ", " + number_or_dash(estimate.at("hi")) + "]";
  return text;
}

void print_analysis(const json& analysis) {
  for (const json& ensemble : analysis.at("ensembles")) {
    std::cout << ensemble.at("name").get<std::string>() << ": " << ensemble.at("members") << " seeds, "
              << ensemble.value("particles", 0) << " particles (95 % bootstrap intervals over seeds)\n";
    const json& regimes = ensemble.at("regimes");
    std::cout << "  elastic -> plastic at phi " << estimate_text(regimes.value("elastic_to_plastic_phi", json()))
              << ", single -> multi-mode at phi " << estimate_text(regimes.value("single_to_multi_mode_phi", json()))
              << "\n";
    for (const auto& [regime, fit] : ensemble.at("power_law").items()) {
      if (!fit.is_object() || !fit.contains("exponent")) continue;
      std::cout << "  lambda (" << regime << ", phi " << number_or_dash(fit.value("phi_min", json())) << "-"
                << number_or_dash(fit.value("phi_max", json())) << "): " << estimate_text(fit.at("exponent")) << "\n";
    }
    const json& gel_point = ensemble.at("gel_point");
    if (gel_point.contains("phi_g"))
      std::cout << "  gel point: phi_g " << estimate_text(gel_point.at("phi_g")) << ", lambda' "
                << estimate_text(gel_point.at("exponent"))
                << (gel_point.value("at_bound", false) ? " (the fit on all seeds put phi_g at its bound: the data fix no gel point)" : "")
                << "\n";
    if (ensemble.contains("xi_power_law") && ensemble.at("xi_power_law").is_object() &&
        ensemble.at("xi_power_law").contains("exponent"))
      std::cout << "  xi^(0.5) ~ phi^" << estimate_text(ensemble.at("xi_power_law").at("exponent")) << "\n";
    if (ensemble.contains("fractal_dimension_initial") && ensemble.at("fractal_dimension_initial").is_object())
      std::cout << "  D_f of the initial networks: " << estimate_text(ensemble.at("fractal_dimension_initial")) << "\n";
    std::cout << "  " << std::left << std::setw(4) << "k" << std::setw(26) << "phi" << std::setw(36) << "P_y [F0/a^2]"
              << "z" << std::right << "\n";
    for (const json& row : ensemble.at("rows"))
      std::cout << "  " << std::left << std::setw(4) << row.at("k").get<int>() << std::setw(26)
                << estimate_text(row.at("phi")) << std::setw(36) << estimate_text(row.at("P"))
                << estimate_text(row.at("contact_number")) << (row.value("trusted", true) ? "" : "  (not used)")
                << std::right << "\n";
  }
}

int run_analysis(gelctl::Client& client, const StudyArgs& args) {
  gel::v1::GetStudyAnalysisRequest request;
  request.set_study_id(args.study_id);
  request.set_include_unequilibrated(args.include_unequilibrated);
  request.set_partial(args.partial);
  request.set_bootstrap_samples(static_cast<std::uint32_t>(args.bootstrap_samples));
  gel::v1::GetStudyAnalysisResponse response;
  auto context = client.context(false);  // a large study's structure analysis takes a while
  gelctl::throw_if_failed(client.stub().GetStudyAnalysis(context.get(), request, &response));
  if (args.json_output) {
    std::cout << response.json() << "\n";
  } else {
    print_analysis(json::parse(response.json()));
  }
  return gelctl::kExitSuccess;
}

const gelctl::Registrar study_registrar{
    "study", "Studies: sets of ensembles (e.g. the paper's) run, followed and analysed as one", 70,
    [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<StudyArgs>();
      sub.require_subcommand(1);
      CLI::App* submit = sub.add_subcommand("submit", "Submit a study; prints its id on the first line");
      submit->add_option("--preset", args->preset, "Built-in study: paper (bond 1 and 2 at paper size), small (the 1408-particle gel) or quick");
      submit->add_option("--file", args->study_file, "A gel.v1.SubmitStudyRequest in JSON (explicit ensembles)");
      submit->add_option("--seeds", args->seeds, "Seeds 1..N per ensemble (default: the preset's)")
          ->check(CLI::Range(1, 1000));
      submit->add_option("--fidelity", args->fidelity, "The preset's fidelity (fast, default, paper, quasistatic)");
      submit->add_option("--name", args->name, "Name (default: the preset's)");
      submit->add_option("--label", args->labels, "key=value, copied to every job (repeatable)");
      submit->add_flag("--rerun", args->rerun, "Run again even when the run cache holds the results");
      submit->add_flag("--watch", args->watch, "Follow it until it ends");
      submit->add_flag("--json", args->json_output, "The study as JSON (with --watch: updates as JSON lines)");
      CLI::App* list = sub.add_subcommand("list", "Studies, newest first");
      list->add_option("--page-size", args->page_size, "How many")->check(CLI::Range(1, 1000));
      list->add_flag("--json", args->json_output, "As JSON");
      CLI::App* show = sub.add_subcommand("show", "A study and the state of its jobs");
      show->add_option("study", args->study_id, "Study id")->required();
      show->add_flag("--json", args->json_output, "As JSON");
      CLI::App* watch = sub.add_subcommand("watch", "Follow a study's jobs until they end");
      watch->add_option("study", args->study_id, "Study id")->required();
      watch->add_flag("--json", args->json_output, "Updates as JSON lines");
      CLI::App* cancel = sub.add_subcommand("cancel", "Cancel the jobs of a study that have not ended");
      cancel->add_option("study", args->study_id, "Study id")->required();
      CLI::App* analysis = sub.add_subcommand(
          "analysis", "Every observable per ensemble with its 95 % bootstrap interval and the seeds behind it");
      analysis->add_option("study", args->study_id, "Study id")->required();
      analysis->add_flag("--json", args->json_output, "The whole analysis as JSON (format gel.study-analysis.v1)");
      analysis->add_flag("--include-unequilibrated", args->include_unequilibrated,
                         "Also fit spanning rows that did not pass the equilibrium test");
      analysis->add_flag("--partial", args->partial, "Analyse the rows stored so far of a study still running");
      analysis->add_option("--bootstrap-samples", args->bootstrap_samples, "Resamples (default 1000)")
          ->check(CLI::Range(1, 100000));
      return [args, submit, list, show, watch, cancel, analysis](gelctl::Client& client) {
        if (submit->parsed()) {
          if (args->preset.empty() && args->study_file.empty())
            throw gelctl::UsageError("study submit: give --preset or --file");
          return run_submit(client, *args);
        }
        if (list->parsed()) return run_list(client, *args);
        if (show->parsed()) return run_show(client, *args);
        if (watch->parsed()) return watch_study(client, args->study_id, args->json_output);
        if (cancel->parsed()) return run_cancel(client, *args);
        return run_analysis(client, *args);
      };
    }};

}  // namespace
