// JobManager's queries: a job, the list, curves (each member's and the ensemble statistic), the
// analysis, QueryCurves, log lines, and the watch stream.
#include <algorithm>

#include <nlohmann/json.hpp>

#include "gel/analysis/ensemble_statistic.hpp"
#include "gel/errors.hpp"
#include "job_manager.hpp"
#include "job_parameters.hpp"
#include "job_updates.hpp"
#include "proto_json.hpp"

namespace geld {
namespace {

// An enum field carries any number on the wire: a state that does not exist is refused rather
// than matching nothing in silence.
void require_job_state(int state) {
  if (!gel::v1::JobState_IsValid(state))
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "state: " + std::to_string(state) + " is not a job state");
}

// Why QueryCurves cannot filter on `field`, or "". A misspelt name would match no job and
// return an empty table that looks like an answer.
std::string query_field_problem(const std::string& field) {
  if (field.empty()) return "must name a scene field, e.g. generator.lx";
  if (field == kCacheKeyParameter || field == kProgramVersionParameter) return "";
  const std::string problem = gel::field_path_problem(*gel::v1::Scene::descriptor(), field);
  if (problem.empty()) return "";
  return problem + "; besides the scene's fields, " + kProgramVersionParameter + " and " + kCacheKeyParameter +
         " can be filtered";
}

// One of the `limit` watcher slots, held for a stream's life. A slot is taken only when one is
// free, in one atomic step: counting first and checking after let a burst of requests that were
// all going to be refused push the count over the limit for a moment and refuse a request that
// had a free slot (56 refusals with at most 100 streams open under mixed load).
class WatcherSlot {
 public:
  WatcherSlot(std::atomic<int>& count, int limit) : count_(count) {
    int current = count_.load();
    while (current < limit && !count_.compare_exchange_weak(current, current + 1)) {
    }
    taken_ = current < limit;
  }
  ~WatcherSlot() {
    if (taken_) --count_;
  }
  WatcherSlot(const WatcherSlot&) = delete;
  WatcherSlot& operator=(const WatcherSlot&) = delete;
  bool taken() const { return taken_; }

 private:
  std::atomic<int>& count_;
  bool taken_ = false;
};

}  // namespace

gel::v1::Job JobManager::get(const std::string& id) {
  require_id(id);
  if (auto live = find_live(id)) {
    std::lock_guard lock(live->mutex);
    return live->job;
  }
  auto job = store_->get_job(id);
  if (!job) throw ApiError(grpc::StatusCode::NOT_FOUND, "job " + id + " not found");
  return *job;
}

gel::v1::ListJobsResponse JobManager::list(const gel::v1::ListJobsRequest& request) {
  JobFilter filter;
  require_job_state(request.state());
  filter.state = request.state();
  filter.name = request.name();
  if (!request.label().empty()) {
    auto eq = request.label().find('=');
    filter.label_key = request.label().substr(0, eq);
    if (eq != std::string::npos) filter.label_value = request.label().substr(eq + 1);
  }
  const Page page = Page::parse(request.page_size(), request.page_token(), "ListJobs");
  filter.before_seq = page.before_seq;
  filter.limit = page.size + 1;  // one more, to know whether there is a next page
  auto rows = store_->list_jobs(filter);
  gel::v1::ListJobsResponse response;
  response.set_next_page_token(page.next_token(rows));
  for (auto& [seq, job] : rows) {
    if (auto live = find_live(job.id())) {
      std::lock_guard lock(live->mutex);
      job = live->job;
    }
    *response.add_jobs() = std::move(job);
  }
  return response;
}

gel::v1::Curve JobManager::member_curve(const gel::v1::Job& job, const std::vector<StoredRow>& rows, int member) {
  gel::v1::Curve curve;
  *curve.mutable_scene() = job.scene();
  if (member < job.seeds_size()) curve.mutable_scene()->mutable_generator()->set_seed(job.seeds(member));
  curve.set_particles(static_cast<std::int32_t>(job.particles()));
  // The program that ran the job, not the one answering (they differ after an upgrade); jobs
  // stored before versions were recorded say nothing rather than something wrong.
  curve.set_program_version(job.program_version());
  for (const auto& r : rows) {
    if (r.member == member) *curve.add_rows() = r.row;
  }
  return curve;
}

std::vector<gel::v1::Curve> JobManager::member_curves(const gel::v1::Job& job) {
  const auto rows = store_->rows(job.id());
  std::vector<gel::v1::Curve> curves;
  for (int m = 0; m < std::max(1, job.seeds_size()); ++m) curves.push_back(member_curve(job, rows, m));
  return curves;
}

