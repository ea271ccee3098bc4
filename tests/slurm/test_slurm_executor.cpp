// The Slurm executor's pieces (no Slurm needed: suite SlurmPieces) and the executor itself
// against a real single-node Slurm started by tests/slurm/slurm_cluster.sh with a fake gelsim
// (suite SlurmCluster; skipped with a message where the cluster cannot start, e.g. not root).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "gel/curve_io.hpp"
#include "gel/progress_file.hpp"
#include "slurm_executor.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using geld::slurm::Phase;

#ifndef GEL_SOURCE_DIR
#error "GEL_SOURCE_DIR must name the source tree"
#endif

namespace {

fs::path temp_dir(const std::string& tag) {
  fs::path dir = fs::temp_directory_path() / ("gel-slurm-" + tag + "-" + std::to_string(::getpid()) + "-" +
                                              std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  fs::create_directories(dir);
  return dir;
}

void append(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::app | std::ios::binary);
  out << text;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
TEST(SlurmPieces, ShellQuote) {
  EXPECT_EQ(geld::slurm::shell_quote("plain"), "'plain'");
  EXPECT_EQ(geld::slurm::shell_quote("a b;$(rm -rf /)"), "'a b;$(rm -rf /)'");
  EXPECT_EQ(geld::slurm::shell_quote("it's"), "'it'\\''s'");
  // The shell gives back exactly the argument.
  const std::string nasty = "x'y \"z\" $HOME `id` \\ \n end";
  auto result = geld::slurm::run_command({"sh", "-c", "printf %s " + geld::slurm::shell_quote(nasty)}, 10s);
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.out, nasty);
}

TEST(SlurmPieces, RunCommandCapturesBothStreamsAndExitCode) {
  auto result = geld::slurm::run_command({"sh", "-c", "echo out; echo err >&2; exit 7"}, 10s);
  EXPECT_EQ(result.exit_code, 7);
  EXPECT_EQ(result.out, "out\n");
  EXPECT_EQ(result.err, "err\n");
  EXPECT_FALSE(result.timed_out);
  // Arguments are passed as they are, no shell in between.
  result = geld::slurm::run_command({"printf", "%s|", "a b", "$HOME", ";"}, 10s);
  EXPECT_EQ(result.out, "a b|$HOME|;|");
}

TEST(SlurmPieces, RunCommandTimesOutAndReportsMissingBinaries) {
  const auto start = std::chrono::steady_clock::now();
  auto result = geld::slurm::run_command({"sleep", "30"}, 300ms);
  EXPECT_TRUE(result.timed_out);
  EXPECT_EQ(result.exit_code, -1);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
  EXPECT_THROW(geld::slurm::run_command({"/nonexistent/sbatch"}, 1s), std::runtime_error);
  // posix_spawnp of a missing name: the child fails; either way no hang and no success.
  bool failed = false;
  try {
    failed = geld::slurm::run_command({"no-such-binary-for-gel"}, 1s).exit_code != 0;
  } catch (const std::runtime_error&) {
    failed = true;
  }
  EXPECT_TRUE(failed);
}

TEST(SlurmPieces, StateMapping) {
  EXPECT_EQ(geld::slurm::phase_of("PENDING"), Phase::Queued);
  EXPECT_EQ(geld::slurm::phase_of("REQUEUED"), Phase::Queued);
  EXPECT_EQ(geld::slurm::phase_of("RUNNING"), Phase::Running);
  EXPECT_EQ(geld::slurm::phase_of("COMPLETING"), Phase::Running);
  EXPECT_EQ(geld::slurm::phase_of("COMPLETED"), Phase::Completed);
  EXPECT_EQ(geld::slurm::phase_of("FAILED"), Phase::Failed);
  EXPECT_EQ(geld::slurm::phase_of("OUT_OF_MEMORY"), Phase::Failed);
  EXPECT_EQ(geld::slurm::phase_of("CANCELLED"), Phase::Cancelled);
  EXPECT_EQ(geld::slurm::phase_of("CANCELLED by 0"), Phase::Cancelled);
  EXPECT_EQ(geld::slurm::phase_of("TIMEOUT"), Phase::Requeue);
  EXPECT_EQ(geld::slurm::phase_of("NODE_FAIL"), Phase::Requeue);
  EXPECT_EQ(geld::slurm::phase_of("PREEMPTED"), Phase::Requeue);
  EXPECT_EQ(geld::slurm::phase_of("BOOT_FAIL"), Phase::Requeue);
  EXPECT_EQ(geld::slurm::phase_of("WHATEVER"), Phase::Unknown);
}

TEST(SlurmPieces, LineFollowerWaitsForNewlinesAndRestartsOnTruncation) {
  const fs::path dir = temp_dir("follow");
  const fs::path file = dir / "progress.jsonl";
  geld::slurm::LineFollower follower(file.string());
  EXPECT_TRUE(follower.poll().empty());  // no file yet
  append(file, "{\"a\":1}\n{\"b\":");
  auto lines = follower.poll();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "{\"a\":1}");
  EXPECT_TRUE(follower.poll().empty());  // the partial line waits
  append(file, "2}\n\n{\"c\":3}\n");
  lines = follower.poll();
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "{\"b\":2}");
  EXPECT_EQ(lines[1], "{\"c\":3}");
  {
    std::ofstream out(file, std::ios::trunc);
    out << "{\"d\":4}\n";
  }
  lines = follower.poll();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "{\"d\":4}");
  fs::remove_all(dir);
}

