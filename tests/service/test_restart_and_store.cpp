// Restart and the store: shutdown and the next start resume what was running, one geld per data
// dir, writes that fail in the kernel (the schema and its migrations: test_store_schema.cpp).
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "service_fixture.hpp"

namespace geld_test {
namespace {

TEST_F(Service, ShutdownRefusesWorkWithUnavailableAndKeepsRunningJobsForTheNextStart) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  script.linger_on_stop = 1500ms;  // a slow checkpoint: the server is still up meanwhile
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  const std::string queued = submit_ok(tiny_scene_json(), {.rerun = true});
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 1; }));
  grpc::Status watch_status;
  std::thread watcher([&] { watch(id, &watch_status); });
  std::this_thread::sleep_for(100ms);
  std::thread stopper([&] { daemon_->shutdown(); });
  ASSERT_TRUE(wait_for([&] { return daemon_->manager().shutting_down(); }));
  std::string refused;
  auto status = submit(tiny_scene_json(), {.rerun = true}, &refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  stopper.join();
  watcher.join();
  EXPECT_EQ(watch_status.error_code(), grpc::StatusCode::UNAVAILABLE);
  daemon_.reset();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE state = 'running'"), 1);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE state = 'queued'"), 1);
  // The next start runs both to the end.
  script.open();
  start({.workers = 1, .executor = scripted(script)});
  watch(id);
  watch(queued);
  EXPECT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(get(queued).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(curve(id).members(0).curve().rows_size(), 3);
}

void expect_same_curve(const gel::v1::Curve& a, const gel::v1::Curve& b) {
  ASSERT_EQ(a.rows_size(), b.rows_size());
  for (int i = 0; i < a.rows_size(); ++i) {
    const auto &x = a.rows(i), &y = b.rows(i);
    EXPECT_EQ(x.k(), y.k());
    EXPECT_EQ(x.phi(), y.phi()) << "k " << x.k();
    EXPECT_EQ(x.p(), y.p()) << "k " << x.k();
    EXPECT_EQ(x.p_top(), y.p_top()) << "k " << x.k();
    EXPECT_EQ(x.p_bot(), y.p_bot()) << "k " << x.k();
    EXPECT_EQ(x.contact_number(), y.contact_number()) << "k " << x.k();
    EXPECT_EQ(x.stored_energy(), y.stored_energy()) << "k " << x.k();
    EXPECT_EQ(x.steps(), y.steps()) << "k " << x.k();
    EXPECT_EQ(x.ruptures().normal(), y.ruptures().normal()) << "k " << x.k();
  }
}

TEST_F(Service, AJobThatRanBeforeARestartIsCancelledWhileRunningNotBeforeItRan) {
  // Two jobs run and geld stops; the next geld has one worker, so one of them waits its turn.
  // Cancelled while it waits, it is a job that ran (its checkpoint and rows are there), and its
  // message said "cancelled before it ran".
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({.workers = 2, .executor = scripted(script)});
  const std::string a = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1}});
  const std::string b = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {2}});
  ASSERT_TRUE(wait_for([&] { return script.running.load() == 2; }));
  stop();
  start({.workers = 1, .executor = scripted(script)});
  ASSERT_TRUE(wait_for([&] { return script.running.load() == 1; }));
  // The job the one worker did not take has logged one start (in the first geld), the other two.
  auto starts = [&](const std::string& id) {
    gel::v1::GetLogsRequest request;
    request.set_job_id(id);
    gel::v1::GetLogsResponse logs;
    EXPECT_TRUE(stub_->GetLogs(ctx().get(), request, &logs).ok());
    int count = 0;
    for (const auto& line : logs.lines()) count += line.message().rfind("member 0 (seed", 0) == 0;
    return count;
  };
  ASSERT_TRUE(wait_for([&] { return starts(a) + starts(b) == 3; }));
  const std::string waiting = starts(a) == 1 ? a : b;
  ASSERT_EQ(starts(waiting), 1);
  gel::v1::CancelJobRequest cancel;
  cancel.set_job_id(waiting);
  gel::v1::Job cancelled;
  ASSERT_TRUE(stub_->CancelJob(ctx().get(), cancel, &cancelled).ok());
  EXPECT_EQ(cancelled.state(), gel::v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(cancelled.error(), "cancelled while running");
  script.open();
}