gel::v1::GetAnalysisResponse JobManager::analysis(const gel::v1::GetAnalysisRequest& request) {
  const gel::v1::Job job = get(request.job_id());
  // Fits over members of unequal length would mix ensembles of different sizes row by row.
  if (job.state() != gel::v1::JOB_STATE_SUCCEEDED)
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION,
                   "job " + job.id() + " is " + Store::state_name(job.state()) + "; its analysis needs every member's rows");
  const std::vector<gel::v1::Curve> curves = member_curves(job);
  gel::v1::GetAnalysisResponse response;
  response.set_job_id(job.id());
  response.set_members(static_cast<std::int32_t>(curves.size()));
  try {
    response.set_json(adapter_->analysis_json(curves, request.include_unequilibrated()));
  } catch (const gel::InvalidArgument& e) {
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION, std::string("job ") + job.id() + ": " + e.what());
  }
  return response;
}

gel::v1::GetCurveResponse JobManager::curve(const std::string& id) {
  gel::v1::Job job = get(id);
  auto rows = store_->rows(id);
  gel::v1::GetCurveResponse response;
  response.set_job_id(id);
  response.set_state(job.state());
  const int members = std::max(1, job.seeds_size());
  for (int m = 0; m < members; ++m) {
    auto* mc = response.add_members();
    mc->set_member(m);
    mc->set_seed(m < job.seeds_size() ? job.seeds(m) : 0);
    *mc->mutable_curve() = member_curve(job, rows, m);
  }
  nlohmann::json out;
  if (members == 1) {
    out = nlohmann::json::parse(adapter_->curve_json(response.members(0).curve()));
  } else {
    // The product's one ensemble statistic (gel/analysis/ensemble_statistic.hpp), named in the answer.
    std::vector<const gel::v1::Curve*> curves;
    for (const auto& mc : response.members()) curves.push_back(&mc.curve());
    // Each observable once: its JSON key, the row's value and the EnsembleRow's Stat.
    struct Observable {
      const char* key;
      double (*value)(const gel::v1::CurveRow&);
      gel::v1::Stat* (*stat)(gel::v1::EnsembleRow&);
    };
    const Observable observables[] = {
        {"phi", [](const gel::v1::CurveRow& r) { return r.phi(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_phi(); }},
        {"P", [](const gel::v1::CurveRow& r) { return r.p(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_p(); }},
        {"P_top", [](const gel::v1::CurveRow& r) { return r.p_top(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_p_top(); }},
        {"P_bot", [](const gel::v1::CurveRow& r) { return r.p_bot(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_p_bot(); }},
        {"contact_number", [](const gel::v1::CurveRow& r) { return r.contact_number(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_contact_number(); }},
        {"stored_energy", [](const gel::v1::CurveRow& r) { return r.stored_energy(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_stored_energy(); }},
        {"dissipated_energy", [](const gel::v1::CurveRow& r) { return r.dissipated_energy(); },
         [](gel::v1::EnsembleRow& e) { return e.mutable_dissipated_energy(); }}};
    std::vector<std::vector<gel::analysis::RowStatistic>> statistics;
    for (const Observable& o : observables)
      statistics.push_back(gel::analysis::ensemble_statistic(curves, o.value));
    nlohmann::json json_rows = nlohmann::json::array();
    for (std::size_t r = 0; r < statistics[0].size(); ++r) {
      auto* er = response.add_ensemble();
      er->set_k(statistics[0][r].k);
      er->set_n(statistics[0][r].n);
      nlohmann::json jr{{"k", statistics[0][r].k}, {"n", statistics[0][r].n}};
      for (std::size_t v = 0; v < std::size(observables); ++v) {
        const gel::analysis::RowStatistic& st = statistics[v][r];
        gel::v1::Stat* stat = observables[v].stat(*er);
        stat->set_mean(st.mean);
        stat->set_std(st.std);
        jr[observables[v].key] = st.mean;
        jr[std::string(observables[v].key) + "_std"] = st.std;
      }
      json_rows.push_back(std::move(jr));
    }
    response.set_ensemble_rule(gel::analysis::kEnsembleRule);
    out["ensemble_rule"] = gel::analysis::kEnsembleRule;
    out["particles"] = job.particles();
    out["seeds"] = nlohmann::json(std::vector<std::uint64_t>(job.seeds().begin(), job.seeds().end()));
    out["rows"] = std::move(json_rows);
    nlohmann::json member_json = nlohmann::json::array();
    for (const auto& mc : response.members()) {
      auto mj = nlohmann::json::parse(adapter_->curve_json(mc.curve()));
      mj["seed"] = mc.seed();
      member_json.push_back(std::move(mj));
    }
    out["members"] = std::move(member_json);
  }
  out["job_id"] = id;
  out["state"] = Store::state_name(job.state());
  response.set_json(out.dump());
  return response;
}

gel::v1::QueryCurvesResponse JobManager::query(const gel::v1::QueryCurvesRequest& request) {
  CurveFilter filter;
  filter.bond_preset = request.bond_preset();
  for (const auto& [k, v] : request.labels()) filter.labels.emplace_back(k, v);
  for (int i = 0; i < request.parameters_size(); ++i) {
    const auto& p = request.parameters(i);
    if (const std::string problem = query_field_problem(p.field()); !problem.empty())
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "parameters[" + std::to_string(i) + "].field: " + problem);
    CurveFilter::Parameter fp;
    fp.name = p.field();
    fp.equals = p.equals();
    if (p.has_min()) fp.min = p.min();
    if (p.has_max()) fp.max = p.max();
    filter.parameters.push_back(std::move(fp));
  }
  require_job_state(request.state());
  filter.state = request.state() == gel::v1::JOB_STATE_UNSPECIFIED ? gel::v1::JOB_STATE_SUCCEEDED : request.state();
  if (request.limit() < 0) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "limit: must be >= 0");
  filter.limit = request.limit() == 0 ? 100 : std::min(request.limit(), 1000);
  gel::v1::QueryCurvesResponse response;
  for (const auto& id : store_->query_curves(filter)) {
    auto* entry = response.add_curves();
    *entry->mutable_job() = get(id);
    *entry->mutable_curve() = curve(id);
  }
  return response;
}

gel::v1::GetLogsResponse JobManager::logs(const gel::v1::GetLogsRequest& request) {
  get(request.job_id());  // NOT_FOUND
  if (request.limit() < 0) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "limit: must be >= 0");
  gel::v1::GetLogsResponse response;
  // Capped like ListJobs and QueryCurves: a client pages with after_id.
  const int limit = request.limit() == 0 ? 1000 : std::min(request.limit(), 1000);
  for (auto& line : store_->logs(request.job_id(), request.after_id(), limit)) {
    *response.add_lines() = std::move(line);
  }
  return response;
}

void JobManager::watch(const std::string& id, const std::function<bool(const gel::v1::JobUpdate&)>& write,
                       const std::function<bool()>& cancelled) {
  require_id(id);
  if (shutting_down_) throw shutting_down_error();
  WatcherSlot slot(watchers_, options_.limits.max_watchers);
  if (!slot.taken()) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "too many watchers: the limit is " + std::to_string(options_.limits.max_watchers));
  }
  auto live = find_live(id);
  if (!live) {
    // Not queued or running: its state is final; one snapshot and the stream ends.
    auto job = store_->get_job(id);
    if (!job) throw ApiError(grpc::StatusCode::NOT_FOUND, "job " + id + " not found");
    if (!write(job_update::snapshot(std::move(*job)))) return;
    for (const auto& update : stored_rows(id, 0)) {
      if (!write(update)) return;
    }
    return;
  }
  std::int64_t seen = 0;
  gel::v1::JobUpdate snapshot;
  std::vector<gel::v1::JobUpdate> rows_so_far;
  {
    std::lock_guard lock(live->mutex);
    seen = live->sequence;
    snapshot = job_update::snapshot(live->job, seen);
    rows_so_far = stored_rows(id, seen);
  }
  // The snapshot, then the rows stored so far (ROW updates carrying the snapshot's sequence),
  // then live updates.
  if (!write(snapshot)) return;
  for (const auto& update : rows_so_far) {
    if (!write(update)) return;
  }
  std::vector<gel::v1::JobUpdate> pending;
  for (;;) {
    bool ended = false;
    {
      std::unique_lock lock(live->mutex);
      live->changed.wait_for(lock, std::chrono::milliseconds(200),
                             [&] { return live->sequence > seen || live->ended || shutting_down_; });
      // History is in sequence order; the latest progress slots in where its sequence says.
      auto it = std::upper_bound(live->history.begin(), live->history.end(), seen,
                                 [](std::int64_t s, const gel::v1::JobUpdate& u) { return s < u.sequence(); });
      bool progress_sent = live->progress.sequence() <= seen;
      for (; it != live->history.end(); ++it) {
        if (!progress_sent && live->progress.sequence() < it->sequence()) {
          pending.push_back(live->progress);
          progress_sent = true;
        }
        pending.push_back(*it);
      }
      if (!progress_sent) pending.push_back(live->progress);
      seen = live->sequence;
      ended = live->ended;
    }
    for (const auto& update : pending) {
      if (!write(update)) return;
    }
    pending.clear();
    if (ended) return;
    if (cancelled && cancelled()) return;
    if (shutting_down_) throw shutting_down_error();
  }
}

std::vector<gel::v1::JobUpdate> JobManager::stored_rows(const std::string& id, std::int64_t sequence) {
  std::vector<gel::v1::JobUpdate> out;
  for (auto& r : store_->rows(id)) out.push_back(job_update::row(std::move(r.row), r.member, r.seed, sequence));
  return out;
}

}  // namespace geld
