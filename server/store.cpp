// The store's file: opening it, checking it, and its schema with the migrations that build it.
// The tables' readers and writers are in store_jobs.cpp, store_curves.cpp and store_studies.cpp.
#include "store.hpp"

#include <filesystem>

#include "store_sql.hpp"

namespace geld {
using store_sql::Stmt;
using store_sql::Transaction;
using store_sql::disk_full;

namespace {

// Migration i takes the schema from version i to i + 1.
const char* const kMigrations[] = {
    // 0 -> 1: the tables.
    R"sql(
CREATE TABLE jobs (
  seq INTEGER PRIMARY KEY AUTOINCREMENT,
  id TEXT NOT NULL UNIQUE,
  name TEXT NOT NULL DEFAULT '',
  state TEXT NOT NULL,
  scene BLOB NOT NULL,
  scene_json TEXT NOT NULL,
  seeds TEXT NOT NULL,
  particles INTEGER NOT NULL,
  bond_preset TEXT NOT NULL DEFAULT '',
  created_ms INTEGER NOT NULL,
  started_ms INTEGER NOT NULL DEFAULT 0,
  finished_ms INTEGER NOT NULL DEFAULT 0,
  error TEXT NOT NULL DEFAULT '',
  member INTEGER NOT NULL DEFAULT 0,
  out_dir TEXT NOT NULL DEFAULT ''
);
CREATE TABLE job_labels (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (job_id, key)
);
CREATE TABLE states (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  job_id TEXT NOT NULL REFERENCES jobs(id),
  state TEXT NOT NULL,
  at_ms INTEGER NOT NULL,
  message TEXT NOT NULL DEFAULT ''
);
CREATE TABLE parameters (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  name TEXT NOT NULL,
  value_text TEXT NOT NULL,
  value_num REAL,
  PRIMARY KEY (job_id, name)
);
CREATE TABLE curve_rows (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  member INTEGER NOT NULL,
  seed INTEGER NOT NULL,
  k INTEGER NOT NULL,
  phi REAL, p REAL, p_top REAL, p_bot REAL, contact_number REAL,
  stored_energy REAL, dissipated_energy REAL,
  row BLOB NOT NULL,
  at_ms INTEGER NOT NULL,
  PRIMARY KEY (job_id, member, k)
);
CREATE TABLE events (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  job_id TEXT NOT NULL REFERENCES jobs(id),
  member INTEGER NOT NULL,
  k INTEGER NOT NULL,
  at_ms INTEGER NOT NULL,
  normal INTEGER NOT NULL, sliding INTEGER NOT NULL, rolling INTEGER NOT NULL, created INTEGER NOT NULL
);
CREATE TABLE logs (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  job_id TEXT NOT NULL,
  at_ms INTEGER NOT NULL,
  level TEXT NOT NULL,
  message TEXT NOT NULL
);
)sql",
    // 1 -> 2: indexes for the list and query paths.
    R"sql(
CREATE INDEX jobs_state ON jobs(state, seq);
CREATE INDEX jobs_name ON jobs(name, seq);
CREATE INDEX job_labels_kv ON job_labels(key, value);
CREATE INDEX parameters_name ON parameters(name, value_num);
CREATE INDEX states_job ON states(job_id, id);
CREATE INDEX logs_job ON logs(job_id, id);
CREATE INDEX events_job ON events(job_id, id);
)sql",
    // 2 -> 3: executors' handles per member (e.g. Slurm job ids), so a restarted geld can
    // follow work that outlived it.
    R"sql(
CREATE TABLE member_runs (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  member INTEGER NOT NULL,
  seed INTEGER NOT NULL,
  executor TEXT NOT NULL,
  handle TEXT NOT NULL,
  updated_ms INTEGER NOT NULL,
  PRIMARY KEY (job_id, member)
);
)sql",
    // 3 -> 4: members of one job run in parallel, so "the member being run" is no longer enough
    // to resume: every finished member is recorded.
    R"sql(
