#pragma once
// The daemon's durable state: one SQLite file in WAL mode. Every write is a committed
// transaction before the call returns, so anything acknowledged to a client survives a crash.
//
// Schema (version 7; migrations run from the `schema_version` table on open):
//   schema_version(version)                          one row: the schema's version
//   jobs(seq PK autoincrement, id UNIQUE, name, state, scene BLOB (resolved gel.v1.Scene),
//        scene_json, seeds (JSON array), particles, bond_preset, created_ms, started_ms,
//        finished_ms, error, out_dir, program_version)
//   job_labels(job_id, key, value)                   PK (job_id, key)
//   states(id PK, job_id, state, at_ms, message)     every state change, in order
//   parameters(job_id, name, value_text, value_num)  the resolved scene flattened to dotted
//                                                    names (for QueryCurves)
//   curve_rows(job_id, member, seed, k, phi, p, p_top, p_bot, contact_number, stored_energy,
//              dissipated_energy, row BLOB (gel.v1.CurveRow), at_ms)  PK (job_id, member, k);
//                                                    written at every equilibrium as reached
//   events(id PK, job_id, member, k, at_ms, normal, sliding, rolling, created)
//                                                    cumulative rupture counts at each row
//   logs(id PK, job_id, at_ms, level, message)       the job's log lines
//   member_runs(job_id, member, seed, executor, handle, updated_ms)  PK (job_id, member); an
//                                                    executor's handle (e.g. Slurm job id)
//   member_finished(job_id, member, finished_ms)     PK (job_id, member); members that finished
//                                                    (members of a job run in parallel); a job's
//                                                    `member` is the lowest one not here
//   studies(seq PK autoincrement, id UNIQUE, name, preset, fidelity, request BLOB
//           (gel.v1.SubmitStudyRequest, preset expanded), created_ms, program_version)
//   study_labels(study_id, key, value)               PK (study_id, key)
//   study_jobs(study_id, position, ensemble, job_id, cached)  PK (study_id, position): one job
//                                                    per ensemble, recorded as it is submitted
//   study_analyses(study_id, options, json, seconds, created_ms)  PK (study_id, options)
#include <cstdint>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "gel/v1/service.pb.h"

struct sqlite3;

namespace geld {

// `full()`: the database or its disk is full (SQLITE_FULL, ENOSPC). The store is intact and
// works again once space is back, so the job manager waits instead of failing jobs.
class StoreError : public std::runtime_error {
 public:
  explicit StoreError(const std::string& message, bool full = false) : std::runtime_error(message), full_(full) {}
  bool full() const { return full_; }

 private:
  bool full_ = false;
};

struct JobFilter {
  gel::v1::JobState state = gel::v1::JOB_STATE_UNSPECIFIED;
  std::string label_key, label_value;  // label_value empty: any value
  std::string name;
  std::int64_t before_seq = 0;         // paging: only jobs with seq < before_seq (0: any)
  int limit = 50;
};

struct CurveFilter {
  std::string bond_preset;
  std::vector<std::pair<std::string, std::string>> labels;
  struct Parameter {
    std::string name;
    std::string equals;
    std::optional<double> min, max;
  };
  std::vector<Parameter> parameters;
  gel::v1::JobState state = gel::v1::JOB_STATE_SUCCEEDED;
  int limit = 100;
};

struct StoredAnalysis {
  std::string json;
  double seconds = 0;
};

struct StoredRow {
  int member = 0;
  std::uint64_t seed = 0;
  gel::v1::CurveRow row;
};

class Store {
 public:
  static constexpr int kSchemaVersion = 7;

  explicit Store(const std::string& path);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  int schema_version();

  // Inserts a new job (state queued) with its labels and flattened parameters; assigns and
  // returns its id. `parameters` are (dotted name, text, number or NaN).
  std::string insert_job(gel::v1::Job& job, const std::string& scene_json,
                         const std::vector<std::tuple<std::string, std::string, double>>& parameters);

