#include "job_manager.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <optional>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gel/analysis/ensemble_statistic.hpp"
#include "gel/errors.hpp"
#include "gel/fnv1a.hpp"
#include "gel/resources.hpp"
#include "gel/seed.hpp"
#include "proto_json.hpp"

namespace geld {

namespace fs = std::filesystem;
using gel::v1::JobState;

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

namespace {
bool is_terminal(JobState state) {
  return state == gel::v1::JOB_STATE_SUCCEEDED || state == gel::v1::JOB_STATE_FAILED ||
         state == gel::v1::JOB_STATE_CANCELLED;
}

// An enum field carries any number on the wire: a state that does not exist is refused rather
// than matching nothing in silence.
void require_job_state(int state) {
  if (!gel::v1::JobState_IsValid(state))
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "state: " + std::to_string(state) + " is not a job state");
}

ApiError unavailable() {
  return ApiError(grpc::StatusCode::UNAVAILABLE, "geld is shutting down; retry when it is back");
}

// Recorded for QueryCurves beside the resolved scene's fields.
constexpr char kCacheKeyParameter[] = "run.cache_key";
constexpr char kProgramVersionParameter[] = "run.program_version";

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

void to_message(const gel::ResourceEstimate& e, int members, gel::v1::ResourceEstimate& out) {
  out.set_particles(e.particles);
  out.set_bonds(e.bonds);
  out.set_neighbour_pairs(e.neighbour_pairs);
  out.set_memory_bytes(e.memory_bytes);
  out.set_disk_bytes(e.disk_bytes);
  out.set_steps(e.steps);
  out.set_particle_steps(e.particle_steps);
  out.set_members(members);
}

std::string describe(const gel::ResourceEstimate& e) {
  return std::to_string(e.particles) + " particles, up to " + std::to_string(e.bonds) + " bonds and " +
         std::to_string(e.neighbour_pairs) + " neighbour pairs";
}

// The per-job budgets of Limits, from one member's estimate: each refusal names the field that
// drives the estimate, the estimate and the limit with the option that sets it.
void check_job_budgets(const gel::ResourceEstimate& e, int members, const Limits& limits) {
  const auto refuse = [](const std::string& field, const std::string& text) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED, field + ": " + text);
  };
  if (e.memory_bytes > limits.max_member_memory)
    refuse("scene." + e.memory_driver, "one member would hold about " + gel::format_bytes(static_cast<double>(e.memory_bytes)) +
                                           " (" + describe(e) + "), the limit is " +
                                           gel::format_bytes(static_cast<double>(limits.max_member_memory)) + " (--max-member-memory)");
  const double disk = static_cast<double>(e.disk_bytes) * members;
  if (disk > static_cast<double>(limits.max_job_disk))
    refuse(members > 1 && e.disk_bytes <= limits.max_job_disk ? "seeds" : "scene." + e.disk_driver,
           "the job's files would take about " + gel::format_bytes(disk) + " (" + std::to_string(members) + " member(s) of " +
               gel::format_bytes(static_cast<double>(e.disk_bytes)) + "), the limit is " +
               gel::format_bytes(static_cast<double>(limits.max_job_disk)) + " (--max-job-disk)");
  const double cost = e.particle_steps * members;
  if (cost > limits.max_job_particle_steps) {
    char text[200];
    std::snprintf(text, sizeof text, "the job would take at least %.3g particle-steps (%d member(s) of %lld particles x %.3g steps), "
                  "the limit is %.3g (--max-job-particle-steps)", cost, members, static_cast<long long>(e.particles),
                  static_cast<double>(e.steps), limits.max_job_particle_steps);
    refuse(members > 1 && e.particle_steps <= limits.max_job_particle_steps ? "seeds" : "scene.generator", text);
  }
}

// What geld itself holds besides its members (measured idle: about 20 MB).
constexpr std::int64_t kDaemonBytes = 64ll << 20;

}  // namespace

std::int64_t JobManager::memory_budget() const {
  if (options_.limits.max_memory > 0) return options_.limits.max_memory;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? static_cast<std::int64_t>(pages) * page / 2 : 4ll << 30;
}

