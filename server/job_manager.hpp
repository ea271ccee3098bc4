#pragma once
// The daemon's core without any network: a bounded job queue, a pool of worker threads, the
// SQLite store and the per-job update channels that watchers follow. The gRPC service is a
// thin layer over this class, and tests drive it directly.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <grpcpp/support/status.h>

#include "executor.hpp"
#include "gel/resources.hpp"
#include "gel/v1/service.pb.h"
#include "store.hpp"
#include "store_lock.hpp"

namespace geld {

// An error with the gRPC status code the client gets.
class ApiError : public std::runtime_error {
 public:
  ApiError(grpc::StatusCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

struct Limits {
  std::size_t max_queue = 1000;            // queued jobs
  std::int64_t max_particles = 2'000'000;  // per ensemble member
  int max_seeds = 1000;                    // ensemble members per job
  int max_watchers = 256;                  // concurrent WatchJob streams, all jobs
  int threads_per_member = 1;              // engine threads of a member whose scene leaves integration.threads 0
  // Budgets on the resources a job's scene says it will need (gel/resources.hpp), checked at
  // submission (docs/api.md "Budgets and bounds"):
  std::int64_t max_member_memory = 4ll << 30;      // one member's state [bytes]
  std::int64_t max_job_disk = 64ll << 30;          // all members' files [bytes]
  double max_job_particle_steps = 1e14;            // all members: about 280 core-hours at 1e8/s
  // What the members running at once may hold together, with geld itself [bytes]: a job is
  // admitted only if the `workers` largest members of the admitted jobs fit. 0: half the
  // machine's memory. Only where members run inside geld (the threads executor).
  std::int64_t max_memory = 0;
};

// The scene side of jobs: validation, resolution and the curve's JSON shape. The compression
// engine in geld (server/compression_engine.cpp); tests may inject their own.
class Engine {
 public:
  virtual ~Engine() = default;
  struct Prepared {
    gel::v1::Scene scene;  // resolved
    std::int64_t particles = 0;
    std::string bond_preset;
    // The resolved scene flattened: (dotted name, text value, numeric value or NaN).
    std::vector<std::tuple<std::string, std::string, double>> parameters;
    std::string scene_json;
    gel::ResourceEstimate estimate;  // one member's
  };
  // Validates and resolves a submission; throws ApiError (INVALID_ARGUMENT naming the field,
  // RESOURCE_EXHAUSTED over the limits).
  virtual Prepared prepare(const gel::v1::SubmitJobRequest& request, const Limits& limits) = 0;
  // The scene with another seed, as JSON (for executors that hand it to a process).
  virtual std::string scene_json(const gel::v1::Scene& scene) = 0;
  // The curve as one JSON object with a "rows" list.
  virtual std::string curve_json(const gel::v1::Curve& curve) = 0;
  virtual std::string program_version() = 0;
  // The curve analysis of one run or an ensemble (gelsim analyze-run's, as JSON text); throws
  // gel::InvalidArgument when the curves cannot be analysed.
  virtual std::string analysis_json(const std::vector<gel::v1::Curve>& curves, bool include_unequilibrated) = 0;
};

// The compression engine (gelcore).
std::shared_ptr<Engine> make_compression_engine();

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
  JobManager(ManagerOptions options, std::shared_ptr<Engine> engine, std::shared_ptr<Executor> executor);
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
  // Every check submit() makes (fields, limits, the engine's validation of the scene), without
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

  Engine::Prepared validated(const gel::v1::SubmitJobRequest& request);
  void worker_loop();
  void run_member(const std::shared_ptr<Live>& live, int member);
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
  std::shared_ptr<Engine> engine_;
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

std::int64_t now_ms();

// A list call's page token (the seq of the last item of the previous page): 0 for none; an
// ApiError INVALID_ARGUMENT naming `method` for anything else that is not a positive number.
std::int64_t parse_page_token(const std::string& token, const std::string& method);

// Job and study ids are short: a longer one is refused as such (INVALID_ARGUMENT naming
// `field`), never looked up or echoed whole in an error.
void require_id_size(const std::string& field, const std::string& id);

}  // namespace geld
