// geld's service against a real gRPC server on a loopback port and a real SQLite file in a
// temporary directory. Physics runs through the real compression engine on tiny scenes; queue
// behaviour (blocking, concurrency, cancellation, limits) uses a plain callable executor, a test
// double of the engine run, never of gRPC or SQLite.
#include <sqlite3.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "executor.hpp"
#include "gel/analysis/ensemble_statistic.hpp"
#include "gel/compression.hpp"
#include "gel/errors.hpp"
#include "gel/resources.hpp"
#include "gel/v1/service.grpc.pb.h"
#include "job_manager.hpp"
#include "service.hpp"
#include "store.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using gel::v1::JobState;
using gel::v1::JobUpdate;

// The daemon's log lines only when asked for (GEL_TEST_LOG=1).
const bool kQuiet = [] {
  spdlog::set_level(std::getenv("GEL_TEST_LOG") ? spdlog::level::info : spdlog::level::warn);
  return true;
}();

// A 64-particle quick scene with the fast protocol: well under a second in Release.
std::string tiny_scene_json(int steps = 3, const std::string& fidelity = "fast") {
  nlohmann::json scene = {{"preset", "quick"},
                          {"generator", {{"n_floc", 8}, {"n_clusters", 8}, {"lx", 30}, {"ly", 50}}},
                          {"compression", {{"fidelity", fidelity}, {"steps", steps}}}};
  return scene.dump();
}

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "geld-test.XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// A callable executor: the test decides what a member does.
class FnExecutor : public geld::Executor {
 public:
  using Fn = std::function<geld::RunResult(const geld::RunContext&)>;
  explicit FnExecutor(Fn fn) : fn_(std::move(fn)) {}
  std::string name() const override { return "test"; }
  geld::RunResult run(const geld::RunContext& ctx) override { return fn_(ctx); }

 private:
  Fn fn_;
};

gel::v1::CurveRow make_row(int k, double seed) {
  gel::v1::CurveRow row;
  row.set_k(k);
  row.set_phi(0.1 + 0.05 * k);
  row.set_target_phi(0.1 + 0.05 * k);
  row.set_p(seed * k);
  row.set_p_top(seed * k + 0.5);
  row.set_p_bot(seed * k - 0.5);
  row.set_contact_number(2.0 + 0.1 * seed);
  row.set_equilibrated(true);
  return row;
}

// Emits `rows` rows (k = 0..rows-1, P = seed * k), waiting `gate` (if given) before each row
// after the first `open_rows`; stops when asked.
struct Script {
  int rows = 3;
  int open_rows = 1000;
  std::chrono::milliseconds row_delay{0};
  std::mutex mutex;
  std::condition_variable cv;
  bool gate_open = false;
  std::atomic<int> running{0};
  std::atomic<int> max_running{0};
  std::chrono::milliseconds linger_on_stop{0};

  void open() {
    std::lock_guard lock(mutex);
    gate_open = true;
    cv.notify_all();
  }

  geld::RunResult run(const geld::RunContext& ctx) {
    const int now = ++running;
    int prev = max_running.load();
    while (prev < now && !max_running.compare_exchange_weak(prev, now)) {
    }
    struct Leave {
      std::atomic<int>& r;
      ~Leave() { --r; }
    } leave{running};
    geld::RunResult result;
    for (int k = 0; k < rows; ++k) {
      if (k >= open_rows) {
        std::unique_lock lock(mutex);
        while (!gate_open && !ctx.stop->load()) cv.wait_for(lock, 10ms);
      }
      if (ctx.stop->load()) {
        std::this_thread::sleep_for(linger_on_stop);
        result.stopped = true;
        return result;
      }
      if (row_delay.count() > 0) std::this_thread::sleep_for(row_delay);
      auto row = make_row(k, static_cast<double>(ctx.seed));
      gel::v1::Progress progress;
      progress.set_k(k);
      progress.set_k_total(rows - 1);
      progress.set_phi(row.phi());
      ctx.on_progress(progress);
      ctx.on_row(row);
      *result.curve.add_rows() = row;
    }
    result.finished = true;
    return result;
  }
};