void JobManager::admit_memory(std::int64_t member_memory, int members) const {
  // Members of a Slurm executor run on the cluster's nodes, not in geld.
  if (!executor_->runs_in_process()) return;
  // Any `workers` members of the admitted jobs may run at once: the largest of them must fit.
  std::vector<std::pair<std::int64_t, int>> admitted;  // (one member's memory, members)
  for (const auto& [id, live] : live_) admitted.emplace_back(live->member_memory, live->members);
  admitted.emplace_back(member_memory, members);
  std::sort(admitted.begin(), admitted.end(), std::greater<>());
  std::int64_t peak = kDaemonBytes + gel::kProgramBytes;
  int slots = options_.workers;
  for (const auto& [memory, count] : admitted) {
    const int running = std::min(slots, std::max(count, 1));
    peak += memory * running;
    slots -= running;
    if (slots <= 0) break;
  }
  const std::int64_t budget = memory_budget();
  if (peak > budget)
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "memory: with this job the " + std::to_string(options_.workers) + " largest members of the " +
                       std::to_string(live_.size() + 1) + " admitted jobs could hold " +
                       gel::format_bytes(static_cast<double>(peak)) + " together (this job's members " +
                       gel::format_bytes(static_cast<double>(member_memory)) + " each), over the daemon's budget of " +
                       gel::format_bytes(static_cast<double>(budget)) + " (--max-memory); wait for jobs to end or raise it");
}

JobManager::JobManager(ManagerOptions options, std::shared_ptr<Engine> engine, std::shared_ptr<Executor> executor)
    : options_(std::move(options)), engine_(std::move(engine)), executor_(std::move(executor)) {
  fs::create_directories(fs::path(options_.data_dir) / "jobs");
  // One daemon per data dir (the jobs tree) and per store (the queue): two would run the same jobs.
  data_dir_lock_ = OwnerLock::data_dir(options_.data_dir);
  const std::string db_path =
      options_.db_path.empty() ? (fs::path(options_.data_dir) / "geld.sqlite").string() : options_.db_path;
  store_lock_ = OwnerLock::store(db_path);
  store_ = std::make_unique<Store>(db_path);
  if (options_.workers <= 0) options_.workers = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

JobManager::~JobManager() {
  shutdown();
  release_data_dir();
}

void JobManager::release_data_dir() {
  data_dir_lock_ = OwnerLock();
  store_lock_.release();  // unlocked, closed only after the store (see OwnerLock::release)
}

std::string JobManager::require_id(const std::string& id) {
  if (id.empty()) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "job_id: must not be empty");
  require_id_size("job_id", id);
  return id;
}

void require_id_size(const std::string& field, const std::string& id) {
  constexpr std::size_t kMaxIdBytes = 64;
  if (id.size() > kMaxIdBytes)
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                   field + ": " + std::to_string(id.size()) + " bytes, the limit is " + std::to_string(kMaxIdBytes));
}

void JobManager::start() {
  std::lock_guard lock(mutex_);
  if (started_) return;
  started_ = true;
  // Jobs that were running resume first (from their checkpoints), then the queue in order.
  for (auto state : {gel::v1::JOB_STATE_RUNNING, gel::v1::JOB_STATE_QUEUED}) {
    for (const auto& id : store_->job_ids_in_state(state)) {
      auto job = store_->get_job(id);
      if (!job) continue;
      auto live = std::make_shared<Live>();
      live->job = *job;
      // Admitted before the restart: counted, never refused again.
      try {
        live->member_memory = gel::estimate_resources(job->scene()).memory_bytes;
      } catch (const std::exception& e) {
        spdlog::warn("job {}: no resource estimate for its stored scene ({})", id, e.what());
      }
      live->members = job->seeds_size();
      live_[id] = live;
      queue_.push_back(id);
      if (state == gel::v1::JOB_STATE_RUNNING) {
        spdlog::info("job {}: was running; resumes from its checkpoint (member {})", id, job->member());
      } else {
        spdlog::info("job {}: still queued", id);
      }
    }
  }
  for (int i = 0; i < options_.workers; ++i) workers_.emplace_back([this] { worker_loop(); });
  spdlog::info("job manager: {} workers, {} jobs recovered, data dir {}", options_.workers, queue_.size(),
               options_.data_dir);
}

void JobManager::shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    stopped_ = true;
    shutting_down_ = true;
    for (auto& [id, live] : live_) {
      live->stop = true;
      std::lock_guard live_lock(live->mutex);
      live->changed.notify_all();
    }
  }
  queue_changed_.notify_all();
  for (auto& worker : workers_) worker.join();
  workers_.clear();
  release_data_dir();  // no job runs from here on: the next daemon may take the data dir
  spdlog::info("job manager stopped");
}

std::shared_ptr<JobManager::Live> JobManager::find_live(const std::string& id) {
  std::lock_guard lock(mutex_);
  auto it = live_.find(id);
  return it == live_.end() ? nullptr : it->second;
}

// Caller holds live.mutex.
void JobManager::publish(Live& live, gel::v1::JobUpdate update) {
  update.set_sequence(++live.sequence);
  if (update.kind() == gel::v1::JobUpdate::PROGRESS) {
    live.progress = std::move(update);
  } else {
    live.history.push_back(std::move(update));
  }
  live.changed.notify_all();
}

