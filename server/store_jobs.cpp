// The store's jobs: submission, states, members' handles and ends, labels, the run-cache
// lookup, listing and log lines.
#include <algorithm>
#include <cstdio>
#include <map>
#include <tuple>

#include <nlohmann/json.hpp>

#include "store.hpp"
#include "store_sql.hpp"

namespace geld {
using store_sql::Stmt;
using store_sql::Transaction;

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
             "INSERT INTO jobs(id, name, state, scene, scene_json, seeds, particles, bond_preset, created_ms, "
             "program_version) VALUES ('', ?, 'queued', ?, ?, ?, ?, ?, ?, ?)");
    ins.bind(1, job.name())
        .bind_blob(2, blob)
        .bind(3, scene_json)
        .bind(4, seeds.dump())
        .bind(5, static_cast<std::int64_t>(job.particles()))
        .bind(6, job.bond_preset())
        .bind(7, job.created_unix_ms())
        .bind(8, job.program_version());
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
    "out_dir, program_version";

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
  job.set_out_dir(q.text(12));
  job.set_program_version(q.text(13));
  return job;
}

void fill_labels_member_and_rows(sqlite3* db, gel::v1::Job& job) {
  Stmt lab(db, "SELECT key, value FROM job_labels WHERE job_id = ?");
  lab.bind(1, job.id());
  while (lab.step()) (*job.mutable_labels())[lab.text(0)] = lab.text(1);
  // The lowest member not finished: the first gap in member_finished (ascending).
  Stmt finished(db, "SELECT member FROM member_finished WHERE job_id = ? ORDER BY member");
  finished.bind(1, job.id());
  int lowest = 0;
  while (finished.step() && finished.i64(0) == lowest) ++lowest;
  job.set_member(lowest);
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
  fill_labels_member_and_rows(db_, job);
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
  for (auto& [seq, job] : out) fill_labels_member_and_rows(db_, job);
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

}  // namespace geld
