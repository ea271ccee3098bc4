#include "study_manager.hpp"

#include <chrono>
#include <exception>
#include <filesystem>
#include <map>
#include <thread>

#include <google/protobuf/util/json_util.h>
#include <spdlog/spdlog.h>

#include "gel/analysis/study_analysis.hpp"
#include "gel/errors.hpp"
#include "gel/study.hpp"

namespace geld {
namespace fs = std::filesystem;
namespace {

ApiError invalid(const std::string& message) { return ApiError(grpc::StatusCode::INVALID_ARGUMENT, message); }

// The job request of one ensemble: the study's labels plus study and ensemble.
gel::v1::SubmitJobRequest job_request(const gel::v1::SubmitStudyRequest& study, const gel::v1::StudyEnsemble& ensemble,
                                      const std::string& study_id) {
  gel::v1::SubmitJobRequest job;
  if (ensemble.has_scene()) *job.mutable_scene() = ensemble.scene();
  job.set_scene_json(ensemble.scene_json());
  *job.mutable_seeds() = ensemble.seeds();
  job.set_name((study.name().empty() ? std::string("study") : study.name()) + "/" + ensemble.name());
  *job.mutable_labels() = study.labels();
  (*job.mutable_labels())["study"] = study_id;
  (*job.mutable_labels())["ensemble"] = ensemble.name();
  job.set_rerun(study.rerun());
  return job;
}

}  // namespace

gel::v1::SubmitStudyRequest StudyManager::expanded(const gel::v1::SubmitStudyRequest& request) {
  gel::v1::SubmitStudyRequest out = request;
  if (request.labels().contains("study") || request.labels().contains("ensemble"))
    throw invalid("labels: 'study' and 'ensemble' are set by geld on the study's jobs");
  if (request.seed_count() > 1000) throw invalid("seed_count: at most 1000, got " + std::to_string(request.seed_count()));
  try {
    if (!request.preset().empty()) {
      if (request.ensembles_size() > 0) throw invalid("ensembles: give a preset or ensembles, not both");
      gel::StudyPresetOptions options;
      options.seed_count = static_cast<int>(request.seed_count());
      options.fidelity = request.fidelity();
      out.clear_ensembles();
      for (const gel::StudyEnsembleSpec& spec : gel::study_preset(request.preset(), options)) {
        gel::v1::StudyEnsemble* ensemble = out.add_ensembles();
        ensemble->set_name(spec.name);
        *ensemble->mutable_scene() = spec.scene;
        for (const std::uint64_t seed : spec.seeds) ensemble->add_seeds(seed);
      }
      if (out.fidelity().empty()) out.set_fidelity(gel::study_preset_fidelity(request.preset()));
    } else {
      if (request.ensembles_size() == 0) throw invalid("ensembles: a study needs a preset or at least one ensemble");
      if (!request.fidelity().empty()) throw invalid("fidelity: applies to a preset; set it in each ensemble's scene");
    }
  } catch (const gel::InvalidArgument& e) {
    throw invalid(e.what());
  }
  if (out.ensembles_size() > kMaxEnsembles)
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED, "ensembles: " + std::to_string(out.ensembles_size()) +
                                                             " ensembles, the limit is " + std::to_string(kMaxEnsembles));
  std::set<std::string> names;
  for (int e = 0; e < out.ensembles_size(); ++e) {
    gel::v1::StudyEnsemble& ensemble = *out.mutable_ensembles(e);
    const std::string field = "ensembles[" + std::to_string(e) + "]";
    try {
      gel::validate_ensemble_name(ensemble.name(), field + ".name");
    } catch (const gel::InvalidArgument& error) {
      throw invalid(error.what());
    }
    if (!names.insert(ensemble.name()).second) throw invalid(field + ".name: '" + ensemble.name() + "' appears twice");
    if (ensemble.seeds_size() == 0 && request.seed_count() > 0)
      for (std::uint32_t s = 1; s <= request.seed_count(); ++s) ensemble.add_seeds(s);
  }
  return out;
}