TEST(SlurmPieces, ParsesProgressRowsAndOutcomes) {
  using gel::ProgressLine;
  auto p = gel::parse_progress_line(
      R"({"type":"progress","progress":{"k":2,"kTotal":5,"phi":0.3,"target_phi":0.31,"remainingSeconds":-1,"phase":"compressing"}})");
  EXPECT_EQ(p.kind, ProgressLine::Progress);
  EXPECT_EQ(p.progress.k(), 2);
  EXPECT_EQ(p.progress.k_total(), 5);
  EXPECT_DOUBLE_EQ(p.progress.target_phi(), 0.31);
  EXPECT_EQ(p.progress.phase(), "compressing");
  // What gelsim compress writes: flat, "P" for the pressure.
  p = gel::parse_progress_line(
      R"({"type":"progress","phase":"compressing","k":1,"k_total":8,"phi":0.2,"target_phi":0.25,"P":0.125,)"
      R"("events":{"normal":3,"sliding":1,"rolling":2,"created":4},"steps":1000,"elapsed_seconds":1.5,"remaining_seconds":9.0})");
  EXPECT_EQ(p.kind, ProgressLine::Progress);
  EXPECT_EQ(p.progress.k_total(), 8);
  EXPECT_DOUBLE_EQ(p.progress.p(), 0.125);
  EXPECT_EQ(p.progress.events().created(), 4);
  EXPECT_EQ(p.progress.steps(), 1000);
  // Flat progress, unknown fields ignored.
  p = gel::parse_progress_line(R"({"type":"progress","k":3,"phi":0.4,"future_field":1})");
  EXPECT_EQ(p.kind, ProgressLine::Progress);
  EXPECT_EQ(p.progress.k(), 3);

  gel::v1::CurveRow row;
  row.set_k(4);
  row.set_phi(0.123456789012345678);
  row.set_target_phi(0.12);
  row.set_p(1.0 / 3.0);
  row.set_p_top(0.25);
  row.set_p_bot(0.5);
  row.set_contact_number(3.25);
  row.mutable_ruptures()->set_normal(7);
  nlohmann::json line = {{"type", "row"}, {"row", gel::curve_row_to_json(row)}};
  p = gel::parse_progress_line(line.dump());
  EXPECT_EQ(p.kind, ProgressLine::Row);
  EXPECT_EQ(p.row.k(), 4);
  EXPECT_EQ(p.row.phi(), row.phi());  // bit for bit
  EXPECT_EQ(p.row.p(), row.p());
  EXPECT_EQ(p.row.ruptures().normal(), 7);
  nlohmann::json flat = gel::curve_row_to_json(row);  // what gelsim compress writes
  flat["type"] = "row";
  p = gel::parse_progress_line(flat.dump());
  EXPECT_EQ(p.kind, ProgressLine::Row);
  EXPECT_EQ(p.row.phi(), row.phi());
  EXPECT_EQ(p.row.p_bot(), 0.5);
  p = gel::parse_progress_line(R"({"type":"row","k":5,"phi":0.5,"pTop":1.5,"contact_number":2})");
  EXPECT_EQ(p.kind, ProgressLine::Row);
  EXPECT_EQ(p.row.k(), 5);
  EXPECT_DOUBLE_EQ(p.row.p_top(), 1.5);
  EXPECT_DOUBLE_EQ(p.row.contact_number(), 2.0);

  EXPECT_EQ(gel::parse_progress_line(R"({"type":"done"})").kind, ProgressLine::Done);
  p = gel::parse_progress_line(R"({"type":"failed","kind":"instability","error":"boom"})");
  EXPECT_EQ(p.kind, ProgressLine::Failed);
  EXPECT_EQ(p.error, "numerical instability: boom");  // as gelsim and the threads executor say it
  p = gel::parse_progress_line(R"({"type":"failed","kind":"error","error":"disk on fire"})");
  EXPECT_EQ(p.error, "disk on fire");
  EXPECT_EQ(gel::parse_progress_line(R"({"type":"log","message":"x"})").kind, ProgressLine::Other);
  EXPECT_EQ(gel::parse_progress_line(R"({"type":"stopped","out":"d","rows":2})").kind, ProgressLine::Other);
  EXPECT_THROW(gel::parse_progress_line("{\"type\":\"row\""), std::runtime_error);
  EXPECT_THROW(gel::parse_progress_line(R"({"type":"row","k":"many"})"), std::runtime_error);
}

