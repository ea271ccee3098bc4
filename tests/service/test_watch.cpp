// Progress streaming: WatchJob's snapshot and live updates (state, log, progress, rows) for
// early, late and many watchers, and the limit on watchers.
#include <atomic>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "service_fixture.hpp"

namespace geld_test {
namespace {

TEST_F(Service, EveryRowIsStoredAsReached) {
  Script& script = make_script();
  script.rows = 5;
  script.open_rows = 2;
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 2; }));
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "'"), 2);
  script.open();
  watch(id);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "'"), 5);
}

TEST_F(Service, LateWatcherGetsSnapshotThenLiveUpdates) {
  Script& script = make_script();
  script.rows = 4;
  script.open_rows = 2;
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 2; }));
  std::thread opener([&] {
    std::this_thread::sleep_for(200ms);
    script.open();
  });
  grpc::Status status;
  auto updates = watch(id, &status);
  opener.join();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_GE(updates.size(), 6u);
  EXPECT_EQ(updates[0].kind(), JobUpdate::SNAPSHOT);
  EXPECT_EQ(updates[0].job().state(), gel::v1::JOB_STATE_RUNNING);
  EXPECT_EQ(updates[0].job().rows(), 2);
  EXPECT_EQ(updates[1].kind(), JobUpdate::ROW);
  EXPECT_EQ(updates[1].row().k(), 0);
  EXPECT_EQ(updates[2].kind(), JobUpdate::ROW);
  EXPECT_EQ(updates[2].row().k(), 1);
  std::vector<int> ks;
  for (const auto& u : updates) {
    if (u.kind() == JobUpdate::ROW) ks.push_back(u.row().k());
  }
  EXPECT_EQ(ks, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(updates.back().job().state(), gel::v1::JOB_STATE_SUCCEEDED);
  // A watcher of a finished job: the snapshot and the stored rows, then the end.
  auto after = watch(id, &status);
  ASSERT_TRUE(status.ok());
  ASSERT_EQ(after.size(), 5u);
  EXPECT_EQ(after[0].job().state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(count_kind(after, JobUpdate::ROW), 4);
}

TEST_F(Service, TenConcurrentWatchersAllGetTheFullStream) {
  Script& script = make_script();
  script.rows = 12;
  script.open_rows = 0;
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  std::vector<std::vector<JobUpdate>> got(10);
  std::vector<grpc::Status> statuses(10);
  std::vector<std::thread> threads;
  std::atomic<int> subscribed{0};
  for (int i = 0; i < 10; ++i) {
    threads.emplace_back([&, i] {
      got[i] = watch(id, &statuses[i], [&](const JobUpdate& u) {
        if (u.kind() == JobUpdate::SNAPSHOT) ++subscribed;
        return true;
      });
    });
  }
  ASSERT_TRUE(wait_for([&] { return subscribed.load() == 10; }));
  script.row_delay = 5ms;
  script.open();
  for (auto& t : threads) t.join();
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(statuses[i].ok()) << statuses[i].error_message();
    std::vector<int> ks;
    for (const auto& u : got[i]) {
      if (u.kind() == JobUpdate::ROW) ks.push_back(u.row().k());
    }
    ASSERT_EQ(ks.size(), 12u) << "watcher " << i;
    for (int k = 0; k < 12; ++k) EXPECT_EQ(ks[k], k);
    EXPECT_EQ(got[i].back().job().state(), gel::v1::JOB_STATE_SUCCEEDED);
  }
}

TEST_F(Service, ALogUpdateNamesTheMemberItIsAbout) {
  // Member 1 logs and finishes while member 0 still runs: its LOG updates carried the job's
  // lowest unfinished member (0) instead of 1.
  // A LOG update is streamed, not replayed from the store: each member logs only once the
  // watcher has its snapshot (under the sanitizers member 1 used to log before it subscribed).
  std::atomic<bool> release{false}, subscribed{false};
  auto executor = std::make_shared<FnExecutor>([&release, &subscribed](const geld::RunContext& ctx) {
    while (!subscribed.load() && !ctx.stop->load()) std::this_thread::sleep_for(5ms);
    if (ctx.member == 0)
      while (!release.load() && !ctx.stop->load()) std::this_thread::sleep_for(5ms);
    ctx.log("info", "hello from member " + std::to_string(ctx.member));
    geld::RunResult result;
    result.finished = true;
    *result.curve.add_rows() = make_row(0, static_cast<double>(ctx.seed));
    return result;
  });
  start({.workers = 2, .executor = executor});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {5, 6}});
  std::vector<JobUpdate> updates;
  std::thread watcher([&] {
    updates = watch(id, nullptr, [&](const JobUpdate& u) {
      if (u.kind() == JobUpdate::SNAPSHOT) subscribed = true;
      if (u.kind() == JobUpdate::LOG && u.message() == "member 1 finished with 1 rows") release = true;
      return true;
    });
  });
  watcher.join();
  std::map<std::string, int> member_of;
  for (const auto& u : updates)
    if (u.kind() == JobUpdate::LOG) member_of[u.message()] = u.member();
  ASSERT_TRUE(member_of.count("hello from member 1")) << "no log line from member 1";
  EXPECT_EQ(member_of["hello from member 1"], 1);
  EXPECT_EQ(member_of["member 1 finished with 1 rows"], 1);
  EXPECT_EQ(member_of["hello from member 0"], 0);
  EXPECT_EQ(member_of["member 0 finished with 1 rows"], 0);
}

