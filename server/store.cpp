#include "store.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <tuple>

#include <sqlite3.h>

#include <nlohmann/json.hpp>

namespace geld {
namespace {

bool disk_full(sqlite3* db, int rc) {
  return (rc & 0xff) == SQLITE_FULL || sqlite3_system_errno(db) == ENOSPC || sqlite3_system_errno(db) == EDQUOT;
}

// A prepared statement that finalizes itself; binds are 1-based like SQLite's.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw StoreError(std::string("sqlite prepare: ") + sqlite3_errmsg(db) + " in: " + sql);
    }
  }
  ~Stmt() { sqlite3_finalize(stmt_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, const std::string& value) {
    check(sqlite3_bind_text(stmt_, i, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind(int i, const char* value) { return bind(i, std::string(value)); }
  Stmt& bind(int i, std::int64_t value) {
    check(sqlite3_bind_int64(stmt_, i, value));
    return *this;
  }
  Stmt& bind(int i, int value) { return bind(i, static_cast<std::int64_t>(value)); }
  Stmt& bind(int i, double value) {
    if (std::isnan(value)) {
      check(sqlite3_bind_null(stmt_, i));
    } else {
      check(sqlite3_bind_double(stmt_, i, value));
    }
    return *this;
  }
  Stmt& bind_blob(int i, const std::string& value) {
    check(sqlite3_bind_blob(stmt_, i, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT));
    return *this;
  }
  // Returns true while there is a row.
  bool step() {
    int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw StoreError(std::string("sqlite step: ") + sqlite3_errmsg(db_), disk_full(db_, rc));
  }
  void run() {
    while (step()) {
    }
  }
  void reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  std::int64_t i64(int col) const { return sqlite3_column_int64(stmt_, col); }
  double f64(int col) const { return sqlite3_column_double(stmt_, col); }
  bool is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }
  std::string blob(int col) const {
    const void* p = sqlite3_column_blob(stmt_, col);
    return p ? std::string(static_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) throw StoreError(std::string("sqlite bind: ") + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN IMMEDIATE ... COMMIT, rolled back if an exception leaves the scope.
class Transaction {
 public:
  explicit Transaction(sqlite3* db) : db_(db) { exec("BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (!done_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  void commit() {
    exec("COMMIT");
    done_ = true;
  }

 private:
  void exec(const char* sql) {
    char* err = nullptr;
    const int rc = sqlite3_exec(db_, sql, nullptr, nullptr, &err);
    if (rc != SQLITE_OK) {
      std::string msg = err ? err : "?";
      sqlite3_free(err);
      throw StoreError(std::string("sqlite: ") + msg + " in: " + sql, disk_full(db_, rc));
    }
  }
  sqlite3* db_;
  bool done_ = false;
};

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

namespace {
// The one writer of job labels: at submission, and a run-cache hit's new ones.
void write_labels(sqlite3* db, const std::string& job_id, const google::protobuf::Map<std::string, std::string>& labels) {
  Stmt lab(db, "INSERT INTO job_labels(job_id, key, value) VALUES (?, ?, ?)");
  for (const auto& [k, v] : labels) {
    lab.bind(1, job_id).bind(2, k).bind(3, v).run();
    lab.reset();
  }
}
}  // namespace

std::string Store::insert_job(gel::v1::Job& job, const std::string& scene_json,
                              const std::vector<std::tuple<std::string, std::string, double>>& parameters) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  nlohmann::json seeds = nlohmann::json::array();
  for (auto s : job.seeds()) seeds.push_back(s);
  std::string blob;
  job.scene().SerializeToString(&blob);
  {
    Stmt ins(db_,
             "INSERT INTO jobs(id, name, state, scene, scene_json, seeds, particles, bond_preset, created_ms) "
             "VALUES ('', ?, 'queued', ?, ?, ?, ?, ?, ?)");
    ins.bind(1, job.name())
        .bind_blob(2, blob)
        .bind(3, scene_json)
        .bind(4, seeds.dump())
        .bind(5, static_cast<std::int64_t>(job.particles()))
        .bind(6, job.bond_preset())
        .bind(7, job.created_unix_ms());
    ins.run();
  }
  std::int64_t seq = sqlite3_last_insert_rowid(db_);
  char id[32];
  std::snprintf(id, sizeof id, "job-%06lld", static_cast<long long>(seq));
  job.set_id(id);
  if (job.out_dir().empty()) job.set_out_dir(std::string("jobs/") + id);
  {
    Stmt up(db_, "UPDATE jobs SET id = ?, out_dir = ? WHERE seq = ?");
    up.bind(1, job.id()).bind(2, job.out_dir()).bind(3, seq).run();
  }
  write_labels(db_, job.id(), job.labels());
  {
    Stmt par(db_, "INSERT OR REPLACE INTO parameters(job_id, name, value_text, value_num) VALUES (?, ?, ?, ?)");
    for (const auto& [name, text, num] : parameters) {
      par.bind(1, job.id()).bind(2, name).bind(3, text).bind(4, num).run();
      par.reset();
    }
  }
  {
    Stmt st(db_, "INSERT INTO states(job_id, state, at_ms) VALUES (?, 'queued', ?)");
    st.bind(1, job.id()).bind(2, job.created_unix_ms()).run();
  }
  tx.commit();
  job.set_state(gel::v1::JOB_STATE_QUEUED);
  return job.id();
}

void Store::set_state(const std::string& id, gel::v1::JobState state, const std::string& message,
                      std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  const std::string name = state_name(state);
  {
    std::string sql = "UPDATE jobs SET state = ?1, error = ?2";
    if (state == gel::v1::JOB_STATE_RUNNING) {
      sql += ", started_ms = CASE WHEN started_ms = 0 THEN ?3 ELSE started_ms END";
    } else if (state != gel::v1::JOB_STATE_QUEUED) {
      sql += ", finished_ms = ?3";
    }
    sql += " WHERE id = ?4";
    Stmt up(db_, sql.c_str());
    up.bind(1, name).bind(2, message).bind(3, now_ms).bind(4, id).run();
  }
  {
    Stmt st(db_, "INSERT INTO states(job_id, state, at_ms, message) VALUES (?, ?, ?, ?)");
    st.bind(1, id).bind(2, name).bind(3, now_ms).bind(4, message).run();
  }
  tx.commit();
}

void Store::set_member(const std::string& id, int member) {
  std::lock_guard lock(mutex_);
  Stmt up(db_, "UPDATE jobs SET member = ? WHERE id = ?");
  up.bind(1, member).bind(2, id).run();
}

namespace {
void insert_row(sqlite3* db, const std::string& id, int member, std::uint64_t seed, const gel::v1::CurveRow& row,
                std::int64_t now_ms) {
  std::string blob;
  row.SerializeToString(&blob);
  Stmt ins(db,
           "INSERT OR REPLACE INTO curve_rows(job_id, member, seed, k, phi, p, p_top, p_bot, contact_number, "
           "stored_energy, dissipated_energy, row, at_ms) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  ins.bind(1, id)
      .bind(2, member)
      .bind(3, static_cast<std::int64_t>(seed))
      .bind(4, row.k())
      .bind(5, row.phi())
      .bind(6, row.p())
      .bind(7, row.p_top())
      .bind(8, row.p_bot())
      .bind(9, row.contact_number())
      .bind(10, row.stored_energy())
      .bind(11, row.dissipated_energy())
      .bind_blob(12, blob)
      .bind(13, now_ms)
      .run();
  Stmt ev(db,
          "INSERT INTO events(job_id, member, k, at_ms, normal, sliding, rolling, created) "
          "VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
  ev.bind(1, id)
      .bind(2, member)
      .bind(3, row.k())
      .bind(4, now_ms)
      .bind(5, static_cast<std::int64_t>(row.ruptures().normal()))
      .bind(6, static_cast<std::int64_t>(row.ruptures().sliding()))
      .bind(7, static_cast<std::int64_t>(row.ruptures().rolling()))
      .bind(8, static_cast<std::int64_t>(row.ruptures().created()))
      .run();
}
}  // namespace

void Store::put_row(const std::string& id, int member, std::uint64_t seed, const gel::v1::CurveRow& row,
                    std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  insert_row(db_, id, member, seed, row, now_ms);
  tx.commit();
}

void Store::replace_rows(const std::string& id, int member, std::uint64_t seed,
                         const std::vector<gel::v1::CurveRow>& rows, std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  {
    Stmt del(db_, "DELETE FROM curve_rows WHERE job_id = ? AND member = ?");
    del.bind(1, id).bind(2, member).run();
    Stmt del_events(db_, "DELETE FROM events WHERE job_id = ? AND member = ?");
    del_events.bind(1, id).bind(2, member).run();
  }
  for (const auto& row : rows) insert_row(db_, id, member, seed, row, now_ms);
  tx.commit();
}

void Store::set_member_handle(const std::string& id, int member, std::uint64_t seed, const std::string& executor,
                              const std::string& handle, std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Stmt up(db_,
          "INSERT OR REPLACE INTO member_runs(job_id, member, seed, executor, handle, updated_ms) "
          "VALUES (?, ?, ?, ?, ?, ?)");
  up.bind(1, id).bind(2, member).bind(3, static_cast<std::int64_t>(seed)).bind(4, executor).bind(5, handle);
  up.bind(6, now_ms).run();
}

void Store::set_member_finished(const std::string& id, int member, std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Stmt ins(db_, "INSERT OR REPLACE INTO member_finished(job_id, member, finished_ms) VALUES (?, ?, ?)");
  ins.bind(1, id).bind(2, member).bind(3, now_ms).run();
}

std::vector<int> Store::finished_members(const std::string& id) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT member FROM member_finished WHERE job_id = ? ORDER BY member");
  q.bind(1, id);
  std::vector<int> members;
  while (q.step()) members.push_back(static_cast<int>(q.i64(0)));
  return members;
}

std::string Store::member_handle(const std::string& id, int member) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT handle FROM member_runs WHERE job_id = ? AND member = ?");
  q.bind(1, id).bind(2, member);
  return q.step() ? q.text(0) : std::string();
}

std::int64_t Store::add_log(const std::string& job_id, const std::string& level, const std::string& message,
                            std::int64_t now_ms) {
  std::lock_guard lock(mutex_);
  Stmt ins(db_, "INSERT INTO logs(job_id, at_ms, level, message) VALUES (?, ?, ?, ?)");
  ins.bind(1, job_id).bind(2, now_ms).bind(3, level).bind(4, message).run();
  return sqlite3_last_insert_rowid(db_);
}

namespace {
constexpr const char* kJobColumns =
    "seq, id, name, state, scene, seeds, particles, bond_preset, created_ms, started_ms, finished_ms, error, "
    "member, out_dir";

gel::v1::Job job_from_row(const Stmt& q) {
  gel::v1::Job job;
  job.set_id(q.text(1));
  job.set_name(q.text(2));
  job.set_state(Store::state_from_name(q.text(3)));
  job.mutable_scene()->ParseFromString(q.blob(4));
  auto seeds = nlohmann::json::parse(q.text(5), nullptr, false);
  if (seeds.is_array()) {
    for (const auto& s : seeds) job.add_seeds(s.get<std::uint64_t>());
  }
  job.set_particles(q.i64(6));
  job.set_bond_preset(q.text(7));
  job.set_created_unix_ms(q.i64(8));
  job.set_started_unix_ms(q.i64(9));
  job.set_finished_unix_ms(q.i64(10));
  job.set_error(q.text(11));
  job.set_member(static_cast<int>(q.i64(12)));
  job.set_out_dir(q.text(13));
  return job;
}

void fill_labels_and_rows(sqlite3* db, gel::v1::Job& job) {
  Stmt lab(db, "SELECT key, value FROM job_labels WHERE job_id = ?");
  lab.bind(1, job.id());
  while (lab.step()) (*job.mutable_labels())[lab.text(0)] = lab.text(1);
  // Kept as a parameter (run.program_version), so no schema change was needed for it.
  Stmt version(db, "SELECT value_text FROM parameters WHERE job_id = ? AND name = 'run.program_version'");
  version.bind(1, job.id());
  if (version.step()) job.set_program_version(version.text(0));
  Stmt cnt(db, "SELECT count(*) FROM curve_rows WHERE job_id = ?");
  cnt.bind(1, job.id());
  if (cnt.step()) job.set_rows(static_cast<int>(cnt.i64(0)));
}
}  // namespace

gel::v1::Job Store::read_job_locked(const std::string& id, bool& found) {
  Stmt q(db_, (std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?").c_str());
  q.bind(1, id);
  found = q.step();
  if (!found) return {};
  gel::v1::Job job = job_from_row(q);
  fill_labels_and_rows(db_, job);
  return job;
}

std::optional<gel::v1::Job> Store::get_job(const std::string& id) {
  std::lock_guard lock(mutex_);
  bool found = false;
  auto job = read_job_locked(id, found);
  if (!found) return std::nullopt;
  return job;
}

Store::MetadataMerge Store::merge_labels_and_name(const std::string& id,
                                                 const google::protobuf::Map<std::string, std::string>& labels,
                                                 const std::string& name, int max_labels) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  std::map<std::string, std::string> stored;
  {
    Stmt q(db_, "SELECT key, value FROM job_labels WHERE job_id = ?");
    q.bind(1, id);
    while (q.step()) stored[q.text(0)] = q.text(1);
  }
  MetadataMerge out;
  google::protobuf::Map<std::string, std::string> added;
  for (const auto& [key, value] : labels) {
    const auto it = stored.find(key);
    if (it == stored.end()) added[key] = value;
    else if (it->second != value) out.conflicts.emplace_back(key, it->second);
  }
  std::sort(out.conflicts.begin(), out.conflicts.end());
  out.labels = static_cast<int>(stored.size() + added.size());
  if (!out.conflicts.empty() || out.labels > max_labels) return out;  // rolled back: nothing written
  write_labels(db_, id, added);
  if (!name.empty()) {
    Stmt up(db_, "UPDATE jobs SET name = ? WHERE id = ? AND name = ''");
    up.bind(1, name).bind(2, id).run();
  }
  tx.commit();
  out.written = true;
  return out;
}

std::optional<std::string> Store::find_job_by_parameter(const std::string& name, const std::string& value,
                                                        gel::v1::JobState state) {
  std::lock_guard lock(mutex_);
  Stmt q(db_,
         "SELECT jobs.id FROM parameters JOIN jobs ON jobs.id = parameters.job_id "
         "WHERE parameters.name = ? AND parameters.value_text = ? AND jobs.state = ? ORDER BY jobs.seq DESC LIMIT 1");
  q.bind(1, name).bind(2, value).bind(3, state_name(state));
  if (!q.step()) return std::nullopt;
  return q.text(0);
}

std::vector<std::pair<std::int64_t, gel::v1::Job>> Store::list_jobs(const JobFilter& filter) {
  std::lock_guard lock(mutex_);
  std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE 1";
  std::vector<std::string> args;
  if (filter.state != gel::v1::JOB_STATE_UNSPECIFIED) {
    sql += " AND state = ?";
    args.push_back(state_name(filter.state));
  }
  if (!filter.name.empty()) {
    sql += " AND name = ?";
    args.push_back(filter.name);
  }
  if (!filter.label_key.empty()) {
    if (filter.label_value.empty()) {
      sql += " AND id IN (SELECT job_id FROM job_labels WHERE key = ?)";
      args.push_back(filter.label_key);
    } else {
      sql += " AND id IN (SELECT job_id FROM job_labels WHERE key = ? AND value = ?)";
      args.push_back(filter.label_key);
      args.push_back(filter.label_value);
    }
  }
  if (filter.before_seq > 0) sql += " AND seq < " + std::to_string(filter.before_seq);
  sql += " ORDER BY seq DESC LIMIT " + std::to_string(filter.limit);
  Stmt q(db_, sql.c_str());
  for (std::size_t i = 0; i < args.size(); ++i) q.bind(static_cast<int>(i + 1), args[i]);
  std::vector<std::pair<std::int64_t, gel::v1::Job>> out;
  while (q.step()) out.emplace_back(q.i64(0), job_from_row(q));
  for (auto& [seq, job] : out) fill_labels_and_rows(db_, job);
  return out;
}

std::vector<std::string> Store::job_ids_in_state(gel::v1::JobState state) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT id FROM jobs WHERE state = ? ORDER BY seq");
  q.bind(1, state_name(state));
  std::vector<std::string> out;
  while (q.step()) out.push_back(q.text(0));
  return out;
}

std::vector<std::string> Store::query_curves(const CurveFilter& filter) {
  std::lock_guard lock(mutex_);
  std::string sql = "SELECT id FROM jobs WHERE state = ?";
  struct Arg {
    enum { kText, kNum } type;
    std::string text;
    double num;
  };
  std::vector<Arg> args{{Arg::kText, state_name(filter.state), 0}};
  if (!filter.bond_preset.empty()) {
    sql += " AND bond_preset = ?";
    args.push_back({Arg::kText, filter.bond_preset, 0});
  }
  for (const auto& [k, v] : filter.labels) {
    sql += " AND id IN (SELECT job_id FROM job_labels WHERE key = ? AND value = ?)";
    args.push_back({Arg::kText, k, 0});
    args.push_back({Arg::kText, v, 0});
  }
  for (const auto& p : filter.parameters) {
    sql += " AND id IN (SELECT job_id FROM parameters WHERE name = ?";
    args.push_back({Arg::kText, p.name, 0});
    if (!p.equals.empty()) {
      char* end = nullptr;
      double num = std::strtod(p.equals.c_str(), &end);
      if (end && *end == '\0' && end != p.equals.c_str()) {
        sql += " AND (value_text = ? OR value_num = ?)";
        args.push_back({Arg::kText, p.equals, 0});
        args.push_back({Arg::kNum, "", num});
      } else {
        sql += " AND value_text = ?";
        args.push_back({Arg::kText, p.equals, 0});
      }
    }
    if (p.min) {
      sql += " AND value_num >= ?";
      args.push_back({Arg::kNum, "", *p.min});
    }
    if (p.max) {
      sql += " AND value_num <= ?";
      args.push_back({Arg::kNum, "", *p.max});
    }
    sql += ")";
  }
  sql += " ORDER BY seq DESC LIMIT " + std::to_string(filter.limit);
  Stmt q(db_, sql.c_str());
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i].type == Arg::kText) {
      q.bind(static_cast<int>(i + 1), args[i].text);
    } else {
      q.bind(static_cast<int>(i + 1), args[i].num);
    }
  }
  std::vector<std::string> out;
  while (q.step()) out.push_back(q.text(0));
  return out;
}

std::vector<StoredRow> Store::rows(const std::string& id) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT member, seed, row FROM curve_rows WHERE job_id = ? ORDER BY member, k");
  q.bind(1, id);
  std::vector<StoredRow> out;
  while (q.step()) {
    StoredRow r;
    r.member = static_cast<int>(q.i64(0));
    r.seed = static_cast<std::uint64_t>(q.i64(1));
    r.row.ParseFromString(q.blob(2));
    out.push_back(std::move(r));
  }
  return out;
}

int Store::row_count(const std::string& id) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT count(*) FROM curve_rows WHERE job_id = ?");
  q.bind(1, id);
  return q.step() ? static_cast<int>(q.i64(0)) : 0;
}

std::vector<gel::v1::LogLine> Store::logs(const std::string& id, std::int64_t after_id, int limit) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT id, at_ms, level, message FROM logs WHERE job_id = ? AND id > ? ORDER BY id LIMIT ?");
  q.bind(1, id).bind(2, after_id).bind(3, limit);
  std::vector<gel::v1::LogLine> out;
  while (q.step()) {
    gel::v1::LogLine line;
    line.set_id(q.i64(0));
    line.set_unix_ms(q.i64(1));
    line.set_level(q.text(2));
    line.set_message(q.text(3));
    out.push_back(std::move(line));
  }
  return out;
}

std::vector<std::pair<std::string, std::int64_t>> Store::states(const std::string& id) {
  std::lock_guard lock(mutex_);
  Stmt q(db_, "SELECT state, at_ms FROM states WHERE job_id = ? ORDER BY id");
  q.bind(1, id);
  std::vector<std::pair<std::string, std::int64_t>> out;
  while (q.step()) out.emplace_back(q.text(0), q.i64(1));
  return out;
}

// --- Studies ------------------------------------------------------------------------------

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