TEST(SlurmPieces, OptionsFromSettings) {
  geld::ExecutorConfig config;
  config.name = "slurm";
  config.gelsim_path = "/opt/gel/bin/gelsim";
  const fs::path shared = temp_dir("opts") / "shared";
  config.settings = {{"shared-dir", shared.string()},
                     {"sbatch-args", "--partition=gel  --time=10"},
                     {"max-requeues", "5"},
                     {"poll-interval", "0.25"}};
  const auto options = geld::SlurmOptions::from_config(config);
  EXPECT_EQ(options.gelsim, "/opt/gel/bin/gelsim");
  EXPECT_EQ(options.shared_dir, shared.string());
  EXPECT_TRUE(fs::is_directory(shared));
  ASSERT_EQ(options.sbatch_args.size(), 2u);
  EXPECT_EQ(options.sbatch_args[1], "--time=10");
  EXPECT_EQ(options.max_requeues, 5);
  EXPECT_DOUBLE_EQ(options.poll_seconds, 0.25);
  config.settings = {{"max-requeues", "-1"}};
  EXPECT_THROW(geld::SlurmOptions::from_config(config), std::invalid_argument);
  config.settings = {{"poll-interval", "fast"}};
  EXPECT_THROW(geld::SlurmOptions::from_config(config), std::invalid_argument);
  config.settings = {{"shared-dir", "relative/dir"}};
  EXPECT_THROW(geld::SlurmOptions::from_config(config), std::invalid_argument);
  config.settings = {{"partition", "x"}};
  EXPECT_THROW(geld::SlurmOptions::from_config(config), std::invalid_argument);
  fs::remove_all(shared.parent_path());
}

// ---------------------------------------------------------------------------------------------
// Against a real Slurm.

class SlurmCluster : public ::testing::Test {
 protected:
  static inline fs::path cluster_dir;
  static inline std::string skip_reason;

