#pragma once
// Executors: what runs one ensemble member of a job. The JobManager owns the queue, the store,
// the watchers and the job states; for every member of a job it builds a RunContext and calls
// Executor::run on one of its worker threads, which blocks until the member ended, stopped or
// failed. Implementations:
//   "threads"  in-process: gel::run_compression / gel::resume_compression on the worker thread
//              (server/thread_executor.cpp);
//   "slurm"    one sbatch job per member running `gelsim compress ... --progress-file F`
//              and following that file; registered in make_executor().
// Selected with `geld --executor NAME`; the worker count (`--workers`) is the number of members
// followed at once.
//
// Contract of run():
//   * Calls ctx.on_row for every equilibrium row as it is reached (in k order; a resumed member
//     may repeat rows it had already reported: the store keeps one per (member, k)), and
//     ctx.on_progress now and then (both from any thread, never concurrently for one member).
//   * Returns {finished = true, curve = the whole curve} when all targets are done.
//   * Returns {stopped = true} soon after *ctx.stop turns true. *ctx.cancel is set (before stop)
//     when the user cancelled the job: discard the work (scancel). Otherwise (daemon shutdown)
//     leave the member resumable: checkpoint in ctx.out_dir (threads), or leave the Slurm job
//     running and remember its handle (slurm); the next geld calls run() again with the same
//     out_dir and the handle saved before.
//   * Throws std::exception on failure; the message becomes the job's error (state FAILED).
//   * ctx.handle is what this executor saved with ctx.save_handle during an earlier run() of the
//     same member (e.g. a Slurm job id), or "" the first time. save_handle commits to SQLite
//     before it returns; handles are per (job, member) and need not be unique over time.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "gel/v1/scene.pb.h"

namespace geld {

struct RunContext {
  std::string job_id;
  int member = 0;           // 0-based index into the job's seeds
  std::uint64_t seed = 0;
  gel::v1::Scene scene;     // resolved, generator.seed = seed
  std::string scene_json;   // the same scene in Protocol Buffers' JSON mapping
  std::string out_dir;      // absolute, this member's own: checkpoint, curve.json, progress file
  const std::atomic<bool>* stop = nullptr;    // shutdown or cancel: return soon
  const std::atomic<bool>* cancel = nullptr;  // the user cancelled (set before stop)
  std::string handle;                         // saved by an earlier run of this member, or ""
  std::function<void(const std::string& handle)> save_handle;
  std::function<void(const gel::v1::Progress&)> on_progress;
  std::function<void(const gel::v1::CurveRow&)> on_row;
  std::function<void(const std::string& level, const std::string& message)> log;  // job log

  // A line of the job's log about this member: "member N: message" (a job's members share its
  // log). Nothing without a log.
  void log_member(const std::string& level, const std::string& message) const {
    if (log) log(level, "member " + std::to_string(member) + ": " + message);
  }
};

struct RunResult {
  bool finished = false;  // all targets done; `curve` is the whole curve
  bool stopped = false;   // stopped on request; resumable
  gel::v1::Curve curve;
};

class Executor {
 public:
  virtual ~Executor() = default;
  virtual std::string name() const = 0;
  virtual RunResult run(const RunContext& ctx) = 0;
  // Whether members run inside geld's process (and count against its memory budget,
  // Limits::max_memory) rather than on other machines.
  virtual bool runs_in_process() const { return true; }
};

// What `geld --executor NAME` and the config file give an executor. geld's flags (and config
// keys) "--NAME-KEY" land in `settings` as KEY (e.g. `--slurm-shared-dir /shared/gel` gives
// settings["shared-dir"] = "/shared/gel"); only flags given (or set in the file) appear.
struct ExecutorConfig {
  std::string name = "threads";
  std::string data_dir;      // absolute; members' out_dirs are below it
  std::string gelsim_path;   // the gelsim binary (for executors that run it as a process)
  std::map<std::string, std::string> settings;
};

// The in-process executor (gel::run_compression on the calling worker thread).
std::unique_ptr<Executor> make_thread_executor();

// By name; throws std::invalid_argument for an unknown or unavailable executor.
std::unique_ptr<Executor> make_executor(const ExecutorConfig& config);

}  // namespace geld