TEST_F(Service, WatchStreamsStateLogProgressAndRowUpdates) {
  // One worker. The first job (seed 1) holds it until `release`; the second (seed 2) is watched
  // from while it is queued, so every update of its run arrives live: the state changes, the
  // manager's and the executor's log lines, progress and rows.
  std::atomic<bool> release{false};
  auto executor = std::make_shared<FnExecutor>([&](const geld::RunContext& ctx) -> geld::RunResult {
    geld::RunResult result;
    while (ctx.seed == 1 && !release && !ctx.stop->load()) std::this_thread::sleep_for(5ms);
    if (ctx.stop->load()) {
      result.stopped = true;
      return result;
    }
    ctx.log("info", "executor log line for seed " + std::to_string(ctx.seed));
    for (int k = 0; k < 3; ++k) {
      gel::v1::Progress progress;
      progress.set_k(k);
      progress.set_k_total(2);
      progress.set_phase("compressing");
      progress.set_phi(0.1 + 0.05 * k);
      ctx.on_progress(progress);
      std::this_thread::sleep_for(20ms);
      auto row = make_row(k, static_cast<double>(ctx.seed));
      ctx.on_row(row);
      *result.curve.add_rows() = row;
    }
    result.finished = true;
    return result;
  });
  start({.workers = 1, .executor = executor});
  const std::string blocker = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1}});
  ASSERT_TRUE(wait_for([&] { return get(blocker).state() == gel::v1::JOB_STATE_RUNNING; }));
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {2}});
  std::atomic<bool> subscribed{false};
  grpc::Status status;
  std::vector<JobUpdate> updates;
  std::thread watcher([&] {
    updates = watch(id, &status, [&](const JobUpdate& u) {
      if (u.kind() == JobUpdate::SNAPSHOT) subscribed = true;
      return true;
    });
  });
  ASSERT_TRUE(wait_for([&] { return subscribed.load(); }));
  release = true;
  watcher.join();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_GE(updates.size(), 2u);
  EXPECT_EQ(updates.front().kind(), JobUpdate::SNAPSHOT);
  EXPECT_EQ(updates.front().job().state(), gel::v1::JOB_STATE_QUEUED);
  // Every kind the proto defines (but KIND_UNSPECIFIED) arrives, in sequence order.
  for (auto kind : {JobUpdate::SNAPSHOT, JobUpdate::STATE, JobUpdate::PROGRESS, JobUpdate::ROW, JobUpdate::LOG}) {
    EXPECT_GE(count_kind(updates, kind), 1) << JobUpdate::Kind_Name(kind);
  }
  EXPECT_EQ(count_kind(updates, JobUpdate::KIND_UNSPECIFIED), 0);
  for (std::size_t i = 1; i < updates.size(); ++i) {
    EXPECT_GT(updates[i].sequence(), updates[i - 1].sequence()) << "update " << i;
  }
  std::vector<gel::v1::JobState> states;
  std::vector<std::string> logs;
  std::vector<int> ks;
  for (const auto& u : updates) {
    if (u.kind() == JobUpdate::STATE) states.push_back(u.job().state());
    if (u.kind() == JobUpdate::LOG) logs.push_back(u.message());
    if (u.kind() == JobUpdate::ROW) ks.push_back(u.row().k());
    if (u.kind() == JobUpdate::PROGRESS) {
      EXPECT_EQ(u.member(), 0);
      EXPECT_EQ(u.seed(), 2u);
      EXPECT_EQ(u.progress().k_total(), 2);
      EXPECT_EQ(u.progress().phase(), "compressing");
      EXPECT_GE(u.progress().k(), 0);
      EXPECT_LE(u.progress().k(), 2);
    }
  }
  EXPECT_EQ(states, (std::vector<gel::v1::JobState>{gel::v1::JOB_STATE_RUNNING, gel::v1::JOB_STATE_SUCCEEDED}));
  EXPECT_EQ(ks, (std::vector<int>{0, 1, 2}));
  // The manager's lines (member start and end) and the executor's own, in the order written.
  ASSERT_EQ(logs.size(), 3u) << ::testing::PrintToString(logs);
  EXPECT_EQ(logs[0].rfind("member 0 (seed 2) starts in ", 0), 0u) << logs[0];
  EXPECT_EQ(logs[1], "executor log line for seed 2");
  EXPECT_EQ(logs[2], "member 0 finished with 3 rows");
  // Progress toward phi_k comes after row k - 1 and before row k (a watcher that falls behind
  // gets only the latest progress, never a stale one after a newer row).
  int rows_before = 0;
  for (const auto& u : updates) {
    if (u.kind() == JobUpdate::ROW) ++rows_before;
    if (u.kind() == JobUpdate::PROGRESS) {
      EXPECT_EQ(u.progress().k(), rows_before);
    }
  }
}