CREATE TABLE member_finished (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  member INTEGER NOT NULL,
  finished_ms INTEGER NOT NULL,
  PRIMARY KEY (job_id, member)
);
)sql",
    // 4 -> 5: a parameter may hold several values for one job: an ensemble's members each have
    // their generator.seed, so a query for seed 3 finds the ensemble that ran seeds 3 and 4 (and
    // not for the seed of the scene it was submitted with, which no member ran).
    R"sql(
CREATE TABLE parameters_v5 (
  job_id TEXT NOT NULL REFERENCES jobs(id),
  name TEXT NOT NULL,
  value_text TEXT NOT NULL,
  value_num REAL,
  PRIMARY KEY (job_id, name, value_text)
);
INSERT INTO parameters_v5 SELECT job_id, name, value_text, value_num FROM parameters WHERE name <> 'generator.seed';
INSERT OR IGNORE INTO parameters_v5
  SELECT jobs.id, 'generator.seed', CAST(seed.value AS TEXT), seed.value FROM jobs, json_each(jobs.seeds) AS seed;
DROP TABLE parameters;
ALTER TABLE parameters_v5 RENAME TO parameters;
CREATE INDEX parameters_name ON parameters(name, value_num);
)sql",
    // 5 -> 6: studies, named sets of ensembles, each ensemble one job; the request is the
    // versioned gel.v1.SubmitStudyRequest with the preset expanded. An analysis of a succeeded
    // study is stored once per set of options.
    R"sql(
CREATE TABLE studies (
  seq INTEGER PRIMARY KEY AUTOINCREMENT,
  id TEXT NOT NULL UNIQUE,
  name TEXT NOT NULL,
  preset TEXT NOT NULL,
  fidelity TEXT NOT NULL,
  request BLOB NOT NULL,
  created_ms INTEGER NOT NULL,
  program_version TEXT NOT NULL
);
CREATE TABLE study_labels (
  study_id TEXT NOT NULL REFERENCES studies(id),
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (study_id, key)
);
CREATE TABLE study_jobs (
  study_id TEXT NOT NULL REFERENCES studies(id),
  position INTEGER NOT NULL,
  ensemble TEXT NOT NULL,
  job_id TEXT NOT NULL REFERENCES jobs(id),
  cached INTEGER NOT NULL,
  PRIMARY KEY (study_id, position)
);
CREATE TABLE study_analyses (
  study_id TEXT NOT NULL REFERENCES studies(id),
  options TEXT NOT NULL,
  json TEXT NOT NULL,
  seconds REAL NOT NULL,
  created_ms INTEGER NOT NULL,
  PRIMARY KEY (study_id, options)
);
)sql",
    // 6 -> 7: compatibility state retired, nothing lost.
    // jobs.member was "the member being run" before members ran in parallel (v4), then kept as the
    // lowest unfinished one, which member_finished already says: a job that only has the column
    // gets the members below it recorded as finished (when is not known: 0), and the column goes.
    // The program that accepted a job moves from the parameter row run.program_version to a
    // column of jobs, where the study's already is (QueryCurves filters on it by the same name).
    R"sql(
WITH RECURSIVE below(job_id, member, members) AS (
  SELECT id, 0, min(member, max(1, json_array_length(seeds))) FROM jobs WHERE member > 0
  UNION ALL
  SELECT job_id, member + 1, members FROM below WHERE member + 1 < members
)
INSERT OR IGNORE INTO member_finished(job_id, member, finished_ms) SELECT job_id, member, 0 FROM below;
ALTER TABLE jobs DROP COLUMN member;
ALTER TABLE jobs ADD COLUMN program_version TEXT NOT NULL DEFAULT '';
UPDATE jobs SET program_version =
  (SELECT max(value_text) FROM parameters WHERE job_id = jobs.id AND name = 'run.program_version')
  WHERE id IN (SELECT job_id FROM parameters WHERE name = 'run.program_version');
DELETE FROM parameters WHERE name = 'run.program_version';
)sql",
};
static_assert(sizeof(kMigrations) / sizeof(kMigrations[0]) == Store::kSchemaVersion);

}  // namespace