void JobManager::set_state(const std::shared_ptr<Live>& live, JobState state, const std::string& message) {
  const auto now = now_ms();
  std::string id;
  {
    std::lock_guard lock(live->mutex);
    id = live->job.id();
  }
  store_->set_state(id, state, message, now);
  std::lock_guard lock(live->mutex);
  live->job.set_state(state);
  live->job.set_error(message);
  if (state == gel::v1::JOB_STATE_RUNNING && live->job.started_unix_ms() == 0) live->job.set_started_unix_ms(now);
  if (is_terminal(state)) {
    live->job.set_finished_unix_ms(now);
    live->ended = true;
  }
  gel::v1::JobUpdate update;
  update.set_kind(gel::v1::JobUpdate::STATE);
  *update.mutable_job() = live->job;
  update.set_member(live->job.member());
  publish(*live, std::move(update));
  spdlog::info("job {}: {}{}{}", id, Store::state_name(state), message.empty() ? "" : ": ", message);
}

void JobManager::job_log(const std::string& id, const std::string& level, const std::string& message, int member) {
  spdlog::log(spdlog::level::from_str(level), "job {}: {}", id, message);
  // A log line that cannot be stored (full disk) is still logged and streamed: it must not fail
  // the job it describes.
  try {
    store_->add_log(id, level, message, now_ms());
  } catch (const StoreError& e) {
    spdlog::warn("job {}: log line not stored: {}", id, e.what());
  }
  if (auto live = find_live(id)) {
    std::lock_guard lock(live->mutex);
    gel::v1::JobUpdate update;
    update.set_kind(gel::v1::JobUpdate::LOG);
    update.set_message(message);
    update.set_member(member >= 0 ? member : live->job.member());
    publish(*live, std::move(update));
  }
}

namespace {
// Protocol Buffers strings must be UTF-8: a job whose name or label is not would be stored, and
// then every client that lists it would fail to parse the answer. (gRPC's own parser refuses
// such requests; this guards the callers that build requests in C++.)
bool valid_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto lead = static_cast<unsigned char>(text[i]);
    const std::size_t length = lead < 0x80 ? 1 : (lead >> 5) == 0x6 ? 2 : (lead >> 4) == 0xe ? 3 : (lead >> 3) == 0x1e ? 4 : 0;
    if (length == 0 || i + length > text.size()) return false;
    std::uint32_t code = length == 1 ? lead : lead & (0x7f >> length);
    for (std::size_t k = 1; k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      if ((next >> 6) != 0x2) return false;
      code = (code << 6) | (next & 0x3f);
    }
    // Overlong forms, UTF-16 surrogates and code points past U+10FFFF are not UTF-8.
    static constexpr std::uint32_t kSmallest[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (code < kSmallest[length] || (code >= 0xd800 && code <= 0xdfff) || code > 0x10ffff) return false;
    i += length;
  }
  return true;
}
}  // namespace

std::int64_t parse_page_token(const std::string& token, const std::string& method) {
  if (token.empty()) return 0;
  std::int64_t before = 0;
  try {
    std::size_t pos = 0;
    before = std::stoll(token, &pos);
    if (pos != token.size() || before <= 0) throw std::invalid_argument("");
  } catch (const std::exception&) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "page_token: not a token from a previous " + method);
  }
  return before;
}

// Labels are listed with every job: 20 000 of them made ListJobs answers too large to read.
constexpr int kMaxLabels = 64;