TEST_F(Service, AWatcherSlotIsFreeOnlyWhenItIsFreeAndAgainWhenItsClientLeaves) {
  // Limit 3, two streams open, eight requests at once for the one free slot: exactly one gets
  // it. (Counting before checking let the burst push the count over the limit and refuse all.)
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 0;
  geld::Limits limits;
  limits.max_watchers = 3;
  start({.workers = 1, .limits = limits, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  std::atomic<int> subscribed{0};
  std::atomic<bool> leave{false};
  std::vector<std::thread> holders;
  std::vector<grpc::Status> holder_status(2);
  for (int i = 0; i < 2; ++i)
    holders.emplace_back([&, i] {
      watch(id, &holder_status[i], [&](const JobUpdate& u) {
        if (u.kind() == JobUpdate::SNAPSHOT) ++subscribed;
        return true;
      });
    });
  ASSERT_TRUE(wait_for([&] { return subscribed.load() == 2; }));
  std::atomic<int> accepted{0}, refused{0};
  std::vector<std::thread> burst;
  std::vector<grpc::Status> burst_status(8);
  for (int i = 0; i < 8; ++i)
    burst.emplace_back([&, i] {
      watch(id, &burst_status[static_cast<std::size_t>(i)], [&](const JobUpdate& u) {
        if (u.kind() == JobUpdate::SNAPSHOT) ++accepted;
        while (!leave.load()) std::this_thread::sleep_for(5ms);  // the winner holds its slot until told to leave
        return false;
      });
      if (burst_status[static_cast<std::size_t>(i)].error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) ++refused;
    });
  ASSERT_TRUE(wait_for([&] { return accepted.load() + refused.load() == 8; }));
  EXPECT_EQ(accepted.load(), 1);
  EXPECT_EQ(refused.load(), 7);
  EXPECT_EQ(daemon_->manager().active_watchers(), 3);
  // The winner's client walks away while the job still runs: its slot is free again at once
  // (the stream notices within its 200 ms poll), and a new watcher gets it.
  leave = true;
  ASSERT_TRUE(wait_for([&] { return daemon_->manager().active_watchers() == 2; }));
  for (auto& t : burst) t.join();
  grpc::Status late;
  auto late_updates = watch(id, &late, [](const JobUpdate&) { return false; });
  EXPECT_NE(late.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << late.error_message();
  EXPECT_FALSE(late_updates.empty());
  script.open();
  for (auto& t : holders) t.join();
  for (const auto& status : holder_status) EXPECT_TRUE(status.ok()) << status.error_message();
}

TEST_F(Service, TooManyWatchersIsResourceExhausted) {
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 0;
  geld::Limits limits;
  limits.max_watchers = 2;
  start({.workers = 1, .limits = limits, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  std::atomic<int> subscribed{0};
  std::vector<std::vector<JobUpdate>> got(2);
  std::vector<grpc::Status> statuses(2);
  std::vector<std::thread> threads;
  for (int i = 0; i < 2; ++i) {
    threads.emplace_back([&, i] {
      got[i] = watch(id, &statuses[i], [&](const JobUpdate& u) {
        if (u.kind() == JobUpdate::SNAPSHOT) ++subscribed;
        return true;
      });
    });
  }
  ASSERT_TRUE(wait_for([&] { return subscribed.load() == 2; }));
  EXPECT_EQ(daemon_->manager().active_watchers(), 2);
  // A third stream on the same job is refused before it gets anything (if it were accepted,
  // stop reading at its first update so the test does not wait for the job).
  grpc::Status refused;
  auto third = watch(id, &refused, [](const JobUpdate&) { return false; });
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_EQ(refused.error_message(), "too many watchers: the limit is 2");
  EXPECT_TRUE(third.empty());
  EXPECT_EQ(daemon_->manager().active_watchers(), 2);  // the refused one holds no slot
  // The two accepted streams are unaffected and run to the end.
  script.open();
  for (auto& t : threads) t.join();
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(statuses[i].ok()) << statuses[i].error_message();
    EXPECT_EQ(count_kind(got[i], JobUpdate::ROW), 2) << "watcher " << i;
    EXPECT_EQ(got[i].back().job().state(), gel::v1::JOB_STATE_SUCCEEDED) << "watcher " << i;
  }
  // Their slots are given back: a new watcher is accepted.
  ASSERT_TRUE(wait_for([&] { return daemon_->manager().active_watchers() == 0; }));
  grpc::Status status;
  auto after = watch(id, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(after.empty());
  EXPECT_EQ(after.front().job().state(), gel::v1::JOB_STATE_SUCCEEDED);
}

}  // namespace
}  // namespace geld_test
