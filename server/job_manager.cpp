// JobManager's life (start, shutdown) and the per-job state that watchers follow: states, log
// lines and the updates they publish. The rest of the class, by concept, is in
// job_submission.cpp, job_scheduling.cpp and job_queries.cpp.
#include "job_manager.hpp"

#include <algorithm>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "gel/resources.hpp"
#include "job_updates.hpp"

namespace geld {

namespace fs = std::filesystem;
using gel::v1::JobState;

JobManager::JobManager(ManagerOptions options, std::shared_ptr<GelcoreAdapter> adapter, std::shared_ptr<Executor> executor)
    : options_(std::move(options)), adapter_(std::move(adapter)), executor_(std::move(executor)) {
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
  publish(*live, job_update::state(live->job));
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
    publish(*live, job_update::log(message, member >= 0 ? member : live->job.member()));
  }
}

std::string JobManager::member_dir(const gel::v1::Job& job, int member) const {
  const std::uint64_t seed = member < job.seeds_size() ? job.seeds(member) : job.scene().generator().seed();
  // Built with append: GCC 12's -Wrestrict misfires on "m" + std::to_string(...).
  std::string name("m");
  name.append(std::to_string(member)).append("-seed").append(std::to_string(seed));
  return (fs::absolute(options_.data_dir) / job.out_dir() / name).string();
}

}  // namespace geld