  static void SetUpTestSuite() {
    cluster_dir = temp_dir("cluster");
    const std::string script = std::string(GEL_SOURCE_DIR) + "/tests/slurm/slurm_cluster.sh";
    auto result = geld::slurm::run_command({"bash", script, "start", cluster_dir.string()}, 120s);
    if (result.exit_code == 77) {
      skip_reason = result.err;
      return;
    }
    if (result.exit_code != 0) {
      skip_reason = "";
      FAIL() << "slurm_cluster.sh start failed: " << result.out << result.err;
    }
    ::setenv("SLURM_CONF", (cluster_dir / "slurm.conf").c_str(), 1);
  }
  static void TearDownTestSuite() {
    const std::string script = std::string(GEL_SOURCE_DIR) + "/tests/slurm/slurm_cluster.sh";
    geld::slurm::run_command({"bash", script, "stop", cluster_dir.string()}, 120s);
    fs::remove_all(cluster_dir);
  }
  void SetUp() override {
    // scripts/test.sh (and so CI) sets GEL_REQUIRE_SLURM=1: there a cluster that cannot start is a
    // failure, not a skip that hides every test below.
    const char* require = std::getenv("GEL_REQUIRE_SLURM");
    if (!skip_reason.empty() && require && std::string(require) == "1")
      FAIL() << "GEL_REQUIRE_SLURM=1 but the test cluster cannot start: " << skip_reason;
    if (!skip_reason.empty()) GTEST_SKIP() << skip_reason;
    if (!fs::exists(cluster_dir / "slurm.conf")) GTEST_SKIP() << "no cluster";
    shared_ = cluster_dir / "shared";
    fs::create_directories(shared_);
  }

  geld::SlurmOptions options() const {
    geld::SlurmOptions o;
    o.shared_dir = shared_.string();
    o.gelsim = std::string(GEL_SOURCE_DIR) + "/tests/slurm/fake_gelsim.sh";
    o.poll_seconds = 0.1;
    return o;
  }

  // A context whose callbacks record what they get.
  struct Recorder {
    std::mutex mutex;
    std::vector<gel::v1::CurveRow> rows;
    std::vector<gel::v1::Progress> progress;
    std::vector<std::string> handles;
    std::vector<std::string> logs;
    std::atomic<bool> stop{false}, cancel{false};
  };
  geld::RunContext context(Recorder& r, const std::string& job, const std::string& mode, int member = 0) const {
    geld::RunContext ctx;
    ctx.job_id = job;
    ctx.member = member;
    ctx.seed = 1;
    ctx.scene_json = "{\"mode\": \"" + mode + "\"}";
    ctx.out_dir = "/nonexistent/data/jobs/" + job + "/m" + std::to_string(member) + "-seed1";
    ctx.stop = &r.stop;
    ctx.cancel = &r.cancel;
    ctx.save_handle = [&r](const std::string& h) {
      std::lock_guard lock(r.mutex);
      r.handles.push_back(h);
    };
    ctx.on_row = [&r](const gel::v1::CurveRow& row) {
      std::lock_guard lock(r.mutex);
      r.rows.push_back(row);
    };
    ctx.on_progress = [&r](const gel::v1::Progress& p) {
      std::lock_guard lock(r.mutex);
      r.progress.push_back(p);
    };
    ctx.log = [&r](const std::string& level, const std::string& message) {
      std::lock_guard lock(r.mutex);
      r.logs.push_back(level + ": " + message);
    };
    return ctx;
  }
  fs::path member_dir(const std::string& job, int member = 0) const {
    // Appended piecewise: GCC 12's -Wrestrict misfires on "m" + std::to_string(...) here.
    std::string leaf = "m";
    leaf += std::to_string(member);
    leaf += "-seed1";
    return shared_ / job / leaf;
  }
  static std::string squeue_state(const std::string& id) {
    auto r = geld::slurm::run_command({"squeue", "-h", "-t", "all", "-j", id, "-o", "%T"}, 30s);
    return r.out.substr(0, r.out.find('\n'));
  }
  static std::string slurm_id(const std::string& handle) { return handle.substr(0, handle.find(':')); }

  fs::path shared_;
};

