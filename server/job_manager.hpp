#pragma once
// The daemon's core without any network: a bounded job queue, a pool of worker threads, the
// SQLite store and the per-job update channels that watchers follow. The gRPC service is a
// thin layer over this class, and tests drive it directly. Its code, by concept:
//   job_manager.cpp     life (start, shutdown) and the per-job state and updates watchers follow
//   job_submission.cpp  submit and validate: checks, budgets, the run cache, admission
//   job_scheduling.cpp  the workers: claiming members, running one in steps, ends, cancel
//   job_queries.cpp     get, list, curves, analysis, QueryCurves, logs and watch
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "executor.hpp"
#include "gel/v1/service.pb.h"
#include "gelcore_adapter.hpp"
#include "limits.hpp"
#include "requests.hpp"
#include "store.hpp"
#include "store_lock.hpp"

namespace geld {

struct ManagerOptions {
  std::string data_dir = "data";  // geld.sqlite and jobs/<id>/ live here
  std::string db_path;            // "": data_dir/geld.sqlite
  int workers = 0;                // 0: number of cores
  Limits limits;
  // A full disk (the store or a job's files) pauses the member that hit it; it is retried from
  // its checkpoint after this many seconds, until space is back.
  double disk_full_retry_seconds = 10;
};

class JobManager {
 public:
  JobManager(ManagerOptions options, std::shared_ptr<GelcoreAdapter> adapter, std::shared_ptr<Executor> executor);
  ~JobManager();  // shuts down (checkpointing running jobs) if still running

  // Recovers the store's queued and running jobs and starts the workers.
  void start();
  // Stops taking work (calls get UNAVAILABLE), asks running jobs to checkpoint and stop, waits
  // for the workers. Running jobs stay "running" in the store and resume on the next start.
  void shutdown();
  bool shutting_down() const { return shutting_down_.load(); }

  // A run-cache hit adds the request's labels to the earlier job and names it if it has no name
  // (a key it has with another value is refused); a study's (adopt_metadata false) leaves the
  // job as it is: the study records the job it got.
  gel::v1::SubmitJobResponse submit(const gel::v1::SubmitJobRequest& request, bool adopt_metadata = true);
  // Every check submit() makes (fields, limits, gelcore's validation of the scene), without
  // storing anything: throws the ApiError submit() would.
  void validate(const gel::v1::SubmitJobRequest& request);
  std::string program_version();
  // The directory of a member's files (checkpoint, curve, snapshots) on this machine.
  std::string member_dir(const gel::v1::Job& job, int member) const;
  gel::v1::Job get(const std::string& id);
  gel::v1::Job cancel(const std::string& id);
  gel::v1::ListJobsResponse list(const gel::v1::ListJobsRequest& request);
  gel::v1::GetCurveResponse curve(const std::string& id);
  // One curve per member of `job` (index = member), from one read of its stored rows.
  std::vector<gel::v1::Curve> member_curves(const gel::v1::Job& job);
  gel::v1::GetAnalysisResponse analysis(const gel::v1::GetAnalysisRequest& request);
  gel::v1::QueryCurvesResponse query(const gel::v1::QueryCurvesRequest& request);
  gel::v1::GetLogsResponse logs(const gel::v1::GetLogsRequest& request);

  // Streams a job's updates to `write` (returns false when the receiver is gone) until the job
  // ends, `cancelled()` turns true, or the daemon shuts down (then throws UNAVAILABLE).
  void watch(const std::string& id, const std::function<bool(const gel::v1::JobUpdate&)>& write,
             const std::function<bool()>& cancelled);

  Store& store() { return *store_; }
  const ManagerOptions& options() const { return options_; }
  int active_watchers() const { return watchers_.load(); }

