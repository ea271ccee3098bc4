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

#include <google/protobuf/util/json_util.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gel/compression.hpp"
#include "gel/curve_io.hpp"
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
// Progress file

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

namespace {

template <class Message>
void proto_from_json(const nlohmann::json& object, Message& message, const char* what) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  const auto status = google::protobuf::util::JsonStringToMessage(object.dump(), &message, options);
  if (!status.ok()) throw std::runtime_error(std::string("bad ") + what + " line: " + status.ToString());
}

// The payload is either nested ({"type":"row","row":{...}}) or the line itself.
nlohmann::json payload(const nlohmann::json& line, const char* key) {
  if (line.contains(key) && line.at(key).is_object()) return line.at(key);
  nlohmann::json copy = line;
  copy.erase("type");
  return copy;
}

}  // namespace

ProgressLine parse_progress_line(const std::string& text) {
  nlohmann::json line;
  try {
    line = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("progress file: not JSON: ") + e.what());
  }
  if (!line.is_object()) throw std::runtime_error("progress file: a line is not a JSON object");
  ProgressLine parsed;
  const std::string type = line.value("type", "");
  if (type == "progress") {
    parsed.kind = ProgressLine::Progress;
    nlohmann::json progress = payload(line, "progress");
    // gelsim writes the pressure as "P" (curve.json's spelling); the proto field is "p".
    if (progress.contains("P") && !progress.contains("p")) {
      progress["p"] = progress["P"];
      progress.erase("P");
    }
    proto_from_json(progress, parsed.progress, "progress");
  } else if (type == "row") {
    parsed.kind = ProgressLine::Row;
    const nlohmann::json row = payload(line, "row");
    // curve.json's spelling ("P", "P_top", ...) or the proto's JSON mapping.
    if (row.contains("P")) {
      try {
        parsed.row = gel::curve_row_from_json(row);
      } catch (const std::exception& e) {
        throw std::runtime_error(std::string("bad row line: ") + e.what());
      }
    } else {
      proto_from_json(row, parsed.row, "row");
    }
  } else if (type == "done") {
    parsed.kind = ProgressLine::Done;
  } else if (type == "failed") {
    parsed.kind = ProgressLine::Failed;
    const auto& error = line.contains("error") ? line.at("error") : line.value("message", nlohmann::json());
    parsed.error = error.is_string() ? error.get<std::string>() : error.dump();
    if (parsed.error.empty() || parsed.error == "null") parsed.error = "gelsim reported a failure";
    if (line.value("kind", "") == "instability") parsed.error = gel::kInstabilityPrefix + parsed.error;
  }
  return parsed;
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

class SlurmExecutor final : public Executor {
 public:
  explicit SlurmExecutor(SlurmOptions options) : options_(std::move(options)) {}
  std::string name() const override { return "slurm"; }
  bool runs_in_process() const override { return false; }
  RunResult run(const RunContext& ctx) override;

