// JobManager's workers: claiming members from the queue, running one member in steps, the
// job's end, a full disk's wait, and cancel.
#include <algorithm>
#include <filesystem>
#include <optional>

#include <spdlog/spdlog.h>

#include "gel/errors.hpp"
#include "job_manager.hpp"
#include "job_updates.hpp"

namespace geld {

namespace fs = std::filesystem;
using gel::v1::JobState;

// Work items are (job, member): a worker takes the job at the head of the queue, claims its next
// unfinished member and, when members remain unclaimed, puts the job back at the head, so idle
// workers run the members of one job in parallel before the next job starts.
std::shared_ptr<JobManager::Live> JobManager::claim_member(int& member) {
  member = -1;
  std::unique_lock lock(mutex_);
  for (;;) {
    queue_changed_.wait(lock, [&] { return shutting_down_ || !queue_.empty(); });
    if (shutting_down_) return nullptr;
    const std::string id = queue_.front();
    queue_.pop_front();
    auto it = live_.find(id);
    if (it == live_.end()) continue;
    std::shared_ptr<Live> live = it->second;
    std::lock_guard live_lock(live->mutex);
    const int members = std::max(1, live->job.seeds_size());
    if (live->member_finished.empty()) {
      // Recovered or new: members finished in an earlier life of geld are not run again.
      live->member_finished.assign(static_cast<std::size_t>(members), 0);
      for (const int done : store_->finished_members(id))
        if (done >= 0 && done < members) live->member_finished[static_cast<std::size_t>(done)] = 1;
    }
    const auto skip_finished = [&] {
      while (live->next_member < members && live->member_finished[static_cast<std::size_t>(live->next_member)])
        ++live->next_member;
    };
    skip_finished();
    if (live->next_member < members) {
      member = live->next_member++;
      ++live->members_running;
    }
    skip_finished();
    if (live->next_member < members && !live->stop) {
      queue_.push_front(id);
      queue_changed_.notify_one();
    }
    return live;
  }
}

void JobManager::worker_loop() {
  for (;;) {
    int member = -1;
    const std::shared_ptr<Live> live = claim_member(member);
    if (!live) return;
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
    publish(*live, job_update::log(message, std::max(member, 0)));
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

// One member, in steps: the job turns RUNNING with its first member, the executor runs the
// member with callbacks that store and publish its rows and progress, its outcome is recorded,
// and the job ends when this member decides it (the last one finished, one failed, cancel).
void JobManager::run_member(const std::shared_ptr<Live>& live, int member) {
  const bool stopping = live->stop;  // then the member is not run: it ends as stopped
  const gel::v1::Job job = begin_member(live, stopping);
  const MemberOutcome outcome = stopping ? MemberOutcome{} : execute_member(live, job, member);
  const bool last_running = record_outcome(live, member, outcome);
  settle_member(live, member, outcome, last_running);
}

gel::v1::Job JobManager::begin_member(const std::shared_ptr<Live>& live, bool stopping) {
  gel::v1::Job job;
  bool first_to_start = false;
  {
    std::lock_guard lock(live->mutex);
    job = live->job;
    first_to_start = !live->started;
    live->started = true;
  }
  if (first_to_start && !stopping) {
    if (job.state() == gel::v1::JOB_STATE_RUNNING) {
      job_log(job.id(), "info", "resuming after a restart");
    } else {
      set_state(live, gel::v1::JOB_STATE_RUNNING, "");
    }
  }
  return job;
}

RunContext JobManager::member_context(const std::shared_ptr<Live>& live, const gel::v1::Job& job, int member) {
  const std::string id = job.id();
  const std::uint64_t seed = job.seeds(member);
  RunContext ctx;
  ctx.job_id = id;
  ctx.member = member;
  ctx.seed = seed;
  ctx.scene = job.scene();
  ctx.scene.mutable_generator()->set_seed(seed);
  ctx.scene_json = adapter_->scene_json(ctx.scene);
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
    publish(*live, job_update::progress(progress, member, seed));
  };
  ctx.on_row = [this, live, id, member, seed](const gel::v1::CurveRow& row) {
    // Stored and published under the job's lock, so that a watcher's snapshot (taken under
    // the same lock) holds each row exactly once: from the store or from the stream.
    std::lock_guard lock(live->mutex);
    store_->put_row(id, member, seed, row, now_ms());
    live->job.set_rows(store_->row_count(id));
    publish(*live, job_update::row(row, member, seed));
  };
  ctx.log = [this, id, member](const std::string& level, const std::string& message) { job_log(id, level, message, member); };
  return ctx;
}

// Runs the member on the executor and stores a finished curve; every failure becomes the
// outcome (a full disk is not the job's fault: it waits, see wait_for_space).
JobManager::MemberOutcome JobManager::execute_member(const std::shared_ptr<Live>& live, const gel::v1::Job& job,
                                                     int member) {
  const std::string& id = job.id();
  try {
    const RunContext ctx = member_context(live, job, member);
    job_log(id, "info",
            "member " + std::to_string(member) + " (seed " + std::to_string(ctx.seed) + ") starts in " + ctx.out_dir +
                (ctx.handle.empty() ? "" : " (handle " + ctx.handle + ")"),
            member);
    RunResult result = executor_->run(ctx);
    if (!result.finished) return {MemberOutcome::kStopped, ""};
    std::vector<gel::v1::CurveRow> rows(result.curve.rows().begin(), result.curve.rows().end());
    store_->replace_rows(id, member, ctx.seed, rows, now_ms());
    store_->set_member_finished(id, member, now_ms());
    job_log(id, "info", "member " + std::to_string(member) + " finished with " + std::to_string(rows.size()) + " rows", member);
    return {MemberOutcome::kFinished, ""};
  } catch (const StoreError& e) {
    return {e.full() ? MemberOutcome::kNoSpace : MemberOutcome::kFailed, e.what()};
  } catch (const gel::NoSpaceError& e) {
    return {MemberOutcome::kNoSpace, e.what()};
  } catch (const gel::StabilityError& e) {
    return {MemberOutcome::kFailed, std::string(gel::kInstabilityPrefix) + e.what()};
  } catch (const std::exception& e) {
    return {MemberOutcome::kFailed, e.what()};
  }
}

// Returns whether this was the last member running.
bool JobManager::record_outcome(const std::shared_ptr<Live>& live, int member, const MemberOutcome& outcome) {
  bool last_running = false;
  {
    std::lock_guard lock(live->mutex);
    --live->members_running;
    last_running = live->members_running == 0;
    if (outcome.kind != MemberOutcome::kFinished) return last_running;
    live->member_finished[static_cast<std::size_t>(member)] = 1;
    live->job.set_rows(store_->row_count(live->job.id()));
    // The lowest unfinished member, as the store reads it back from member_finished.
    int lowest = 0;
    while (lowest < static_cast<int>(live->member_finished.size()) && live->member_finished[static_cast<std::size_t>(lowest)]) ++lowest;
    live->job.set_member(lowest);
  }
  return last_running;
}

void JobManager::settle_member(const std::shared_ptr<Live>& live, int member, const MemberOutcome& outcome,
                               bool last_running) {
  std::string id;
  {
    std::lock_guard lock(live->mutex);
    id = live->job.id();
  }
  if (outcome.kind == MemberOutcome::kFinished) {
    finish_if_done(live);
    return;
  }
  if (outcome.kind == MemberOutcome::kNoSpace && !live->cancel_requested) {
    wait_for_space(live, member, outcome.error);
    return;
  }
  if (outcome.kind == MemberOutcome::kFailed || outcome.kind == MemberOutcome::kNoSpace) {
    if (live->cancel_requested) {
      if (last_running) end_job(live, gel::v1::JOB_STATE_CANCELLED, "cancelled while running");
      return;
    }
    try {
      job_log(id, "error", "member " + std::to_string(member) + ": " + outcome.error, member);
    } catch (...) {
    }
    // One member failing fails the job: the others stop (they stay resumable on disk).
    live->stop = true;
    end_job(live, gel::v1::JOB_STATE_FAILED, outcome.error);
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
    throw shutting_down_error();
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

}  // namespace geld
