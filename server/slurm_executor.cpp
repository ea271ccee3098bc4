// The Slurm executor: see slurm_executor.hpp for the protocol and the state mapping.
#include "slurm_executor.hpp"

#include "gel/errors.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <spdlog/spdlog.h>

#include "gel/compression.hpp"
#include "gel/curve_io.hpp"
#include "gel/progress_file.hpp"
#include "gel/run_directory.hpp"

extern char** environ;

namespace geld {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace slurm {

// ---------------------------------------------------------------------------------------
// Commands

namespace {

struct Fd {
  int fd = -1;
  Fd() = default;
  explicit Fd(int f) : fd(f) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { reset(); }
  void reset() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
};

void make_pipe(Fd& read_end, Fd& write_end) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  read_end.fd = fds[0];
  write_end.fd = fds[1];
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
  if (argv.empty()) throw std::invalid_argument("run_command: empty argument vector");
  Fd out_r, out_w, err_r, err_w;
  make_pipe(out_r, out_w);
  make_pipe(err_r, err_w);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  // dup2 clears close-on-exec on the target; every pipe end itself is O_CLOEXEC.
  posix_spawn_file_actions_adddup2(&actions, out_w.fd, 1);
  posix_spawn_file_actions_adddup2(&actions, err_w.fd, 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // The child starts with default signal dispositions and an empty mask whatever geld set.
  sigset_t all, none;
  sigfillset(&all);
  sigemptyset(&none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);

  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = argv[0].find('/') == std::string::npos
                     ? posix_spawnp(&pid, argv[0].c_str(), &actions, &attr, args.data(), environ)
                     : posix_spawn(&pid, argv[0].c_str(), &actions, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) throw std::runtime_error("cannot run " + argv[0] + ": " + std::strerror(rc));
  out_w.reset();
  err_w.reset();

  CommandResult result;
  const auto deadline = Clock::now() + timeout;
  bool out_open = true, err_open = true;
  char buffer[8192];
  while (out_open || err_open) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      result.timed_out = true;
      ::kill(pid, SIGKILL);
      break;
    }
    pollfd fds[2];
    int n = 0;
    if (out_open) fds[n++] = {out_r.fd, POLLIN, 0};
    if (err_open) fds[n++] = {err_r.fd, POLLIN, 0};
    const int ready = ::poll(fds, n, static_cast<int>(std::min<long long>(left, 1000)));
    if (ready < 0) {
      if (errno == EINTR) continue;
      ::kill(pid, SIGKILL);
      break;
    }
    for (int i = 0; i < n; ++i) {
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const bool is_out = fds[i].fd == out_r.fd;
      const ssize_t got = ::read(fds[i].fd, buffer, sizeof buffer);
      if (got > 0) {
        (is_out ? result.out : result.err).append(buffer, static_cast<std::size_t>(got));
      } else if (got == 0 || errno != EINTR) {
        (is_out ? out_open : err_open) = false;
      }
    }
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!result.timed_out && WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  return result;
}

std::string shell_quote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) {
    if (c == '\'')
      quoted += "'\\''";
    else
      quoted += c;
  }
  return quoted + "'";
}

Phase phase_of(const std::string& raw) {
  std::string state = raw.substr(0, raw.find_first_of(" \t\n"));
  static const std::pair<const char*, Phase> table[] = {
      {"PENDING", Phase::Queued},      {"CONFIGURING", Phase::Queued},   {"REQUEUED", Phase::Queued},
      {"REQUEUE_FED", Phase::Queued},  {"REQUEUE_HOLD", Phase::Queued},  {"RESV_DEL_HOLD", Phase::Queued},
      {"SUSPENDED", Phase::Queued},    {"STOPPED", Phase::Queued},       {"RESIZING", Phase::Running},
      {"RUNNING", Phase::Running},     {"COMPLETING", Phase::Running},   {"STAGE_OUT", Phase::Running},
      {"SIGNALING", Phase::Running},   {"COMPLETED", Phase::Completed},  {"FAILED", Phase::Failed},
      {"OUT_OF_MEMORY", Phase::Failed}, {"DEADLINE", Phase::Failed},     {"SPECIAL_EXIT", Phase::Failed},
      {"REVOKED", Phase::Failed},      {"CANCELLED", Phase::Cancelled},  {"TIMEOUT", Phase::Requeue},
      {"NODE_FAIL", Phase::Requeue},   {"PREEMPTED", Phase::Requeue},    {"BOOT_FAIL", Phase::Requeue},
  };
  for (const auto& [name, phase] : table)
    if (state == name) return phase;
  return Phase::Unknown;
}