TEST_F(SlurmCluster, RunsAMemberAndStreamsItsRows) {
  // A curve.json for the member (what gelsim writes) next to it, for the fake to copy.
  gel::v1::Curve curve;
  for (int k = 1; k <= 3; ++k) {
    auto* row = curve.add_rows();
    row->set_k(k);
    row->set_phi(0.3 + 0.01 * k);
  }
  curve.set_program_version("fake");
  fs::create_directories(shared_ / "jobA");
  gel::write_curve(curve, (shared_ / "jobA").string());
  fs::rename(shared_ / "jobA" / "curve.json", shared_ / "jobA" / "curve-template.json");

  Recorder r;
  auto executor = geld::make_slurm_executor(options());
  EXPECT_EQ(executor->name(), "slurm");
  const auto result = executor->run(context(r, "jobA", "ok"));
  EXPECT_TRUE(result.finished);
  EXPECT_FALSE(result.stopped);
  EXPECT_EQ(result.curve.program_version(), "fake");  // from curve.json
  ASSERT_EQ(result.curve.rows_size(), 3);
  ASSERT_EQ(r.rows.size(), 3u);
  EXPECT_EQ(r.rows[0].k(), 1);
  EXPECT_DOUBLE_EQ(r.rows[0].p_top(), 1.25);
  EXPECT_EQ(r.rows[2].k(), 3);
  ASSERT_EQ(r.progress.size(), 2u);  // the split line arrived whole
  EXPECT_EQ(r.progress[1].k(), 2);
  EXPECT_EQ(r.progress[1].k_total(), 3);
  ASSERT_EQ(r.handles.size(), 1u);
  EXPECT_EQ(r.handles[0].substr(r.handles[0].find(':')), ":0");
  EXPECT_TRUE(fs::exists(member_dir("jobA") / "scene.json"));
  EXPECT_TRUE(fs::exists(member_dir("jobA") / ("slurm-" + slurm_id(r.handles[0]) + ".out")));
}

TEST_F(SlurmCluster, WithoutCurveJsonTheStreamedRowsAreTheCurve) {
  Recorder r;
  const auto result = geld::make_slurm_executor(options())->run(context(r, "jobB", "ok"));
  ASSERT_TRUE(result.finished);
  ASSERT_EQ(result.curve.rows_size(), 3);
  EXPECT_DOUBLE_EQ(result.curve.rows(2).phi(), 0.33);
}