gel::v1::SubmitStudyResponse StudyManager::submit(const gel::v1::SubmitStudyRequest& request) {
  if (jobs_.shutting_down()) throw shutting_down_error();
  const gel::v1::SubmitStudyRequest full = expanded(request);
  // Every ensemble is checked before anything is stored: a bad one refuses the whole study.
  for (int e = 0; e < full.ensembles_size(); ++e) {
    try {
      jobs_.validate(job_request(full, full.ensembles(e), "study-0"));
    } catch (const ApiError& error) {
      throw ApiError(error.code(), "ensembles[" + std::to_string(e) + "] (" + full.ensembles(e).name() + "): " + error.what());
    }
  }
  gel::v1::Study study;
  study.set_name(full.name());
  study.set_preset(full.preset());
  study.set_fidelity(full.fidelity());
  *study.mutable_labels() = full.labels();
  study.set_created_unix_ms(now_ms());
  study.set_program_version(jobs_.program_version());
  *study.mutable_request() = full;
  const std::string id = jobs_.store().insert_study(study);
  {
    std::lock_guard lock(submitting_mutex_);
    submitting_.insert(id);
  }
  std::vector<std::string> queued;  // this study's own new jobs, cancelled if a later one is refused
  try {
    for (int e = 0; e < full.ensembles_size(); ++e) {
      const gel::v1::SubmitJobResponse job = jobs_.submit(job_request(full, full.ensembles(e), id), false);
      jobs_.store().add_study_job(id, e, full.ensembles(e).name(), job.job_id(), job.cached());
      if (!job.cached()) queued.push_back(job.job_id());
    }
  } catch (const ApiError& error) {
    for (const std::string& job_id : queued) {
      try {
        jobs_.cancel(job_id);
      } catch (const std::exception&) {
        // It ended meanwhile: nothing to stop.
      }
    }
    {
      std::lock_guard lock(submitting_mutex_);
      submitting_.erase(id);
    }
    throw ApiError(error.code(), "study " + id + " was not started (its queued jobs are cancelled): " + error.what());
  }
  {
    std::lock_guard lock(submitting_mutex_);
    submitting_.erase(id);
  }
  spdlog::info("study {}: {} ensemble(s) submitted (name '{}', preset '{}')", id, full.ensembles_size(), full.name(),
               full.preset());
  gel::v1::SubmitStudyResponse response;
  response.set_study_id(id);
  *response.mutable_study() = get(id);
  return response;
}

