// Bad input: every malformed, out-of-range or contradictory request is refused with a status
// that names the field in the product's words, and nothing is stored.
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "service_fixture.hpp"

namespace geld_test {
namespace {

TEST_F(Service, UnknownJobIsNotFound) {
  start({.workers = 2});
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
  start({.workers = 2});
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
    auto status = submit(c.json, {.rerun = true}, &id);
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
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  EXPECT_FALSE(id.empty());
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 1);
}

// Finite values far outside the model's range (each held a worker, slowed a run 30x or took
// geld to gigabytes before its bound existed) are refused at submission, naming the field.
TEST_F(Service, AbsurdFiniteValuesAreRefusedByTheirPhysicalBounds) {
  start({.workers = 2});
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
    const grpc::Status status = submit(scene.dump(), {.rerun = true}, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field << ": " << status.error_message();
    EXPECT_EQ(status.error_message().rfind(field + ":", 0), 0u) << status.error_message();
  }
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
}

// Every text of a scene is capped, and an error quoting a huge value still arrives whole as
// INVALID_ARGUMENT naming its field (a 16 kB value once made the status too large for the
// client's metadata limit: RESOURCE_EXHAUSTED with no field).
TEST_F(Service, HugeStringsAreRefusedNamingTheirFieldInAStatusThatArrives) {
  start({.workers = 2});
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
    const grpc::Status status = submit(scene.dump(), {.rerun = true}, &id);
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
  EXPECT_FALSE(submit_ok(scene.dump(), {.rerun = true}).empty());
}

TEST_F(Service, SeedZeroUnknownStatesAndHugeLogPagesAreRefusedOrCapped) {
  Script& script = make_script();
  start({.workers = 1, .executor = scripted(script)});
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
  start({.workers = 1, .executor = chatty});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
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

TEST_F(Service, SceneJsonMistakesAreSaidInTheProductsWordsNamingTheField) {
  // gelctl --set and Python overrides send scene_json; protobuf's parser answered these with
  // "invalid value \"nan\" for type TYPE_DOUBLE", "Cannot find field" or "Unexpected token".
  start({.workers = 2});
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
    const auto status = submit(c.json, {.rerun = true}, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.json;
    EXPECT_EQ(status.error_message().rfind(c.message, 0), 0u) << c.json << ": " << status.error_message();
    for (const char* internal : {"TYPE_", "INVALID_ARGUMENT:", "Unexpected token", "Cannot find field", "json.exception"})
      EXPECT_EQ(status.error_message().find(internal), std::string::npos) << status.error_message();
  }
  // What protobuf's mapping allows still goes through: numbers in strings, lowerCamelCase names, null.
  const std::string id = submit_ok(R"({"preset": "quick", "generator": {"nFloc": 8, "n_clusters": "8", "lx": 30, "ly": 50,
                                       "walk_step": null}, "compression": {"fidelity": "fast", "steps": 3, "phi_max": "0.2"}})",
                                 {.rerun = true});
  EXPECT_FALSE(id.empty());
}

TEST_F(Service, OverLongNameIsInvalidArgumentNamingTheField) {
  Script& script = make_script();
  script.rows = 1;
  start({.workers = 1, .executor = scripted(script)});
  std::string id;
  auto status = submit(tiny_scene_json(), {.rerun = true, .name = std::string(257, 'n')}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(status.error_message().rfind("name: ", 0), 0u) << status.error_message();
  EXPECT_NE(status.error_message().find("256"), std::string::npos) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  // 256 characters is the longest accepted, and stored whole.
  const std::string longest(256, 'n');
  id = submit_ok(tiny_scene_json(), {.rerun = true, .name = longest});
  ASSERT_FALSE(id.empty());
  EXPECT_EQ(get(id).name(), longest);
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs WHERE length(name) = 256"), 1);
}

TEST_F(Service, AnEmptySceneIsRefusedAtSubmit) {
  // It used to be accepted and to fail only when a worker took it.
  start({.workers = 2});
  std::string id;
  const grpc::Status status = submit("{}", {.rerun = true}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("scene.generator: no gel to generate", 0), 0u) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
}

TEST_F(Service, ScenesThatCouldNeverFinishAreRefusedNamingTheField) {
  // Each value is valid on its own, and each would hold a worker for ever.
  start({.workers = 2});
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"preset": "quick", "compression": {"v_wall": 1e-300}})", "scene.compression.v_wall: "},
      {R"({"preset": "quick", "integration": {"dt": 1e-300}})", "scene.integration.dt: "},
      {R"({"preset": "quick", "compression": {"m_exam": 9000000000000000000}})", "scene.compression.m_exam: "},
  };
  for (const auto& [scene, field] : cases) {
    std::string id;
    const grpc::Status status = submit(scene, {.rerun = true}, &id);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << scene;
    EXPECT_EQ(status.error_message().rfind(field, 0), 0u) << status.error_message();
  }
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  // The largest preset is far inside the limit.
  std::string id;
  const grpc::Status ok = submit(R"({"preset": "paper-bond2-16x"})", {.rerun = true}, &id);
  EXPECT_TRUE(ok.ok()) << ok.error_message();
}

TEST_F(Service, TooManyOrTooLongLabelsAreInvalidArgumentNamingTheField) {
  start({.workers = 2});
  std::map<std::string, std::string> many;
  for (int i = 0; i < 65; ++i) many.emplace(std::to_string(1000 + i), "v");
  std::string id;
  grpc::Status status = submit(tiny_scene_json(), {.rerun = true, .labels = many}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("labels: 65 labels, the limit is 64", 0), 0u) << status.error_message();
  status = submit(tiny_scene_json(), {.rerun = true, .labels = {{"k", std::string(257, 'v')}}}, &id);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("labels: key 'k'", 0), 0u) << status.error_message();
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  many.erase("1000");
  EXPECT_TRUE(submit(tiny_scene_json(), {.rerun = true, .labels = many}, &id).ok());
}

TEST_F(Service, NegativePageSizeAndLimitsAreInvalidArgumentNamingTheField) {
  Script& script = make_script();
  script.rows = 1;
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
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
  start({.workers = 1, .executor = scripted(script)});
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

}  // namespace
}  // namespace geld_test