// ---------------------------------------------------------------------------------------
// Following the progress file (its lines: gel/progress_file.hpp)

std::vector<std::string> LineFollower::poll() {
  std::vector<std::string> lines;
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) return lines;
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < offset_) {  // rewritten: start again (repeated rows are harmless)
    offset_ = 0;
    partial_.clear();
  }
  if (size == offset_) return lines;
  std::ifstream in(path_, std::ios::binary);
  if (!in) return lines;
  in.seekg(static_cast<std::streamoff>(offset_));
  std::string chunk(size - offset_, '\0');
  in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
  chunk.resize(static_cast<std::size_t>(in.gcount()));
  offset_ += chunk.size();
  partial_ += chunk;
  std::size_t start = 0;
  for (std::size_t nl; (nl = partial_.find('\n', start)) != std::string::npos; start = nl + 1) {
    std::string line = partial_.substr(start, nl - start);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty()) lines.push_back(std::move(line));
  }
  partial_.erase(0, start);
  return lines;
}

}  // namespace slurm

// ---------------------------------------------------------------------------------------
// Options

namespace {

std::vector<std::string> split_words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

}  // namespace

SlurmOptions SlurmOptions::from_config(const ExecutorConfig& config) {
  SlurmOptions options;
  if (!config.gelsim_path.empty()) options.gelsim = config.gelsim_path;
  for (const auto& [key, value] : config.settings) {
    try {
      if (key == "shared-dir" || key == "shared_dir") {
        options.shared_dir = value;
      } else if (key == "gelsim") {
        if (!value.empty()) options.gelsim = value;
      } else if (key == "sbatch-args" || key == "sbatch_args") {
        options.sbatch_args = split_words(value);
      } else if (key == "max-requeues" || key == "max_requeues") {
        options.max_requeues = std::stoi(value);
        if (options.max_requeues < 0) throw std::invalid_argument("negative");
      } else if (key == "poll-interval" || key == "poll_interval") {
        options.poll_seconds = std::stod(value);
        if (!(options.poll_seconds > 0 && options.poll_seconds <= 60)) throw std::invalid_argument("out of (0, 60]");
      } else if (key == "bin-dir" || key == "bin_dir") {
        options.bin_dir = value;
      } else {
        throw std::invalid_argument("unknown setting");
      }
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("slurm executor: setting '" + key + "' = '" + value + "': " + e.what());
    } catch (const std::out_of_range&) {
      throw std::invalid_argument("slurm executor: setting '" + key + "' = '" + value + "': out of range");
    }
  }
  if (!options.shared_dir.empty()) {
    if (!fs::path(options.shared_dir).is_absolute())
      throw std::invalid_argument("slurm executor: shared-dir must be an absolute path (the nodes see it there)");
    fs::create_directories(options.shared_dir);
  }
  return options;
}

// ---------------------------------------------------------------------------------------
// The executor