gel::v1::Study StudyManager::with_job_states(gel::v1::Study study) {
  bool any_running = false, any_started = false, all_ended = true, all_succeeded = true;
  std::int64_t finished = 0;
  std::string failure, cancellation;
  for (gel::v1::StudyJob& entry : *study.mutable_jobs()) {
    const gel::v1::Job job = jobs_.get(entry.job_id());
    entry.set_state(job.state());
    entry.set_members(job.seeds_size());
    entry.set_members_finished(static_cast<std::int32_t>(jobs_.store().finished_members(job.id()).size()));
    if (job.state() == gel::v1::JOB_STATE_SUCCEEDED) entry.set_members_finished(job.seeds_size());
    entry.set_rows(job.rows());
    if (job.has_progress() && job.state() == gel::v1::JOB_STATE_RUNNING) *entry.mutable_progress() = job.progress();
    any_running |= job.state() == gel::v1::JOB_STATE_RUNNING;
    any_started |= job.state() != gel::v1::JOB_STATE_QUEUED;
    all_ended &= is_terminal(job.state());
    all_succeeded &= job.state() == gel::v1::JOB_STATE_SUCCEEDED;
    finished = std::max(finished, job.finished_unix_ms());
    if (job.state() == gel::v1::JOB_STATE_FAILED && failure.empty())
      failure = entry.ensemble() + " (" + job.id() + "): " + job.error();
    if (job.state() == gel::v1::JOB_STATE_CANCELLED && cancellation.empty())
      cancellation = entry.ensemble() + " (" + job.id() + "): " + job.error();
  }
  bool submitting;
  {
    std::lock_guard lock(submitting_mutex_);
    submitting = submitting_.contains(study.id());
  }
  if (study.jobs_size() < study.request().ensembles_size() && !submitting) {
    // A submission that did not complete: refused part-way or interrupted by a crash.
    study.set_state(gel::v1::JOB_STATE_FAILED);
    study.set_error("only " + std::to_string(study.jobs_size()) + " of its " +
                    std::to_string(study.request().ensembles_size()) + " ensembles were submitted");
    return study;
  }
  if (submitting || (!any_started && !all_ended)) {
    study.set_state(gel::v1::JOB_STATE_QUEUED);
  } else if (!all_ended || any_running) {
    study.set_state(gel::v1::JOB_STATE_RUNNING);
  } else if (all_succeeded) {
    study.set_state(gel::v1::JOB_STATE_SUCCEEDED);
  } else if (!failure.empty()) {
    study.set_state(gel::v1::JOB_STATE_FAILED);
    study.set_error(failure);
  } else {
    study.set_state(gel::v1::JOB_STATE_CANCELLED);
    study.set_error(cancellation);
  }
  if (all_ended && !submitting) study.set_finished_unix_ms(finished);
  return study;
}

gel::v1::Study StudyManager::get(const std::string& id) {
  if (id.empty()) throw invalid("study_id: required");
  require_id_size("study_id", id);
  auto study = jobs_.store().get_study(id);
  if (!study) throw ApiError(grpc::StatusCode::NOT_FOUND, "study_id: no study '" + id.substr(0, 64) + "'");
  return with_job_states(std::move(*study));
}

gel::v1::ListStudiesResponse StudyManager::list(const gel::v1::ListStudiesRequest& request) {
  const Page page = Page::parse(request.page_size(), request.page_token(), "ListStudies");
  auto rows = jobs_.store().list_studies(page.before_seq, page.size + 1);  // one more: is there a next page?
  gel::v1::ListStudiesResponse response;
  response.set_next_page_token(page.next_token(rows));
  for (auto& [seq, study] : rows) *response.add_studies() = with_job_states(std::move(study));
  return response;
}

gel::v1::Study StudyManager::cancel(const std::string& id) {
  const gel::v1::Study study = get(id);
  bool cancelled_any = false;
  for (const gel::v1::StudyJob& job : study.jobs()) {
    if (is_terminal(job.state())) continue;
    try {
      jobs_.cancel(job.job_id());
      cancelled_any = true;
    } catch (const ApiError& error) {
      if (error.code() != grpc::StatusCode::FAILED_PRECONDITION) throw;  // it ended meanwhile
    }
  }
  if (!cancelled_any && is_terminal(study.state()))
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION, "study " + id + " has already ended (" +
                                                              Store::state_name(study.state()) + ")");
  return get(id);
}