  void set_state(const std::string& id, gel::v1::JobState state, const std::string& message,
                 std::int64_t now_ms);
  void put_row(const std::string& id, int member, std::uint64_t seed, const gel::v1::CurveRow& row,
               std::int64_t now_ms);
  // Replaces a member's rows by a finished curve's (one transaction).
  void replace_rows(const std::string& id, int member, std::uint64_t seed,
                    const std::vector<gel::v1::CurveRow>& rows, std::int64_t now_ms);
  // An executor's handle for a member (committed before the call returns).
  void set_member_handle(const std::string& id, int member, std::uint64_t seed, const std::string& executor,
                         const std::string& handle, std::int64_t now_ms);
  std::string member_handle(const std::string& id, int member);  // "" if none
  // A member whose whole curve is stored (committed before the call returns).
  void set_member_finished(const std::string& id, int member, std::int64_t now_ms);
  std::vector<int> finished_members(const std::string& id);  // ascending
  std::int64_t add_log(const std::string& job_id, const std::string& level, const std::string& message,
                       std::int64_t now_ms);

  // A run-cache hit's metadata, put on the job `id` that answered it, in one transaction: the
  // request's `labels` are added to the job's, and `name` becomes its name if it has none.
  // `conflicts`: the keys the job already has with another value (sorted), with the job's value.
  // Written only if there are none and the job then has at most max_labels labels.
  struct MetadataMerge {
    std::vector<std::pair<std::string, std::string>> conflicts;
    int labels = 0;  // the job's labels after the merge
    bool written = false;
  };
  MetadataMerge merge_labels_and_name(const std::string& id, const google::protobuf::Map<std::string, std::string>& labels,
                                      const std::string& name, int max_labels);

  std::optional<gel::v1::Job> get_job(const std::string& id);
  // The newest job in `state` with the parameter name = value (the run cache's lookup).
  std::optional<std::string> find_job_by_parameter(const std::string& name, const std::string& value,
                                                   gel::v1::JobState state);
  // Newest first; the second value is the seq of the last job returned (for paging).
  std::vector<std::pair<std::int64_t, gel::v1::Job>> list_jobs(const JobFilter& filter);
  std::vector<std::string> job_ids_in_state(gel::v1::JobState state);  // oldest first
  std::vector<std::string> query_curves(const CurveFilter& filter);   // newest first
  std::vector<StoredRow> rows(const std::string& id);                 // by member, k
  int row_count(const std::string& id);
  std::vector<gel::v1::LogLine> logs(const std::string& id, std::int64_t after_id, int limit);

  // Studies. insert_study assigns the id ("study-000001") and stores the request and labels;
  // the jobs are added one by one as they are submitted. Read back, a study holds its stored
  // fields and its jobs' ensemble, id and cached flag (their states are the jobs' own).
  std::string insert_study(gel::v1::Study& study);
  void add_study_job(const std::string& study_id, int position, const std::string& ensemble, const std::string& job_id,
                     bool cached);
  std::optional<gel::v1::Study> get_study(const std::string& id);
  std::vector<std::pair<std::int64_t, gel::v1::Study>> list_studies(std::int64_t before_seq, int limit);  // newest first
  std::optional<StoredAnalysis> study_analysis(const std::string& study_id, const std::string& options);
  void put_study_analysis(const std::string& study_id, const std::string& options, const std::string& json,
                          double seconds, std::int64_t now_ms);

  static std::string state_name(gel::v1::JobState state);  // "queued", "running", ...
  static gel::v1::JobState state_from_name(const std::string& name);

 private:
  void exec(const char* sql);
  void check_integrity(const std::string& path);
  void migrate();
  gel::v1::Job read_job_locked(const std::string& id, bool& found);

  sqlite3* db_ = nullptr;
  std::mutex mutex_;
};

}  // namespace geld
