// The store's schema: its tables, and files written by every earlier version opened with
// their jobs, curves and versions intact.
#include <sqlite3.h>

#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "service_fixture.hpp"
#include "store.hpp"

namespace geld_test {
namespace {

TEST(Store, MigratesFromAnOlderSchemaVersion) {
  TempDir dir;
  const std::string path = (fs::path(dir.path()) / "geld.sqlite").string();
  std::string id;
  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), geld::Store::kSchemaVersion);
    gel::v1::Job job;
    job.set_name("old");
    job.add_seeds(7);
    job.set_particles(64);
    job.set_created_unix_ms(1);
    // Stored as before version 5: the submitted scene's seed, not the member's.
    id = store.insert_job(job, "{}", {{"generator.seed", "1", 1.0}, {"generator.lx", "30", 30.0}});
  }
  // Turn the file into a version 1 database: no indexes (v2), no member_runs table (v3), no
  // member_finished table (v4), no study tables (v6), jobs.member and no jobs.program_version (v7).
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    const char* sql =
        "DROP TABLE study_analyses; DROP TABLE study_jobs; DROP TABLE study_labels; DROP TABLE studies; "
        "DROP TABLE member_finished; DROP TABLE member_runs; DROP INDEX jobs_state; DROP INDEX jobs_name; DROP INDEX job_labels_kv; "
        "DROP INDEX parameters_name; DROP INDEX states_job; DROP INDEX logs_job; DROP INDEX events_job; "
        "ALTER TABLE jobs DROP COLUMN program_version; ALTER TABLE jobs ADD COLUMN member INTEGER NOT NULL DEFAULT 0; "
        "UPDATE schema_version SET version = 1;";
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_close(db);
  }
  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), geld::Store::kSchemaVersion);
    auto job = store.get_job(id);
    ASSERT_TRUE(job.has_value());
    EXPECT_EQ(job->name(), "old");
    EXPECT_EQ(job->seeds(0), 7u);
    store.set_member_handle(id, 0, 7, "slurm", "1234:0", 2);
    EXPECT_EQ(store.member_handle(id, 0), "1234:0");
    EXPECT_EQ(store.member_handle(id, 1), "");
    EXPECT_TRUE(store.finished_members(id).empty());
    store.set_member_finished(id, 0, 3);
    EXPECT_EQ(store.finished_members(id), std::vector<int>{0});
    // Version 6: studies can be stored in the migrated file.
    gel::v1::Study study;
    study.set_name("migrated");
    study.mutable_request()->set_preset("quick");
    const std::string study_id = store.insert_study(study);
    store.add_study_job(study_id, 0, "bond1", id, false);
    ASSERT_TRUE(store.get_study(study_id).has_value());
    EXPECT_EQ(store.get_study(study_id)->jobs(0).job_id(), id);
  }
  // Version 5 holds the members' seeds as generator.seed (7), not the scene's (1); others stay.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT name, value_text FROM parameters ORDER BY name, value_text", -1, &stmt, nullptr), SQLITE_OK);
    std::vector<std::string> rows;
    while (sqlite3_step(stmt) == SQLITE_ROW)
      rows.push_back(std::string(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0))) + "=" +
                     reinterpret_cast<const char*>(sqlite3_column_text(stmt, 1)));
    sqlite3_finalize(stmt);
    sqlite3_close(db);
    EXPECT_EQ(rows, (std::vector<std::string>{"generator.lx=30", "generator.seed=7"}));
  }
  // A newer schema than this geld knows is refused.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE schema_version SET version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    EXPECT_THROW(geld::Store store(path), geld::StoreError);
  }
}

TEST(Store, WalModeAndSchemaTables) {
  TempDir dir;
  const std::string path = (fs::path(dir.path()) / "geld.sqlite").string();
  geld::Store store(path);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0))), "wal");
  sqlite3_finalize(stmt);
  for (const char* table : {"schema_version", "jobs", "job_labels", "states", "parameters", "curve_rows", "events",
                            "logs", "member_runs", "member_finished", "studies", "study_labels", "study_jobs",
                            "study_analyses"}) {
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?", -1, &stmt,
                                 nullptr),
              SQLITE_OK);
    sqlite3_bind_text(stmt, 1, table, -1, SQLITE_STATIC);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(stmt, 0), 1) << table;
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
}