namespace {

constexpr auto kCommandTimeout = std::chrono::seconds(60);

struct Handle {
  std::string slurm_id;
  int requeues = 0;
  static Handle parse(const std::string& text) {
    Handle h;
    const auto colon = text.find(':');
    h.slurm_id = text.substr(0, colon);
    if (colon != std::string::npos) {
      try {
        h.requeues = std::stoi(text.substr(colon + 1));
      } catch (const std::exception&) {
        h.requeues = 0;
      }
    }
    return h;
  }
  std::string text() const { return slurm_id + ":" + std::to_string(requeues); }
};

// What squeue said about a job.
struct QueueState {
  enum Kind { Known, Gone, Unreachable } kind = Unreachable;
  std::string state;   // e.g. "RUNNING"
  std::string name;    // job name
  std::string reason;  // pending reason
  std::string message;  // squeue's error when Unreachable
};

std::string trim(std::string text) {
  const auto b = text.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = text.find_last_not_of(" \t\r\n");
  return text.substr(b, e - b + 1);
}

// Up to the last `lines` non-empty lines of a file, joined by " | ".
std::string file_tail(const std::string& path, int lines) {
  std::ifstream in(path);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);)
    if (!trim(line).empty()) all.push_back(trim(line));
  std::string joined;
  for (std::size_t i = all.size() > static_cast<std::size_t>(lines) ? all.size() - lines : 0; i < all.size(); ++i)
    joined += (joined.empty() ? "" : " | ") + all[i];
  return joined;
}

// The files of a member's folder the executor names: the scene it runs, the progress file,
// Slurm's output of one of its jobs.
std::string scene_path(const std::string& dir) { return (fs::path(dir) / "scene.json").string(); }
std::string progress_path(const std::string& dir) { return (fs::path(dir) / "progress.jsonl").string(); }
std::string slurm_output_path(const std::string& dir, const std::string& slurm_id) {
  return (fs::path(dir) / ("slurm-" + slurm_id + ".out")).string();
}

// Whether a done or failed line (the member's outcome) is in the progress file.
bool outcome_written(const std::string& dir) {
  slurm::LineFollower probe(progress_path(dir));
  for (const auto& line : probe.poll()) {
    try {
      const auto kind = gel::parse_progress_line(line).kind;
      if (kind == gel::ProgressLine::Done || kind == gel::ProgressLine::Failed) return true;
    } catch (const std::exception&) {
    }
  }
  return false;
}

// The member's progress file as the run goes: rows and progress go to the context's callbacks
// as they come; the outcome is decided by its done or failed line.
class MemberProgress {
 public:
  explicit MemberProgress(const std::string& dir) : dir_(dir), follower_(progress_path(dir)) {}

  // Reads the new lines. Returns the finished member's result after a done line; throws
  // gelsim's error after a failed line; nothing while the run goes on.
  std::optional<RunResult> read(const RunContext& ctx, const Handle& handle) {
    bool done = false;
    std::string failure;
    for (const auto& line : follower_.poll()) {
      gel::ProgressLine parsed;
      try {
        parsed = gel::parse_progress_line(line);
      } catch (const std::exception& e) {
        ctx.log_member("warn", e.what());
        continue;
      }
      switch (parsed.kind) {
        case gel::ProgressLine::Progress:
          if (ctx.on_progress) ctx.on_progress(parsed.progress);
          break;
        case gel::ProgressLine::Row:
          rows_.push_back(parsed.row);
          if (ctx.on_row) ctx.on_row(parsed.row);
          break;
        case gel::ProgressLine::Done:
          done = true;
          break;
        case gel::ProgressLine::Failed:
          failure = parsed.error;
          break;
        case gel::ProgressLine::Other:
          break;
      }
    }
    if (done) return finished(ctx);
    if (!failure.empty()) throw std::runtime_error("gelsim failed (Slurm job " + handle.slurm_id + "): " + failure);
    return std::nullopt;
  }

 private:
  RunResult finished(const RunContext& ctx) const {
    RunResult result;
    result.finished = true;
    try {
      result.curve = gel::read_curve(dir_);
    } catch (const std::exception& e) {
      // curve.json unreadable: the rows the progress file gave are the curve.
      ctx.log_member("warn", std::string(e.what()) + "; using the streamed rows");
      for (const auto& row : rows_) *result.curve.add_rows() = row;
      *result.curve.mutable_scene() = ctx.scene;
    }
    return result;
  }

  std::string dir_;
  slurm::LineFollower follower_;
  std::vector<gel::v1::CurveRow> rows_;
};

