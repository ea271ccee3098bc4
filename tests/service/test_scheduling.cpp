// Scheduling: jobs and their members on the workers, a member that fails, and cancel.
#include <atomic>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "service_fixture.hpp"

namespace geld_test {
namespace {

TEST_F(Service, TwoJobsRunConcurrently) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({.workers = 2, .executor = scripted(script)});
  const std::string a = submit_ok(tiny_scene_json(), {.rerun = true});
  const std::string b = submit_ok(tiny_scene_json(), {.rerun = true});
  // Each emits one row, then blocks: both rows stored means both run at once.
  ASSERT_TRUE(wait_for([&] { return get(a).rows() == 1 && get(b).rows() == 1; }));
  EXPECT_EQ(get(a).state(), gel::v1::JOB_STATE_RUNNING);
  EXPECT_EQ(get(b).state(), gel::v1::JOB_STATE_RUNNING);
  EXPECT_EQ(script.running.load(), 2);
  script.open();
  watch(a);
  watch(b);
  EXPECT_EQ(get(a).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(get(b).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(script.max_running.load(), 2);
}

TEST_F(Service, CancelRunningQueuedAndFinished) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({.workers = 1, .executor = scripted(script)});
  const std::string running = submit_ok(tiny_scene_json(), {.rerun = true});
  const std::string queued = submit_ok(tiny_scene_json(), {.rerun = true});
  ASSERT_TRUE(wait_for([&] { return get(running).rows() == 1; }));
  EXPECT_EQ(get(queued).state(), gel::v1::JOB_STATE_QUEUED);

  gel::v1::CancelJobRequest request;
  gel::v1::Job job;
  request.set_job_id(queued);
  ASSERT_TRUE(stub_->CancelJob(ctx().get(), request, &job).ok());
  EXPECT_EQ(job.state(), gel::v1::JOB_STATE_CANCELLED);

  request.set_job_id(running);
  ASSERT_TRUE(stub_->CancelJob(ctx().get(), request, &job).ok());
  EXPECT_EQ(job.state(), gel::v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(get(running).state(), gel::v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(get(queued).state(), gel::v1::JOB_STATE_CANCELLED);

  auto status = stub_->CancelJob(ctx().get(), request, &job);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("already ended"), std::string::npos) << status.error_message();

  // A watcher of a cancelled job ends at once with its state.
  auto updates = watch(running);
  ASSERT_FALSE(updates.empty());
  EXPECT_EQ(updates[0].job().state(), gel::v1::JOB_STATE_CANCELLED);
}

TEST_F(Service, CancelFinishedRealJobIsFailedPrecondition) {
  start({.workers = 2});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  gel::v1::CancelJobRequest request;
  request.set_job_id(id);
  gel::v1::Job job;
  EXPECT_EQ(stub_->CancelJob(ctx().get(), request, &job).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(Service, MembersOfOneJobRunInParallelOnIdleWorkers) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({.workers = 3, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2, 3}});
  // Each member emits one row, then blocks: three rows stored means three members at once.
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 3; }));
  EXPECT_EQ(script.running.load(), 3);
  EXPECT_EQ(get(id).state(), gel::v1::JOB_STATE_RUNNING);
  script.open();
  auto updates = watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  EXPECT_EQ(script.max_running.load(), 3);
  std::set<int> members_streamed;
  for (const auto& u : updates)
    if (u.kind() == JobUpdate::ROW) members_streamed.insert(u.member());
  EXPECT_EQ(members_streamed, (std::set<int>{0, 1, 2}));
  EXPECT_EQ(get(id).rows(), 9);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM member_finished WHERE job_id = '" + id + "'"), 3);
}

TEST_F(Service, AJobsMembersGoFirstThenTheNextJob) {
  // One worker: members run one after another, and a job queued later waits for all of them.
  Script& script = make_script();
  script.rows = 2;
  start({.workers = 1, .executor = scripted(script)});
  const std::string first = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2}});
  const std::string second = submit_ok(tiny_scene_json(), {.rerun = true});
  watch(second);
  ASSERT_EQ(get(first).state(), gel::v1::JOB_STATE_SUCCEEDED);
  ASSERT_EQ(get(second).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(script.max_running.load(), 1);
  EXPECT_LE(get(first).finished_unix_ms(), get(second).started_unix_ms());
}