TEST_F(SlurmCluster, FailedLineBecomesTheError) {
  Recorder r;
  try {
    geld::make_slurm_executor(options())->run(context(r, "jobC", "fail"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("phi_max: must exceed phi0"), std::string::npos) << e.what();
  }
}

TEST_F(SlurmCluster, CrashWithoutOutcomeReportsSlurmStateAndOutputTail) {
  Recorder r;
  try {
    geld::make_slurm_executor(options())->run(context(r, "jobD", "crash"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("FAILED"), std::string::npos) << what;
    EXPECT_NE(what.find("numerical instability"), std::string::npos) << what;
  }
}

TEST_F(SlurmCluster, CancelRunsScancel) {
  Recorder r;
  auto executor = geld::make_slurm_executor(options());
  std::thread canceller([&r] {
    for (int i = 0; i < 300; ++i) {
      {
        std::lock_guard lock(r.mutex);
        if (!r.progress.empty()) break;
      }
      std::this_thread::sleep_for(50ms);
    }
    r.cancel = true;
    r.stop = true;
  });
  const auto result = executor->run(context(r, "jobE", "slow"));
  canceller.join();
  EXPECT_TRUE(result.stopped);
  EXPECT_FALSE(result.finished);
  ASSERT_EQ(r.handles.size(), 1u);
  const std::string id = slurm_id(r.handles[0]);
  std::string state;
  for (int i = 0; i < 100; ++i) {
    state = squeue_state(id);
    if (state == "CANCELLED") break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(state, "CANCELLED");
}

TEST_F(SlurmCluster, ShutdownLeavesTheJobRunningAndTheNextRunFollowsIt) {
  Recorder first;
  auto executor = geld::make_slurm_executor(options());
  std::thread stopper([&first] {
    std::this_thread::sleep_for(1s);
    first.stop = true;  // shutdown: stop without cancel
  });
  const auto stopped = executor->run(context(first, "jobF", "wait"));
  stopper.join();
  EXPECT_TRUE(stopped.stopped);
  ASSERT_EQ(first.handles.size(), 1u);
  const std::string id = slurm_id(first.handles[0]);
  const std::string state = squeue_state(id);
  EXPECT_TRUE(state == "RUNNING" || state == "PENDING") << state;

  // "geld restarts": a new executor, the saved handle.
  Recorder second;
  auto ctx = context(second, "jobF", "wait");
  ctx.handle = first.handles[0];
  std::ofstream(member_dir("jobF") / "go") << "go";
  const auto result = geld::make_slurm_executor(options())->run(ctx);
  EXPECT_TRUE(result.finished);
  EXPECT_TRUE(second.handles.empty()) << "resubmitted instead of following " << id;
  EXPECT_EQ(second.rows.size(), 3u);
}

TEST_F(SlurmCluster, AStaleHandleResubmitsFromTheCheckpoint) {
  // The saved id is unknown to Slurm now (state wiped, ids restarted): the member continues
  // from its checkpoint with --resume.
  Recorder r;
  auto ctx = context(r, "jobG", "timeout");
  fs::create_directories(member_dir("jobG"));
  std::ofstream(member_dir("jobG") / "scene.json") << ctx.scene_json;
  std::ofstream(member_dir("jobG") / "checkpoint.bin") << "checkpoint";
  ctx.handle = "987654:0";
  const auto result = geld::make_slurm_executor(options())->run(ctx);
  EXPECT_TRUE(result.finished);
  ASSERT_EQ(r.handles.size(), 1u);
  EXPECT_EQ(r.handles[0].substr(r.handles[0].find(':')), ":1");
  EXPECT_EQ(r.rows.size(), 2u);  // rows 2 and 3 after the resume
}

TEST_F(SlurmCluster, AFreshMemberResumesOnlyACheckpointOfItsOwnScene) {
  // Another job's checkpoint at this member's path (a second geld on the same shared folder
  // numbers its jobs from 1 too): refused before anything is submitted, and left untouched.
  Recorder foreign;
  auto ctx = context(foreign, "jobJ", "timeout");
  fs::create_directories(member_dir("jobJ"));
  std::ofstream(member_dir("jobJ") / "scene.json") << "{\"mode\": \"ok\", \"seed\": 7}";
  std::ofstream(member_dir("jobJ") / "checkpoint.bin") << "checkpoint";
  try {
    geld::make_slurm_executor(options())->run(ctx);
    ADD_FAILURE() << "a foreign checkpoint was resumed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("different scene"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(foreign.handles.empty());
  EXPECT_TRUE(fs::exists(member_dir("jobJ") / "checkpoint.bin"));

  // Its own scene's checkpoint (geld stopped before it saved the handle): resumed.
  std::ofstream(member_dir("jobJ") / "scene.json") << ctx.scene_json;
  Recorder own;
  ctx = context(own, "jobJ", "timeout");
  const auto result = geld::make_slurm_executor(options())->run(ctx);
  EXPECT_TRUE(result.finished);
  ASSERT_EQ(own.handles.size(), 1u);
  EXPECT_EQ(own.rows.size(), 2u);  // rows 2 and 3: it ran with --resume
}

TEST_F(SlurmCluster, TimeoutRequeuesWithResume) {
  // Slurm's time limits are whole minutes: this test takes 1-2 minutes, in every run, because it
  // is the only one in which Slurm itself ends a job and the executor resumes it.
  Recorder r;
  auto o = options();
  o.sbatch_args = {"--time=1"};
  const auto result = geld::make_slurm_executor(o)->run(context(r, "jobH", "timeout"));
  EXPECT_TRUE(result.finished);
  ASSERT_EQ(r.handles.size(), 2u);
  EXPECT_EQ(squeue_state(slurm_id(r.handles[0])), "TIMEOUT");
  EXPECT_EQ(r.rows.size(), 3u);
}

TEST_F(SlurmCluster, RequeuesAreBounded) {
  Recorder r;
  auto o = options();
  o.max_requeues = 0;
  auto ctx = context(r, "jobI", "ok");
  ctx.handle = "987655:0";  // unknown to Slurm, no outcome, and no requeue allowed
  fs::create_directories(member_dir("jobI"));
  EXPECT_THROW(geld::make_slurm_executor(o)->run(ctx), std::runtime_error);
}
