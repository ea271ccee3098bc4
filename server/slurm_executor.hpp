#pragma once
// The "slurm" executor: each ensemble member is one Slurm batch job,
//
//   sbatch --parsable --job-name gel-<job>-<member> --output <dir>/slurm-%j.out [extra args]
//          --wrap "<gelsim> compress --scene <dir>/scene.json --out <dir>
//                  --progress-file <dir>/progress.jsonl [--resume]"
//
// where <dir> is the member's directory on a filesystem shared with the compute nodes
// (<shared-dir>/<job>/<member dir>). gelsim appends one JSON line per progress message and per
// equilibrium to progress.jsonl (its writer and reader: gel/progress_file.hpp); run() follows
// that file by offset (a partial last line waits for its newline) and hands rows and progress
// to the same callbacks as the thread executor, so store and streams do not change. The Slurm
// state comes from `squeue -h -t all -j ID -o ...` (no accounting needed) and `scontrol show
// job ID` for the exit code; the outcome of a job that has left the queue is read from the
// progress file's last line (done / failed).
//
// State mapping (Slurm -> member):
//   PENDING, CONFIGURING, REQUEUED, SUSPENDED, ...   queued in Slurm (the job shows running)
//   RUNNING, COMPLETING                              running, progress followed
//   COMPLETED + "done" line                          finished: the curve is <dir>/curve.json
//   FAILED, OUT_OF_MEMORY, DEADLINE, "failed" line    failed: gelsim's message (or the tail of
//                                                    slurm-<id>.out) becomes the job's error
//   CANCELLED (geld's scancel)                       stopped (the job manager marks CANCELLED)
//   CANCELLED (by someone else)                      failed, saying so
//   TIMEOUT, NODE_FAIL, PREEMPTED, BOOT_FAIL, or     resubmitted with --resume from the last
//   the job vanished without a done/failed line      checkpoint, up to max-requeues times
//
// The handle saved with the job (RunContext::save_handle, stored in SQLite by the manager) is
// "<slurm job id>:<requeues so far>". On a geld restart run() is called again with it: a
// Slurm job that is still queued or running under the expected name is followed again;
// anything else (ended, or the id now names another job: ids restart when Slurm's state is
// wiped) is decided from the member's files. geld's shutdown leaves Slurm jobs running.
//
// Commands run with posix_spawn and argument vectors (no shell, except the --wrap script,
// whose every path is single-quoted).
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "executor.hpp"
#include "gel/v1/scene.pb.h"

namespace geld {

struct SlurmOptions {
  std::string shared_dir;            // "": members run in RunContext::out_dir
  std::string gelsim = "gelsim";     // gelsim's path on the compute nodes
  std::vector<std::string> sbatch_args;  // extra arguments for sbatch
  int max_requeues = 3;
  double poll_seconds = 0.5;         // progress file; squeue every other poll (>= 1 s)
  std::string bin_dir;               // directory of sbatch/squeue/scancel/scontrol; "": PATH

  // From ExecutorConfig::settings: "shared-dir", "gelsim", "sbatch-args" (split on
  // whitespace), "max-requeues", "poll-interval", "bin-dir"; gelsim defaults to
  // config.gelsim_path. Throws std::invalid_argument naming a bad setting.
  static SlurmOptions from_config(const ExecutorConfig& config);
};

std::unique_ptr<Executor> make_slurm_executor(const ExecutorConfig& config);
std::unique_ptr<Executor> make_slurm_executor(SlurmOptions options);

// Pieces of the executor, exposed for tests.
namespace slurm {

struct CommandResult {
  int exit_code = -1;      // -1: did not run or was killed
  bool timed_out = false;
  std::string out, err;
};
// Runs argv[0] (searched in PATH unless it contains '/') with stdin from /dev/null, capturing
// stdout and stderr; kills it after `timeout`. Throws std::runtime_error if it cannot start.
CommandResult run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout);

// 'text' for a POSIX shell ('\'' for quotes inside).
std::string shell_quote(const std::string& text);

enum class Phase { Queued, Running, Completed, Failed, Cancelled, Requeue, Unknown };
Phase phase_of(const std::string& slurm_state);  // e.g. "RUNNING"; "CANCELLED by 0" works too

// Follows an append-only JSON-lines file by offset. poll() returns the complete new lines;
// a last line without its newline stays for the next poll. If the file shrinks (rewritten),
// it starts again from the beginning.
class LineFollower {
 public:
  explicit LineFollower(std::string path) : path_(std::move(path)) {}
  std::vector<std::string> poll();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::uint64_t offset_ = 0;
  std::string partial_;
};

}  // namespace slurm
}  // namespace geld
