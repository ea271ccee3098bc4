// The shared fixture of the service tests (see service_fixture.hpp).
#include "service_fixture.hpp"

#include <sqlite3.h>
#include <stdlib.h>

#include <cstdlib>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

namespace geld_test {
namespace {

// The daemon's log lines only when asked for (GEL_TEST_LOG=1).
const bool kQuiet = [] {
  spdlog::set_level(std::getenv("GEL_TEST_LOG") ? spdlog::level::info : spdlog::level::warn);
  return true;
}();

}  // namespace

std::string tiny_scene_json(int steps, const std::string& fidelity) {
  nlohmann::json scene = {{"preset", "quick"},
                          {"generator", {{"n_floc", 8}, {"n_clusters", 8}, {"lx", 30}, {"ly", 50}}},
                          {"compression", {{"fidelity", fidelity}, {"steps", steps}}}};
  return scene.dump();
}

TempDir::TempDir() {
  std::string pattern = (fs::temp_directory_path() / "geld-test.XXXXXX").string();
  path_ = mkdtemp(pattern.data());
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

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

void Script::open() {
  std::lock_guard lock(mutex);
  gate_open = true;
  cv.notify_all();
}

geld::RunResult Script::run(const geld::RunContext& ctx) {
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

int count_kind(const std::vector<JobUpdate>& updates, JobUpdate::Kind kind) {
  int n = 0;
  for (const auto& u : updates) n += u.kind() == kind;
  return n;
}

void Service::start(const DaemonSetup& setup) {
  geld::DaemonOptions options;
  options.listen = setup.listen;
  options.token = setup.token;
  options.manager.data_dir = dir_.path();
  options.manager.workers = setup.workers.value;
  options.manager.limits = setup.limits;
  std::shared_ptr<geld::Executor> executor = setup.executor ? setup.executor : geld::make_thread_executor();
  std::shared_ptr<geld::GelcoreAdapter> gelcore = setup.gelcore ? setup.gelcore : geld::make_gelcore_adapter();
  daemon_ = std::make_unique<geld::Daemon>(options, gelcore, executor);
  daemon_->start();
  channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(daemon_->port()), grpc::InsecureChannelCredentials());
  stub_ = gel::v1::GelService::NewStub(channel_);
}

void Service::stop() {
  if (daemon_) daemon_->shutdown();
  daemon_.reset();
}

std::shared_ptr<geld::Executor> Service::scripted(Script& script) {
  return std::make_shared<FnExecutor>([&script](const geld::RunContext& ctx) { return script.run(ctx); });
}

std::unique_ptr<grpc::ClientContext> Service::ctx(const std::string& token) {
  auto c = std::make_unique<grpc::ClientContext>();
  if (!token.empty()) c->AddMetadata("authorization", "Bearer " + token);
  c->set_deadline(std::chrono::system_clock::now() + 60s);
  return c;
}

grpc::Status Service::submit(const std::string& scene_json, const SubmitOptions& options, std::string* id) {
  gel::v1::SubmitJobRequest request;
  request.set_scene_json(scene_json);
  request.set_rerun(options.rerun.value);
  for (auto s : options.seeds) request.add_seeds(s);
  request.set_name(options.name);
  for (const auto& [k, v] : options.labels) (*request.mutable_labels())[k] = v;
  gel::v1::SubmitJobResponse response;
  auto status = stub_->SubmitJob(ctx().get(), request, &response);
  if (id) *id = response.job_id();
  return status;
}

std::string Service::submit_ok(const std::string& scene_json, const SubmitOptions& options) {
  std::string id;
  auto status = submit(scene_json, options, &id);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return id;
}

gel::v1::Job Service::get(const std::string& id) {
  gel::v1::GetJobRequest request;
  request.set_job_id(id);
  gel::v1::Job job;
  auto status = stub_->GetJob(ctx().get(), request, &job);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return job;
}

std::vector<JobUpdate> Service::watch(const std::string& id, grpc::Status* status,
                                      const std::function<bool(const JobUpdate&)>& on_update) {
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

bool Service::wait_for(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (condition()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return condition();
}

gel::v1::GetCurveResponse Service::curve(const std::string& id) {
  gel::v1::GetCurveRequest request;
  request.set_job_id(id);
  gel::v1::GetCurveResponse response;
  auto status = stub_->GetCurve(ctx().get(), request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

int Service::sqlite_count(const std::string& sql) {
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

}  // namespace geld_test