TEST_F(Service, JobStoppedByShutdownResumesOnRestartWithTheSameCurve) {
  // Long enough (several targets) that the shutdown lands mid-way.
  const std::string scene = tiny_scene_json(6, "fast");
  start({.workers = 1});
  const std::string reference = submit_ok(scene, {.rerun = true});
  watch(reference);
  ASSERT_EQ(get(reference).state(), gel::v1::JOB_STATE_SUCCEEDED);
  const auto expected = curve(reference).members(0).curve();
  ASSERT_EQ(expected.rows_size(), 7);

  const std::string id = submit_ok(scene, {.rerun = true});
  // Stop the daemon as soon as the first target is reached.
  watch(id, nullptr, [](const JobUpdate& u) { return !(u.kind() == JobUpdate::ROW && u.row().k() >= 1); });
  stop();
  const int rows_before = sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "'");
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE id = '" + id + "' AND state = 'running'"), 1);
  EXPECT_GE(rows_before, 2);
  if (rows_before == 7) GTEST_SKIP() << "the job finished before the shutdown reached it";

  start({.workers = 1});
  grpc::Status status;
  auto updates = watch(id, &status);
  ASSERT_TRUE(status.ok());
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  expect_same_curve(curve(id).members(0).curve(), expected);
}

TEST_F(Service, RestartRunsOnlyTheMembersThatHadNotFinished) {
  std::mutex mutex;
  std::vector<int> started;
  std::atomic<bool> release{false};
  auto executor = std::make_shared<FnExecutor>([&](const geld::RunContext& ctx) -> geld::RunResult {
    {
      std::lock_guard lock(mutex);
      started.push_back(ctx.member);
    }
    geld::RunResult result;
    // Member 1 blocks until the daemon stops (or the second life releases it).
    while (ctx.member == 1 && !release && !ctx.stop->load()) std::this_thread::sleep_for(5ms);
    if (ctx.member == 1 && !release) {
      result.stopped = true;
      return result;
    }
    for (int k = 0; k < 2; ++k) {
      auto row = make_row(k, static_cast<double>(ctx.seed));
      ctx.on_row(row);
      *result.curve.add_rows() = row;
    }
    result.finished = true;
    return result;
  });
  start({.workers = 2, .executor = executor});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {4, 5, 6}});
  ASSERT_TRUE(wait_for([&] { return sqlite_count("SELECT count(*) FROM member_finished WHERE job_id = '" + id + "'") == 2; }));
  stop();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE id = '" + id + "' AND state = 'running'"), 1);
  {
    std::lock_guard lock(mutex);
    started.clear();
  }
  release = true;
  start({.workers = 2, .executor = executor});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  std::lock_guard lock(mutex);
  EXPECT_EQ(started, std::vector<int>{1});
  EXPECT_EQ(curve(id).members_size(), 3);
  EXPECT_EQ(get(id).rows(), 6);
}

// While alive, this process cannot write to any regular file at or past `bytes` (EFBIG, as with
// an exhausted quota or a full disk; SIGXFSZ ignored meanwhile): every SQLite commit fails for
// real in the kernel, reads do not.
class FileWritesFail {
 public:
  // Only the soft limit changes (the hard one stays), so any user can set it back.
  explicit FileWritesFail(rlim_t bytes) {
    if (getrlimit(RLIMIT_FSIZE, &saved_) != 0) {
      ADD_FAILURE() << "getrlimit: " << std::strerror(errno);
      return;
    }
    saved_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    active_ = setrlimit(RLIMIT_FSIZE, &limit) == 0;
    EXPECT_TRUE(active_) << "setrlimit: " << std::strerror(errno);
  }
  ~FileWritesFail() {
    if (active_) setrlimit(RLIMIT_FSIZE, &saved_);
    if (saved_handler_ != SIG_ERR) std::signal(SIGXFSZ, saved_handler_);
  }
  FileWritesFail(const FileWritesFail&) = delete;
  FileWritesFail& operator=(const FileWritesFail&) = delete;

 private:
  rlimit saved_{};
  bool active_ = false;
  void (*saved_handler_)(int) = SIG_ERR;
};