// What the follow loop remembers of squeue's answers.
struct QueueWatch {
  Clock::time_point next_query = Clock::now();
  std::string last_state;                     // the last state logged
  std::optional<Clock::time_point> ended_at;  // first seen ended without an outcome line
  std::string unreachable_message;            // squeue's error while it fails ("" once it answers)
};

class SlurmExecutor final : public Executor {
 public:
  explicit SlurmExecutor(SlurmOptions options) : options_(std::move(options)) {}
  std::string name() const override { return "slurm"; }
  bool runs_in_process() const override { return false; }

  // In steps: the scene the nodes run, the Slurm job (found again or submitted), then its
  // progress file and queue state followed until an outcome, a stop or a failure.
  RunResult run(const RunContext& ctx) override {
    const std::string dir = member_dir(ctx);
    fs::create_directories(dir);
    write_scene(ctx, dir);
    return follow(ctx, dir, attach_or_submit(ctx, dir));
  }

 private:
  std::string bin(const char* name) const {
    return options_.bin_dir.empty() ? std::string(name) : (fs::path(options_.bin_dir) / name).string();
  }
  std::string member_dir(const RunContext& ctx) const;
  std::string job_name(const RunContext& ctx) const {
    return "gel-" + ctx.job_id + "-" + std::to_string(ctx.member);
  }
  // A queue entry is this member's only under its job name (Slurm's ids restart when its state
  // is wiped); the phase of anyone else's is Unknown.
  bool ours(const QueueState& q, const RunContext& ctx) const {
    return q.kind == QueueState::Known && q.name == job_name(ctx);
  }
  slurm::Phase phase(const QueueState& q, const RunContext& ctx) const {
    return ours(q, ctx) ? slurm::phase_of(q.state) : slurm::Phase::Unknown;
  }

  void write_scene(const RunContext& ctx, const std::string& dir) const;
  Handle attach_or_submit(const RunContext& ctx, const std::string& dir);
  RunResult follow(const RunContext& ctx, const std::string& dir, Handle handle);
  std::optional<RunResult> check_queue(const RunContext& ctx, const std::string& dir, Handle& handle, QueueWatch& watch,
                                       MemberProgress& progress);
  void ended_without_outcome(const RunContext& ctx, const std::string& dir, Handle& handle, const QueueState& q);

  Handle submit(const RunContext& ctx, const std::string& dir, int requeues);
  QueueState query(const std::string& slurm_id) const;
  std::string scontrol_summary(const std::string& slurm_id) const;
  void cancel(const RunContext& ctx, const Handle& handle) const;

  SlurmOptions options_;
};

std::string SlurmExecutor::member_dir(const RunContext& ctx) const {
  if (options_.shared_dir.empty()) return ctx.out_dir;
  const std::string leaf = fs::path(ctx.out_dir).filename().string();
  return (fs::path(options_.shared_dir) / ctx.job_id /
          (leaf.empty() ? "m" + std::to_string(ctx.member) + "-seed" + std::to_string(ctx.seed) : leaf))
      .string();
}