Engine::Prepared JobManager::validated(const gel::v1::SubmitJobRequest& request) {
  // gelsim's rule (gel/seed.hpp): 0 would run as seed 1 while being recorded as 0.
  for (int i = 0; i < request.seeds_size(); ++i)
    if (const std::string problem = gel::seed_problem(request.seeds(i)); !problem.empty())
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "seeds[" + std::to_string(i) + "]: " + problem);
  if (request.seeds_size() > options_.limits.max_seeds) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "seeds: " + std::to_string(request.seeds_size()) + " ensemble members, the limit is " +
                       std::to_string(options_.limits.max_seeds));
  }
  constexpr std::size_t kMaxLabelSize = 256;
  if (request.labels_size() > kMaxLabels) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                   "labels: " + std::to_string(request.labels_size()) + " labels, the limit is " + std::to_string(kMaxLabels));
  }
  for (const auto& [key, value] : request.labels()) {
    if (key.empty() || key.find('=') != std::string::npos) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: key '" + key.substr(0, 64) + "' must be non-empty without '='");
    }
    if (key.size() > kMaxLabelSize || value.size() > kMaxLabelSize) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: key '" + key.substr(0, 64) + "': key and value are limited to " +
                                                             std::to_string(kMaxLabelSize) + " characters each");
    }
  }
  if (request.name().size() > 256) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "name: longer than 256 characters");
  }
  if (!valid_utf8(request.name())) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "name: not valid UTF-8");
  for (const auto& [key, value] : request.labels())
    if (!valid_utf8(key) || !valid_utf8(value)) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: not valid UTF-8");
  if (!valid_utf8(request.scene_json())) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene_json: not valid UTF-8");
  Engine::Prepared prepared = engine_->prepare(request, options_.limits);
  check_job_budgets(prepared.estimate, std::max(1, request.seeds_size()), options_.limits);
  if (request.seeds_size() > 0) {
    // The members' seeds are what ran: each is queryable as generator.seed, the scene's is not.
    std::erase_if(prepared.parameters, [](const auto& parameter) { return std::get<0>(parameter) == "generator.seed"; });
    for (const std::uint64_t seed : request.seeds())
      prepared.parameters.emplace_back("generator.seed", std::to_string(seed), static_cast<double>(seed));
  }
  return prepared;
}

void JobManager::validate(const gel::v1::SubmitJobRequest& request) { validated(request); }

std::string JobManager::program_version() { return engine_->program_version(); }

std::string JobManager::member_dir(const gel::v1::Job& job, int member) const {
  const std::uint64_t seed = member < job.seeds_size() ? job.seeds(member) : job.scene().generator().seed();
  // Built with append: GCC 12's -Wrestrict misfires on "m" + std::to_string(...).
  std::string name("m");
  name.append(std::to_string(member)).append("-seed").append(std::to_string(seed));
  return (fs::absolute(options_.data_dir) / job.out_dir() / name).string();
}

gel::v1::SubmitJobResponse JobManager::submit(const gel::v1::SubmitJobRequest& request, bool adopt_metadata) {
  if (shutting_down_) throw unavailable();
  Engine::Prepared prepared = validated(request);
  // Run cache: the same resolved scene, seeds and program give the same bits (the engine is
  // deterministic), so an identical submission gets the job that already has them.
  // The key leaves out what does not change a bit of the result: the engine threads (runs are
  // bit-identical for any number) and the scene's own seed when a seed list replaces it; a run
  // without a list is the list of its scene's seed.
  const std::string version = engine_->program_version();
  gel::v1::Scene keyed = prepared.scene;
  keyed.mutable_integration()->clear_threads();
  std::string seeds_text;
  if (request.seeds_size() == 0) seeds_text = std::to_string(keyed.generator().seed()) + ",";
  for (const std::uint64_t seed : request.seeds()) seeds_text += std::to_string(seed) + ",";
  keyed.mutable_generator()->clear_seed();
  const std::string cache_key = gel::fnv1a_hex(engine_->scene_json(keyed) + "|" + seeds_text + "|" + version);
  const double no_number = std::numeric_limits<double>::quiet_NaN();
  prepared.parameters.emplace_back(kCacheKeyParameter, cache_key, no_number);
  prepared.parameters.emplace_back(kProgramVersionParameter, version, no_number);
  if (!request.rerun()) {
    if (const auto earlier = store_->find_job_by_parameter(kCacheKeyParameter, cache_key, gel::v1::JOB_STATE_SUCCEEDED)) {
      // Labels and name are metadata: the job takes them, so `list --label` finds it for this
      // submitter too; its first submitter still lists it by theirs, so a changed value is refused.
      if (adopt_metadata) {
        const Store::MetadataMerge merge = store_->merge_labels_and_name(*earlier, request.labels(), request.name(), kMaxLabels);
        if (!merge.conflicts.empty())
          throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                         "labels: key '" + merge.conflicts.front().first + "' is '" + merge.conflicts.front().second + "' on " +
                             *earlier + ", the job that already has these results (run cache); give another key, or rerun");
        if (!merge.written)
          throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: " + *earlier + " (run cache) would have " +
                                                                 std::to_string(merge.labels) + " labels, the limit is " +
                                                                 std::to_string(kMaxLabels));
      }
      gel::v1::SubmitJobResponse response;
      response.set_job_id(*earlier);
      *response.mutable_job() = get(*earlier);
      response.set_cached(true);
      spdlog::info("job {}: returned from the run cache (same scene, seeds and program)", *earlier);
      return response;
    }
  }

  gel::v1::Job job;
  job.set_name(request.name());
  *job.mutable_labels() = request.labels();
  *job.mutable_scene() = prepared.scene;
  if (request.seeds_size() > 0) {
    *job.mutable_seeds() = request.seeds();
  } else {
    job.add_seeds(prepared.scene.generator().seed());
  }
  job.set_particles(prepared.particles);
  job.set_bond_preset(prepared.bond_preset);
  job.set_created_unix_ms(now_ms());
  job.set_program_version(version);

  {
    std::lock_guard lock(mutex_);
    if (shutting_down_) throw unavailable();
    if (queue_.size() + reserved_ >= options_.limits.max_queue) {
      throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                     "queue full: " + std::to_string(queue_.size()) + " jobs queued, the limit is " +
                         std::to_string(options_.limits.max_queue));
    }
    admit_memory(prepared.estimate.memory_bytes, job.seeds_size());
    ++reserved_;
  }
  // Committed before the reply: an acknowledged job is never lost.
  try {
    store_->insert_job(job, prepared.scene_json, prepared.parameters);
  } catch (...) {
    std::lock_guard lock(mutex_);
    --reserved_;
    throw;
  }
  {
    std::lock_guard lock(mutex_);
    --reserved_;
    auto live = std::make_shared<Live>();
    live->job = job;
    live->member_memory = prepared.estimate.memory_bytes;
    live->members = job.seeds_size();
    live_[job.id()] = live;
    queue_.push_back(job.id());
  }
  queue_changed_.notify_one();
  spdlog::info("job {}: queued ({} particles, {} seed(s), name '{}')", job.id(), job.particles(), job.seeds_size(),
               job.name());
  gel::v1::SubmitJobResponse response;
  response.set_job_id(job.id());
  to_message(prepared.estimate, job.seeds_size(), *response.mutable_estimate());
  *response.mutable_job() = std::move(job);
  return response;
}

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

