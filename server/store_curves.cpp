// The store's curves: each member's rows as reached (with their rupture counts in `events`),
// a finished member's whole curve, and QueryCurves' search over the flattened parameters.
#include <cstdlib>

#include "job_parameters.hpp"
#include "store.hpp"
#include "store_sql.hpp"

namespace geld {
using store_sql::Stmt;
using store_sql::Transaction;

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
    if (p.name == kProgramVersionParameter) {
      // A column of jobs (schema 7), filtered as its parameter row was: the text, and a version
      // has no number, so a bound matches no job.
      sql += p.equals.empty() ? " AND program_version <> ''" : " AND program_version = ?";
      if (!p.equals.empty()) args.push_back({Arg::kText, p.equals, 0});
      if (p.min || p.max) sql += " AND 0";
      continue;
    }
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

}  // namespace geld