TEST_F(Service, AFailingMemberFailsTheJobAndStopsTheOthers) {
  std::atomic<bool> other_saw_stop{false};
  auto executor = std::make_shared<FnExecutor>([&](const geld::RunContext& ctx) -> geld::RunResult {
    if (ctx.member == 0) {
      std::this_thread::sleep_for(200ms);  // let member 1 start first
      throw std::runtime_error("numerical instability in member 0");
    }
    const auto until = std::chrono::steady_clock::now() + 60s;
    while (!ctx.stop->load() && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(5ms);
    other_saw_stop = ctx.stop->load();
    geld::RunResult result;
    result.stopped = true;
    return result;
  });
  start({.workers = 2, .executor = executor});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2}});
  watch(id);
  const auto job = get(id);
  EXPECT_EQ(job.state(), gel::v1::JOB_STATE_FAILED);
  EXPECT_NE(job.error().find("member 0"), std::string::npos) << job.error();
  ASSERT_TRUE(wait_for([&] { return other_saw_stop.load(); }, 10s));
}

TEST_F(Service, CancelStopsEveryRunningMember) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({.workers = 2, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2, 3}});
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 2; }));  // members 0 and 1 run, 2 waits
  gel::v1::CancelJobRequest request;
  request.set_job_id(id);
  gel::v1::Job job;
  ASSERT_TRUE(stub_->CancelJob(ctx().get(), request, &job).ok());
  ASSERT_TRUE(wait_for([&] { return get(id).state() == gel::v1::JOB_STATE_CANCELLED; }));
  ASSERT_TRUE(wait_for([&] { return script.running.load() == 0; }));
  EXPECT_EQ(script.max_running.load(), 2);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "' AND member = 2"), 0);
}

TEST_F(Service, FailedRunIsFailedWithItsMessage) {
  auto executor = std::make_shared<FnExecutor>([](const geld::RunContext&) -> geld::RunResult {
    throw std::runtime_error("numerical instability at step 42");
  });
  start({.workers = 1, .executor = executor});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  auto updates = watch(id);
  const auto job = get(id);
  EXPECT_EQ(job.state(), gel::v1::JOB_STATE_FAILED);
  EXPECT_NE(job.error().find("step 42"), std::string::npos);
}

TEST_F(Service, RealEngineInstabilityFailsTheJobWithTheEngineMessage) {
  // dt at half the shortest natural period: the real engine's stability guard stops the run
  // within its first steps (gelsim exits 3 on this scene).
  const std::string unstable =
      R"({"preset": "quick", "integration": {"dt_fraction": 0.5},
          "compression": {"fidelity": "fast", "steps": 2, "phi_max": 0.2}})";
  start({.workers = 1});
  const std::string id = submit_ok(unstable, {.rerun = true});
  grpc::Status status;
  auto updates = watch(id, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(updates.empty());
  EXPECT_EQ(updates.back().job().state(), gel::v1::JOB_STATE_FAILED);
  const auto job = get(id);
  ASSERT_EQ(job.state(), gel::v1::JOB_STATE_FAILED);
  EXPECT_GT(job.finished_unix_ms(), 0);
  // The job's error is the engine's own StabilityError message for this scene and seed, introduced
  // as gelsim introduces it.
  std::string expected;
  try {
    (void)gel::run_compression(job.scene(), gel::RunOptions{});
    ADD_FAILURE() << "the scene ran without an instability";
  } catch (const gel::StabilityError& e) {
    expected = std::string(gel::kInstabilityPrefix) + e.what();
  }
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(job.error(), expected);
  EXPECT_NE(job.error().find("reduce integration.dt_fraction"), std::string::npos) << job.error();
  // The log says which member failed and why; nothing was passed off as a finished member.
  gel::v1::GetLogsRequest logs_request;
  logs_request.set_job_id(id);
  gel::v1::GetLogsResponse logs;
  ASSERT_TRUE(stub_->GetLogs(ctx().get(), logs_request, &logs).ok());
  bool logged = false;
  for (const auto& line : logs.lines()) logged |= line.level() == "error" && line.message() == "member 0: " + expected;
  EXPECT_TRUE(logged);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM member_finished WHERE job_id = '" + id + "'"), 0);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE id = '" + id + "' AND state = 'failed'"), 1);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM states WHERE job_id = '" + id + "'"), 3);  // queued running failed
}

}  // namespace
}  // namespace geld_test