// The schema as version 6 left it (migrations 0 to 5, as `sqlite3 .schema` prints it), frozen
// here so that this test opens a file of that version whatever the migrations become.
constexpr const char* kVersion6Schema = R"sql(
CREATE TABLE schema_version (version INTEGER NOT NULL);
INSERT INTO schema_version(version) VALUES (6);
CREATE TABLE jobs (
  seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, name TEXT NOT NULL DEFAULT '',
  state TEXT NOT NULL, scene BLOB NOT NULL, scene_json TEXT NOT NULL, seeds TEXT NOT NULL,
  particles INTEGER NOT NULL, bond_preset TEXT NOT NULL DEFAULT '', created_ms INTEGER NOT NULL,
  started_ms INTEGER NOT NULL DEFAULT 0, finished_ms INTEGER NOT NULL DEFAULT 0, error TEXT NOT NULL DEFAULT '',
  member INTEGER NOT NULL DEFAULT 0, out_dir TEXT NOT NULL DEFAULT '');
CREATE TABLE job_labels (job_id TEXT NOT NULL REFERENCES jobs(id), key TEXT NOT NULL, value TEXT NOT NULL,
  PRIMARY KEY (job_id, key));
CREATE TABLE states (id INTEGER PRIMARY KEY AUTOINCREMENT, job_id TEXT NOT NULL REFERENCES jobs(id),
  state TEXT NOT NULL, at_ms INTEGER NOT NULL, message TEXT NOT NULL DEFAULT '');
CREATE TABLE curve_rows (job_id TEXT NOT NULL REFERENCES jobs(id), member INTEGER NOT NULL, seed INTEGER NOT NULL,
  k INTEGER NOT NULL, phi REAL, p REAL, p_top REAL, p_bot REAL, contact_number REAL, stored_energy REAL,
  dissipated_energy REAL, row BLOB NOT NULL, at_ms INTEGER NOT NULL, PRIMARY KEY (job_id, member, k));
CREATE TABLE events (id INTEGER PRIMARY KEY AUTOINCREMENT, job_id TEXT NOT NULL REFERENCES jobs(id),
  member INTEGER NOT NULL, k INTEGER NOT NULL, at_ms INTEGER NOT NULL, normal INTEGER NOT NULL,
  sliding INTEGER NOT NULL, rolling INTEGER NOT NULL, created INTEGER NOT NULL);
CREATE TABLE logs (id INTEGER PRIMARY KEY AUTOINCREMENT, job_id TEXT NOT NULL, at_ms INTEGER NOT NULL,
  level TEXT NOT NULL, message TEXT NOT NULL);
CREATE INDEX jobs_state ON jobs(state, seq);
CREATE INDEX jobs_name ON jobs(name, seq);
CREATE INDEX job_labels_kv ON job_labels(key, value);
CREATE INDEX states_job ON states(job_id, id);
CREATE INDEX logs_job ON logs(job_id, id);
CREATE INDEX events_job ON events(job_id, id);
CREATE TABLE member_runs (job_id TEXT NOT NULL REFERENCES jobs(id), member INTEGER NOT NULL, seed INTEGER NOT NULL,
  executor TEXT NOT NULL, handle TEXT NOT NULL, updated_ms INTEGER NOT NULL, PRIMARY KEY (job_id, member));
CREATE TABLE member_finished (job_id TEXT NOT NULL REFERENCES jobs(id), member INTEGER NOT NULL,
  finished_ms INTEGER NOT NULL, PRIMARY KEY (job_id, member));
CREATE TABLE parameters (job_id TEXT NOT NULL REFERENCES jobs(id), name TEXT NOT NULL, value_text TEXT NOT NULL,
  value_num REAL, PRIMARY KEY (job_id, name, value_text));
CREATE INDEX parameters_name ON parameters(name, value_num);
CREATE TABLE studies (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, name TEXT NOT NULL,
  preset TEXT NOT NULL, fidelity TEXT NOT NULL, request BLOB NOT NULL, created_ms INTEGER NOT NULL,
  program_version TEXT NOT NULL);