 private:
  // The in-memory side of a queued or running job: its current Job message, its stop flag
  // and its update history (states, rows and log lines in full; progress as the latest one).
  struct Live {
    std::mutex mutex;
    std::condition_variable changed;
    gel::v1::Job job;
    std::int64_t sequence = 0;
    std::vector<gel::v1::JobUpdate> history;
    gel::v1::JobUpdate progress;  // latest; sequence 0: none yet
    bool ended = false;
    bool ending = false;                // a terminal state is being set (by one member thread)
    // Members (guarded by mutex): claimed in index order by the workers, run in parallel.
    std::vector<char> member_finished;  // per member; empty until a worker first takes the job
    int next_member = 0;                // first member not yet claimed
    int members_running = 0;            // claimed and not yet returned
    bool started = false;               // a member has been handed to an executor
    std::atomic<bool> cancel_requested{false};
    std::atomic<bool> stop{false};
    // Admission (Limits::max_memory): one member's estimated memory and the member count.
    std::int64_t member_memory = 0;
    int members = 0;
  };

  GelcoreAdapter::Prepared validated(const gel::v1::SubmitJobRequest& request);
  void worker_loop();
  // The job at the queue's head and its next unclaimed member (-1: none left to claim); null
  // when the workers are to stop.
  std::shared_ptr<Live> claim_member(int& member);

  // One member's run, in steps (run_member calls them in this order).
  struct MemberOutcome {
    enum Kind { kFinished, kStopped, kFailed, kNoSpace } kind = kStopped;
    std::string error;
  };
  void run_member(const std::shared_ptr<Live>& live, int member);
  // The job as the member starts; the job turns RUNNING with its first member unless stopping.
  gel::v1::Job begin_member(const std::shared_ptr<Live>& live, bool stopping);
  RunContext member_context(const std::shared_ptr<Live>& live, const gel::v1::Job& job, int member);
  MemberOutcome execute_member(const std::shared_ptr<Live>& live, const gel::v1::Job& job, int member);
  bool record_outcome(const std::shared_ptr<Live>& live, int member, const MemberOutcome& outcome);  // last running?
  void settle_member(const std::shared_ptr<Live>& live, int member, const MemberOutcome& outcome, bool last_running);

  void finish_if_done(const std::shared_ptr<Live>& live);
  void end_job(const std::shared_ptr<Live>& live, gel::v1::JobState state, const std::string& message);
  void publish(Live& live, gel::v1::JobUpdate update);
  void set_state(const std::shared_ptr<Live>& live, gel::v1::JobState state, const std::string& message);
  // member: the member the line is about (its LOG update says so); -1: the job as a whole.
  void job_log(const std::string& id, const std::string& level, const std::string& message, int member = -1);
  void wait_for_space(const std::shared_ptr<Live>& live, int member, const std::string& error);
  std::shared_ptr<Live> find_live(const std::string& id);
  gel::v1::Curve member_curve(const gel::v1::Job& job, const std::vector<StoredRow>& rows, int member);
  std::vector<gel::v1::JobUpdate> stored_rows(const std::string& id, std::int64_t sequence);
  static std::string require_id(const std::string& id);

  void release_data_dir();
  // Throws RESOURCE_EXHAUSTED when a job whose members each hold `member_memory` would let
  // the members that may run at once exceed Limits::max_memory. Called with mutex_ held.
  void admit_memory(std::int64_t member_memory, int members) const;
  std::int64_t memory_budget() const;

  ManagerOptions options_;
  OwnerLock data_dir_lock_;  // data_dir/geld.lock, held while this manager may run jobs
  OwnerLock store_lock_;     // the store file, the same; declared before store_ to outlive it
  std::shared_ptr<GelcoreAdapter> adapter_;
  std::shared_ptr<Executor> executor_;
  std::unique_ptr<Store> store_;

  std::mutex mutex_;  // queue_ and live_
  std::condition_variable queue_changed_;
  std::deque<std::string> queue_;
  std::size_t reserved_ = 0;  // submissions between the queue-length check and the insert
  std::map<std::string, std::shared_ptr<Live>> live_;
  std::vector<std::thread> workers_;
  std::atomic<bool> shutting_down_{false};
  std::atomic<int> watchers_{0};
  bool started_ = false;
  bool stopped_ = false;
};

}  // namespace geld