class Service : public ::testing::Test {
 protected:
  void start(geld::Limits limits = {}, int workers = 2, std::shared_ptr<geld::Executor> executor = nullptr,
             const std::string& listen = "127.0.0.1:0", const std::string& token = "",
             std::shared_ptr<geld::Engine> engine = nullptr) {
    geld::DaemonOptions options;
    options.listen = listen;
    options.token = token;
    options.manager.data_dir = dir_.path();
    options.manager.workers = workers;
    options.manager.limits = limits;
    if (!executor) executor = geld::make_thread_executor();
    if (!engine) engine = geld::make_compression_engine();
    daemon_ = std::make_unique<geld::Daemon>(options, engine, executor);
    daemon_->start();
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(daemon_->port()), grpc::InsecureChannelCredentials());
    stub_ = gel::v1::GelService::NewStub(channel_);
  }
  void stop() {
    if (daemon_) daemon_->shutdown();
    daemon_.reset();
  }
  void TearDown() override { stop(); }

  // Scripts live as long as the fixture, so workers still inside one at the end of a test
  // (stopped in TearDown) never see it destroyed.
  Script& make_script() { return *scripts_.emplace_back(std::make_unique<Script>()); }

  std::shared_ptr<geld::Executor> scripted(Script& script) {
    return std::make_shared<FnExecutor>([&script](const geld::RunContext& ctx) { return script.run(ctx); });
  }

  std::unique_ptr<grpc::ClientContext> ctx(const std::string& token = "") {
    auto c = std::make_unique<grpc::ClientContext>();
    if (!token.empty()) c->AddMetadata("authorization", "Bearer " + token);
    c->set_deadline(std::chrono::system_clock::now() + 60s);
    return c;
  }

  grpc::Status submit(const std::string& scene_json, std::string* id, std::vector<std::uint64_t> seeds = {},
                      const std::string& name = "", std::map<std::string, std::string> labels = {}) {
    gel::v1::SubmitJobRequest request;
    request.set_scene_json(scene_json);
    // Every test but the run cache's wants a job per submission, however alike the scenes.
    request.set_rerun(true);
    for (auto s : seeds) request.add_seeds(s);
    request.set_name(name);
    for (const auto& [k, v] : labels) (*request.mutable_labels())[k] = v;
    gel::v1::SubmitJobResponse response;
    auto status = stub_->SubmitJob(ctx().get(), request, &response);
    if (id) *id = response.job_id();
    return status;
  }
  std::string submit_ok(const std::string& scene_json, std::vector<std::uint64_t> seeds = {},
                        const std::string& name = "", std::map<std::string, std::string> labels = {}) {
    std::string id;
    auto status = submit(scene_json, &id, seeds, name, labels);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return id;
  }

  gel::v1::Job get(const std::string& id) {
    gel::v1::GetJobRequest request;
    request.set_job_id(id);
    gel::v1::Job job;
    auto status = stub_->GetJob(ctx().get(), request, &job);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return job;
  }

  // Watches until the stream ends; `on_update` may return false to stop reading early.
  std::vector<JobUpdate> watch(const std::string& id, grpc::Status* status = nullptr,
                               const std::function<bool(const JobUpdate&)>& on_update = nullptr) {
    gel::v1::WatchJobRequest request;
    request.set_job_id(id);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + 300s);
    auto reader = stub_->WatchJob(&context, request);
    std::vector<JobUpdate> updates;
    JobUpdate update;
    while (reader->Read(&update)) {
      updates.push_back(update);
      if (on_update && !on_update(update)) {
        context.TryCancel();
        break;
      }
    }
    auto s = reader->Finish();
    if (status) *status = s;
    return updates;
  }

  bool wait_for(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 60s) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < until) {
      if (condition()) return true;
      std::this_thread::sleep_for(5ms);
    }
    return condition();
  }

  gel::v1::GetCurveResponse curve(const std::string& id) {
    gel::v1::GetCurveRequest request;
    request.set_job_id(id);
    gel::v1::GetCurveResponse response;
    auto status = stub_->GetCurve(ctx().get(), request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response;
  }

  int sqlite_count(const std::string& sql) {
    sqlite3* db = nullptr;
    EXPECT_EQ(sqlite3_open_v2((fs::path(dir_.path()) / "geld.sqlite").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
              SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
    int count = -1;
    if (sqlite3_step(stmt) == SQLITE_ROW) count = sqlite3_column_int(stmt, 0);
    sqlite3_finalize(stmt);
    sqlite3_close(db);
    return count;
  }

  TempDir dir_;
  std::vector<std::unique_ptr<Script>> scripts_;
  std::unique_ptr<geld::Daemon> daemon_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<gel::v1::GelService::Stub> stub_;
};

int count_kind(const std::vector<JobUpdate>& updates, JobUpdate::Kind kind) {
  int n = 0;
  for (const auto& u : updates) n += u.kind() == kind;
  return n;
}

TEST_F(Service, SubmitWatchSucceedsWithRowsStreamedAndStored) {
  start();
  const std::string id = submit_ok(tiny_scene_json(), {}, "tiny", {{"suite", "service"}});
  ASSERT_FALSE(id.empty());
  grpc::Status status;
  auto updates = watch(id, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(updates.empty());
  EXPECT_EQ(updates.front().kind(), JobUpdate::SNAPSHOT);
  EXPECT_EQ(updates.back().kind(), JobUpdate::STATE);
  EXPECT_EQ(updates.back().job().state(), gel::v1::JOB_STATE_SUCCEEDED) << updates.back().job().error();
  // Rows: the snapshot's rows so far plus the streamed ones, once each, k = 0..3.
  std::vector<int> ks;
  for (const auto& u : updates) {
    if (u.kind() == JobUpdate::ROW) ks.push_back(u.row().k());
  }
  EXPECT_EQ(ks, (std::vector<int>{0, 1, 2, 3}));
  for (std::size_t i = 1; i < updates.size(); ++i) {
    if (updates[i].kind() != JobUpdate::ROW || updates[i].sequence() != updates[0].sequence()) {
      EXPECT_GT(updates[i].sequence(), updates[i - 1].sequence() - (i == 1 ? 1 : 0));
    }
  }
  auto c = curve(id);
  ASSERT_EQ(c.members_size(), 1);
  ASSERT_EQ(c.members(0).curve().rows_size(), 4);
  EXPECT_EQ(c.members(0).curve().particles(), 64);
  EXPECT_EQ(c.state(), gel::v1::JOB_STATE_SUCCEEDED);
  auto json = nlohmann::json::parse(c.json());
  ASSERT_EQ(json["rows"].size(), 4u);
  for (const char* key : {"phi", "P", "P_top", "P_bot", "contact_number"}) EXPECT_TRUE(json["rows"][2].contains(key)) << key;
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "'"), 4);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM events WHERE job_id = '" + id + "'"), 4);
  EXPECT_GE(sqlite_count("SELECT count(*) FROM logs WHERE job_id = '" + id + "'"), 2);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM states WHERE job_id = '" + id + "'"), 3);  // queued running succeeded
  const auto job = get(id);
  EXPECT_EQ(job.rows(), 4);
  EXPECT_EQ(job.name(), "tiny");
  EXPECT_EQ(job.labels().at("suite"), "service");
  EXPECT_EQ(job.bond_preset(), "bond1");
  EXPECT_GT(job.finished_unix_ms(), 0);
  gel::v1::GetLogsRequest logs_request;
  logs_request.set_job_id(id);
  gel::v1::GetLogsResponse logs;
  ASSERT_TRUE(stub_->GetLogs(ctx().get(), logs_request, &logs).ok());
  EXPECT_GE(logs.lines_size(), 2);
}

TEST_F(Service, EveryRowIsStoredAsReached) {
  Script& script = make_script();
  script.rows = 5;
  script.open_rows = 2;
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
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
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
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
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
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

TEST_F(Service, TwoJobsRunConcurrently) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({}, 2, scripted(script));
  const std::string a = submit_ok(tiny_scene_json());
  const std::string b = submit_ok(tiny_scene_json());
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
  start({}, 1, scripted(script));
  const std::string running = submit_ok(tiny_scene_json());
  const std::string queued = submit_ok(tiny_scene_json());
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
  start();
  const std::string id = submit_ok(tiny_scene_json());
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  gel::v1::CancelJobRequest request;
  request.set_job_id(id);
  gel::v1::Job job;
  EXPECT_EQ(stub_->CancelJob(ctx().get(), request, &job).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(Service, UnknownJobIsNotFound) {
  start();
  const std::string id = "job-999999";
  gel::v1::Job job;
  gel::v1::GetJobRequest get_request;
  get_request.set_job_id(id);
  auto s = stub_->GetJob(ctx().get(), get_request, &job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(s.error_message().find(id), std::string::npos);
  gel::v1::CancelJobRequest cancel_request;
  cancel_request.set_job_id(id);
  EXPECT_EQ(stub_->CancelJob(ctx().get(), cancel_request, &job).error_code(), grpc::StatusCode::NOT_FOUND);
  gel::v1::GetCurveRequest curve_request;
  curve_request.set_job_id(id);
  gel::v1::GetCurveResponse curve_response;
  EXPECT_EQ(stub_->GetCurve(ctx().get(), curve_request, &curve_response).error_code(), grpc::StatusCode::NOT_FOUND);
  gel::v1::GetLogsRequest logs_request;
  logs_request.set_job_id(id);
  gel::v1::GetLogsResponse logs_response;
  EXPECT_EQ(stub_->GetLogs(ctx().get(), logs_request, &logs_response).error_code(), grpc::StatusCode::NOT_FOUND);
  grpc::Status status;
  watch(id, &status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(Service, BadInputIsInvalidArgumentNamingTheField) {
  start();
  struct Case {
    std::string json;
    std::string field;
  };
  const std::vector<Case> cases = {
      {"{\"preset\": \"quick\", ", "scene_json"},                                    // malformed JSON
      {"{\"preset\": \"nope\"}", "scene.preset"},                                   // unknown preset
      {"{\"preset\": \"quick\", \"bogus\": 1}", "scene.bogus"},                      // unknown field
      {"{\"preset\": \"quick\", \"generator\": {\"lx\": -30}}", "scene.generator.lx"},  // negative size
      {"{\"preset\": \"quick\", \"compression\": {\"w0\": \"NaN\"}}", "scene.compression.w0"},
      {"{\"preset\": \"quick\", \"compression\": {\"steps\": -2}}", "scene.compression.steps"},
      {"{\"preset\": \"quick\", \"compression\": {\"fidelity\": \"ultra\"}}", "scene.compression.fidelity"},
      {"{\"preset\": \"quick\", \"bending\": {\"chain\": 5}}", "scene.bending"},
  };
  for (const auto& c : cases) {
    std::string id;
    auto status = submit(c.json, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.json << ": " << status.error_message();
    EXPECT_EQ(status.error_message().rfind(c.field, 0), 0u) << c.json << ": " << status.error_message();
  }
  // No scene at all, and an empty job id.
  gel::v1::SubmitJobRequest empty;
  gel::v1::SubmitJobResponse response;
  auto status = stub_->SubmitJob(ctx().get(), empty, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("scene", 0), 0u);
  gel::v1::GetJobRequest get_request;
  gel::v1::Job job;
  status = stub_->GetJob(ctx().get(), get_request, &job);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("job_id", 0), 0u);
  gel::v1::SubmitJobRequest bad_label;
  bad_label.set_scene_json(tiny_scene_json());
  (*bad_label.mutable_labels())["a=b"] = "c";
  status = stub_->SubmitJob(ctx().get(), bad_label, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("labels", 0), 0u);
  gel::v1::ListJobsRequest list_request;
  list_request.set_page_token("garbage");
  gel::v1::ListJobsResponse list_response;
  status = stub_->ListJobs(ctx().get(), list_request, &list_response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("page_token", 0), 0u);
  // Still serving.
  const std::string id = submit_ok(tiny_scene_json());
  EXPECT_FALSE(id.empty());
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 1);
}

TEST_F(Service, QueueFullIsResourceExhausted) {
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 1;
  geld::Limits limits;
  limits.max_queue = 2;
  start(limits, 1, scripted(script));
  const std::string first = submit_ok(tiny_scene_json());
  ASSERT_TRUE(wait_for([&] { return get(first).state() == gel::v1::JOB_STATE_RUNNING; }));
  submit_ok(tiny_scene_json());
  submit_ok(tiny_scene_json());
  std::string id;
  auto status = submit(tiny_scene_json(), &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("queue full"), std::string::npos) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 3);  // nothing stored for the refused one
  script.open();
}

TEST_F(Service, TooManyParticlesIsResourceExhausted) {
  geld::Limits limits;
  limits.max_particles = 100;
  start(limits);
  std::string id;
  auto status = submit("{\"preset\": \"quick\"}", &id);  // 256 particles
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("256 particles"), std::string::npos) << status.error_message();
  status = submit("{\"preset\": \"quick\", \"generator\": {\"n_floc\": 1073741824, \"n_clusters\": 2000000000}}", &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("scene.generator", 0), 0u);
  status = submit("{\"preset\": \"quick\", \"generator\": {\"n_floc\": 1073741824}}", &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_FALSE(submit_ok(tiny_scene_json()).empty());  // 64 particles: fine
  gel::v1::SubmitJobRequest many;
  many.set_scene_json(tiny_scene_json());
  for (int i = 0; i < 1001; ++i) many.add_seeds(static_cast<std::uint64_t>(i) + 1);
  gel::v1::SubmitJobResponse response;
  EXPECT_EQ(stub_->SubmitJob(ctx().get(), many, &response).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

// Finite values far outside the model's range (each held a worker, slowed a run 30x or took
// geld to gigabytes before its bound existed) are refused at submission, naming the field.
TEST_F(Service, AbsurdFiniteValuesAreRefusedByTheirPhysicalBounds) {
  start();
  const std::vector<std::pair<std::string, nlohmann::json>> cases = {
      {"scene.integration.skin", {{"integration", {{"skin", 1e300}}}}},
      {"scene.generator.walk_step", {{"generator", {{"walk_step", 1e-300}}}}},
      {"scene.compression.checkpoint_seconds", {{"compression", {{"checkpoint_seconds", 1e-300}}}}},
      {"scene.integration.eta_factor", {{"integration", {{"eta_factor", 1e300}}}}},
      {"scene.integration.dt_fraction", {{"integration", {{"dt_fraction", 1e-300}}}}},
  };
  for (const auto& [field, change] : cases) {
    nlohmann::json scene = nlohmann::json::parse(tiny_scene_json());
    scene.merge_patch(change);
    std::string id;
    const grpc::Status status = submit(scene.dump(), &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field << ": " << status.error_message();
    EXPECT_EQ(status.error_message().rfind(field + ":", 0), 0u) << status.error_message();
  }
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
}

// Every text of a scene is capped, and an error quoting a huge value still arrives whole as
// INVALID_ARGUMENT naming its field (a 16 kB value once made the status too large for the
// client's metadata limit: RESOURCE_EXHAUSTED with no field).
TEST_F(Service, HugeStringsAreRefusedNamingTheirFieldInAStatusThatArrives) {
  start();
  const std::string huge(3'000'000, 'x'), long_choice(16'000, 'y');
  const std::vector<std::pair<std::string, nlohmann::json>> cases = {
      {"scene.name", {{"name", huge}}},
      {"scene.compression.fidelity", {{"compression", {{"fidelity", long_choice}}}}},
      {"scene.bond.preset", {{"bond", {{"preset", long_choice}}}}},
      {"scene.effects", {{"effects", {long_choice}}}},
      {"scene.generator.preset", {{"generator", {{"preset", long_choice}}}}},
  };
  for (const auto& [field, change] : cases) {
    nlohmann::json scene = nlohmann::json::parse(tiny_scene_json());
    scene.merge_patch(change);
    std::string id;
    const grpc::Status status = submit(scene.dump(), &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field << ": " << status.error_message().substr(0, 200);
    EXPECT_EQ(status.error_message().rfind(field, 0), 0u) << status.error_message().substr(0, 200);
    EXPECT_LT(status.error_message().size(), 1200u);
  }
  // A job id longer than any id is refused as such, not looked up and echoed.
  gel::v1::GetJobRequest get_request;
  get_request.set_job_id(std::string(1'000'000, '7'));
  gel::v1::Job job;
  const grpc::Status get_status = stub_->GetJob(ctx().get(), get_request, &job);
  EXPECT_EQ(get_status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(get_status.error_message(), "job_id: 1000000 bytes, the limit is 64");
  // At the cap it is accepted.
  nlohmann::json scene = nlohmann::json::parse(tiny_scene_json());
  scene["name"] = std::string(256, 'n');
  EXPECT_FALSE(submit_ok(scene.dump()).empty());
}

// What a job's scene will hold and cost is estimated at submission and refused over a budget,
// naming the field that drives the estimate; the estimate comes back with an admitted job.
TEST_F(Service, JobsOverAResourceBudgetAreRefusedNamingTheEstimate) {
  const gel::ResourceEstimate estimate =
      gel::estimate_resources(gel::resolve_compression_scene(gel::scene_from_json(tiny_scene_json())));
  ASSERT_GT(estimate.particle_steps, 0);
  geld::Limits limits;
  limits.max_member_memory = estimate.memory_bytes - 1;
  start(limits);
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("scene.generator: one member would hold about", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("--max-member-memory"), std::string::npos) << status.error_message();
  stop();

  limits = {};
  limits.max_job_particle_steps = 2.5 * estimate.particle_steps;  // two members fit, three do not
  start(limits);
  gel::v1::SubmitJobRequest request;
  request.set_scene_json(tiny_scene_json());
  request.set_rerun(true);
  request.add_seeds(1);
  request.add_seeds(2);
  gel::v1::SubmitJobResponse response;
  status = stub_->SubmitJob(ctx().get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.estimate().particles(), 64);
  EXPECT_EQ(response.estimate().members(), 2);
  EXPECT_EQ(response.estimate().memory_bytes(), estimate.memory_bytes);
  EXPECT_EQ(response.estimate().particle_steps(), estimate.particle_steps);
  request.add_seeds(3);
  status = stub_->SubmitJob(ctx().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(status.error_message().rfind("seeds: the job would take at least", 0), 0u) << status.error_message();
  stop();

  limits = {};
  limits.max_job_disk = estimate.disk_bytes / 2;
  start(limits);
  status = submit(tiny_scene_json(), &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(status.error_message().rfind("scene.generator: the job's files would take about", 0), 0u) << status.error_message();
}

// Admission counts the jobs already admitted: with two workers, two members that each fit
// alone cannot both be admitted when together they exceed the daemon's memory budget; once
// the first job ends, the second is admitted.
TEST_F(Service, AdmissionCountsTheMembersThatMayRunAtOnce) {
  const gel::ResourceEstimate estimate =
      gel::estimate_resources(gel::resolve_compression_scene(gel::scene_from_json(tiny_scene_json())));
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 1;
  geld::Limits limits;
  // geld's own share (64 MiB), one program (16 MiB) and one and a half members.
  limits.max_memory = (80ll << 20) + estimate.memory_bytes * 3 / 2;
  start(limits, 2, scripted(script));
  const std::string first = submit_ok(tiny_scene_json());
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("memory: with this job the 2 largest members", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("--max-memory"), std::string::npos);
  script.open();
  ASSERT_TRUE(wait_for([&] { return get(first).state() == gel::v1::JOB_STATE_SUCCEEDED; }));
  ASSERT_TRUE(wait_for([&] { return submit(tiny_scene_json(), &id).ok(); }, 10s));
}

// One unary call of `method` with the request's raw bytes, through a generic stub.
grpc::Status raw_unary_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, const std::string& method,
                            const std::string& request_bytes, std::string* response_bytes) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + 30s);
  grpc::CompletionQueue cq;
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  auto call = stub.PrepareUnaryCall(&context, method, request, &cq);
  call->StartCall();
  grpc::Status status;
  call->Finish(&response, &status, reinterpret_cast<void*>(1));
  void* tag = nullptr;
  bool ok = false;
  cq.Next(&tag, &ok);
  std::vector<grpc::Slice> slices;
  response_bytes->clear();
  if (status.ok() && response.Dump(&slices).ok()) {
    for (const auto& s : slices) response_bytes->append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

// One server-streaming call of `method` with the request's raw bytes: the first message's bytes
// (if one came) and the final status. When the first message equals `cancel_after`, the test
// cancels the stream itself.
grpc::Status raw_stream_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, const std::string& method,
                             const std::string& request_bytes, std::string* first, const std::string& cancel_after = "") {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + 10s);
  grpc::CompletionQueue cq;
  void* tag = nullptr;
  bool ok = false;
  auto call = stub.PrepareCall(&context, method, &cq);
  call->StartCall(reinterpret_cast<void*>(1));
  cq.Next(&tag, &ok);
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  call->WriteLast(request, grpc::WriteOptions(), reinterpret_cast<void*>(2));
  cq.Next(&tag, &ok);
  call->Read(&response, reinterpret_cast<void*>(3));
  cq.Next(&tag, &ok);
  first->clear();
  std::vector<grpc::Slice> slices;
  if (ok && response.Dump(&slices).ok())
    for (const auto& s : slices) first->append(reinterpret_cast<const char*>(s.begin()), s.size());
  if (ok && !cancel_after.empty() && *first == cancel_after) context.TryCancel();
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(4));
  cq.Next(&tag, &ok);
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

// grpc.health.v1.Health through the generic stub (Debian ships no health client stubs): an
// empty request asks for the server's overall status; SERVING encodes as 08 01.
const std::string kServing("\x08\x01", 2);

grpc::Status health_check(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, bool* serving) {
  std::string bytes;
  const grpc::Status status = raw_unary_call(channel, token, "/grpc.health.v1.Health/Check", "", &bytes);
  *serving = bytes == kServing;
  return status;
}

// Health Watch: with a valid token the first message says SERVING and the test then cancels.
grpc::Status health_watch(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, std::string* first) {
  return raw_stream_call(channel, token, "/grpc.health.v1.Health/Watch", "", first, kServing);
}

TEST_F(Service, AMalformedRequestIsInvalidArgumentNotInternal) {
  // A length-delimited field 1 that claims 2^31 bytes: no protobuf parser accepts it. gRPC's own
  // answer to such a request was INTERNAL with no message, as if geld had failed.
  start();
  const std::string garbage("\x0a\xff\xff\xff\xff\x07", 6);
  for (const char* method : {"SubmitJob", "GetJob", "CancelJob", "ListJobs", "GetCurve", "QueryCurves", "GetLogs", "GetAnalysis"}) {
    std::string response;
    const grpc::Status status = raw_unary_call(channel_, "", std::string("/gel.v1.GelService/") + method, garbage, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << method << ": " << status.error_message();
    EXPECT_EQ(status.error_message(), std::string("request: not a valid gel.v1.") + method + "Request message");
  }
  std::string first;
  const grpc::Status watch = raw_stream_call(channel_, "", "/gel.v1.GelService/WatchJob", garbage, &first);
  EXPECT_EQ(watch.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << watch.error_message();
  EXPECT_TRUE(first.empty());
  // Nothing was stored, and well-formed calls go on being served; an empty message is a valid
  // (all-default) request and still gets the handler's own answer.
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  std::string response;
  EXPECT_EQ(raw_unary_call(channel_, "", "/gel.v1.GelService/GetJob", "", &response).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(raw_unary_call(channel_, "", "/gel.v1.GelService/ListJobs", "", &response).ok());
  std::string id;
  ASSERT_TRUE(submit(tiny_scene_json(), &id).ok());
}

TEST_F(Service, HealthServiceAnswers) {
  start();
  bool serving = false;
  auto status = health_check(channel_, "", &serving);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(serving);
}

TEST_F(Service, RemoteModeRequiresTheToken) {
  // A non-loopback address without a token is refused at start.
  {
    geld::DaemonOptions options;
    options.listen = "0.0.0.0:0";
    options.manager.data_dir = dir_.path();
    geld::Daemon refused(options, geld::make_compression_engine(), geld::make_thread_executor());
    EXPECT_THROW(refused.start(), std::invalid_argument);
  }
  const std::string token = "s3cret-token";
  start({}, 1, nullptr, "0.0.0.0:0", token);
  gel::v1::ListJobsRequest request;
  gel::v1::ListJobsResponse response;
  auto status = stub_->ListJobs(ctx().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  status = stub_->ListJobs(ctx("wrong").get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  std::string id;
  {
    gel::v1::SubmitJobRequest submit_request;
    submit_request.set_scene_json(tiny_scene_json());
    gel::v1::SubmitJobResponse submit_response;
    EXPECT_EQ(stub_->SubmitJob(ctx().get(), submit_request, &submit_response).error_code(),
              grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
    ASSERT_TRUE(stub_->SubmitJob(ctx(token).get(), submit_request, &submit_response).ok());
    id = submit_response.job_id();
  }
  status = stub_->ListJobs(ctx(token).get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.jobs_size(), 1);
  bool serving = false;
  EXPECT_EQ(health_check(channel_, "", &serving).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(health_check(channel_, token, &serving).ok());
  EXPECT_TRUE(serving);
  // The health Watch stream answered SERVING before its status could refuse it: now it ends at
  // once, without the status, and only with the token does it report SERVING.
  std::string first;
  const auto watch_start = std::chrono::steady_clock::now();
  const grpc::Status refused = health_watch(channel_, "", &first);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(first, std::string("\x08\x01", 2)) << "the serving status leaked without the token";
  EXPECT_LT(std::chrono::steady_clock::now() - watch_start, 5s) << "the refused stream stayed open";
  health_watch(channel_, token, &first);
  EXPECT_EQ(first, std::string("\x08\x01", 2));
  // Watch too.
  gel::v1::WatchJobRequest watch_request;
  watch_request.set_job_id(id);
  grpc::ClientContext context;
  auto reader = stub_->WatchJob(&context, watch_request);
  JobUpdate update;
  EXPECT_FALSE(reader->Read(&update));
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);
}

TEST_F(Service, ShutdownRefusesWorkWithUnavailableAndKeepsRunningJobsForTheNextStart) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  script.linger_on_stop = 1500ms;  // a slow checkpoint: the server is still up meanwhile
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
  const std::string queued = submit_ok(tiny_scene_json());
  ASSERT_TRUE(wait_for([&] { return get(id).rows() == 1; }));
  grpc::Status watch_status;
  std::thread watcher([&] { watch(id, &watch_status); });
  std::this_thread::sleep_for(100ms);
  std::thread stopper([&] { daemon_->shutdown(); });
  ASSERT_TRUE(wait_for([&] { return daemon_->manager().shutting_down(); }));
  std::string refused;
  auto status = submit(tiny_scene_json(), &refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  stopper.join();
  watcher.join();
  EXPECT_EQ(watch_status.error_code(), grpc::StatusCode::UNAVAILABLE);
  daemon_.reset();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE state = 'running'"), 1);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE state = 'queued'"), 1);
  // The next start runs both to the end.
  script.open();
  start({}, 1, scripted(script));
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

// The real compression engine under another program version, as after an upgrade of geld.
class VersionedEngine final : public geld::Engine {
 public:
  explicit VersionedEngine(std::string version) : version_(std::move(version)) {}
  Prepared prepare(const gel::v1::SubmitJobRequest& request, const geld::Limits& limits) override {
    return real_->prepare(request, limits);
  }
  std::string scene_json(const gel::v1::Scene& scene) override { return real_->scene_json(scene); }
  std::string curve_json(const gel::v1::Curve& curve) override { return real_->curve_json(curve); }
  std::string program_version() override { return version_; }
  std::string analysis_json(const std::vector<gel::v1::Curve>& curves, bool include_unequilibrated) override {
    return real_->analysis_json(curves, include_unequilibrated);
  }

 private:
  std::shared_ptr<geld::Engine> real_ = geld::make_compression_engine();
  std::string version_;
};

TEST_F(Service, ACurveNamesTheProgramThatRanItNotTheOneAnswering) {
  // GetCurve used to stamp every curve with the answering geld's version.
  Script& script = make_script();
  start({}, 1, scripted(script), "127.0.0.1:0", "", std::make_shared<VersionedEngine>("0.1.0 git aaaaaaa Release"));
  const std::string id = submit_ok(tiny_scene_json());
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  stop();
  start({}, 1, scripted(script), "127.0.0.1:0", "", std::make_shared<VersionedEngine>("0.2.0 git bbbbbbb Release"));
  EXPECT_EQ(get(id).program_version(), "0.1.0 git aaaaaaa Release");
  const auto response = curve(id);
  ASSERT_EQ(response.members_size(), 1);
  EXPECT_EQ(response.members(0).curve().program_version(), "0.1.0 git aaaaaaa Release");
  EXPECT_EQ(nlohmann::json::parse(response.json()).at("program_version"), "0.1.0 git aaaaaaa Release");
  // A job of the new geld says the new version.
  const std::string fresh = submit_ok(tiny_scene_json(4));
  watch(fresh);
  EXPECT_EQ(curve(fresh).members(0).curve().program_version(), "0.2.0 git bbbbbbb Release");
}

TEST_F(Service, AJobThatRanBeforeARestartIsCancelledWhileRunningNotBeforeItRan) {
  // Two jobs run and geld stops; the next geld has one worker, so one of them waits its turn.
  // Cancelled while it waits, it is a job that ran (its checkpoint and rows are there), and its
  // message said "cancelled before it ran".
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({}, 2, scripted(script));
  const std::string a = submit_ok(tiny_scene_json(), {1});
  const std::string b = submit_ok(tiny_scene_json(), {2});
  ASSERT_TRUE(wait_for([&] { return script.running.load() == 2; }));
  stop();
  start({}, 1, scripted(script));
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
  start({}, 2, executor);
  const std::string id = submit_ok(tiny_scene_json(), {5, 6});
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

TEST_F(Service, GetAnalysisAnalysesAFinishedEnsembleWhereItsRowsAre) {
  start({}, 2);
  const std::string id = submit_ok(tiny_scene_json(5), {3, 4, 5});
  gel::v1::GetAnalysisRequest request;
  request.set_job_id(id);
  gel::v1::GetAnalysisResponse response;
  // Not before it has finished: members of unequal length would be mixed row by row.
  auto status = stub_->GetAnalysis(ctx().get(), request, &response);
  if (!status.ok()) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
    EXPECT_NE(status.error_message().find("needs every member's rows"), std::string::npos) << status.error_message();
  }
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  status = stub_->GetAnalysis(ctx().get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.job_id(), id);
  EXPECT_EQ(response.members(), 3);
  const nlohmann::json analysis = nlohmann::json::parse(response.json());
  EXPECT_EQ(analysis.at("members"), 3);
  EXPECT_NEAR(analysis.at("E0").get<double>(), 0.025, 1e-15);  // the model's unit, bond 1
  // The ensemble mean of P at each row is the mean of the members' rows as GetCurve gives them.
  const auto curves = curve(id);
  ASSERT_EQ(curves.members_size(), 3);
  const auto& mean_p = analysis.at("rows").at("P").at("mean");
  ASSERT_EQ(mean_p.size(), static_cast<std::size_t>(curves.members(0).curve().rows_size()));
  for (std::size_t k = 0; k < mean_p.size(); ++k) {
    double sum = 0;
    for (const auto& member : curves.members()) sum += member.curve().rows(static_cast<int>(k)).p();
    EXPECT_NEAR(mean_p[k].get<double>(), sum / 3, 1e-12 * std::max(1.0, std::abs(sum))) << "k " << k;
  }
  // Every interval names its rows, and the fits say which rows they used or why none.
  EXPECT_EQ(analysis.at("regimes").at("intervals").size(), mean_p.size() - 1);
  EXPECT_TRUE(analysis.at("power_law").is_object() || analysis.contains("power_law_error"));
  // Errors: unknown job, no id.
  request.set_job_id("job-999999");
  EXPECT_EQ(stub_->GetAnalysis(ctx().get(), request, &response).error_code(), grpc::StatusCode::NOT_FOUND);
  request.set_job_id("");
  EXPECT_EQ(stub_->GetAnalysis(ctx().get(), request, &response).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(Service, SeedZeroUnknownStatesAndHugeLogPagesAreRefusedOrCapped) {
  Script& script = make_script();
  start({}, 1, scripted(script));
  // Seed 0 would run as seed 1 (0 means "default" in a scene) while being recorded as 0.
  gel::v1::SubmitJobRequest zero;
  zero.set_scene_json(tiny_scene_json());
  zero.add_seeds(3);
  zero.add_seeds(0);
  gel::v1::SubmitJobResponse submitted;
  auto status = stub_->SubmitJob(ctx().get(), zero, &submitted);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "seeds[1]: 0 is not a seed; seeds are whole numbers from 1 to 9223372036854775807 (2^63-1)");
  // Nor is a number past 2^63-1 (what -1 becomes when a client wraps it).
  zero.set_seeds(1, std::numeric_limits<std::uint64_t>::max());
  status = stub_->SubmitJob(ctx().get(), zero, &submitted);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "seeds[1]: 18446744073709551615 is not a seed; seeds are whole numbers from 1 to 9223372036854775807 (2^63-1)");
  // A state number that names no state matched nothing in silence.
  gel::v1::ListJobsRequest list;
  list.set_state(static_cast<gel::v1::JobState>(9));
  gel::v1::ListJobsResponse listed;
  status = stub_->ListJobs(ctx().get(), list, &listed);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "state: 9 is not a job state");
  gel::v1::QueryCurvesRequest query;
  query.set_state(static_cast<gel::v1::JobState>(-2));
  gel::v1::QueryCurvesResponse queried;
  status = stub_->QueryCurves(ctx().get(), query, &queried);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "state: -2 is not a job state");
  // GetLogs pages like ListJobs and QueryCurves: at most 1000 lines, whatever the limit.
  auto chatty = std::make_shared<FnExecutor>([](const geld::RunContext& ctx) {
    for (int i = 0; i < 1200; ++i) ctx.log("info", "line " + std::to_string(i));
    geld::RunResult result;
    result.finished = true;
    *result.curve.add_rows() = make_row(0, 1);
    return result;
  });
  stop();
  start({}, 1, chatty);
  const std::string id = submit_ok(tiny_scene_json());
  watch(id);
  gel::v1::GetLogsRequest logs_request;
  logs_request.set_job_id(id);
  logs_request.set_limit(100000);
  gel::v1::GetLogsResponse logs;
  ASSERT_TRUE(stub_->GetLogs(ctx().get(), logs_request, &logs).ok());
  EXPECT_EQ(logs.lines_size(), 1000);
  logs_request.set_after_id(logs.lines(999).id());
  ASSERT_TRUE(stub_->GetLogs(ctx().get(), logs_request, &logs).ok());
  EXPECT_GT(logs.lines_size(), 200);  // the rest: 1200 lines and geld's own
  EXPECT_LT(logs.lines_size(), 1000);
}

TEST_F(Service, JobStoppedByShutdownResumesOnRestartWithTheSameCurve) {
  // Long enough (several targets) that the shutdown lands mid-way.
  const std::string scene = tiny_scene_json(6, "fast");
  start({}, 1);
  const std::string reference = submit_ok(scene);
  watch(reference);
  ASSERT_EQ(get(reference).state(), gel::v1::JOB_STATE_SUCCEEDED);
  const auto expected = curve(reference).members(0).curve();
  ASSERT_EQ(expected.rows_size(), 7);

  const std::string id = submit_ok(scene);
  // Stop the daemon as soon as the first target is reached.
  watch(id, nullptr, [](const JobUpdate& u) { return !(u.kind() == JobUpdate::ROW && u.row().k() >= 1); });
  stop();
  const int rows_before = sqlite_count("SELECT count(*) FROM curve_rows WHERE job_id = '" + id + "'");
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE id = '" + id + "' AND state = 'running'"), 1);
  EXPECT_GE(rows_before, 2);
  if (rows_before == 7) GTEST_SKIP() << "the job finished before the shutdown reached it";

  start({}, 1);
  grpc::Status status;
  auto updates = watch(id, &status);
  ASSERT_TRUE(status.ok());
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  expect_same_curve(curve(id).members(0).curve(), expected);
}

TEST_F(Service, ListJobsFiltersAndPages) {
  Script& script = make_script();
  script.rows = 1;
  start({}, 2, scripted(script));
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) {
    ids.push_back(submit_ok(tiny_scene_json(), {}, i % 2 ? "odd" : "even",
                            {{"batch", i < 3 ? "a" : "b"}, {"index", std::to_string(i)}}));
  }
  for (const auto& id : ids) watch(id);
  auto list = [&](gel::v1::ListJobsRequest request) {
    std::vector<std::string> out;
    for (int page = 0; page < 20; ++page) {
      gel::v1::ListJobsResponse response;
      auto status = stub_->ListJobs(ctx().get(), request, &response);
      EXPECT_TRUE(status.ok()) << status.error_message();
      for (const auto& job : response.jobs()) out.push_back(job.id());
      if (response.next_page_token().empty()) break;
      EXPECT_LE(response.jobs_size(), request.page_size());
      request.set_page_token(response.next_page_token());
    }
    return out;
  };
  gel::v1::ListJobsRequest request;
  request.set_page_size(2);
  EXPECT_EQ(list(request), (std::vector<std::string>{ids[4], ids[3], ids[2], ids[1], ids[0]}));
  {
    gel::v1::ListJobsRequest one_page;
    one_page.set_page_size(2);
    gel::v1::ListJobsResponse response;
    ASSERT_TRUE(stub_->ListJobs(ctx().get(), one_page, &response).ok());
    EXPECT_EQ(response.jobs_size(), 2);
    EXPECT_FALSE(response.next_page_token().empty());
  }
  gel::v1::ListJobsRequest by_label;
  by_label.set_label("batch=a");
  EXPECT_EQ(list(by_label), (std::vector<std::string>{ids[2], ids[1], ids[0]}));
  by_label.set_label("index");
  EXPECT_EQ(list(by_label).size(), 5u);
  gel::v1::ListJobsRequest by_name;
  by_name.set_name("odd");
  EXPECT_EQ(list(by_name), (std::vector<std::string>{ids[3], ids[1]}));
  gel::v1::ListJobsRequest by_state;
  by_state.set_state(gel::v1::JOB_STATE_SUCCEEDED);
  by_state.set_page_size(3);
  EXPECT_EQ(list(by_state).size(), 5u);
  by_state.set_state(gel::v1::JOB_STATE_QUEUED);
  EXPECT_TRUE(list(by_state).empty());
  by_name.set_label("batch=b");
  EXPECT_EQ(list(by_name), (std::vector<std::string>{ids[3]}));
}

TEST_F(Service, EnsembleCurveHasMembersAndMeanStdPerPhiK) {
  Script& script = make_script();
  script.rows = 3;
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json(), {1, 2, 6});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  auto c = curve(id);
  ASSERT_EQ(c.members_size(), 3);
  EXPECT_EQ(c.members(2).seed(), 6u);
  EXPECT_EQ(c.members(2).curve().scene().generator().seed(), 6u);
  ASSERT_EQ(c.ensemble_size(), 3);
  // P = seed * k over seeds 1, 2, 6 at k = 2: 2, 4, 12 -> mean 6, sample std sqrt(28).
  const auto& row = c.ensemble(2);
  EXPECT_EQ(row.k(), 2);
  EXPECT_EQ(row.n(), 3);
  EXPECT_DOUBLE_EQ(row.p().mean(), 6.0);
  EXPECT_NEAR(row.p().std(), std::sqrt(28.0), 1e-12);
  EXPECT_DOUBLE_EQ(row.phi().mean(), 0.2);
  EXPECT_NEAR(row.phi().std(), 0.0, 1e-15);
  auto json = nlohmann::json::parse(c.json());
  ASSERT_EQ(json["rows"].size(), 3u);
  EXPECT_DOUBLE_EQ(json["rows"][2]["P"].get<double>(), 6.0);
  EXPECT_NEAR(json["rows"][2]["P_std"].get<double>(), std::sqrt(28.0), 1e-12);
  EXPECT_EQ(json["members"].size(), 3u);
  EXPECT_EQ(get(id).rows(), 9);
  // The answer names its rule, the one gelsim's ensemble summary and the analyses use.
  EXPECT_EQ(c.ensemble_rule(), gel::analysis::kEnsembleRule);
  EXPECT_EQ(json["ensemble_rule"], gel::analysis::kEnsembleRule);
}

TEST_F(Service, RealEnsembleRunsEachSeed) {
  start({}, 1);
  const std::string id = submit_ok(tiny_scene_json(2), {3, 4});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  auto c = curve(id);
  ASSERT_EQ(c.members_size(), 2);
  ASSERT_EQ(c.members(0).curve().rows_size(), 3);
  ASSERT_EQ(c.members(1).curve().rows_size(), 3);
  EXPECT_NE(c.members(0).curve().rows(0).phi(), c.members(1).curve().rows(0).phi());  // different gels
  EXPECT_EQ(c.ensemble_size(), 3);
}

TEST_F(Service, MembersOfOneJobRunInParallelOnIdleWorkers) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 1;
  start({}, 3, scripted(script));
  const std::string id = submit_ok(tiny_scene_json(), {1, 2, 3});
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
  start({}, 1, scripted(script));
  const std::string first = submit_ok(tiny_scene_json(), {1, 2});
  const std::string second = submit_ok(tiny_scene_json());
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
  start({}, 2, executor);
  const std::string id = submit_ok(tiny_scene_json(), {1, 2});
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
  start({}, 2, scripted(script));
  const std::string id = submit_ok(tiny_scene_json(), {1, 2, 3});
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
  start({}, 2, executor);
  const std::string id = submit_ok(tiny_scene_json(), {4, 5, 6});
  ASSERT_TRUE(wait_for([&] { return sqlite_count("SELECT count(*) FROM member_finished WHERE job_id = '" + id + "'") == 2; }));
  stop();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE id = '" + id + "' AND state = 'running'"), 1);
  {
    std::lock_guard lock(mutex);
    started.clear();
  }
  release = true;
  start({}, 2, executor);
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  std::lock_guard lock(mutex);
  EXPECT_EQ(started, std::vector<int>{1});
  EXPECT_EQ(curve(id).members_size(), 3);
  EXPECT_EQ(get(id).rows(), 6);
}

TEST_F(Service, QueryCurvesByBondLabelsAndParameters) {
  Script& script = make_script();
  script.rows = 2;
  start({}, 1, scripted(script));
  const std::string a = submit_ok(tiny_scene_json(), {}, "a", {{"study", "s1"}});
  const std::string b = submit_ok(
      R"({"preset": "quick", "bond": {"preset": "bond2"}, "generator": {"n_floc": 8, "n_clusters": 8, "lx": 40, "ly": 50},
          "compression": {"fidelity": "fast", "steps": 3}})",
      {}, "b", {{"study", "s1"}});
  const std::string c = submit_ok(tiny_scene_json(), {}, "c", {{"study", "s2"}});
  for (const auto& id : {a, b, c}) watch(id);
  auto query = [&](const gel::v1::QueryCurvesRequest& request) {
    gel::v1::QueryCurvesResponse response;
    auto status = stub_->QueryCurves(ctx().get(), request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    std::vector<std::string> ids;
    for (const auto& e : response.curves()) {
      ids.push_back(e.job().id());
      EXPECT_EQ(e.curve().members(0).curve().rows_size(), 2);
    }
    return ids;
  };
  gel::v1::QueryCurvesRequest request;
  EXPECT_EQ(query(request), (std::vector<std::string>{c, b, a}));
  request.set_bond_preset("bond2");
  EXPECT_EQ(query(request), (std::vector<std::string>{b}));
  request.clear_bond_preset();
  (*request.mutable_labels())["study"] = "s1";
  EXPECT_EQ(query(request), (std::vector<std::string>{b, a}));
  auto* p = request.add_parameters();
  p->set_field("generator.lx");
  p->set_min(35);
  EXPECT_EQ(query(request), (std::vector<std::string>{b}));
  p->clear_min();
  p->set_equals("30");
  EXPECT_EQ(query(request), (std::vector<std::string>{a}));
  request.clear_labels();
  p->set_equals("fast");
  p->set_field("compression.fidelity");
  EXPECT_EQ(query(request).size(), 3u);
  // Values at their proto3 default are values too: a fast run has compression.quasistatic false.
  p->set_field("compression.quasistatic");
  p->set_equals("false");
  EXPECT_EQ(query(request).size(), 3u);
  p->set_equals("true");
  EXPECT_TRUE(query(request).empty());
  p->set_field("compression.fidelity");
  p->set_equals("fast");
  request.set_state(gel::v1::JOB_STATE_FAILED);
  EXPECT_TRUE(query(request).empty());
  // An ensemble is found by any of its members' seeds, not by the seed of the scene submitted.
  request.clear_state();
  const std::string ensemble = submit_ok(tiny_scene_json(), {3, 4}, "ensemble", {{"study", "s3"}});
  watch(ensemble);
  request.clear_parameters();
  (*request.mutable_labels())["study"] = "s3";
  auto* seed = request.add_parameters();
  seed->set_field("generator.seed");
  for (const char* value : {"3", "4"}) {
    seed->set_equals(value);
    gel::v1::QueryCurvesResponse found;
    ASSERT_TRUE(stub_->QueryCurves(ctx().get(), request, &found).ok());
    ASSERT_EQ(found.curves_size(), 1) << "seed " << value;
    EXPECT_EQ(found.curves(0).job().id(), ensemble);
  }
  seed->set_equals("1");
  gel::v1::QueryCurvesResponse not_found;
  ASSERT_TRUE(stub_->QueryCurves(ctx().get(), request, &not_found).ok());
  EXPECT_EQ(not_found.curves_size(), 0) << "found by the submitted scene's seed, which no member ran";
  gel::v1::QueryCurvesRequest bad;
  bad.add_parameters()->set_equals("1");
  gel::v1::QueryCurvesResponse response;
  auto status = stub_->QueryCurves(ctx().get(), bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("parameters[0].field", 0), 0u);
  // A misspelt field matched no job and answered with an empty table, as if there were none.
  struct Case {
    std::string field, message;
  };
  for (const Case& c : std::vector<Case>{
           {"generator.nosuch", "parameters[1].field: 'generator.nosuch': no such field (generator has preset, lx, "},
           {"generator.lz", "parameters[1].field: 'generator.lz': no such field; did you mean 'lx'?"},
           {"generator", "parameters[1].field: 'generator' is a group of fields, not a value"},
           {"generator.lx.a", "parameters[1].field: 'generator.lx.a': generator.lx is a value and has no fields"}}) {
    gel::v1::QueryCurvesRequest misspelt;
    misspelt.add_parameters()->set_field("generator.lx");
    misspelt.add_parameters()->set_field(c.field);
    status = stub_->QueryCurves(ctx().get(), misspelt, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.field;
    EXPECT_EQ(status.error_message().rfind(c.message, 0), 0u) << status.error_message();
  }
  // What submit records beside the scene can be filtered too.
  gel::v1::QueryCurvesRequest by_version;
  by_version.add_parameters()->set_field("run.program_version");
  by_version.mutable_parameters(0)->set_equals(get(a).program_version());
  ASSERT_TRUE(stub_->QueryCurves(ctx().get(), by_version, &response).ok());
  EXPECT_EQ(response.curves_size(), 4);
}

TEST_F(Service, SceneJsonMistakesAreSaidInTheProductsWordsNamingTheField) {
  // gelctl --set and Python overrides send scene_json; protobuf's parser answered these with
  // "invalid value \"nan\" for type TYPE_DOUBLE", "Cannot find field" or "Unexpected token".
  start();
  struct Case {
    std::string json, message;
  };
  const std::vector<Case> cases = {
      {R"({"preset": "quick", "compression": {"stepz": 4}})", "scene.compression.stepz: no such field; did you mean 'steps'?"},
      {R"({"preset": "quick", "compression": {"v_wall": "nan"}})", "scene.compression.v_wall: must be a finite number, got \"nan\""},
      {R"({"preset": "quick", "compression": {"v_wall": "inf"}})", "scene.compression.v_wall: must be a finite number, got \"inf\""},
      {R"({"preset": "quick", "compression": {"v_wall": "Infinity"}})", "scene.compression.v_wall: must be a finite number"},
      {R"({"preset": "quick", "compression": {"steps": 4.5}})",
       "scene.compression.steps: must be a whole number from -2147483648 to 2147483647, got 4.5"},
      {R"({"preset": "quick", "generator": {"seed": -1}})", "scene.generator.seed: must be a whole number from 0 to 2^64-1, got -1"},
      {R"({"preset": "quick", "compression": {"fidelity": 3}})", "scene.compression.fidelity: must be a string (in quotes), got 3"},
      {R"({"preset": "quick", "effects": "normal"})", "scene.effects: must be a list [...], got \"normal\""},
      {R"({"preset": "quick", "effects": ["normal", 3]})", "scene.effects[1]: must be a string (in quotes), got 3"},
      {R"({"preset": "quick", "compression": 4})", "scene.compression: must be a JSON object of compression fields"},
      {R"({"preset": "quick", "compression": {}, "bending": {}})", "scene.compression: cannot be set together with bending"},
      {R"({"preset": "quick", "nosuch": 1})", "scene.nosuch: no such field (the Scene has name, bond, effects, "},
      {R"({"preset": "quick", "compression": {"v_wall": NaN}})", "scene_json: not JSON: parse error at line 1, column "},
      {"{\"preset\": \"quick\",\n \"compression\": {\"steps\": 3,}}", "scene_json: not JSON: parse error at line 2, column"},
      {"[1, 2]", "scene_json: must be a JSON object of the Scene fields"},
  };
  for (const auto& c : cases) {
    std::string id;
    const auto status = submit(c.json, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.json;
    EXPECT_EQ(status.error_message().rfind(c.message, 0), 0u) << c.json << ": " << status.error_message();
    for (const char* internal : {"TYPE_", "INVALID_ARGUMENT:", "Unexpected token", "Cannot find field", "json.exception"})
      EXPECT_EQ(status.error_message().find(internal), std::string::npos) << status.error_message();
  }
  // What protobuf's mapping allows still goes through: numbers in strings, lowerCamelCase names, null.
  const std::string id = submit_ok(R"({"preset": "quick", "generator": {"nFloc": 8, "n_clusters": "8", "lx": 30, "ly": 50,
                                       "walk_step": null}, "compression": {"fidelity": "fast", "steps": 3, "phi_max": "0.2"}})");
  EXPECT_FALSE(id.empty());
}

TEST_F(Service, FailedRunIsFailedWithItsMessage) {
  auto executor = std::make_shared<FnExecutor>([](const geld::RunContext&) -> geld::RunResult {
    throw std::runtime_error("numerical instability at step 42");
  });
  start({}, 1, executor);
  const std::string id = submit_ok(tiny_scene_json());
  auto updates = watch(id);
  const auto job = get(id);
  EXPECT_EQ(job.state(), gel::v1::JOB_STATE_FAILED);
  EXPECT_NE(job.error().find("step 42"), std::string::npos);
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
  start({}, 1, executor);
  const std::string blocker = submit_ok(tiny_scene_json(), {1});
  ASSERT_TRUE(wait_for([&] { return get(blocker).state() == gel::v1::JOB_STATE_RUNNING; }));
  const std::string id = submit_ok(tiny_scene_json(), {2});
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
  start(limits, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
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
  start(limits, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
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

TEST_F(Service, OverLongNameIsInvalidArgumentNamingTheField) {
  Script& script = make_script();
  script.rows = 1;
  start({}, 1, scripted(script));
  std::string id;
  auto status = submit(tiny_scene_json(), &id, {}, std::string(257, 'n'));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("name: ", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("256"), std::string::npos) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  // 256 characters is the longest accepted, and stored whole.
  const std::string longest(256, 'n');
  id = submit_ok(tiny_scene_json(), {}, longest);
  ASSERT_FALSE(id.empty());
  EXPECT_EQ(get(id).name(), longest);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE length(name) = 256"), 1);
}

TEST_F(Service, AnEmptySceneIsRefusedAtSubmit) {
  // It used to be accepted and to fail only when a worker took it.
  start();
  std::string id;
  const grpc::Status status = submit("{}", &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("scene.generator: no gel to generate", 0), 0u) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
}

TEST_F(Service, ScenesThatCouldNeverFinishAreRefusedNamingTheField) {
  // Each value is valid on its own, and each would hold a worker for ever.
  start();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"preset": "quick", "compression": {"v_wall": 1e-300}})", "scene.compression.v_wall: "},
      {R"({"preset": "quick", "integration": {"dt": 1e-300}})", "scene.integration.dt: "},
      {R"({"preset": "quick", "compression": {"m_exam": 9000000000000000000}})", "scene.compression.m_exam: "},
  };
  for (const auto& [scene, field] : cases) {
    std::string id;
    const grpc::Status status = submit(scene, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << scene;
    EXPECT_EQ(status.error_message().rfind(field, 0), 0u) << status.error_message();
  }
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  // The largest preset is far inside the limit.
  std::string id;
  const grpc::Status ok = submit(R"({"preset": "paper-bond2-16x"})", &id);
  EXPECT_TRUE(ok.ok()) << ok.error_message();
}

TEST_F(Service, EngineThreadsAreAJobFieldWithTheDaemonsDefaultAndGiveTheSameRows) {
  // --threads-per-member 2: a scene without integration.threads gets 2, written into the stored
  // scene; a scene with its own value keeps it. Threads never change the bits, so both members'
  // rows equal a one-thread run of the same seed.
  geld::Limits limits;
  limits.threads_per_member = 2;
  start(limits);
  const std::string defaulted = submit_ok(tiny_scene_json());
  nlohmann::json one_thread = nlohmann::json::parse(tiny_scene_json());
  one_thread["integration"] = {{"threads", 1}};
  const std::string explicit_one = submit_ok(one_thread.dump());
  grpc::Status status;
  watch(defaulted, &status);
  watch(explicit_one, &status);
  const auto a = curve(defaulted), b = curve(explicit_one);
  EXPECT_EQ(get(defaulted).scene().integration().threads(), 2);
  EXPECT_EQ(get(explicit_one).scene().integration().threads(), 1);
  ASSERT_EQ(a.state(), gel::v1::JOB_STATE_SUCCEEDED);
  ASSERT_EQ(b.state(), gel::v1::JOB_STATE_SUCCEEDED);
  ASSERT_EQ(a.members(0).curve().rows_size(), b.members(0).curve().rows_size());
  for (int k = 0; k < a.members(0).curve().rows_size(); ++k) {
    gel::v1::CurveRow x = a.members(0).curve().rows(k), y = b.members(0).curve().rows(k);
    x.clear_wall_seconds();
    y.clear_wall_seconds();
    EXPECT_EQ(x.SerializeAsString(), y.SerializeAsString()) << "row " << k;
  }
  nlohmann::json too_many = nlohmann::json::parse(tiny_scene_json());
  too_many["integration"] = {{"threads", 5000}};
  std::string id;
  status = submit(too_many.dump(), &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("integration.threads"), std::string::npos) << status.error_message();
}

TEST_F(Service, TooManyOrTooLongLabelsAreInvalidArgumentNamingTheField) {
  start();
  std::map<std::string, std::string> many;
  for (int i = 0; i < 65; ++i) many.emplace(std::to_string(1000 + i), "v");
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), &id, {}, "", many);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("labels: 65 labels, the limit is 64", 0), 0u) << status.error_message();
  status = submit(tiny_scene_json(), &id, {}, "", {{"k", std::string(257, 'v')}});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("labels: key 'k'", 0), 0u) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  many.erase("1000");
  EXPECT_TRUE(submit(tiny_scene_json(), &id, {}, "", many).ok());
}

TEST_F(Service, NegativePageSizeAndLimitsAreInvalidArgumentNamingTheField) {
  Script& script = make_script();
  script.rows = 1;
  start({}, 1, scripted(script));
  const std::string id = submit_ok(tiny_scene_json());
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  {
    gel::v1::ListJobsRequest request;
    request.set_page_size(-1);
    gel::v1::ListJobsResponse response;
    auto status = stub_->ListJobs(ctx().get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(status.error_message().rfind("page_size: ", 0), 0u) << status.error_message();
    EXPECT_EQ(response.jobs_size(), 0);
  }
  {
    gel::v1::QueryCurvesRequest request;
    request.set_limit(-1);
    gel::v1::QueryCurvesResponse response;
    auto status = stub_->QueryCurves(ctx().get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(status.error_message().rfind("limit: ", 0), 0u) << status.error_message();
    EXPECT_EQ(response.curves_size(), 0);
  }
  {
    gel::v1::GetLogsRequest request;
    request.set_job_id(id);
    request.set_limit(-1);
    gel::v1::GetLogsResponse response;
    auto status = stub_->GetLogs(ctx().get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(status.error_message().rfind("limit: ", 0), 0u) << status.error_message();
    EXPECT_EQ(response.lines_size(), 0);
  }
  // The same calls with 0 (the defaults) answer.
  gel::v1::ListJobsRequest list_request;
  gel::v1::ListJobsResponse list_response;
  ASSERT_TRUE(stub_->ListJobs(ctx().get(), list_request, &list_response).ok());
  EXPECT_EQ(list_response.jobs_size(), 1);
  gel::v1::QueryCurvesRequest query_request;
  gel::v1::QueryCurvesResponse query_response;
  ASSERT_TRUE(stub_->QueryCurves(ctx().get(), query_request, &query_response).ok());
  EXPECT_EQ(query_response.curves_size(), 1);
  gel::v1::GetLogsRequest logs_request;
  logs_request.set_job_id(id);
  gel::v1::GetLogsResponse logs_response;
  ASSERT_TRUE(stub_->GetLogs(ctx().get(), logs_request, &logs_response).ok());
  EXPECT_GE(logs_response.lines_size(), 2);
}

TEST_F(Service, SceneAndSceneJsonTogetherIsInvalidArgument) {
  Script& script = make_script();
  script.rows = 1;
  start({}, 1, scripted(script));
  gel::v1::SubmitJobRequest request;
  auto* scene = request.mutable_scene();
  scene->set_preset("quick");
  scene->mutable_generator()->set_n_floc(8);
  scene->mutable_generator()->set_n_clusters(8);
  scene->mutable_generator()->set_lx(30);
  scene->mutable_generator()->set_ly(50);
  scene->mutable_compression()->set_fidelity("fast");
  scene->mutable_compression()->set_steps(3);
  request.set_scene_json(tiny_scene_json());
  request.set_rerun(true);  // the two accepted submissions below are the same scene
  gel::v1::SubmitJobResponse response;
  auto status = stub_->SubmitJob(ctx().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("scene: ", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("not both"), std::string::npos) << status.error_message();
  EXPECT_TRUE(response.job_id().empty());
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  // Each of the two alone is accepted.
  request.clear_scene_json();
  status = stub_->SubmitJob(ctx().get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(get(response.job_id()).particles(), 64);
  request.clear_scene();
  request.set_scene_json(tiny_scene_json());
  status = stub_->SubmitJob(ctx().get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 2);
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
  start({}, 1, scripted(script));
  const std::string busy = submit_ok(tiny_scene_json(), {}, "busy");
  ASSERT_TRUE(wait_for([&] { return get(busy).rows() == 1; }));
  const std::string queued = submit_ok(tiny_scene_json(), {}, "queued");
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

// Run cache: the same resolved scene, seeds and program return the job that succeeded with
// them; another seed, a changed parameter or rerun make a new job; a job records its program.
TEST_F(Service, AnIdenticalSubmissionReturnsTheJobThatAlreadySucceeded) {
  Script& script = make_script();
  script.rows = 2;
  start({}, 1, scripted(script));
  auto submit_plain = [&](const std::string& scene_json, std::vector<std::uint64_t> seeds, bool rerun) {
    gel::v1::SubmitJobRequest request;
    request.set_scene_json(scene_json);
    for (auto seed : seeds) request.add_seeds(seed);
    request.set_rerun(rerun);
    gel::v1::SubmitJobResponse response;
    const grpc::Status status = stub_->SubmitJob(ctx().get(), request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response;
  };
  const auto first = submit_plain(tiny_scene_json(), {3, 4}, false);
  EXPECT_FALSE(first.cached());
  watch(first.job_id());
  ASSERT_EQ(get(first.job_id()).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(get(first.job_id()).program_version(), gel::program_version());
  const auto again = submit_plain(tiny_scene_json(), {3, 4}, false);
  EXPECT_TRUE(again.cached());
  EXPECT_EQ(again.job_id(), first.job_id());
  EXPECT_EQ(again.job().state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 1);
  const auto other_seeds = submit_plain(tiny_scene_json(), {3, 5}, false);
  EXPECT_FALSE(other_seeds.cached());
  EXPECT_NE(other_seeds.job_id(), first.job_id());
  const auto other_scene = submit_plain(tiny_scene_json(4), {3, 4}, false);
  EXPECT_FALSE(other_scene.cached());
  const auto rerun = submit_plain(tiny_scene_json(), {3, 4}, true);
  EXPECT_FALSE(rerun.cached());
  EXPECT_NE(rerun.job_id(), first.job_id());
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 4);
  // What does not change a bit of the result does not miss the cache: the engine threads (geld
  // writes its --threads-per-member into the stored scene), and the scene's own seed when a
  // seed list replaces it. A run without a list is the list of its scene's seed.
  auto with = [](const std::string& extra) {
    nlohmann::json scene = nlohmann::json::parse(tiny_scene_json());
    scene.merge_patch(nlohmann::json::parse(extra));
    return scene.dump();
  };
  EXPECT_EQ(submit_plain(with(R"({"integration": {"threads": 2}})"), {3, 4}, false).job_id(), first.job_id());
  EXPECT_EQ(submit_plain(with(R"({"generator": {"seed": 99}})"), {3, 4}, false).job_id(), first.job_id());
  const auto single = submit_plain(with(R"({"generator": {"seed": 6}})"), {}, false);
  watch(single.job_id());
  ASSERT_EQ(get(single.job_id()).state(), gel::v1::JOB_STATE_SUCCEEDED);
  const auto as_list = submit_plain(tiny_scene_json(), {6}, false);
  EXPECT_TRUE(as_list.cached());
  EXPECT_EQ(as_list.job_id(), single.job_id());
  // The order of the members is part of the job (member 0 is seed 4 here): a new job.
  EXPECT_FALSE(submit_plain(tiny_scene_json(), {4, 3}, false).cached());
}

// A cache hit's labels and name are metadata: the earlier job takes them (ListJobs finds it by
// the new label and name), keeps a name it has, and a key it has with another value is refused.
TEST_F(Service, ACacheHitPutsItsLabelsAndNameOnTheJobItReturns) {
  Script& script = make_script();
  script.rows = 2;
  start({}, 1, scripted(script));
  auto submit_cached = [&](const std::string& name, std::map<std::string, std::string> labels, grpc::Status* status) {
    gel::v1::SubmitJobRequest request;
    request.set_scene_json(tiny_scene_json());
    request.add_seeds(3);
    request.set_name(name);
    for (const auto& [k, v] : labels) (*request.mutable_labels())[k] = v;
    gel::v1::SubmitJobResponse response;
    *status = stub_->SubmitJob(ctx().get(), request, &response);
    return response;
  };
  auto listed = [&](const std::string& label, const std::string& name) {
    gel::v1::ListJobsRequest request;
    request.set_label(label);
    request.set_name(name);
    gel::v1::ListJobsResponse response;
    EXPECT_TRUE(stub_->ListJobs(ctx().get(), request, &response).ok());
    std::vector<std::string> ids;
    for (const auto& job : response.jobs()) ids.push_back(job.id());
    return ids;
  };
  grpc::Status status;
  const auto first = submit_cached("", {{"study", "A"}}, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  watch(first.job_id());
  const auto hit = submit_cached("mine", {{"owner", "B"}, {"study", "A"}}, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(hit.cached());
  ASSERT_EQ(hit.job_id(), first.job_id());
  EXPECT_EQ(hit.job().name(), "mine");
  EXPECT_EQ(hit.job().labels().size(), 2u);
  const std::vector<std::string> just_first{first.job_id()};
  EXPECT_EQ(listed("owner=B", ""), just_first);
  EXPECT_EQ(listed("study=A", ""), just_first);
  EXPECT_EQ(listed("", "mine"), just_first);
  EXPECT_EQ(get(first.job_id()).labels().at("owner"), "B");
  // A name it has is kept; a key it has with another value is refused and nothing is written.
  submit_cached("other", {{"study", "B"}, {"extra", "x"}}, &status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "labels: key 'study' is 'A' on " + first.job_id() +
                                        ", the job that already has these results (run cache); give another key, or rerun");
  EXPECT_TRUE(listed("extra", "").empty());
  EXPECT_EQ(submit_cached("other", {}, &status).job().name(), "mine");
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 1);
}

TEST_F(Service, StoreWriteFailureIsInternalAndReadsGoOn) {
  Script& script = make_script();
  script.rows = 2;
  start({}, 1, scripted(script));
  const std::string done = submit_ok(tiny_scene_json(), {}, "before");
  watch(done);
  ASSERT_EQ(get(done).state(), gel::v1::JOB_STATE_SUCCEEDED);
  grpc::Status submit_status, get_status, list_status, curve_status;
  std::string refused;
  gel::v1::Job job_during;
  gel::v1::ListJobsResponse list_during;
  gel::v1::GetCurveResponse curve_during;
  {
    FileWritesFail fault(1);
    submit_status = submit(tiny_scene_json(), &refused, {}, "during");
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
  const std::string after = submit_ok(tiny_scene_json(), {}, "after");
  ASSERT_FALSE(after.empty());
  watch(after);
  EXPECT_EQ(get(after).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 2);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE name = 'during'"), 0);
}

TEST_F(Service, RealEngineInstabilityFailsTheJobWithTheEngineMessage) {
  // dt at half the shortest natural period: the real engine's stability guard stops the run
  // within its first steps (gelsim exits 3 on this scene).
  const std::string unstable =
      R"({"preset": "quick", "integration": {"dt_fraction": 0.5},
          "compression": {"fidelity": "fast", "steps": 2, "phi_max": 0.2}})";
  start({}, 1);
  const std::string id = submit_ok(unstable);
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

// --- Studies -------------------------------------------------------------------------------

gel::v1::SubmitStudyRequest two_bond_study(int steps, std::uint32_t seeds, const std::string& name = "two-bonds") {
  gel::v1::SubmitStudyRequest request;
  request.set_name(name);
  request.set_seed_count(seeds);
  for (const char* bond : {"bond1", "bond2"}) {
    gel::v1::StudyEnsemble* ensemble = request.add_ensembles();
    ensemble->set_name(bond);
    nlohmann::json scene = nlohmann::json::parse(tiny_scene_json(steps));
    scene["bond"] = {{"preset", bond}};
    ensemble->set_scene_json(scene.dump());
  }
  (*request.mutable_labels())["campaign"] = "test";
  request.set_rerun(true);
  return request;
}

TEST_F(Service, AStudyRunsOneJobPerEnsembleStreamsThemAndStoresItsAnalysis) {
  start({}, 2);
  gel::v1::SubmitStudyResponse submitted;
  auto status = stub_->SubmitStudy(ctx().get(), two_bond_study(3, 3), &submitted);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const std::string id = submitted.study_id();
  EXPECT_EQ(id.rfind("study-", 0), 0u) << id;
  ASSERT_EQ(submitted.study().jobs_size(), 2);
  EXPECT_EQ(submitted.study().request().ensembles(0).seeds_size(), 3);  // seed_count expanded, stored
  // Each ensemble is a job carrying the study's labels and its own.
  for (const auto& entry : submitted.study().jobs()) {
    const gel::v1::Job job = get(entry.job_id());
    EXPECT_EQ(job.labels().at("study"), id);
    EXPECT_EQ(job.labels().at("ensemble"), entry.ensemble());
    EXPECT_EQ(job.labels().at("campaign"), "test");
    EXPECT_EQ(job.seeds_size(), 3);
    EXPECT_EQ(job.bond_preset(), entry.ensemble());
  }

  // The stream: the study first, then both jobs' updates tagged with their ensemble, then the
  // study as it ended.
  gel::v1::WatchStudyRequest watch_request;
  watch_request.set_study_id(id);
  grpc::ClientContext watch_context;
  watch_context.set_deadline(std::chrono::system_clock::now() + 300s);
  auto reader = stub_->WatchStudy(&watch_context, watch_request);
  std::vector<gel::v1::StudyUpdate> updates;
  gel::v1::StudyUpdate update;
  while (reader->Read(&update)) updates.push_back(update);
  ASSERT_TRUE(reader->Finish().ok());
  ASSERT_GE(updates.size(), 3u);
  EXPECT_TRUE(updates.front().has_study() && !updates.front().has_update());
  EXPECT_EQ(updates.back().study().state(), gel::v1::JOB_STATE_SUCCEEDED);
  std::map<std::string, int> rows_by_ensemble;
  for (const auto& u : updates)
    if (u.has_update() && u.update().kind() == JobUpdate::ROW) ++rows_by_ensemble[u.ensemble()];
  EXPECT_EQ(rows_by_ensemble["bond1"], 3 * 4);  // 3 seeds x (initial row + 3 targets)
  EXPECT_EQ(rows_by_ensemble["bond2"], 3 * 4);

  gel::v1::GetStudyRequest get_request;
  get_request.set_study_id(id);
  gel::v1::Study study;
  ASSERT_TRUE(stub_->GetStudy(ctx().get(), get_request, &study).ok());
  EXPECT_EQ(study.state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_GT(study.finished_unix_ms(), 0);
  for (const auto& entry : study.jobs()) EXPECT_EQ(entry.members_finished(), 3);

  // The analysis: each ensemble's mean P per row is the mean of its members' stored rows, with
  // an interval over the three seeds, and the structures come from the members' snapshots.
  gel::v1::GetStudyAnalysisRequest analysis_request;
  analysis_request.set_study_id(id);
  analysis_request.set_bootstrap_samples(200);
  gel::v1::GetStudyAnalysisResponse analysis;
  status = stub_->GetStudyAnalysis(ctx().get(), analysis_request, &analysis);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(analysis.stored());
  const nlohmann::json json = nlohmann::json::parse(analysis.json());
  EXPECT_EQ(json.at("format"), "gel.study-analysis.v1");
  ASSERT_EQ(json.at("ensembles").size(), 2u);
  for (std::size_t e = 0; e < 2; ++e) {
    const nlohmann::json& ensemble = json.at("ensembles")[e];
    EXPECT_EQ(ensemble.at("name"), study.jobs(static_cast<int>(e)).ensemble());
    EXPECT_EQ(ensemble.at("members"), 3);
    const auto curves = curve(study.jobs(static_cast<int>(e)).job_id());
    ASSERT_EQ(ensemble.at("rows").size(), 4u);
    for (int k = 0; k < 4; ++k) {
      double sum = 0;
      for (const auto& member : curves.members()) sum += member.curve().rows(k).p();
      const nlohmann::json& p = ensemble.at("rows")[static_cast<std::size_t>(k)].at("P");
      EXPECT_NEAR(p.at("value").get<double>(), sum / 3, 1e-12 * std::max(1.0, std::abs(sum))) << "k " << k;
      EXPECT_EQ(p.at("n"), 3);
    }
    ASSERT_TRUE(ensemble.at("fractal_dimension_initial").is_object()) << ensemble.dump();
    EXPECT_EQ(ensemble.at("fractal_dimension_initial").at("n"), 3);
  }
  // Stored once the study succeeded: the second call reads it back.
  gel::v1::GetStudyAnalysisResponse again;
  ASSERT_TRUE(stub_->GetStudyAnalysis(ctx().get(), analysis_request, &again).ok());
  EXPECT_TRUE(again.stored());
  EXPECT_EQ(again.json(), analysis.json());
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM study_analyses WHERE study_id = '" + id + "'"), 1);

  // Listed, newest first, and a second identical study comes from the run cache.
  gel::v1::SubmitStudyRequest repeat = two_bond_study(3, 3, "again");
  repeat.set_rerun(false);
  gel::v1::SubmitStudyResponse cached;
  ASSERT_TRUE(stub_->SubmitStudy(ctx().get(), repeat, &cached).ok());
  ASSERT_EQ(cached.study().jobs_size(), 2);
  EXPECT_TRUE(cached.study().jobs(0).cached());
  EXPECT_EQ(cached.study().jobs(0).job_id(), study.jobs(0).job_id());
  EXPECT_EQ(cached.study().state(), gel::v1::JOB_STATE_SUCCEEDED);
  gel::v1::ListStudiesRequest list_request;
  list_request.set_page_size(1);
  gel::v1::ListStudiesResponse page;
  ASSERT_TRUE(stub_->ListStudies(ctx().get(), list_request, &page).ok());
  ASSERT_EQ(page.studies_size(), 1);
  EXPECT_EQ(page.studies(0).id(), cached.study_id());
  ASSERT_FALSE(page.next_page_token().empty());
  list_request.set_page_token(page.next_page_token());
  ASSERT_TRUE(stub_->ListStudies(ctx().get(), list_request, &page).ok());
  ASSERT_EQ(page.studies_size(), 1);
  EXPECT_EQ(page.studies(0).id(), id);
  EXPECT_TRUE(page.next_page_token().empty());
  list_request.set_page_token("abc");
  const auto bad_token = stub_->ListStudies(ctx().get(), list_request, &page);
  EXPECT_EQ(bad_token.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(bad_token.error_message(), "page_token: not a token from a previous ListStudies");
}

TEST_F(Service, ABadStudyIsRefusedNamingTheFieldAndStoresNothing) {
  start({}, 1);
  auto refused = [&](const gel::v1::SubmitStudyRequest& request, grpc::StatusCode code, const std::string& text) {
    gel::v1::SubmitStudyResponse response;
    const auto status = stub_->SubmitStudy(ctx().get(), request, &response);
    EXPECT_EQ(status.error_code(), code) << status.error_message();
    EXPECT_NE(status.error_message().find(text), std::string::npos) << status.error_message();
  };
  gel::v1::SubmitStudyRequest bad_scene = two_bond_study(3, 2);
  bad_scene.mutable_ensembles(1)->set_scene_json(R"({"preset": "quick", "generator": {"lx": -5}})");
  refused(bad_scene, grpc::StatusCode::INVALID_ARGUMENT, "ensembles[1] (bond2): scene.generator.lx: must be positive");
  gel::v1::SubmitStudyRequest twice = two_bond_study(3, 2);
  twice.mutable_ensembles(1)->set_name("bond1");
  refused(twice, grpc::StatusCode::INVALID_ARGUMENT, "ensembles[1].name: 'bond1' appears twice");
  gel::v1::SubmitStudyRequest slash = two_bond_study(3, 2);
  slash.mutable_ensembles(0)->set_name("../x");
  refused(slash, grpc::StatusCode::INVALID_ARGUMENT, "ensembles[0].name");
  gel::v1::SubmitStudyRequest reserved = two_bond_study(3, 2);
  (*reserved.mutable_labels())["study"] = "mine";
  refused(reserved, grpc::StatusCode::INVALID_ARGUMENT, "labels: 'study' and 'ensemble'");
  gel::v1::SubmitStudyRequest both = two_bond_study(3, 2);
  both.set_preset("quick");
  refused(both, grpc::StatusCode::INVALID_ARGUMENT, "ensembles: give a preset or ensembles, not both");
  gel::v1::SubmitStudyRequest unknown;
  unknown.set_preset("nope");
  refused(unknown, grpc::StatusCode::INVALID_ARGUMENT, "preset: unknown study preset 'nope' (known: paper, small, quick)");
  unknown.set_preset("quick");
  unknown.set_fidelity("slowest");
  refused(unknown, grpc::StatusCode::INVALID_ARGUMENT, "compression.fidelity: unknown fidelity 'slowest'");
  refused(gel::v1::SubmitStudyRequest(), grpc::StatusCode::INVALID_ARGUMENT, "ensembles: a study needs a preset");
  gel::v1::SubmitStudyRequest too_many_seeds = two_bond_study(3, 2);
  too_many_seeds.set_seed_count(5000);
  refused(too_many_seeds, grpc::StatusCode::INVALID_ARGUMENT, "seed_count");
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM studies"), 0);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);

  gel::v1::GetStudyRequest missing;
  missing.set_study_id("study-999999");
  gel::v1::Study study;
  EXPECT_EQ(stub_->GetStudy(ctx().get(), missing, &study).error_code(), grpc::StatusCode::NOT_FOUND);
  missing.set_study_id("");
  EXPECT_EQ(stub_->GetStudy(ctx().get(), missing, &study).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(Service, CancellingAStudyCancelsItsJobsAndAnUnfinishedStudyIsNotAnalysed) {
  Script& script = make_script();
  script.rows = 4;
  script.open_rows = 1;
  start({}, 2, scripted(script));
  gel::v1::SubmitStudyResponse submitted;
  ASSERT_TRUE(stub_->SubmitStudy(ctx().get(), two_bond_study(3, 2), &submitted).ok());
  const std::string id = submitted.study_id();
  ASSERT_TRUE(wait_for([&] { return script.running.load() >= 1; }));
  gel::v1::GetStudyAnalysisRequest analysis_request;
  analysis_request.set_study_id(id);
  gel::v1::GetStudyAnalysisResponse analysis;
  auto status = stub_->GetStudyAnalysis(ctx().get(), analysis_request, &analysis);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_NE(status.error_message().find("partial = true"), std::string::npos) << status.error_message();

  gel::v1::CancelStudyRequest cancel;
  cancel.set_study_id(id);
  gel::v1::Study study;
  status = stub_->CancelStudy(ctx().get(), cancel, &study);
  ASSERT_TRUE(status.ok()) << status.error_message();
  gel::v1::GetStudyRequest get_request;
  get_request.set_study_id(id);
  ASSERT_TRUE(wait_for([&] {
    stub_->GetStudy(ctx().get(), get_request, &study);
    return study.state() == gel::v1::JOB_STATE_CANCELLED;
  })) << gel::v1::JobState_Name(study.state());
  for (const auto& entry : study.jobs()) EXPECT_EQ(get(entry.job_id()).state(), gel::v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(stub_->CancelStudy(ctx().get(), cancel, &study).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(Service, AStudyRefusedPartWayCancelsWhatItQueuedAndIsListedAsFailed) {
  Script& script = make_script();
  script.rows = 3;
  script.open_rows = 0;  // every member waits for the gate
  geld::Limits limits;
  limits.max_queue = 1;
  start(limits, 1, scripted(script));
  const std::string blocker = submit_ok(tiny_scene_json(), {});
  ASSERT_TRUE(wait_for([&] { return script.running.load() == 1; }));  // the one worker is busy
  gel::v1::SubmitStudyResponse submitted;
  const auto status = stub_->SubmitStudy(ctx().get(), two_bond_study(3, 1), &submitted);
  ASSERT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("was not started (its queued jobs are cancelled): queue full"), std::string::npos)
      << status.error_message();
  gel::v1::ListStudiesResponse listed;
  ASSERT_TRUE(stub_->ListStudies(ctx().get(), gel::v1::ListStudiesRequest(), &listed).ok());
  ASSERT_EQ(listed.studies_size(), 1);
  EXPECT_EQ(listed.studies(0).state(), gel::v1::JOB_STATE_FAILED);
  EXPECT_NE(listed.studies(0).error().find("only 1 of its 2 ensembles were submitted"), std::string::npos)
      << listed.studies(0).error();
  ASSERT_EQ(listed.studies(0).jobs_size(), 1);
  EXPECT_EQ(get(listed.studies(0).jobs(0).job_id()).state(), gel::v1::JOB_STATE_CANCELLED);
  script.open();
  watch(blocker);
  EXPECT_EQ(get(blocker).state(), gel::v1::JOB_STATE_SUCCEEDED);
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
    return std::make_unique<geld::Daemon>(options, geld::make_compression_engine(), geld::make_thread_executor());
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

TEST(Store, MigratesFromAnOlderSchemaVersion) {
  TempDir dir;
  const std::string path = (fs::path(dir.path()) / "geld.sqlite").string();
  std::string id;
  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), geld::Store::kSchemaVersion);
    gel::v1::Job job;
    job.set_name("old");
    job.add_seeds(7);
    job.set_particles(64);
    job.set_created_unix_ms(1);
    // Stored as before version 5: the submitted scene's seed, not the member's.
    id = store.insert_job(job, "{}", {{"generator.seed", "1", 1.0}, {"generator.lx", "30", 30.0}});
  }
  // Turn the file into a version 1 database: no indexes (v2), no member_runs table (v3), no
  // member_finished table (v4), no study tables (v6).
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    const char* sql =
        "DROP TABLE study_analyses; DROP TABLE study_jobs; DROP TABLE study_labels; DROP TABLE studies; "
        "DROP TABLE member_finished; DROP TABLE member_runs; DROP INDEX jobs_state; DROP INDEX jobs_name; DROP INDEX job_labels_kv; "
        "DROP INDEX parameters_name; DROP INDEX states_job; DROP INDEX logs_job; DROP INDEX events_job; "
        "UPDATE schema_version SET version = 1;";
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_close(db);
  }
  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), geld::Store::kSchemaVersion);
    auto job = store.get_job(id);
    ASSERT_TRUE(job.has_value());
    EXPECT_EQ(job->name(), "old");
    EXPECT_EQ(job->seeds(0), 7u);
    store.set_member_handle(id, 0, 7, "slurm", "1234:0", 2);
    EXPECT_EQ(store.member_handle(id, 0), "1234:0");
    EXPECT_EQ(store.member_handle(id, 1), "");
    EXPECT_TRUE(store.finished_members(id).empty());
    store.set_member_finished(id, 0, 3);
    EXPECT_EQ(store.finished_members(id), std::vector<int>{0});
    // Version 6: studies can be stored in the migrated file.
    gel::v1::Study study;
    study.set_name("migrated");
    study.mutable_request()->set_preset("quick");
    const std::string study_id = store.insert_study(study);
    store.add_study_job(study_id, 0, "bond1", id, false);
    ASSERT_TRUE(store.get_study(study_id).has_value());
    EXPECT_EQ(store.get_study(study_id)->jobs(0).job_id(), id);
  }
  // Version 5 holds the members' seeds as generator.seed (7), not the scene's (1); others stay.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT name, value_text FROM parameters ORDER BY name, value_text", -1, &stmt, nullptr), SQLITE_OK);
    std::vector<std::string> rows;
    while (sqlite3_step(stmt) == SQLITE_ROW)
      rows.push_back(std::string(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0))) + "=" +
                     reinterpret_cast<const char*>(sqlite3_column_text(stmt, 1)));
    sqlite3_finalize(stmt);
    sqlite3_close(db);
    EXPECT_EQ(rows, (std::vector<std::string>{"generator.lx=30", "generator.seed=7"}));
  }
  // A newer schema than this geld knows is refused.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE schema_version SET version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    EXPECT_THROW(geld::Store store(path), geld::StoreError);
  }
}

TEST(Store, WalModeAndSchemaTables) {
  TempDir dir;
  const std::string path = (fs::path(dir.path()) / "geld.sqlite").string();
  geld::Store store(path);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0))), "wal");
  sqlite3_finalize(stmt);
  for (const char* table : {"schema_version", "jobs", "job_labels", "states", "parameters", "curve_rows", "events",
                            "logs", "member_runs", "member_finished", "studies", "study_labels", "study_jobs",
                            "study_analyses"}) {
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?", -1, &stmt,
                                 nullptr),
              SQLITE_OK);
    sqlite3_bind_text(stmt, 1, table, -1, SQLITE_STATIC);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(stmt, 0), 1) << table;
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
}

TEST(Address, LoopbackDetection) {
  EXPECT_TRUE(geld::is_loopback_address("127.0.0.1:50051"));
  EXPECT_TRUE(geld::is_loopback_address("127.1.2.3:1"));
  EXPECT_TRUE(geld::is_loopback_address("localhost:50051"));
  EXPECT_TRUE(geld::is_loopback_address("[::1]:50051"));
  EXPECT_FALSE(geld::is_loopback_address("0.0.0.0:50051"));
  EXPECT_FALSE(geld::is_loopback_address("[::]:50051"));
  EXPECT_FALSE(geld::is_loopback_address("192.168.1.2:50051"));
  EXPECT_FALSE(geld::is_loopback_address("example.org:50051"));
}

}  // namespace
