#pragma once
// What geld's service tests (tests/service/test_*.cpp, one binary: service_tests) share: a real
// geld per test (a gRPC server on a loopback port, a real SQLite file in a temporary directory),
// started with named options; clients for its calls; and test doubles of the engine run, never
// of gRPC or SQLite. Physics runs through the real compression engine on tiny scenes; queue
// behaviour (blocking, concurrency, cancellation, limits) uses a plain callable executor.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include "executor.hpp"
#include "gelcore_adapter.hpp"
#include "gel/v1/service.grpc.pb.h"
#include "job_manager.hpp"
#include "service.hpp"

namespace geld_test {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using gel::v1::JobState;
using gel::v1::JobUpdate;

// A 64-particle quick scene with the fast protocol: well under a second in Release.
std::string tiny_scene_json(int steps = 3, const std::string& fidelity = "fast");

// A field the call site must give: with no default constructor, a designated initializer that
// leaves it out does not compile. (A helper that set `rerun` silently was a trap for the next
// run-cache test.)
template <typename T>
struct Required {
  Required(T v) : value(v) {}  // implicit on purpose: `.rerun = true`, `.workers = 1`
  T value;
};

class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
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

// Row k of a made-up curve: phi = 0.1 + 0.05 k, P = seed * k.
gel::v1::CurveRow make_row(int k, double seed);

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

  void open();
  geld::RunResult run(const geld::RunContext& ctx);
};

// How a test's geld starts, every choice named at the call site:
//   start({.workers = 1, .limits = limits, .executor = scripted(script)}).
// Fields in this order (designated initializers follow it).
struct DaemonSetup {
  Required<int> workers;                               // how many members run at once
  geld::Limits limits = {};                            // geld's defaults
  std::shared_ptr<geld::Executor> executor = nullptr;  // null: the real thread executor
  std::shared_ptr<geld::GelcoreAdapter> gelcore = nullptr;  // null: the real gelcore adapter
  std::string listen = "127.0.0.1:0";                  // loopback, any free port
  std::string token = "";                              // remote mode's bearer token
};

// What a SubmitJob carries besides the scene, named at the call site:
//   submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2}, .name = "a"}).
struct SubmitOptions {
  // SubmitJobRequest.rerun. true: a new job even when the same scene, seeds and program already
  // succeeded (what most tests want, as they submit alike scenes); false: the run cache may
  // answer with the earlier job. No default: each test says which.
  Required<bool> rerun;
  std::vector<std::uint64_t> seeds = {};  // none: the scene's own seed
  std::string name = "";
  std::map<std::string, std::string> labels = {};
};

int count_kind(const std::vector<JobUpdate>& updates, JobUpdate::Kind kind);

class Service : public ::testing::Test {
 protected:
  void start(const DaemonSetup& setup);
  void stop();
  void TearDown() override { stop(); }

  // Scripts live as long as the fixture, so workers still inside one at the end of a test
  // (stopped in TearDown) never see it destroyed.
  Script& make_script() { return *scripts_.emplace_back(std::make_unique<Script>()); }
  std::shared_ptr<geld::Executor> scripted(Script& script);

  // A client context with a 60 s deadline, and the bearer token if one is given.
  std::unique_ptr<grpc::ClientContext> ctx(const std::string& token = "");

  grpc::Status submit(const std::string& scene_json, const SubmitOptions& options, std::string* id);
  std::string submit_ok(const std::string& scene_json, const SubmitOptions& options);
  gel::v1::Job get(const std::string& id);
  gel::v1::GetCurveResponse curve(const std::string& id);

  // Watches until the stream ends; `on_update` may return false to stop reading early.
  std::vector<JobUpdate> watch(const std::string& id, grpc::Status* status = nullptr,
                               const std::function<bool(const JobUpdate&)>& on_update = nullptr);

  bool wait_for(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 60s);

  // The first column of the first row of `sql` on the daemon's SQLite file, read-only.
  int sqlite_count(const std::string& sql);

  TempDir dir_;
  std::vector<std::unique_ptr<Script>> scripts_;
  std::unique_ptr<geld::Daemon> daemon_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<gel::v1::GelService::Stub> stub_;
};

}  // namespace geld_test