gel::v1::Job JobManager::cancel(const std::string& id) {
  require_id(id);
  auto live = find_live(id);
  if (!live) {
    auto job = store_->get_job(id);
    if (!job) throw ApiError(grpc::StatusCode::NOT_FOUND, "job " + id + " not found");
    if (is_terminal(job->state())) {
      throw ApiError(grpc::StatusCode::FAILED_PRECONDITION,
                     "job " + id + " already ended (" + Store::state_name(job->state()) + ")");
    }
    throw unavailable();
  }
  bool idle = false;  // queued, or between members, with no member running: cancel at once
  std::optional<std::size_t> queue_position;  // where it was queued, to put it back on failure
  {
    std::lock_guard lock(mutex_);
    auto it = std::find(queue_.begin(), queue_.end(), id);
    if (it != queue_.end()) {
      queue_position = static_cast<std::size_t>(it - queue_.begin());
      queue_.erase(it);
    }
    std::lock_guard live_lock(live->mutex);
    idle = !live->ended && live->members_running == 0;
    if (idle) {
      live->cancel_requested = true;
      live->stop = true;
    }
  }
  if (idle) {
    bool ran = false;
    {
      std::lock_guard lock(live->mutex);
      // Started in this geld, or in an earlier one (a job that ran before a restart waits in the
      // queue again until a worker resumes it).
      ran = live->started || live->job.started_unix_ms() > 0;
    }
    try {
      end_job(live, gel::v1::JOB_STATE_CANCELLED, ran ? "cancelled while running" : "cancelled before it ran");
    } catch (...) {
      // The cancel could not be stored (a full or failing disk): undo it, so that the job is
      // as it was (queued at its place) and the caller, told of the failure, can try again.
      // Otherwise the job was neither cancelled in the store nor queued any more, and a
      // restarted geld ran it.
      {
        std::lock_guard live_lock(live->mutex);
        live->ending = false;
        live->cancel_requested = false;
        live->stop = false;
      }
      if (queue_position) {
        std::lock_guard lock(mutex_);
        queue_.insert(queue_.begin() + static_cast<std::ptrdiff_t>(std::min(*queue_position, queue_.size())), id);
      }
      queue_changed_.notify_all();
      throw;
    }
    {
      std::lock_guard lock(mutex_);
      live_.erase(id);
    }
    std::lock_guard lock(live->mutex);
    return live->job;
  }
  std::unique_lock lock(live->mutex);
  if (live->ended) {
    throw ApiError(grpc::StatusCode::FAILED_PRECONDITION,
                   "job " + id + " already ended (" + Store::state_name(live->job.state()) + ")");
  }
  live->cancel_requested = true;
  live->stop = true;
  lock.unlock();
  live->changed.notify_all();
  lock.lock();
  // The run checks its stop flag often; wait a little so the reply usually shows "cancelled".
  live->changed.wait_for(lock, std::chrono::seconds(20), [&] { return live->ended; });
  return live->job;
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
  if (request.page_size() < 0) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "page_size: must be >= 0");
  filter.limit = request.page_size() == 0 ? 50 : std::min(request.page_size(), 1000);
  filter.before_seq = parse_page_token(request.page_token(), "ListJobs");
  ++filter.limit;  // one more, to know whether there is a next page
  auto rows = store_->list_jobs(filter);
  gel::v1::ListJobsResponse response;
  const std::size_t page = static_cast<std::size_t>(filter.limit - 1);
  for (std::size_t i = 0; i < rows.size() && i < page; ++i) {
    gel::v1::Job job = rows[i].second;
    if (auto live = find_live(job.id())) {
      std::lock_guard lock(live->mutex);
      job = live->job;
    }
    *response.add_jobs() = std::move(job);
  }
  if (rows.size() > page) response.set_next_page_token(std::to_string(rows[page - 1].first));
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
    response.set_json(engine_->analysis_json(curves, request.include_unequilibrated()));
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
    out = nlohmann::json::parse(engine_->curve_json(response.members(0).curve()));
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
      auto mj = nlohmann::json::parse(engine_->curve_json(mc.curve()));
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
  if (shutting_down_) throw unavailable();
  WatcherSlot slot(watchers_, options_.limits.max_watchers);
  if (!slot.taken()) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "too many watchers: the limit is " + std::to_string(options_.limits.max_watchers));
  }
  auto live = find_live(id);
  gel::v1::JobUpdate snapshot;
  snapshot.set_kind(gel::v1::JobUpdate::SNAPSHOT);
  if (!live) {
    // Not queued or running: its state is final; one snapshot and the stream ends.
    auto job = store_->get_job(id);
    if (!job) throw ApiError(grpc::StatusCode::NOT_FOUND, "job " + id + " not found");
    snapshot.set_member(job->member());
    *snapshot.mutable_job() = std::move(*job);
    if (!write(snapshot)) return;
    for (const auto& update : stored_rows(id, 0)) {
      if (!write(update)) return;
    }
    return;
  }
  std::int64_t seen = 0;
  std::vector<gel::v1::JobUpdate> rows_so_far;
  {
    std::lock_guard lock(live->mutex);
    *snapshot.mutable_job() = live->job;
    snapshot.set_member(live->job.member());
    seen = live->sequence;
    snapshot.set_sequence(seen);
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
    if (shutting_down_) throw unavailable();
  }
}