// A cancel that cannot be stored used to leave the job neither cancelled nor queued (and a
// restarted geld ran it): now the caller gets the error, the job stays queued, and a retry works.
TEST_F(Service, ACancelThatCannotBeStoredLeavesTheJobQueuedAndCanBeRetried) {
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 1;  // the first job holds the only worker until the gate opens
  start({.workers = 1, .executor = scripted(script)});
  const std::string busy = submit_ok(tiny_scene_json(), {.rerun = true, .name = "busy"});
  ASSERT_TRUE(wait_for([&] { return get(busy).rows() == 1; }));
  const std::string queued = submit_ok(tiny_scene_json(), {.rerun = true, .name = "queued"});
  ASSERT_EQ(get(queued).state(), gel::v1::JOB_STATE_QUEUED);
  grpc::Status cancel_status;
  {
    FileWritesFail fault(1);
    gel::v1::CancelJobRequest request;
    request.set_job_id(queued);
    gel::v1::Job reply;
    cancel_status = stub_->CancelJob(ctx().get(), request, &reply);
  }
  EXPECT_FALSE(cancel_status.ok()) << "a cancel that was not stored was acknowledged";
  EXPECT_EQ(get(queued).state(), gel::v1::JOB_STATE_QUEUED);
  gel::v1::CancelJobRequest retry;
  retry.set_job_id(queued);
  gel::v1::Job cancelled;
  const grpc::Status retry_status = stub_->CancelJob(ctx().get(), retry, &cancelled);
  ASSERT_TRUE(retry_status.ok()) << retry_status.error_message();
  EXPECT_EQ(cancelled.state(), gel::v1::JOB_STATE_CANCELLED);
  script.open();
  watch(busy);
  EXPECT_EQ(get(busy).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(get(queued).state(), gel::v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(get(queued).rows(), 0);
}

TEST_F(Service, StoreWriteFailureIsInternalAndReadsGoOn) {
  Script& script = make_script();
  script.rows = 2;
  start({.workers = 1, .executor = scripted(script)});
  const std::string done = submit_ok(tiny_scene_json(), {.rerun = true, .name = "before"});
  watch(done);
  ASSERT_EQ(get(done).state(), gel::v1::JOB_STATE_SUCCEEDED);
  grpc::Status submit_status, get_status, list_status, curve_status;
  std::string refused;
  gel::v1::Job job_during;
  gel::v1::ListJobsResponse list_during;
  gel::v1::GetCurveResponse curve_during;
  {
    FileWritesFail fault(1);
    submit_status = submit(tiny_scene_json(), {.rerun = true, .name = "during"}, &refused);
    // Reads while the disk still refuses writes.
    gel::v1::GetJobRequest get_request;
    get_request.set_job_id(done);
    get_status = stub_->GetJob(ctx().get(), get_request, &job_during);
    list_status = stub_->ListJobs(ctx().get(), gel::v1::ListJobsRequest(), &list_during);
    gel::v1::GetCurveRequest curve_request;
    curve_request.set_job_id(done);
    curve_status = stub_->GetCurve(ctx().get(), curve_request, &curve_during);
  }
  EXPECT_EQ(submit_status.error_code(), grpc::StatusCode::INTERNAL) << submit_status.error_message();
  EXPECT_EQ(submit_status.error_message().rfind("store: ", 0), 0u) << submit_status.error_message();
  EXPECT_NE(submit_status.error_message().find("disk I/O error"), std::string::npos) << submit_status.error_message();
  EXPECT_TRUE(refused.empty());
  ASSERT_TRUE(get_status.ok()) << get_status.error_message();
  EXPECT_EQ(job_during.state(), gel::v1::JOB_STATE_SUCCEEDED);
  ASSERT_TRUE(list_status.ok()) << list_status.error_message();
  ASSERT_EQ(list_during.jobs_size(), 1);  // the refused job was not stored
  EXPECT_EQ(list_during.jobs(0).id(), done);
  ASSERT_TRUE(curve_status.ok()) << curve_status.error_message();
  EXPECT_EQ(curve_during.members(0).curve().rows_size(), 2);
  // Once writes work again, so does the daemon.
  const std::string after = submit_ok(tiny_scene_json(), {.rerun = true, .name = "after"});
  ASSERT_FALSE(after.empty());
  watch(after);
  EXPECT_EQ(get(after).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 2);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE name = 'during'"), 0);
}

TEST(Daemon, ASecondDaemonOnTheSameDataDirOrPortRefusesToStart) {
  // Two daemons on one data dir both ran the queued jobs in the same job directories, and a
  // second one on the same port started silently (SO_REUSEPORT) and took half the clients.
  TempDir dir, other;
  auto make = [](const std::string& data, const std::string& listen) {
    geld::DaemonOptions options;
    options.listen = listen;
    options.manager.data_dir = data;
    options.manager.workers = 1;
    return std::make_unique<geld::Daemon>(options, geld::make_gelcore_adapter(), geld::make_thread_executor());
  };
  auto first = make(dir.path(), "127.0.0.1:0");
  first->start();
  try {
    auto second = make(dir.path(), "127.0.0.1:0");
    second->start();
    ADD_FAILURE() << "a second daemon started on a data dir in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("in use by another geld (pid " + std::to_string(::getpid()) + ")"), std::string::npos)
        << e.what();
  }
  auto same_port = make(other.path(), "127.0.0.1:" + std::to_string(first->port()));
  EXPECT_THROW(same_port->start(), std::runtime_error);
  same_port.reset();
  // Once the first has shut down, the data dir is free again.
  first->shutdown();
  auto next = make(dir.path(), "127.0.0.1:0");
  EXPECT_NO_THROW(next->start());
  next->shutdown();
}

}  // namespace
}  // namespace geld_test