CREATE TABLE study_labels (study_id TEXT NOT NULL REFERENCES studies(id), key TEXT NOT NULL, value TEXT NOT NULL,
  PRIMARY KEY (study_id, key));
CREATE TABLE study_jobs (study_id TEXT NOT NULL REFERENCES studies(id), position INTEGER NOT NULL,
  ensemble TEXT NOT NULL, job_id TEXT NOT NULL REFERENCES jobs(id), cached INTEGER NOT NULL,
  PRIMARY KEY (study_id, position));
CREATE TABLE study_analyses (study_id TEXT NOT NULL REFERENCES studies(id), options TEXT NOT NULL,
  json TEXT NOT NULL, seconds REAL NOT NULL, created_ms INTEGER NOT NULL, PRIMARY KEY (study_id, options));
)sql";

// A blob as an SQL literal.
std::string blob_literal(const std::string& bytes) {
  static const char* const kDigits = "0123456789abcdef";
  std::string out = "X'";
  for (const unsigned char c : bytes) {
    out += kDigits[c >> 4];
    out += kDigits[c & 15];
  }
  return out + "'";
}

// Runs `sql` on the file; returns SQLite's error, or "".
std::string exec_sql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  std::string error;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) error = "cannot open " + path;
  char* err = nullptr;
  if (error.empty() && sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) error = err ? err : "?";
  sqlite3_free(err);
  sqlite3_close(db);
  return error;
}

// The rows `sql` selects, one string each: the columns joined by '|', blobs as literals.
std::vector<std::string> select_rows(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  std::vector<std::string> rows;
  while (stmt && sqlite3_step(stmt) == SQLITE_ROW) {
    std::string row;
    for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
      if (c > 0) row += "|";
      if (sqlite3_column_type(stmt, c) == SQLITE_BLOB) {
        row += blob_literal(std::string(static_cast<const char*>(sqlite3_column_blob(stmt, c)),
                                        static_cast<std::size_t>(sqlite3_column_bytes(stmt, c))));
      } else if (sqlite3_column_type(stmt, c) != SQLITE_NULL) {
        row += reinterpret_cast<const char*>(sqlite3_column_text(stmt, c));
      }
    }
    rows.push_back(row);
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return rows;
}

// The schema and every row of every table: two equal dumps, nothing changed in between.
std::vector<std::string> dump(const std::string& path) {
  std::vector<std::string> out = select_rows(path, "SELECT type, name, sql FROM sqlite_master ORDER BY name");
  for (const auto& table : select_rows(path, "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")) {
    for (const auto& row : select_rows(path, "SELECT * FROM \"" + table + "\" ORDER BY rowid")) out.push_back(table + ": " + row);
  }
  return out;
}

