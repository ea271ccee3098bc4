// The store's studies: the study, its labels, the job of each ensemble and its stored analyses.
#include <cstdio>

#include "store.hpp"
#include "store_sql.hpp"

namespace geld {
using store_sql::Stmt;
using store_sql::Transaction;

std::string Store::insert_study(gel::v1::Study& study) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  std::string request;
  study.request().SerializeToString(&request);
  {
    Stmt ins(db_,
             "INSERT INTO studies(id, name, preset, fidelity, request, created_ms, program_version) "
             "VALUES ('', ?, ?, ?, ?, ?, ?)");
    ins.bind(1, study.name())
        .bind(2, study.preset())
        .bind(3, study.fidelity())
        .bind_blob(4, request)
        .bind(5, study.created_unix_ms())
        .bind(6, study.program_version())
        .run();
  }
  const std::int64_t seq = sqlite3_last_insert_rowid(db_);
  char id[32];
  std::snprintf(id, sizeof id, "study-%06lld", static_cast<long long>(seq));
  study.set_id(id);
  Stmt(db_, "UPDATE studies SET id = ? WHERE seq = ?").bind(1, study.id()).bind(2, seq).run();
  Stmt lab(db_, "INSERT INTO study_labels(study_id, key, value) VALUES (?, ?, ?)");
  for (const auto& [key, value] : study.labels()) {
    lab.bind(1, study.id()).bind(2, key).bind(3, value).run();
    lab.reset();
  }
  tx.commit();
  return study.id();
}

void Store::add_study_job(const std::string& study_id, int position, const std::string& ensemble,
                          const std::string& job_id, bool cached) {
  std::lock_guard lock(mutex_);
  Stmt ins(db_, "INSERT INTO study_jobs(study_id, position, ensemble, job_id, cached) VALUES (?, ?, ?, ?, ?)");
  ins.bind(1, study_id).bind(2, position).bind(3, ensemble).bind(4, job_id).bind(5, cached ? 1 : 0).run();
}

namespace {

constexpr const char* kStudyColumns = "seq, id, name, preset, fidelity, request, created_ms, program_version";

gel::v1::Study study_from_row(sqlite3* db, const Stmt& q) {
  gel::v1::Study study;
  study.set_id(q.text(1));
  study.set_name(q.text(2));
  study.set_preset(q.text(3));
  study.set_fidelity(q.text(4));
  if (!study.mutable_request()->ParseFromString(q.blob(5)))
    throw StoreError("study " + study.id() + ": its stored request is not a gel.v1.SubmitStudyRequest");
  study.set_created_unix_ms(q.i64(6));
  study.set_program_version(q.text(7));
  Stmt labels(db, "SELECT key, value FROM study_labels WHERE study_id = ?");
  labels.bind(1, study.id());
  while (labels.step()) (*study.mutable_labels())[labels.text(0)] = labels.text(1);
  Stmt jobs(db, "SELECT ensemble, job_id, cached FROM study_jobs WHERE study_id = ? ORDER BY position");
  jobs.bind(1, study.id());
  while (jobs.step()) {
    gel::v1::StudyJob* job = study.add_jobs();
    job->set_ensemble(jobs.text(0));
    job->set_job_id(jobs.text(1));
    job->set_cached(jobs.i64(2) != 0);
  }
  return study;
}

}  // namespace

std::optional<gel::v1::Study> Store::get_study(const std::string& id) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, (std::string("SELECT ") + kStudyColumns + " FROM studies WHERE id = ?").c_str());
  q.bind(1, id);
  if (!q.step()) return std::nullopt;
  return study_from_row(db_, q);
}

std::vector<std::pair<std::int64_t, gel::v1::Study>> Store::list_studies(std::int64_t before_seq, int limit) {
  std::lock_guard lock(mutex_);
  std::string sql = std::string("SELECT ") + kStudyColumns + " FROM studies";
  if (before_seq > 0) sql += " WHERE seq < " + std::to_string(before_seq);
  sql += " ORDER BY seq DESC LIMIT " + std::to_string(limit);
  Stmt q(db_, sql.c_str());
  std::vector<std::pair<std::int64_t, gel::v1::Study>> out;
  while (q.step()) out.emplace_back(q.i64(0), study_from_row(db_, q));
  return out;
}

std::optional<StoredAnalysis> Store::study_analysis(const std::string& study_id, const std::string& options) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT json, seconds FROM study_analyses WHERE study_id = ? AND options = ?");
  q.bind(1, study_id).bind(2, options);
  if (!q.step()) return std::nullopt;
  return StoredAnalysis{q.text(0), q.f64(1)};
}

void Store::put_study_analysis(const std::string& study_id, const std::string& options, const std::string& json,
                               double seconds, std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Stmt ins(db_,
           "INSERT OR REPLACE INTO study_analyses(study_id, options, json, seconds, created_ms) VALUES (?, ?, ?, ?, ?)");
  ins.bind(1, study_id).bind(2, options).bind(3, json).bind(4, seconds).bind(5, now_ms).run();
}

}  // namespace geld