std::vector<gel::v1::JobUpdate> JobManager::stored_rows(const std::string& id, std::int64_t sequence) {
  std::vector<gel::v1::JobUpdate> out;
  for (auto& r : store_->rows(id)) {
    gel::v1::JobUpdate update;
    update.set_kind(gel::v1::JobUpdate::ROW);
    update.set_member(r.member);
    update.set_seed(r.seed);
    update.set_sequence(sequence);
    *update.mutable_row() = std::move(r.row);
    out.push_back(std::move(update));
  }
  return out;
}

// Work items are (job, member): a worker takes the job at the head of the queue, claims its next
// unfinished member and, when members remain unclaimed, puts the job back at the head, so idle
// workers run the members of one job in parallel before the next job starts.
void JobManager::worker_loop() {
  for (;;) {
    std::shared_ptr<Live> live;
    int member = -1;
    {
      std::unique_lock lock(mutex_);
      queue_changed_.wait(lock, [&] { return shutting_down_ || !queue_.empty(); });
      if (shutting_down_) return;
      const std::string id = queue_.front();
      queue_.pop_front();
      auto it = live_.find(id);
      if (it == live_.end()) continue;
      live = it->second;
      std::lock_guard live_lock(live->mutex);
      const int members = std::max(1, live->job.seeds_size());
      if (live->member_finished.empty()) {
        // Recovered or new: members finished in an earlier life of geld are not run again.
        live->member_finished.assign(static_cast<std::size_t>(members), 0);
        for (const int done : store_->finished_members(id))
          if (done >= 0 && done < members) live->member_finished[static_cast<std::size_t>(done)] = 1;
        // Stores written before members ran in parallel only know the member being run.
        for (int m = 0; m < std::min(live->job.member(), members); ++m) live->member_finished[static_cast<std::size_t>(m)] = 1;
      }
      while (live->next_member < members && live->member_finished[static_cast<std::size_t>(live->next_member)]) ++live->next_member;
      if (live->next_member < members) {
        member = live->next_member++;
        ++live->members_running;
      }
      while (live->next_member < members && live->member_finished[static_cast<std::size_t>(live->next_member)]) ++live->next_member;
      if (live->next_member < members && !live->stop) {
        queue_.push_front(id);
        queue_changed_.notify_one();
      }
    }
    try {
      if (member >= 0) {
        run_member(live, member);
      } else {
        // Every member had finished before (a job recovered after its last member ended).
        finish_if_done(live);
      }
    } catch (const std::exception& e) {
      // Storing the job's end failed (run_member handles everything before it). The daemon
      // keeps serving; the job keeps its stored state, so a restart or a retry finishes it.
      std::string id_for_log;
      {
        std::lock_guard lock(live->mutex);
        live->ending = false;
        id_for_log = live->job.id();
      }
      spdlog::error("job {}: {}", id_for_log, e.what());
      const auto* store_error = dynamic_cast<const StoreError*>(&e);
      if (store_error && store_error->full()) wait_for_space(live, -1, e.what());
    }
    bool forget = false;
    std::string id;
    {
      std::lock_guard lock(live->mutex);
      forget = live->ended && live->members_running == 0;
      id = live->job.id();
    }
    if (forget) {
      std::lock_guard lock(mutex_);
      live_.erase(id);
    }
  }
}