 private:
  std::string bin(const char* name) const {
    return options_.bin_dir.empty() ? std::string(name) : (fs::path(options_.bin_dir) / name).string();
  }
  std::string member_dir(const RunContext& ctx) const;
  std::string job_name(const RunContext& ctx) const {
    return "gel-" + ctx.job_id + "-" + std::to_string(ctx.member);
  }
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

Handle SlurmExecutor::submit(const RunContext& ctx, const std::string& dir, int requeues) {
  const bool resume = gel::has_checkpoint(dir);
  // Without a checkpoint the member starts over (the run is deterministic); what an attempt
  // left before its first checkpoint would make gelsim refuse the folder as a used one.
  if (!resume)
    for (const std::string& name : gel::earlier_run_outputs(dir)) fs::remove_all(fs::path(dir) / name);
  const std::string scene_path = (fs::path(dir) / "scene.json").string();
  std::string script = slurm::shell_quote(options_.gelsim) + " compress --scene " + slurm::shell_quote(scene_path) +
                       " --out " + slurm::shell_quote(dir) + " --progress-file " +
                       slurm::shell_quote((fs::path(dir) / "progress.jsonl").string());
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
  if (ctx.log)
    ctx.log("info", "member " + std::to_string(ctx.member) + " (seed " + std::to_string(ctx.seed) +
                        "): Slurm job " + id + (resume ? " resumes from the checkpoint" : " submitted") +
                        (requeues ? " (requeue " + std::to_string(requeues) + ")" : "") + " in " + dir);
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
  if (result.exit_code != 0 && ctx.log)
    ctx.log("warn", "scancel " + handle.slurm_id + " failed: " + trim(result.err));
  else if (ctx.log)
    ctx.log("info", "member " + std::to_string(ctx.member) + ": Slurm job " + handle.slurm_id + " cancelled (scancel)");
}

RunResult SlurmExecutor::run(const RunContext& ctx) {
  const std::string dir = member_dir(ctx);
  fs::create_directories(dir);
  const std::string progress_path = (fs::path(dir) / "progress.jsonl").string();

  // The scene the nodes run, written atomically (the same resolved scene on every run).
  const std::string scene_path = (fs::path(dir) / "scene.json").string();
  if (ctx.handle.empty() && gel::has_checkpoint(dir)) {
    // A fresh member resumes a checkpoint it finds (geld stopped between sbatch and saving the
    // handle), but only its own: job ids are numbered per database, so two gelds on one shared
    // folder, or one whose database was replaced, meet at the same paths, and resuming another
    // job's checkpoint would report that job's curve as this one's.
    std::ifstream in(scene_path, std::ios::binary);
    const std::string previous((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (previous != ctx.scene_json)
      throw std::runtime_error("the member folder " + dir +
                               " holds a checkpoint of a different scene (another job with the same id, from "
                               "another geld or an earlier database, on this shared folder); it is left as it is: "
                               "give each geld its own slurm-shared-dir, or remove that folder to run this member");
  }
  {
    std::ofstream out(scene_path + ".tmp", std::ios::binary | std::ios::trunc);
    out << ctx.scene_json;
    if (!out) throw std::runtime_error("cannot write " + scene_path);
  }
  fs::rename(scene_path + ".tmp", scene_path);

  // Re-attach to a job submitted by an earlier run (geld restarted), or submit.
  std::optional<Handle> handle;
  if (!ctx.handle.empty()) {
    Handle saved = Handle::parse(ctx.handle);
    const QueueState q = query(saved.slurm_id);
    const bool ours = q.kind == QueueState::Known && q.name == job_name(ctx);
    const auto phase = ours ? slurm::phase_of(q.state) : slurm::Phase::Unknown;
    if (q.kind == QueueState::Unreachable ||
        (ours && (phase == slurm::Phase::Queued || phase == slurm::Phase::Running || phase == slurm::Phase::Completed))) {
      // Still there (or Slurm cannot say right now: the follow loop waits for it).
      handle = saved;
      if (ctx.log)
        ctx.log("info", "member " + std::to_string(ctx.member) + ": following Slurm job " + saved.slurm_id + " again (" +
                            (q.kind == QueueState::Unreachable ? "squeue: " + q.message : q.state) + ")");
    } else {
      // Ended while geld was away, or the id is someone else's now (Slurm's ids restart when
      // its state is wiped). A done/failed line decides; otherwise it counts as a requeue and
      // continues from the checkpoint.
      slurm::LineFollower probe(progress_path);
      bool decided = false;
      for (const auto& line : probe.poll()) {
        try {
          const auto kind = slurm::parse_progress_line(line).kind;
          if (kind == slurm::ProgressLine::Done || kind == slurm::ProgressLine::Failed) decided = true;
        } catch (const std::exception&) {
        }
      }
      if (decided) {
        handle = saved;  // the follow loop below reads the outcome
      } else {
        if (saved.requeues >= options_.max_requeues)
          throw std::runtime_error("Slurm job " + saved.slurm_id + " is gone (" + (ours ? q.state : "not in the queue") +
                                   ") without an outcome, after " + std::to_string(saved.requeues) +
                                   " requeues (max-requeues)");
        if (ctx.log)
          ctx.log("warn", "member " + std::to_string(ctx.member) + ": Slurm job " + saved.slurm_id + " is gone (" +
                              (ours ? q.state : "not in the queue") + "); resubmitting");
        handle = submit(ctx, dir, saved.requeues + 1);
      }
    }
  } else {
    // A fresh member. A stale progress file of an attempt whose handle was never saved goes
    // away unless a checkpoint continues it.
    if (!gel::has_checkpoint(dir)) fs::remove(progress_path);
    handle = submit(ctx, dir, 0);
  }

  slurm::LineFollower follower(progress_path);
  std::vector<gel::v1::CurveRow> rows;
  bool done = false;
  std::string failure;
  std::string last_state;
  auto next_query = Clock::now();
  const auto poll_period = std::chrono::duration<double>(options_.poll_seconds);
  const auto query_period = std::max<std::chrono::duration<double>>(poll_period * 2, std::chrono::seconds(1));
  // When the job was first seen ended without an outcome line (grace for a shared filesystem).
  bool ended_seen = false;
  Clock::time_point ended_at{};
  std::string unreachable_since_message;

  auto drain = [&] {
    for (const auto& line : follower.poll()) {
      slurm::ProgressLine parsed;
      try {
        parsed = slurm::parse_progress_line(line);
      } catch (const std::exception& e) {
        if (ctx.log) ctx.log("warn", std::string("member ") + std::to_string(ctx.member) + ": " + e.what());
        continue;
      }
      switch (parsed.kind) {
        case slurm::ProgressLine::Progress:
          if (ctx.on_progress) ctx.on_progress(parsed.progress);
          break;
        case slurm::ProgressLine::Row:
          rows.push_back(parsed.row);
          if (ctx.on_row) ctx.on_row(parsed.row);
          break;
        case slurm::ProgressLine::Done:
          done = true;
          break;
        case slurm::ProgressLine::Failed:
          failure = parsed.error;
          break;
        case slurm::ProgressLine::Other:
          break;
      }
    }
  };

  auto finished_result = [&] {
    RunResult result;
    result.finished = true;
    try {
      result.curve = gel::read_curve(dir);
    } catch (const std::exception& e) {
      // curve.json unreadable: the rows the progress file gave are the curve.
      if (ctx.log) ctx.log("warn", "member " + std::to_string(ctx.member) + ": " + e.what() + "; using the streamed rows");
      for (const auto& row : rows) *result.curve.add_rows() = row;
      *result.curve.mutable_scene() = ctx.scene;
    }
    return result;
  };

  while (true) {
    if (ctx.stop && ctx.stop->load()) {
      if (ctx.cancel && ctx.cancel->load()) cancel(ctx, *handle);
      // Shutdown: the Slurm job keeps running; the saved handle finds it again.
      RunResult result;
      result.stopped = true;
      return result;
    }
    drain();
    if (done) return finished_result();
    if (!failure.empty()) throw std::runtime_error("gelsim failed (Slurm job " + handle->slurm_id + "): " + failure);

    if (Clock::now() >= next_query) {
      next_query = Clock::now() + std::chrono::duration_cast<Clock::duration>(query_period);
      const QueueState q = query(handle->slurm_id);
      if (q.kind == QueueState::Unreachable) {
        // slurmctld restarting or overloaded: keep waiting, say so once.
        if (unreachable_since_message.empty() && ctx.log)
          ctx.log("warn", "squeue failed (" + q.message + "); still waiting for Slurm job " + handle->slurm_id);
        unreachable_since_message = q.message;
      } else {
        unreachable_since_message.clear();
        const bool ours = q.kind == QueueState::Known && q.name == job_name(ctx);
        const auto phase = ours ? slurm::phase_of(q.state) : slurm::Phase::Unknown;
        if (ours && q.state != last_state) {
          last_state = q.state;
          if (ctx.log)
            ctx.log("info", "member " + std::to_string(ctx.member) + ": Slurm job " + handle->slurm_id + " " + q.state +
                                (phase == slurm::Phase::Queued && !q.reason.empty() && q.reason != "None"
                                     ? " (" + q.reason + ")"
                                     : ""));
        }
        if (phase == slurm::Phase::Queued || phase == slurm::Phase::Running) {
          ended_seen = false;
        } else {
          // The job ended (or left the queue). Give the shared filesystem a moment to show the
          // last lines, then decide.
          drain();
          if (done) return finished_result();
          if (!failure.empty())
            throw std::runtime_error("gelsim failed (Slurm job " + handle->slurm_id + "): " + failure);
          if (!ended_seen) {
            ended_seen = true;
            ended_at = Clock::now();
          }
          if (Clock::now() - ended_at >= std::chrono::seconds(5) || phase == slurm::Phase::Cancelled) {
            const std::string out_file = (fs::path(dir) / ("slurm-" + handle->slurm_id + ".out")).string();
            const std::string detail = scontrol_summary(handle->slurm_id);
            const std::string tail = file_tail(out_file, 3);
            const std::string state_text = ours ? q.state : "gone from the queue";
            if (phase == slurm::Phase::Cancelled) {
              throw std::runtime_error("Slurm job " + handle->slurm_id + " was cancelled outside geld (" + q.state + ")");
            }
            if (phase == slurm::Phase::Requeue || phase == slurm::Phase::Unknown) {
              if (handle->requeues >= options_.max_requeues)
                throw std::runtime_error("Slurm job " + handle->slurm_id + " ended " + state_text + " after " +
                                         std::to_string(handle->requeues) + " requeues (max-requeues)");
              if (ctx.log)
                ctx.log("warn", "member " + std::to_string(ctx.member) + ": Slurm job " + handle->slurm_id + " ended " +
                                    state_text + "; resubmitting from the last checkpoint");
              handle = submit(ctx, dir, handle->requeues + 1);
              last_state.clear();
              ended_seen = false;
              continue;
            }
            // COMPLETED without a done line, FAILED, OUT_OF_MEMORY, ...
            std::string message = "Slurm job " + handle->slurm_id + " ended " + state_text;
            if (!detail.empty()) message += " [" + detail + "]";
            if (!tail.empty()) message += ": " + tail;
            throw std::runtime_error(message);
          }
        }
      }
    }
    // Sleep one poll period in short slices, so stop requests are seen quickly.
    const auto wake = Clock::now() + std::chrono::duration_cast<Clock::duration>(poll_period);
    while (Clock::now() < wake && !(ctx.stop && ctx.stop->load()))
      std::this_thread::sleep_for(std::min<Clock::duration>(wake - Clock::now(), std::chrono::milliseconds(50)));
  }
}

}  // namespace

std::unique_ptr<Executor> make_slurm_executor(SlurmOptions options) {
  return std::make_unique<SlurmExecutor>(std::move(options));
}

std::unique_ptr<Executor> make_slurm_executor(const ExecutorConfig& config) {
  return make_slurm_executor(SlurmOptions::from_config(config));
}

}  // namespace geld
