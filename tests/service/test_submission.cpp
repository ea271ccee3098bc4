// Submission: a job from a scene, what it records, the run cache that answers an identical
// submission with the job that already ran, and the resource budgets that refuse a job.
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/resources.hpp"
#include "service_fixture.hpp"

namespace geld_test {
namespace {

TEST_F(Service, SubmitWatchSucceedsWithRowsStreamedAndStored) {
  start({.workers = 2});
  const std::string id = submit_ok(tiny_scene_json(),
                                   {.rerun = true, .name = "tiny", .labels = {{"suite", "service"}}});
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

TEST_F(Service, QueueFullIsResourceExhausted) {
  Script& script = make_script();
  script.rows = 2;
  script.open_rows = 1;
  geld::Limits limits;
  limits.max_queue = 2;
  start({.workers = 1, .limits = limits, .executor = scripted(script)});
  const std::string first = submit_ok(tiny_scene_json(), {.rerun = true});
  ASSERT_TRUE(wait_for([&] { return get(first).state() == gel::v1::JOB_STATE_RUNNING; }));
  submit_ok(tiny_scene_json(), {.rerun = true});
  submit_ok(tiny_scene_json(), {.rerun = true});
  std::string id;
  auto status = submit(tiny_scene_json(), {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("queue full"), std::string::npos) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 3);  // nothing stored for the refused one
  script.open();
}

TEST_F(Service, TooManyParticlesIsResourceExhausted) {
  geld::Limits limits;
  limits.max_particles = 100;
  start({.workers = 2, .limits = limits});
  std::string id;
  auto status = submit("{\"preset\": \"quick\"}", {.rerun = true}, &id);  // 256 particles
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("256 particles"), std::string::npos) << status.error_message();
  status = submit("{\"preset\": \"quick\", \"generator\": {\"n_floc\": 1073741824, \"n_clusters\": 2000000000}}",
                  {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("scene.generator", 0), 0u);
  status = submit("{\"preset\": \"quick\", \"generator\": {\"n_floc\": 1073741824}}", {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_FALSE(submit_ok(tiny_scene_json(), {.rerun = true}).empty());  // 64 particles: fine
  gel::v1::SubmitJobRequest many;
  many.set_scene_json(tiny_scene_json());
  for (int i = 0; i < 1001; ++i) many.add_seeds(static_cast<std::uint64_t>(i) + 1);
  gel::v1::SubmitJobResponse response;
  EXPECT_EQ(stub_->SubmitJob(ctx().get(), many, &response).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

// What a job's scene will hold and cost is estimated at submission and refused over a budget,
// naming the field that drives the estimate; the estimate comes back with an admitted job.
TEST_F(Service, JobsOverAResourceBudgetAreRefusedNamingTheEstimate) {
  const gel::ResourceEstimate estimate =
      gel::estimate_resources(gel::resolve_compression_scene(gel::scene_from_json(tiny_scene_json())));
  ASSERT_GT(estimate.particle_steps, 0);
  geld::Limits limits;
  limits.max_member_memory = estimate.memory_bytes - 1;
  start({.workers = 2, .limits = limits});
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("scene.generator: one member would hold about", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("--max-member-memory"), std::string::npos) << status.error_message();
  stop();

  limits = {};
  limits.max_job_particle_steps = 2.5 * estimate.particle_steps;  // two members fit, three do not
  start({.workers = 2, .limits = limits});
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
  start({.workers = 2, .limits = limits});
  status = submit(tiny_scene_json(), {.rerun = true}, &id);
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
  start({.workers = 2, .limits = limits, .executor = scripted(script)});
  const std::string first = submit_ok(tiny_scene_json(), {.rerun = true});
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("memory: with this job the 2 largest members", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("--max-memory"), std::string::npos);
  script.open();
  ASSERT_TRUE(wait_for([&] { return get(first).state() == gel::v1::JOB_STATE_SUCCEEDED; }));
  ASSERT_TRUE(wait_for([&] { return submit(tiny_scene_json(), {.rerun = true}, &id).ok(); }, 10s));
}

TEST_F(Service, EngineThreadsAreAJobFieldWithTheDaemonsDefaultAndGiveTheSameRows) {
  // --threads-per-member 2: a scene without integration.threads gets 2, written into the stored
  // scene; a scene with its own value keeps it. Threads never change the bits, so both members'
  // rows equal a one-thread run of the same seed.
  geld::Limits limits;
  limits.threads_per_member = 2;
  start({.workers = 2, .limits = limits});
  const std::string defaulted = submit_ok(tiny_scene_json(), {.rerun = true});
  nlohmann::json one_thread = nlohmann::json::parse(tiny_scene_json());
  one_thread["integration"] = {{"threads", 1}};
  const std::string explicit_one = submit_ok(one_thread.dump(), {.rerun = true});
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
  status = submit(too_many.dump(), {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("integration.threads"), std::string::npos) << status.error_message();
}

// Run cache: the same resolved scene, seeds and program return the job that succeeded with
// them; another seed, a changed parameter or rerun make a new job; a job records its program.
TEST_F(Service, AnIdenticalSubmissionReturnsTheJobThatAlreadySucceeded) {
  Script& script = make_script();
  script.rows = 2;
  start({.workers = 1, .executor = scripted(script)});
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
  // Two jobs now hold the same result; the cache answers with the newest that succeeded. The
  // rerun is waited for: while it runs the answer is the first job, after it the rerun (the
  // test used to race it and failed when the worker was quick, 2026-12-07).
  watch(rerun.job_id());
  ASSERT_EQ(get(rerun.job_id()).state(), gel::v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(submit_plain(tiny_scene_json(), {3, 4}, false).job_id(), rerun.job_id());
  // What does not change a bit of the result does not miss the cache: the engine threads (geld
  // writes its --threads-per-member into the stored scene), and the scene's own seed when a
  // seed list replaces it. A run without a list is the list of its scene's seed.
  auto with = [](const std::string& extra) {
    nlohmann::json scene = nlohmann::json::parse(tiny_scene_json());
    scene.merge_patch(nlohmann::json::parse(extra));
    return scene.dump();
  };
  EXPECT_EQ(submit_plain(with(R"({"integration": {"threads": 2}})"), {3, 4}, false).job_id(), rerun.job_id());
  EXPECT_EQ(submit_plain(with(R"({"generator": {"seed": 99}})"), {3, 4}, false).job_id(), rerun.job_id());
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
  start({.workers = 1, .executor = scripted(script)});
  auto submit_cached = [&](const std::string& name, std::map<std::string, std::string> labels, grpc::Status* status) {
    gel::v1::SubmitJobRequest request;
    request.set_scene_json(tiny_scene_json());
    request.add_seeds(3);
    request.set_rerun(false);  // the run cache may answer: that is what is tested
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

}  // namespace
}  // namespace geld_test