// A full disk is not the job's fault: the member (or, with member < 0, the job's end) is
// retried from its checkpoint every disk_full_retry_seconds until the write succeeds. The job
// stays running, its message says why it waits, watchers get a LOG line, and this worker waits
// (a full disk stalls every job alike) unless geld shuts down or the job is cancelled.
void JobManager::wait_for_space(const std::shared_ptr<Live>& live, int member, const std::string& error) {
  std::string id;
  const std::string message =
      fmt::format("waiting for disk space ({}); retrying every {:g} s", error, options_.disk_full_retry_seconds);
  {
    std::lock_guard lock(live->mutex);
    id = live->job.id();
    if (member >= 0) live->next_member = std::min(live->next_member, member);
    live->job.set_error(message);
    gel::v1::JobUpdate update;
    update.set_kind(gel::v1::JobUpdate::LOG);
    update.set_message(message);
    update.set_member(std::max(member, 0));
    publish(*live, std::move(update));
  }
  spdlog::warn("job {}: {}", id, message);
  {
    std::unique_lock lock(mutex_);
    queue_changed_.wait_for(lock, std::chrono::duration<double>(options_.disk_full_retry_seconds),
                            [&] { return shutting_down_ || live->stop.load(); });
    if (shutting_down_) return;  // the job stays running in the store and resumes on restart
    queue_.push_back(id);
  }
  {
    std::lock_guard lock(live->mutex);
    live->job.set_error("");
  }
  queue_changed_.notify_one();
}

// Sets a terminal state once, whichever member thread gets there first.
void JobManager::end_job(const std::shared_ptr<Live>& live, JobState state, const std::string& message) {
  {
    std::lock_guard lock(live->mutex);
    if (live->ending) return;
    live->ending = true;
  }
  set_state(live, state, message);
}

void JobManager::finish_if_done(const std::shared_ptr<Live>& live) {
  bool all_done = false;
  {
    std::lock_guard lock(live->mutex);
    all_done = std::all_of(live->member_finished.begin(), live->member_finished.end(), [](char done) { return done != 0; });
  }
  if (all_done) end_job(live, gel::v1::JOB_STATE_SUCCEEDED, "");
}