// The scene the nodes run, written atomically (the same resolved scene on every run).
void SlurmExecutor::write_scene(const RunContext& ctx, const std::string& dir) const {
  const std::string path = scene_path(dir);
  if (ctx.handle.empty() && gel::has_checkpoint(dir)) {
    // A fresh member resumes a checkpoint it finds (geld stopped between sbatch and saving the
    // handle), but only its own: job ids are numbered per database, so two gelds on one shared
    // folder, or one whose database was replaced, meet at the same paths, and resuming another
    // job's checkpoint would report that job's curve as this one's.
    std::ifstream in(path, std::ios::binary);
    const std::string previous((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (previous != ctx.scene_json)
      throw std::runtime_error("the member folder " + dir +
                               " holds a checkpoint of a different scene (another job with the same id, from "
                               "another geld or an earlier database, on this shared folder); it is left as it is: "
                               "give each geld its own slurm-shared-dir, or remove that folder to run this member");
  }
  {
    std::ofstream out(path + ".tmp", std::ios::binary | std::ios::trunc);
    out << ctx.scene_json;
    if (!out) throw std::runtime_error("cannot write " + path);
  }
  fs::rename(path + ".tmp", path);
}

// Re-attaches to the Slurm job an earlier run submitted (geld restarted), or submits one.
Handle SlurmExecutor::attach_or_submit(const RunContext& ctx, const std::string& dir) {
  if (ctx.handle.empty()) {
    // A fresh member. A stale progress file of an attempt whose handle was never saved goes
    // away unless a checkpoint continues it.
    if (!gel::has_checkpoint(dir)) fs::remove(progress_path(dir));
    return submit(ctx, dir, 0);
  }
  const Handle saved = Handle::parse(ctx.handle);
  const QueueState q = query(saved.slurm_id);
  const slurm::Phase p = phase(q, ctx);
  if (q.kind == QueueState::Unreachable ||
      p == slurm::Phase::Queued || p == slurm::Phase::Running || p == slurm::Phase::Completed) {
    // Still there (or Slurm cannot say right now: the follow loop waits for it).
    ctx.log_member("info", "following Slurm job " + saved.slurm_id + " again (" +
                               (q.kind == QueueState::Unreachable ? "squeue: " + q.message : q.state) + ")");
    return saved;
  }
  // Ended while geld was away, or the id is someone else's now. A done/failed line decides (the
  // follow loop reads it); otherwise it counts as a requeue and continues from the checkpoint.
  if (outcome_written(dir)) return saved;
  const std::string gone = "Slurm job " + saved.slurm_id + " is gone (" + (ours(q, ctx) ? q.state : "not in the queue") + ")";
  if (saved.requeues >= options_.max_requeues)
    throw std::runtime_error(gone + " without an outcome, after " + std::to_string(saved.requeues) +
                             " requeues (max-requeues)");
  ctx.log_member("warn", gone + "; resubmitting");
  return submit(ctx, dir, saved.requeues + 1);
}

RunResult SlurmExecutor::follow(const RunContext& ctx, const std::string& dir, Handle handle) {
  MemberProgress progress(dir);
  QueueWatch watch;
  const auto poll_period = std::chrono::duration<double>(options_.poll_seconds);
  const auto query_period = std::max<std::chrono::duration<double>>(poll_period * 2, std::chrono::seconds(1));
  while (true) {
    if (ctx.stop && ctx.stop->load()) {
      if (ctx.cancel && ctx.cancel->load()) cancel(ctx, handle);
      // Shutdown: the Slurm job keeps running; the saved handle finds it again.
      RunResult result;
      result.stopped = true;
      return result;
    }
    if (auto result = progress.read(ctx, handle)) return *result;
    if (Clock::now() >= watch.next_query) {
      watch.next_query = Clock::now() + std::chrono::duration_cast<Clock::duration>(query_period);
      if (auto result = check_queue(ctx, dir, handle, watch, progress)) return *result;
    }
    // Sleep one poll period in short slices, so stop requests are seen quickly.
    const auto wake = Clock::now() + std::chrono::duration_cast<Clock::duration>(poll_period);
    while (Clock::now() < wake && !(ctx.stop && ctx.stop->load()))
      std::this_thread::sleep_for(std::min<Clock::duration>(wake - Clock::now(), std::chrono::milliseconds(50)));
  }
}

// One squeue look at the member's Slurm job: its state changes are logged; once it has ended
// the last lines of the progress file decide, or, without an outcome line after a grace,
// ended_without_outcome. Returns the member's result when a late done line came.
std::optional<RunResult> SlurmExecutor::check_queue(const RunContext& ctx, const std::string& dir, Handle& handle,
                                                    QueueWatch& watch, MemberProgress& progress) {
  const QueueState q = query(handle.slurm_id);
  if (q.kind == QueueState::Unreachable) {
    // slurmctld restarting or overloaded: keep waiting, say so once.
    if (watch.unreachable_message.empty())
      ctx.log_member("warn", "squeue failed (" + q.message + "); still waiting for Slurm job " + handle.slurm_id);
    watch.unreachable_message = q.message;
    return std::nullopt;
  }
  watch.unreachable_message.clear();
  const slurm::Phase p = phase(q, ctx);
  if (ours(q, ctx) && q.state != watch.last_state) {
    watch.last_state = q.state;
    ctx.log_member("info", "Slurm job " + handle.slurm_id + " " + q.state +
                               (p == slurm::Phase::Queued && !q.reason.empty() && q.reason != "None" ? " (" + q.reason + ")" : ""));
  }
  if (p == slurm::Phase::Queued || p == slurm::Phase::Running) {
    watch.ended_at.reset();
    return std::nullopt;
  }
  // The job ended (or left the queue). Give the shared filesystem a moment to show the last
  // lines, then decide.
  if (auto result = progress.read(ctx, handle)) return result;
  if (!watch.ended_at) watch.ended_at = Clock::now();
  if (Clock::now() - *watch.ended_at >= std::chrono::seconds(5) || p == slurm::Phase::Cancelled) {
    ended_without_outcome(ctx, dir, handle, q);
    // Resubmitted: a new Slurm job to follow.
    watch.last_state.clear();
    watch.ended_at.reset();
  }
  return std::nullopt;
}

// The Slurm job ended without a done or failed line: cancelled outside geld and failed ends
// throw the member's error; a requeue state (TIMEOUT, NODE_FAIL, ...) or a job gone from the
// queue resubmits the member from its last checkpoint, up to max-requeues times.
void SlurmExecutor::ended_without_outcome(const RunContext& ctx, const std::string& dir, Handle& handle,
                                          const QueueState& q) {
  const slurm::Phase p = phase(q, ctx);
  const std::string detail = scontrol_summary(handle.slurm_id);
  const std::string tail = file_tail(slurm_output_path(dir, handle.slurm_id), 3);
  const std::string state_text = ours(q, ctx) ? q.state : "gone from the queue";
  if (p == slurm::Phase::Cancelled)
    throw std::runtime_error("Slurm job " + handle.slurm_id + " was cancelled outside geld (" + q.state + ")");
  if (p == slurm::Phase::Requeue || p == slurm::Phase::Unknown) {
    if (handle.requeues >= options_.max_requeues)
      throw std::runtime_error("Slurm job " + handle.slurm_id + " ended " + state_text + " after " +
                               std::to_string(handle.requeues) + " requeues (max-requeues)");
    ctx.log_member("warn", "Slurm job " + handle.slurm_id + " ended " + state_text + "; resubmitting from the last checkpoint");
    handle = submit(ctx, dir, handle.requeues + 1);
    return;
  }
  // COMPLETED without a done line, FAILED, OUT_OF_MEMORY, ...
  std::string message = "Slurm job " + handle.slurm_id + " ended " + state_text;
  if (!detail.empty()) message += " [" + detail + "]";
  if (!tail.empty()) message += ": " + tail;
  throw std::runtime_error(message);
}

Handle SlurmExecutor::submit(const RunContext& ctx, const std::string& dir, int requeues) {
  const bool resume = gel::has_checkpoint(dir);
  // Without a checkpoint the member starts over (the run is deterministic); what an attempt
  // left before its first checkpoint would make gelsim refuse the folder as a used one.
  if (!resume)
    for (const std::string& name : gel::earlier_run_outputs(dir)) fs::remove_all(fs::path(dir) / name);
  std::string script = slurm::shell_quote(options_.gelsim) + " compress --scene " + slurm::shell_quote(scene_path(dir)) +
                       " --out " + slurm::shell_quote(dir) + " --progress-file " + slurm::shell_quote(progress_path(dir));
  if (resume) script += " --resume";
  std::vector<std::string> argv = {bin("sbatch"),  "--parsable", "--job-name", job_name(ctx),
                                   "--output",     (fs::path(dir) / "slurm-%j.out").string(),
                                   "--chdir",      dir};
  argv.insert(argv.end(), options_.sbatch_args.begin(), options_.sbatch_args.end());
  argv.push_back("--wrap");
  argv.push_back(script);
  const auto result = slurm::run_command(argv, kCommandTimeout);
  if (result.exit_code != 0) {
    std::string why = trim(result.err.empty() ? result.out : result.err);
    if (result.timed_out) why = "timed out after 60 s";
    throw std::runtime_error("sbatch failed (exit " + std::to_string(result.exit_code) + "): " + why);
  }
  std::string id = trim(result.out);
  id = id.substr(0, id.find(';'));  // "<id>;<cluster>" on multi-cluster setups
  if (id.empty() || id.find_first_not_of("0123456789_") != std::string::npos)
    throw std::runtime_error("sbatch printed no job id: '" + trim(result.out) + "'");
  Handle handle{id, requeues};
  if (ctx.save_handle) ctx.save_handle(handle.text());
  ctx.log_member("info", "Slurm job " + id + (resume ? " resumes from the checkpoint" : " submitted") + " (seed " +
                             std::to_string(ctx.seed) + (requeues ? ", requeue " + std::to_string(requeues) : "") +
                             ") in " + dir);
  spdlog::info("job {} member {}: Slurm job {} submitted{}", ctx.job_id, ctx.member, id, resume ? " (--resume)" : "");
  return handle;
}

QueueState SlurmExecutor::query(const std::string& slurm_id) const {
  QueueState state;
  const auto result =
      slurm::run_command({bin("squeue"), "-h", "-t", "all", "-j", slurm_id, "-o", "%T|%j|%r"}, kCommandTimeout);
  const std::string out = trim(result.out);
  if (result.exit_code == 0 && !out.empty()) {
    const std::string first = out.substr(0, out.find('\n'));
    const auto bar1 = first.find('|');
    const auto bar2 = first.find('|', bar1 == std::string::npos ? bar1 : bar1 + 1);
    state.kind = QueueState::Known;
    state.state = first.substr(0, bar1);
    if (bar1 != std::string::npos) state.name = first.substr(bar1 + 1, bar2 - bar1 - 1);
    if (bar2 != std::string::npos) state.reason = first.substr(bar2 + 1);
    return state;
  }
  if ((result.exit_code == 0 && out.empty()) || result.err.find("Invalid job id") != std::string::npos) {
    state.kind = QueueState::Gone;
    return state;
  }
  state.kind = QueueState::Unreachable;
  state.message = trim(result.timed_out ? "squeue timed out" : result.err);
  return state;
}

std::string SlurmExecutor::scontrol_summary(const std::string& slurm_id) const {
  const auto result = slurm::run_command({bin("scontrol"), "show", "job", slurm_id}, kCommandTimeout);
  if (result.exit_code != 0) return "";
  std::string summary;
  std::istringstream in(result.out);
  for (std::string word; in >> word;)
    if (word.rfind("JobState=", 0) == 0 || word.rfind("Reason=", 0) == 0 || word.rfind("ExitCode=", 0) == 0)
      summary += (summary.empty() ? "" : " ") + word;
  return summary;
}

void SlurmExecutor::cancel(const RunContext& ctx, const Handle& handle) const {
  const auto result = slurm::run_command({bin("scancel"), handle.slurm_id}, kCommandTimeout);
  if (result.exit_code != 0)
    ctx.log_member("warn", "scancel " + handle.slurm_id + " failed: " + trim(result.err));
  else
    ctx.log_member("info", "Slurm job " + handle.slurm_id + " cancelled (scancel)");
}

}  // namespace

std::unique_ptr<Executor> make_slurm_executor(SlurmOptions options) {
  return std::make_unique<SlurmExecutor>(std::move(options));
}

std::unique_ptr<Executor> make_slurm_executor(const ExecutorConfig& config) {
  return make_slurm_executor(SlurmOptions::from_config(config));
}

}  // namespace geld