// Version 7 retired two pieces of compatibility state: jobs.member (the member being run, from
// before members ran in parallel; member_finished says it) and the parameter row
// run.program_version (now a column of jobs). A file written by version 6 opens with every job,
// curve and version as version 6 read them, and a second open changes nothing.
TEST(Store, Version7KeepsEveryJobCurveAndVersionOfAVersion6File) {
  TempDir dir;
  const std::string path = (fs::path(dir.path()) / "geld.sqlite").string();
  gel::v1::Scene scene;
  scene.mutable_generator()->set_lx(30);
  const std::string scene_blob = blob_literal(scene.SerializeAsString());
  const auto row_of = [](int k, double seed) { return blob_literal(make_row(k, seed).SerializeAsString()); };
  gel::v1::SubmitStudyRequest study_request;
  study_request.set_preset("quick");
  const std::string v1 = "0.1.0 git aaaaaaa Release", v2 = "0.2.0 git bbbbbbb Release";
  // 1: from before member_finished (only its member column says members 0 and 1 are done);
  // 2: members in parallel, 0 and 2 finished; 3: one member, finished; 4: from before
  // member_finished and before versions were recorded.
  ASSERT_EQ(exec_sql(path, std::string(kVersion6Schema) +
                     "INSERT INTO jobs(seq, id, name, state, scene, scene_json, seeds, particles, bond_preset, created_ms, "
                     "started_ms, finished_ms, error, member, out_dir) VALUES "
                     "(1, 'job-000001', 'before-parallel', 'running', " + scene_blob + ", '{}', '[4,5,6]', 64, 'bond1', 100, 110, 0, '', 2, 'jobs/job-000001'), "
                     "(2, 'job-000002', 'parallel', 'failed', " + scene_blob + ", '{}', '[7,8,9]', 64, 'bond1', 200, 210, 290, 'member 1: boom', 1, 'jobs/job-000002'), "
                     "(3, 'job-000003', 'single', 'succeeded', " + scene_blob + ", '{}', '[3]', 64, 'bond2', 300, 310, 390, '', 1, 'jobs/job-000003'), "
                     "(4, 'job-000004', 'unversioned', 'succeeded', " + scene_blob + ", '{}', '[1]', 64, 'bond2', 400, 410, 490, '', 1, 'jobs/job-000004');"
                     "INSERT INTO member_finished VALUES ('job-000002', 0, 250), ('job-000002', 2, 260), ('job-000003', 0, 380);"
                     "INSERT INTO parameters VALUES ('job-000001', 'generator.lx', '30', 30), ('job-000001', 'generator.seed', '4', 4), "
                     "('job-000001', 'generator.seed', '5', 5), ('job-000001', 'generator.seed', '6', 6), "
                     "('job-000001', 'run.cache_key', 'key1', NULL), ('job-000001', 'run.program_version', '" + v1 + "', NULL), "
                     "('job-000002', 'run.program_version', '" + v2 + "', NULL), ('job-000003', 'run.program_version', '" + v2 + "', NULL), "
                     "('job-000003', 'run.cache_key', 'key3', NULL), ('job-000004', 'generator.lx', '30', 30);"
                     "INSERT INTO job_labels VALUES ('job-000001', 'who', 'old');"
                     "INSERT INTO states(job_id, state, at_ms, message) VALUES ('job-000001', 'queued', 100, ''), "
                     "('job-000001', 'running', 110, ''), ('job-000002', 'failed', 290, 'member 1: boom');"
                     "INSERT INTO curve_rows(job_id, member, seed, k, phi, p, row, at_ms) VALUES "
                     "('job-000001', 0, 4, 0, 0.1, 0, " + row_of(0, 4) + ", 120), ('job-000001', 0, 4, 1, 0.15, 4, " + row_of(1, 4) + ", 121), "
                     "('job-000001', 1, 5, 0, 0.1, 0, " + row_of(0, 5) + ", 122), ('job-000003', 0, 3, 0, 0.1, 0, " + row_of(0, 3) + ", 320);"
                     "INSERT INTO events(job_id, member, k, at_ms, normal, sliding, rolling, created) VALUES ('job-000001', 0, 1, 121, 2, 1, 0, 3);"
                     "INSERT INTO logs(job_id, at_ms, level, message) VALUES ('job-000002', 290, 'error', 'member 1: boom');"
                     "INSERT INTO member_runs VALUES ('job-000001', 2, 6, 'slurm', '1234:2', 130);"
                     "INSERT INTO studies(id, name, preset, fidelity, request, created_ms, program_version) VALUES "
                     "('study-000001', 'small', 'quick', 'fast', " + blob_literal(study_request.SerializeAsString()) + ", 290, '" + v2 + "');"
                     "INSERT INTO study_labels VALUES ('study-000001', 'who', 'old');"
                     "INSERT INTO study_jobs VALUES ('study-000001', 0, 'bond2', 'job-000003', 0);"),
            "");
  const std::string kept_tables[] = {"job_labels", "states", "curve_rows", "events", "logs", "member_runs",
                                     "studies", "study_labels", "study_jobs", "study_analyses"};
  const std::string job_columns =
      "SELECT seq, id, name, state, scene, scene_json, seeds, particles, bond_preset, created_ms, started_ms, "
      "finished_ms, error, out_dir FROM jobs ORDER BY seq";
  std::vector<std::vector<std::string>> kept_before;
  for (const auto& table : kept_tables) kept_before.push_back(select_rows(path, "SELECT * FROM " + table + " ORDER BY rowid"));
  const auto jobs_before = select_rows(path, job_columns);
  const auto parameters_before = select_rows(
      path, "SELECT job_id, name, value_text, value_num FROM parameters WHERE name <> 'run.program_version' ORDER BY rowid");

  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), 7);
    struct Expected {
      std::string id;
      gel::v1::JobState state;
      int member;
      std::vector<int> finished;
      std::string program_version;
      int rows;
    };
    for (const Expected& e : {Expected{"job-000001", gel::v1::JOB_STATE_RUNNING, 2, {0, 1}, v1, 3},
                              Expected{"job-000002", gel::v1::JOB_STATE_FAILED, 1, {0, 2}, v2, 0},
                              Expected{"job-000003", gel::v1::JOB_STATE_SUCCEEDED, 1, {0}, v2, 1},
                              Expected{"job-000004", gel::v1::JOB_STATE_SUCCEEDED, 1, {0}, "", 0}}) {
      SCOPED_TRACE(e.id);
      const auto job = store.get_job(e.id);
      ASSERT_TRUE(job.has_value());
      EXPECT_EQ(job->state(), e.state);
      EXPECT_EQ(job->member(), e.member);
      EXPECT_EQ(store.finished_members(e.id), e.finished);
      EXPECT_EQ(job->program_version(), e.program_version);
      EXPECT_EQ(job->rows(), e.rows);
      EXPECT_EQ(job->scene().generator().lx(), 30);
    }
    const auto first = store.get_job("job-000001");
    EXPECT_EQ(first->seeds_size(), 3);
    EXPECT_EQ(first->labels().at("who"), "old");
    EXPECT_EQ(first->out_dir(), "jobs/job-000001");
    // The listing reads the same jobs as get_job does.
    for (const auto& [seq, job] : store.list_jobs({}))
      EXPECT_EQ(job.SerializeAsString(), store.get_job(job.id())->SerializeAsString()) << job.id();
    const auto rows = store.rows("job-000001");
    ASSERT_EQ(rows.size(), 3u);
    EXPECT_EQ(rows[2].member, 1);
    EXPECT_EQ(rows[2].seed, 5u);
    EXPECT_EQ(rows[2].row.SerializeAsString(), make_row(0, 5).SerializeAsString());
    EXPECT_EQ(store.get_study("study-000001")->program_version(), v2);
    // QueryCurves filters on run.program_version as it did on the parameter row: the text; any
    // version; a numeric bound matches none (a version has no number).
    geld::CurveFilter by_version;
    by_version.parameters = {{"run.program_version", v2, std::nullopt, std::nullopt}};
    EXPECT_EQ(store.query_curves(by_version), std::vector<std::string>{"job-000003"});
    by_version.state = gel::v1::JOB_STATE_FAILED;
    EXPECT_EQ(store.query_curves(by_version), std::vector<std::string>{"job-000002"});
    geld::CurveFilter any_version;
    any_version.parameters = {{"run.program_version", "", std::nullopt, std::nullopt}};
    EXPECT_EQ(store.query_curves(any_version), std::vector<std::string>{"job-000003"});
    any_version.parameters[0].min = 0.0;
    EXPECT_TRUE(store.query_curves(any_version).empty());
  }
  // Nothing else moved: the other columns of jobs, the other parameters and the other tables.
  EXPECT_EQ(select_rows(path, job_columns), jobs_before);
  EXPECT_EQ(select_rows(path, "SELECT job_id, name, value_text, value_num FROM parameters ORDER BY rowid"), parameters_before);
  for (std::size_t t = 0; t < std::size(kept_tables); ++t)
    EXPECT_EQ(select_rows(path, "SELECT * FROM " + kept_tables[t] + " ORDER BY rowid"), kept_before[t]) << kept_tables[t];
  EXPECT_EQ(select_rows(path, "SELECT job_id, member, finished_ms FROM member_finished ORDER BY job_id, member"),
            (std::vector<std::string>{"job-000001|0|0", "job-000001|1|0", "job-000002|0|250", "job-000002|2|260",
                                      "job-000003|0|380", "job-000004|0|0"}));

  // A second open migrates nothing and writes nothing.
  const auto migrated = dump(path);
  {
    geld::Store store(path);
    EXPECT_EQ(store.schema_version(), 7);
  }
  EXPECT_EQ(dump(path), migrated);
}

}  // namespace
}  // namespace geld_test