void JobManager::run_member(const std::shared_ptr<Live>& live, int member) {
  gel::v1::Job job;
  bool first_to_start = false;
  {
    std::lock_guard lock(live->mutex);
    job = live->job;
    first_to_start = !live->started;
    live->started = true;
  }
  const std::string id = job.id();
  enum class Outcome { kFinished, kStopped, kFailed, kNoSpace } outcome = Outcome::kStopped;
  std::string error;
  if (!live->stop) {
    if (first_to_start) {
      const bool resumed = job.state() == gel::v1::JOB_STATE_RUNNING;
      if (job.state() != gel::v1::JOB_STATE_RUNNING) set_state(live, gel::v1::JOB_STATE_RUNNING, "");
      if (resumed) job_log(id, "info", "resuming after a restart");
    }
    try {
      const std::uint64_t seed = job.seeds(member);
      RunContext ctx;
      ctx.job_id = id;
      ctx.member = member;
      ctx.seed = seed;
      ctx.scene = job.scene();
      ctx.scene.mutable_generator()->set_seed(seed);
      ctx.scene_json = engine_->scene_json(ctx.scene);
      ctx.out_dir = member_dir(job, member);
      fs::create_directories(ctx.out_dir);
      ctx.stop = &live->stop;
      ctx.cancel = &live->cancel_requested;
      ctx.handle = store_->member_handle(id, member);
      ctx.save_handle = [this, id, member, seed](const std::string& handle) {
        store_->set_member_handle(id, member, seed, executor_->name(), handle, now_ms());
      };
      ctx.on_progress = [this, live, member, seed](const gel::v1::Progress& progress) {
        std::lock_guard lock(live->mutex);
        *live->job.mutable_progress() = progress;
        gel::v1::JobUpdate update;
        update.set_kind(gel::v1::JobUpdate::PROGRESS);
        *update.mutable_progress() = progress;
        update.set_member(member);
        update.set_seed(seed);
        publish(*live, std::move(update));
      };
      ctx.on_row = [this, live, id, member, seed](const gel::v1::CurveRow& row) {
        // Stored and published under the job's lock, so that a watcher's snapshot (taken under
        // the same lock) holds each row exactly once: from the store or from the stream.
        std::lock_guard lock(live->mutex);
        store_->put_row(id, member, seed, row, now_ms());
        live->job.set_rows(store_->row_count(id));
        gel::v1::JobUpdate update;
        update.set_kind(gel::v1::JobUpdate::ROW);
        *update.mutable_row() = row;
        update.set_member(member);
        update.set_seed(seed);
        publish(*live, std::move(update));
      };
      ctx.log = [this, id, member](const std::string& level, const std::string& message) { job_log(id, level, message, member); };
      job_log(id, "info",
              "member " + std::to_string(member) + " (seed " + std::to_string(seed) + ") starts in " + ctx.out_dir +
                  (ctx.handle.empty() ? "" : " (handle " + ctx.handle + ")"),
              member);
      RunResult result = executor_->run(ctx);
      if (result.finished) {
        std::vector<gel::v1::CurveRow> rows(result.curve.rows().begin(), result.curve.rows().end());
        store_->replace_rows(id, member, seed, rows, now_ms());
        store_->set_member_finished(id, member, now_ms());
        job_log(id, "info", "member " + std::to_string(member) + " finished with " + std::to_string(rows.size()) + " rows", member);
        outcome = Outcome::kFinished;
      }
    } catch (const StoreError& e) {
      outcome = e.full() ? Outcome::kNoSpace : Outcome::kFailed;
      error = e.what();
    } catch (const gel::NoSpaceError& e) {
      outcome = Outcome::kNoSpace;
      error = e.what();
    } catch (const gel::StabilityError& e) {
      outcome = Outcome::kFailed;
      error = std::string(gel::kInstabilityPrefix) + e.what();
    } catch (const std::exception& e) {
      outcome = Outcome::kFailed;
      error = e.what();
    }
  }

  bool last_running = false;
  {
    std::lock_guard lock(live->mutex);
    --live->members_running;
    last_running = live->members_running == 0;
    if (outcome == Outcome::kFinished) {
      live->member_finished[static_cast<std::size_t>(member)] = 1;
      live->job.set_rows(store_->row_count(id));
      // The lowest unfinished member: where a geld without member_finished would resume.
      int lowest = 0;
      while (lowest < static_cast<int>(live->member_finished.size()) && live->member_finished[static_cast<std::size_t>(lowest)]) ++lowest;
      live->job.set_member(lowest);
    }
  }
  if (outcome == Outcome::kFinished) {
    {
      std::lock_guard lock(live->mutex);
      store_->set_member(id, live->job.member());
    }
    finish_if_done(live);
    return;
  }
  if (outcome == Outcome::kNoSpace && !live->cancel_requested) {
    wait_for_space(live, member, error);
    return;
  }
  if (outcome == Outcome::kFailed || outcome == Outcome::kNoSpace) {
    if (live->cancel_requested) {
      if (last_running) end_job(live, gel::v1::JOB_STATE_CANCELLED, "cancelled while running");
      return;
    }
    try {
      job_log(id, "error", "member " + std::to_string(member) + ": " + error, member);
    } catch (...) {
    }
    // One member failing fails the job: the others stop (they stay resumable on disk).
    live->stop = true;
    end_job(live, gel::v1::JOB_STATE_FAILED, error);
    return;
  }
  // Stopped (or never started because the job was stopping).
  if (!last_running) return;
  if (live->cancel_requested) {
    bool ran = false;
    {
      std::lock_guard lock(live->mutex);
      ran = live->job.state() == gel::v1::JOB_STATE_RUNNING;
    }
    end_job(live, gel::v1::JOB_STATE_CANCELLED, ran ? "cancelled while running" : "cancelled before it ran");
  } else if (shutting_down_) {
    job_log(id, "info", "checkpointed for shutdown; resumes on restart");
  } else {
    bool ended = false;
    {
      std::lock_guard lock(live->mutex);
      ended = live->ending;
    }
    if (!ended) end_job(live, gel::v1::JOB_STATE_FAILED, "the run stopped before the last target");
  }
}

}  // namespace geld
