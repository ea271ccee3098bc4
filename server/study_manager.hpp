#pragma once
// Studies on top of the job manager: a study is a named set of ensembles, each one job
// (labels study=<id>, ensemble=<name>). Its jobs queue, run, resume after a restart and come from
// the run cache like any job; the study itself stores its request and the list of its jobs, and
// its state is computed from theirs. Its analysis (gel::analysis::analyse_study) is computed
// from the jobs' stored rows and their members' snapshots, and stored once the study succeeded.
#include <functional>
#include <mutex>
#include <set>
#include <string>

#include "gel/v1/service.pb.h"
#include "job_manager.hpp"

namespace geld {

class StudyManager {
 public:
  explicit StudyManager(JobManager& jobs) : jobs_(jobs) {}

  // Validates every ensemble first (nothing is stored when one is refused), then stores the
  // study and submits its jobs. A job refused after others were queued (e.g. the queue filled
  // up meanwhile) cancels those and fails the call; the study stays listed as failed.
  gel::v1::SubmitStudyResponse submit(const gel::v1::SubmitStudyRequest& request);
  gel::v1::Study get(const std::string& id);
  gel::v1::ListStudiesResponse list(const gel::v1::ListStudiesRequest& request);
  gel::v1::Study cancel(const std::string& id);
  // Streams the study's jobs (one watcher per job) until every job has ended.
  void watch(const std::string& id, const std::function<bool(const gel::v1::StudyUpdate&)>& write,
             const std::function<bool()>& cancelled);
  gel::v1::GetStudyAnalysisResponse analysis(const gel::v1::GetStudyAnalysisRequest& request);

  static constexpr int kMaxEnsembles = 64;

 private:
  gel::v1::SubmitStudyRequest expanded(const gel::v1::SubmitStudyRequest& request);
  gel::v1::Study with_job_states(gel::v1::Study study);

  JobManager& jobs_;
  std::mutex submitting_mutex_;
  std::set<std::string> submitting_;  // studies whose jobs are being submitted
};

}  // namespace geld