std::string Store::state_name(gel::v1::JobState state) {
  switch (state) {
    case gel::v1::JOB_STATE_QUEUED: return "queued";
    case gel::v1::JOB_STATE_RUNNING: return "running";
    case gel::v1::JOB_STATE_SUCCEEDED: return "succeeded";
    case gel::v1::JOB_STATE_FAILED: return "failed";
    case gel::v1::JOB_STATE_CANCELLED: return "cancelled";
    default: return "unspecified";
  }
}

gel::v1::JobState Store::state_from_name(const std::string& name) {
  for (auto s : {gel::v1::JOB_STATE_QUEUED, gel::v1::JOB_STATE_RUNNING, gel::v1::JOB_STATE_SUCCEEDED,
                 gel::v1::JOB_STATE_FAILED, gel::v1::JOB_STATE_CANCELLED}) {
    if (state_name(s) == name) return s;
  }
  return gel::v1::JOB_STATE_UNSPECIFIED;
}

Store::Store(const std::string& path) {
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw StoreError("cannot open " + path + ": " + msg);
  }
  try {
    sqlite3_busy_timeout(db_, 10000);
    check_integrity(path);
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=FULL");
    exec("PRAGMA foreign_keys=ON");
    migrate();
  } catch (...) {
    sqlite3_close_v2(db_);  // no destructor runs for a constructor that throws
    db_ = nullptr;
    throw;
  }
}

// A damaged file used to open fine and fail later, job by job, with whatever page a query
// happened to touch, so a daemon refuses to start on it and says what to do instead.
// quick_check reads every page once and checks the b-trees, but not that each index holds the
// rows of its table: it passed 4 of 12 random 16-byte overwrites that integrity_check caught, and
// geld then wrote new rows through the damaged index. integrity_check also looks every row up in
// every index. Measured (SQLite 3.40.1, 2 shared cores, file in the page cache): 5,000 jobs of 21
// rows each, 105 MB: 0.5 s against quick_check's 0.2 s; 48,000 such jobs, 1 GiB: 7.5 s against
// 2 s. Above kFullCheckBytes a start would wait longer than a restart should, so quick_check it is.
void Store::check_integrity(const std::string& path) {
  constexpr std::uintmax_t kFullCheckBytes = std::uintmax_t{1} << 30;
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  const bool full = !ec && bytes <= kFullCheckBytes;
  std::vector<std::string> problems;
  try {
    Stmt check(db_, full ? "PRAGMA integrity_check(5)" : "PRAGMA quick_check(5)");
    while (check.step()) problems.push_back(check.text(0));
  } catch (const StoreError& error) {  // a header too damaged for the check itself to run
    problems = {error.what()};
  }
  if (problems.size() == 1 && problems[0] == "ok") return;
  std::string summary;
  for (const auto& problem : problems) summary += (summary.empty() ? "" : "; ") + problem;
  throw StoreError("the store " + path + " is damaged (" + summary +
                   "): move it away and restore a backup, or salvage it with `sqlite3 " + path + " .recover`");
}

Store::~Store() {
  if (db_) sqlite3_close_v2(db_);
}

void Store::exec(const char* sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db_, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    std::string msg = err ? err : "?";
    sqlite3_free(err);
    throw StoreError("sqlite: " + msg, disk_full(db_, rc));
  }
}

void Store::migrate() {
  std::lock_guard lock(mutex_);
  exec("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)");
  Transaction tx(db_);
  int version = 0;
  {
    Stmt q(db_, "SELECT version FROM schema_version");
    if (q.step()) {
      version = static_cast<int>(q.i64(0));
    } else {
      Stmt ins(db_, "INSERT INTO schema_version(version) VALUES (0)");
      ins.run();
    }
  }
  if (version > kSchemaVersion) {
    throw StoreError("database schema version " + std::to_string(version) + " is newer than this geld (" +
                     std::to_string(kSchemaVersion) + ")");
  }
  for (int v = version; v < kSchemaVersion; ++v) {
    exec(kMigrations[v]);
    Stmt up(db_, "UPDATE schema_version SET version = ?");
    up.bind(1, v + 1).run();
  }
  tx.commit();
}

int Store::schema_version() {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT version FROM schema_version");
  return q.step() ? static_cast<int>(q.i64(0)) : 0;
}

}  // namespace geld
