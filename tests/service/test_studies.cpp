// Studies: one job per ensemble, streamed together, analysed and stored; refused, cancelled or
// refused part-way.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "service_fixture.hpp"

namespace geld_test {
namespace {

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
  start({.workers = 2});
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
  start({.workers = 1});
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
  start({.workers = 2, .executor = scripted(script)});
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
  start({.workers = 1, .limits = limits, .executor = scripted(script)});
  const std::string blocker = submit_ok(tiny_scene_json(), {.rerun = true});
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

}  // namespace
}  // namespace geld_test