void StudyManager::watch(const std::string& id, const std::function<bool(const gel::v1::StudyUpdate&)>& write,
                         const std::function<bool()>& cancelled) {
  const gel::v1::Study study = get(id);
  std::mutex write_mutex;
  bool receiver_gone = false;
  {
    gel::v1::StudyUpdate first;
    *first.mutable_study() = study;
    if (!write(first)) return;
  }
  auto send = [&](gel::v1::StudyUpdate update) {
    std::lock_guard lock(write_mutex);
    if (receiver_gone) return false;
    if (!write(update)) receiver_gone = true;
    return !receiver_gone;
  };
  std::exception_ptr failure;
  std::mutex failure_mutex;
  std::vector<std::thread> watchers;
  for (const gel::v1::StudyJob& job : study.jobs()) {
    watchers.emplace_back([&, job] {
      try {
        jobs_.watch(
            job.job_id(),
            [&](const gel::v1::JobUpdate& update) {
              gel::v1::StudyUpdate out;
              out.set_ensemble(job.ensemble());
              out.set_job_id(job.job_id());
              *out.mutable_update() = update;
              if (update.kind() == gel::v1::JobUpdate::STATE) *out.mutable_study() = get(id);
              return send(std::move(out));
            },
            [&] {
              std::lock_guard lock(write_mutex);
              return receiver_gone || cancelled();
            });
      } catch (...) {
        std::lock_guard lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        std::lock_guard write_lock(write_mutex);
        receiver_gone = true;  // the other watchers stop too
      }
    });
  }
  for (std::thread& watcher : watchers) watcher.join();
  if (failure) std::rethrow_exception(failure);
  if (receiver_gone || cancelled()) return;
  gel::v1::StudyUpdate last;
  *last.mutable_study() = get(id);
  write(last);
}

gel::v1::GetStudyAnalysisResponse StudyManager::analysis(const gel::v1::GetStudyAnalysisRequest& request) {
  const gel::v1::Study study = get(request.study_id());
  const bool succeeded = study.state() == gel::v1::JOB_STATE_SUCCEEDED;
  if (!succeeded && !request.partial())
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION,
                   "study " + study.id() + " is " + Store::state_name(study.state()) +
                       "; its analysis needs every member's rows (partial = true analyses the rows stored so far)");
  if (request.bootstrap_samples() > 100000) throw invalid("bootstrap_samples: at most 100000");
  gel::analysis::StudyAnalysisOptions options;
  if (request.bootstrap_samples() > 0) options.bootstrap_samples = static_cast<int>(request.bootstrap_samples());
  options.include_unequilibrated = request.include_unequilibrated();
  const std::string options_key = "bootstrap=" + std::to_string(options.bootstrap_samples) +
                                  ";unequilibrated=" + (options.include_unequilibrated ? "1" : "0");
  gel::v1::GetStudyAnalysisResponse response;
  response.set_study_id(study.id());
  response.set_state(study.state());
  if (succeeded) {
    if (auto stored = jobs_.store().study_analysis(study.id(), options_key)) {
      response.set_json(stored->json);
      response.set_seconds(stored->seconds);
      response.set_stored(true);
      return response;
    }
  }
  std::vector<gel::analysis::StudyEnsembleInput> inputs;
  for (const gel::v1::StudyJob& entry : study.jobs()) {
    const gel::v1::Job job = jobs_.get(entry.job_id());
    std::vector<gel::v1::Curve> curves = jobs_.member_curves(job);
    gel::analysis::StudyEnsembleInput input;
    input.name = entry.ensemble();
    bool every_dir = true;
    for (int member = 0; member < static_cast<int>(curves.size()); ++member) {
      if (curves[member].rows_size() == 0) continue;  // partial: a member that has not reached a row
      input.curves.push_back(std::move(curves[member]));
      input.seeds.push_back(member < job.seeds_size() ? job.seeds(member) : 0);
      const std::string dir = jobs_.member_dir(job, member);
      every_dir &= fs::exists(fs::path(dir) / "snapshots");
      input.dirs.push_back(dir);
    }
    // Structures need every member's snapshots (a Slurm member's may live on another machine).
    if (!every_dir) input.dirs.clear();
    if (input.curves.empty())
      throw ApiError(grpc::StatusCode::FAILED_PRECONDITION, "ensemble " + entry.ensemble() + " has no stored row yet");
    inputs.push_back(std::move(input));
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    response.set_json(gel::analysis::to_json(gel::analysis::analyse_study(inputs, options)).dump());
  } catch (const gel::InvalidArgument& e) {
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION, "study " + study.id() + ": " + e.what());
  }
  response.set_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  if (succeeded) jobs_.store().put_study_analysis(study.id(), options_key, response.json(), response.seconds(), now_ms());
  return response;
}

}  // namespace geld
