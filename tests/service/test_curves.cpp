// Results: a job's curve and its ensemble statistic, the analysis of an ensemble, and finding
// jobs and curves again (ListJobs, QueryCurves).
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gel/analysis/ensemble_statistic.hpp"
#include "service_fixture.hpp"

namespace geld_test {
namespace {

// The real gelcore adapter under another program version, as after an upgrade of geld.
class VersionedGelcore final : public geld::GelcoreAdapter {
 public:
  explicit VersionedGelcore(std::string version) : version_(std::move(version)) {}
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
  std::shared_ptr<geld::GelcoreAdapter> real_ = geld::make_gelcore_adapter();
  std::string version_;
};

TEST_F(Service, ACurveNamesTheProgramThatRanItNotTheOneAnswering) {
  // GetCurve used to stamp every curve with the answering geld's version.
  Script& script = make_script();
  start({.workers = 1,
         .executor = scripted(script),
         .gelcore = std::make_shared<VersionedGelcore>("0.1.0 git aaaaaaa Release")});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED);
  stop();
  start({.workers = 1,
         .executor = scripted(script),
         .gelcore = std::make_shared<VersionedGelcore>("0.2.0 git bbbbbbb Release")});
  EXPECT_EQ(get(id).program_version(), "0.1.0 git aaaaaaa Release");
  const auto response = curve(id);
  ASSERT_EQ(response.members_size(), 1);
  EXPECT_EQ(response.members(0).curve().program_version(), "0.1.0 git aaaaaaa Release");
  EXPECT_EQ(nlohmann::json::parse(response.json()).at("program_version"), "0.1.0 git aaaaaaa Release");
  // A job of the new geld says the new version.
  const std::string fresh = submit_ok(tiny_scene_json(4), {.rerun = true});
  watch(fresh);
  EXPECT_EQ(curve(fresh).members(0).curve().program_version(), "0.2.0 git bbbbbbb Release");
}

TEST_F(Service, GetAnalysisAnalysesAFinishedEnsembleWhereItsRowsAre) {
  start({.workers = 2});
  const std::string id = submit_ok(tiny_scene_json(5), {.rerun = true, .seeds = {3, 4, 5}});
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

TEST_F(Service, ListJobsFiltersAndPages) {
  Script& script = make_script();
  script.rows = 1;
  start({.workers = 2, .executor = scripted(script)});
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) {
    ids.push_back(submit_ok(tiny_scene_json(),
                            {.rerun = true,
                             .name = i % 2 ? "odd" : "even",
                             .labels = {{"batch", i < 3 ? "a" : "b"}, {"index", std::to_string(i)}}}));
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
  start({.workers = 1, .executor = scripted(script)});
  const std::string id = submit_ok(tiny_scene_json(), {.rerun = true, .seeds = {1, 2, 6}});
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
  start({.workers = 1});
  const std::string id = submit_ok(tiny_scene_json(2), {.rerun = true, .seeds = {3, 4}});
  watch(id);
  ASSERT_EQ(get(id).state(), gel::v1::JOB_STATE_SUCCEEDED) << get(id).error();
  auto c = curve(id);
  ASSERT_EQ(c.members_size(), 2);
  ASSERT_EQ(c.members(0).curve().rows_size(), 3);
  ASSERT_EQ(c.members(1).curve().rows_size(), 3);
  EXPECT_NE(c.members(0).curve().rows(0).phi(), c.members(1).curve().rows(0).phi());  // different gels
  EXPECT_EQ(c.ensemble_size(), 3);
}

TEST_F(Service, QueryCurvesByBondLabelsAndParameters) {
  Script& script = make_script();
  script.rows = 2;
  start({.workers = 1, .executor = scripted(script)});
  const std::string a = submit_ok(tiny_scene_json(), {.rerun = true, .name = "a", .labels = {{"study", "s1"}}});
  const std::string b = submit_ok(
      R"({"preset": "quick", "bond": {"preset": "bond2"}, "generator": {"n_floc": 8, "n_clusters": 8, "lx": 40, "ly": 50},
          "compression": {"fidelity": "fast", "steps": 3}})",
      {.rerun = true, .name = "b", .labels = {{"study", "s1"}}});
  const std::string c = submit_ok(tiny_scene_json(), {.rerun = true, .name = "c", .labels = {{"study", "s2"}}});
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
  const std::string ensemble = submit_ok(tiny_scene_json(),
                                         {.rerun = true, .seeds = {3, 4}, .name = "ensemble", .labels = {{"study", "s3"}}});
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

}  // namespace
}  // namespace geld_test
