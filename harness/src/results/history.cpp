#include "scanbench/harness/results/history.h"

#include "scanbench/harness/results/folder_lock.h"

#include <fmt/format.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <optional>
#include <regex>
#include <set>

#include "results/history_db.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/stats.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

// ---- the database handle (history_db.h) ----------------------------------------------------

namespace {

// Migration k takes user_version k to k + 1. Plain CREATE TABLE (not IF NOT EXISTS): a foreign
// database with a table of the same name fails the migration, which rolls back untouched.
const char* const kMigrations[] = {
    R"(CREATE TABLE runs(
         id INTEGER PRIMARY KEY, identity TEXT NOT NULL UNIQUE, folder TEXT, experiment TEXT,
         commit_id TEXT, commit_date TEXT, branch TEXT, dirty INTEGER, host TEXT, machine TEXT,
         cpu TEXT, cores INTEGER, isa TEXT, compiler TEXT, build TEXT, config_hash TEXT,
         config_name TEXT, started TEXT, ended TEXT, added TEXT);
       CREATE TABLE jobs(
         id INTEGER PRIMARY KEY, run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
         job_id TEXT, key TEXT NOT NULL, dataset TEXT, scanner TEXT, variant TEXT, point TEXT,
         seed INTEGER, repeats INTEGER, status TEXT, error TEXT, UNIQUE(run_id, key));
       CREATE TABLE samples(
         job INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE, quantity TEXT NOT NULL,
         idx INTEGER NOT NULL, value REAL, direction INTEGER NOT NULL,
         PRIMARY KEY(job, quantity, idx)) WITHOUT ROWID;
       CREATE TABLE claims(
         run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, claim TEXT NOT NULL,
         verdict TEXT, reason TEXT, PRIMARY KEY(run_id, claim));
       CREATE INDEX jobs_key ON jobs(key);
       CREATE INDEX runs_commit ON runs(commit_id);)",
};
constexpr int kMigrationCount = static_cast<int>(sizeof(kMigrations) / sizeof(kMigrations[0]));
static_assert(kMigrationCount == kHistorySchema);

}  // namespace

Db::Db(const fs::path& file, bool create) : file_(file) {
  if (!create && !fs::exists(file)) {
    throw IoError(fmt::format("{}: no such history database (`scanbench history add` makes one)",
                              file.string()));
  }
  if (create && !file.parent_path().empty()) fs::create_directories(file.parent_path());
  const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  if (sqlite3_open_v2(file.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
    const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw IoError(fmt::format("{}: cannot open the history database: {}", file.string(), msg));
  }
  sqlite3_busy_timeout(db_, 60000);
  try {
    // The first read fails on a file that is not a database (SQLITE_NOTADB): refused before any
    // write, so such a file is never touched.
    int version = 0;
    try {
      version = static_cast<int>(Stmt(*this, "PRAGMA user_version").step_int());
    } catch (const IoError&) {
      throw IoError(fmt::format("{}: not a readable SQLite database ({}); left untouched",
                                file.string(), sqlite3_errmsg(db_)));
    }
    if (version > kHistorySchema) {
      throw IoError(fmt::format(
          "{}: history schema version {} is newer than this scanbench's ({}); use a newer "
          "scanbench",
          file.string(), version, kHistorySchema));
    }
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    exec("PRAGMA foreign_keys=ON");
    if (version < kHistorySchema) migrate(create);
  } catch (...) {
    sqlite3_close(db_);  // the destructor does not run for a throwing constructor
    db_ = nullptr;
    throw;
  }
}

Db::~Db() {
  sqlite3_close(db_);
}

void Db::fail(const std::string& what) const {
  throw IoError(fmt::format("{}: {}: {}", file_.string(), what, sqlite3_errmsg(db_)));
}

void Db::exec(const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "error";
    sqlite3_free(err);
    throw IoError(fmt::format("{}: {}", file_.string(), msg));
  }
}

void Db::migrate(bool create) {
  Transaction t(*this);
  // Another process may have migrated while this one waited for the lock.
  const int version = static_cast<int>(Stmt(*this, "PRAGMA user_version").step_int());
  if (version == 0 && !create) {
    throw IoError(fmt::format("{}: not a scanbench history database (no schema)", file_.string()));
  }
  for (int v = version; v < kHistorySchema; ++v) {
    exec(kMigrations[v]);
    exec(fmt::format("PRAGMA user_version={}", v + 1));
  }
  t.commit();
}

Transaction::Transaction(Db& db) : db_(db) {
  db_.exec("BEGIN IMMEDIATE");
}

Transaction::~Transaction() {
  if (!done_) sqlite3_exec(db_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit() {
  db_.exec("COMMIT");
  done_ = true;
}

Stmt::Stmt(Db& db, const std::string& sql) : db_(db) {
  if (sqlite3_prepare_v2(db.handle(), sql.c_str(), -1, &s_, nullptr) != SQLITE_OK) {
    db.fail("cannot prepare \"" + sql.substr(0, 40) + "\"");
  }
}

Stmt::~Stmt() {
  sqlite3_finalize(s_);
}

Stmt& Stmt::bind(int i, const std::string& v) {
  sqlite3_bind_text(s_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  return *this;
}
Stmt& Stmt::bind(int i, std::int64_t v) {
  sqlite3_bind_int64(s_, i, v);
  return *this;
}
Stmt& Stmt::bind(int i, double v) {
  if (std::isfinite(v)) {
    sqlite3_bind_double(s_, i, v);
  } else {
    sqlite3_bind_null(s_, i);  // SQLite stores NaN as NULL anyway
  }
  return *this;
}
Stmt& Stmt::bind_null(int i) {
  sqlite3_bind_null(s_, i);
  return *this;
}

bool Stmt::step() {
  const int rc = sqlite3_step(s_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_.fail("query failed");
  return false;
}

void Stmt::run() {
  step();
  sqlite3_reset(s_);
  sqlite3_clear_bindings(s_);
}

std::int64_t Stmt::step_int() {
  const std::int64_t v = step() ? sqlite3_column_int64(s_, 0) : 0;
  sqlite3_reset(s_);
  return v;
}

std::string Stmt::text(int col) const {
  const unsigned char* t = sqlite3_column_text(s_, col);
  return t ? reinterpret_cast<const char*>(t) : "";
}
double Stmt::real(int col) const {
  return sqlite3_column_type(s_, col) == SQLITE_NULL ? std::nan("")
                                                     : sqlite3_column_double(s_, col);
}
std::int64_t Stmt::integer(int col) const {
  return sqlite3_column_int64(s_, col);
}

std::int64_t Db::last_id() const {
  return sqlite3_last_insert_rowid(db_);
}

// ---- import -----------------------------------------------------------------------------------

fs::path default_history_db() {
  return fs::path("results") / "history.sqlite";
}

std::string machine_identity(const Json& c) {
  if (!c.is_object()) return "unknown";
  return fmt::format("{} / {} / {} threads / {}", c.value("host", std::string("?")),
                     c.value("cpu", std::string("?")), c.value("hardware_threads", 0),
                     c.value("isa", std::string("?")));
}

namespace {

/// One line of `git -C <project root> ARGS` (empty when git or the commit is unavailable).
/// `rev` is checked to be a hash so that nothing from a record reaches a shell unquoted.
std::string git_line(const std::string& args, const std::string& rev) {
  if (rev != "HEAD" && !std::regex_match(rev, std::regex("[0-9a-fA-F]{4,40}"))) return {};
  const std::string cmd =
      fmt::format("git -C '{}' {} {} 2>/dev/null", project_root().string(), args, rev);
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {};
  char buf[256] = {0};
  std::string out = fgets(buf, sizeof(buf), p) ? buf : "";
  pclose(p);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r'))
    out.pop_back();
  return out;
}

/// Seconds since the epoch of an ISO 8601 UTC date ("2026-12-02T06:30:00Z"); NaN when invalid.
double parse_utc(const std::string& s) {
  std::tm tm{};
  if (!strptime(s.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm)) return std::nan("");
  return static_cast<double>(timegm(&tm));
}

std::string format_utc(double t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

struct RunRow {
  std::string identity, experiment, commit, commit_date, branch, started, ended;
  bool dirty = false;
  Json context = Json::object();
  std::string config_hash, config_name;
};

/// The run's row from its records (or the claims summary's context).
RunRow run_row(const fs::path& dir, const std::vector<Json>& records, const Json& claims) {
  RunRow row;
  std::string ident;
  double start = INFINITY, end = -INFINITY;
  for (const auto& r : records) {
    const Json c = r.value("context", Json::object());
    if (row.context.empty() && c.is_object()) row.context = c;
    const std::string date = c.is_object() ? c.value("date", std::string()) : "";
    // Dates have one-second resolution: the measured times tell apart two quick runs of the
    // same jobs started in the same second.
    const Json timing = r.value("timing", Json::object());
    ident += r.value("id", std::string()) + "@" + date + "/" +
             timing.value("job_wall_s", Json()).dump() + timing.value("total_s", Json()).dump() +
             ";";
    const double t = parse_utc(date);
    if (std::isnan(t)) continue;
    start = std::min(start, t);
    end = std::max(end, t + timing.value("job_wall_s", 0.0));
  }
  if (records.empty() && claims.is_object()) {
    row.context = claims.value("context", Json::object());
    ident = "claims@" + row.context.value("date", std::string());
    start = end = parse_utc(row.context.value("date", std::string()));
  }
  if (row.context.empty() && ident.empty()) {
    throw IoError(fmt::format("{}: no job records and no claims.json to add", dir.string()));
  }
  std::string commit = row.context.value("commit", std::string("unknown"));
  if (commit.size() > 6 && commit.compare(commit.size() - 6, 6, "-dirty") == 0) {
    row.dirty = true;
    commit.resize(commit.size() - 6);
  }
  row.commit = commit;
  row.identity = content_hash(commit + "|" + ident);
  if (std::isfinite(start)) row.started = format_utc(start);
  if (std::isfinite(end)) row.ended = format_utc(end);
  row.experiment = records.empty() ? "claims" : records.front().value("experiment", std::string());
  row.commit_date = git_line("show -s --format=%cI", commit);
  if (!row.commit_date.empty() && git_line("rev-parse --short=12", "HEAD") == commit) {
    row.branch = git_line("rev-parse --abbrev-ref", "HEAD");
  }
  if (fs::exists(dir / "config.json")) {
    const Json cfg = read_json_file(dir / "config.json").value("config", Json::object());
    row.config_hash = content_hash(cfg.dump());
    row.config_name = cfg.is_object() ? cfg.value("name", std::string()) : "";
  }
  return row;
}

std::int64_t insert_run(Db& db, const fs::path& dir, const RunRow& row,
                        const std::string& machine) {
  const Json& c = row.context;
  Stmt s(
      db,
      "INSERT INTO runs(identity, folder, experiment, commit_id, commit_date, branch, dirty, "
      "host, machine, cpu, cores, isa, compiler, build, config_hash, config_name, started, "
      "ended, added) VALUES(?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11,?12,?13,?14,?15,?16,?17,?18,?19)");
  s.bind(1, row.identity).bind(2, fs::absolute(dir).lexically_normal().string());
  s.bind(3, row.experiment).bind(4, row.commit);
  row.commit_date.empty() ? s.bind_null(5) : s.bind(5, row.commit_date);
  row.branch.empty() ? s.bind_null(6) : s.bind(6, row.branch);
  s.bind(7, std::int64_t{row.dirty});
  s.bind(8, c.value("host", std::string()));
  s.bind(9, machine.empty() ? machine_identity(c) : machine);
  s.bind(10, c.value("cpu", std::string()));
  s.bind(11, static_cast<std::int64_t>(c.value("hardware_threads", 0)));
  s.bind(12, c.value("isa", std::string()));
  s.bind(13, c.value("compiler", std::string()));
  s.bind(14, c.value("build", std::string()));
  s.bind(15, row.config_hash).bind(16, row.config_name);
  s.bind(17, row.started).bind(18, row.ended).bind(19, utc_now());
  s.run();
  return db.last_id();
}

std::string label_of(const Json& r, const char* field) {
  const Json f = r.value(field, Json::object());
  return f.is_object() ? f.value("label", std::string()) : std::string();
}

/// Every quantity of a record with its samples: metric keys, time.*, peak_rss_mb, sizes.*.
std::vector<std::pair<std::string, std::vector<double>>> quantities_of_record(const Json& r) {
  std::vector<std::pair<std::string, std::vector<double>>> out;
  // Named locals: a temporary in a range-for initialiser dies before the loop (C++20).
  const Json metrics = r.value("metrics", Json::object());
  for (const auto& [k, v] : metrics.items())
    if (v.is_number()) out.push_back({k, {v.get<double>()}});
  for (const std::string q : {"time.total", "time.cpu"}) {
    auto s = record_samples(r, q);
    if (!s.empty()) out.push_back({q, std::move(s)});
  }
  const Json timing = r.value("timing", Json::object());
  const Json phases = timing.value("phases", Json::object());
  for (const auto& [phase, v] : phases.items()) {
    auto s = record_samples(r, "time." + phase);
    if (!s.empty()) out.push_back({"time." + phase, std::move(s)});
  }
  if (r.contains("peak_rss_mb") && r["peak_rss_mb"].is_number()) {
    out.push_back({"peak_rss_mb", {r["peak_rss_mb"].get<double>()}});
  }
  const Json sizes = r.value("sizes", Json::object());
  for (const auto& [k, v] : sizes.items())
    if (v.is_number()) out.push_back({"sizes." + k, {v.get<double>()}});
  return out;
}

void insert_jobs(Db& db, std::int64_t run_id, const std::vector<Json>& records,
                 HistoryAddResult& res) {
  Stmt job(db,
           "INSERT INTO jobs(run_id, job_id, key, dataset, scanner, variant, point, seed, "
           "repeats, status, error) VALUES(?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11)");
  Stmt sample(db,
              "INSERT INTO samples(job, quantity, idx, value, direction) VALUES(?1,?2,?3,?4,?5)");
  for (const auto& r : records) {
    job.bind(1, run_id).bind(2, r.value("id", std::string()));
    job.bind(3, r.value("key", std::string()));
    job.bind(4, label_of(r, "dataset")).bind(5, label_of(r, "scanner"));
    job.bind(6, label_of(r, "variant")).bind(7, r.value("point_label", std::string()));
    job.bind(8, static_cast<std::int64_t>(r.value("seed", std::uint64_t{0})));
    job.bind(9, static_cast<std::int64_t>(r.value("repeats", 0)));
    job.bind(10, r.value("status", std::string())).bind(11, r.value("error", std::string()));
    job.run();
    const std::int64_t job_id = db.last_id();
    ++res.jobs;
    for (const auto& [q, samples] : quantities_of_record(r)) {
      const std::int64_t dir = quantity_direction(q);
      for (std::size_t i = 0; i < samples.size(); ++i) {
        sample.bind(1, job_id).bind(2, q).bind(3, static_cast<std::int64_t>(i));
        sample.bind(4, samples[i]).bind(5, dir);
        sample.run();
        ++res.samples;
      }
    }
  }
}

}  // namespace

HistoryAddResult history_add(const fs::path& db_file, const fs::path& dir,
                             const std::string& machine) {
  if (!fs::is_directory(dir)) throw IoError(fmt::format("{}: not a results folder", dir.string()));
  // Not while a run writes the folder (folder_lock.h): wait for it a minute, then refuse. A
  // folder this process cannot write (a read-only copy) has no scanbench writer either.
  std::optional<FolderLock> lock;
  try {
    lock.emplace(FolderLock::acquire(dir, "scanbench history add", 60));
  } catch (const FolderBusyError&) {
    throw;
  } catch (const IoError&) {
  }
  std::vector<Json> records;
  if (fs::exists(dir / "runs.jsonl") || fs::is_directory(dir / "jobs")) {
    records = load_records(dir);
  }
  Json claims;
  if (fs::exists(dir / "claims.json")) {
    claims = read_json_file(dir / "claims.json");
    if (!claims.is_object() || !claims.value("claims", Json()).is_array()) {
      throw IoError(fmt::format("{}: claims: expected an array", (dir / "claims.json").string()));
    }
  }
  const RunRow row = run_row(dir, records, claims);
  HistoryAddResult res;
  res.identity = row.identity;
  Db db(db_file, true);
  Transaction t(db);
  Stmt find(db, "SELECT id FROM runs WHERE identity = ?1");
  find.bind(1, row.identity);
  if (const std::int64_t id = find.step_int(); id != 0) {
    res.run_id = id;
    return res;  // already there: the transaction rolls back, nothing changes
  }
  res.run_id = insert_run(db, dir, row, machine);
  insert_jobs(db, res.run_id, records, res);
  if (claims.is_object()) {
    Stmt c(db, "INSERT OR REPLACE INTO claims(run_id, claim, verdict, reason) VALUES(?1,?2,?3,?4)");
    for (const auto& cl : claims["claims"]) {
      if (!cl.is_object()) continue;
      c.bind(1, res.run_id).bind(2, cl.value("id", std::string()));
      c.bind(3, cl.value("verdict", std::string())).bind(4, cl.value("reason", std::string()));
      c.run();
      ++res.claims;
    }
  }
  t.commit();
  res.added = true;
  return res;
}

// ---- queries ----------------------------------------------------------------------------------

std::vector<HistorySeries> history_series(const fs::path& db_file, const HistoryFilter& f) {
  Db db(db_file, false);
  std::string since_date;
  if (!f.since.empty()) {
    Stmt s(db,
           "SELECT COALESCE(commit_date, started) AS d FROM runs WHERE commit_id LIKE ?1 || '%' "
           "ORDER BY d LIMIT 1");
    s.bind(1, f.since);
    if (!s.step()) {
      throw ParamError(fmt::format("--since: {} is no commit in {}", f.since, db_file.string()));
    }
    since_date = s.text(0);
  }
  // Quantities: the metric asked for, else every metric key and (with timing) time.total.
  Stmt q(db,
         "SELECT j.key, j.dataset, j.variant, s.quantity, s.direction, r.commit_id, "
         "COALESCE(r.commit_date, r.started) AS d, r.id, s.value FROM samples s "
         "JOIN jobs j ON j.id = s.job JOIN runs r ON r.id = j.run_id "
         "WHERE j.status = 'ok' AND (?1 = '' AND (s.quantity NOT LIKE 'time.%' OR "
         "(?7 AND s.quantity = 'time.total')) AND s.quantity NOT LIKE 'sizes.%' AND "
         "s.quantity <> 'peak_rss_mb' OR s.quantity = ?1) "
         "AND (?2 = '' OR j.dataset = ?2) AND (?3 = '' OR j.variant = ?3) "
         "AND (?4 = '' OR j.key = ?4) AND (?5 = '' OR d >= ?5) AND (?6 = '' OR r.machine = ?6) "
         "ORDER BY j.key, s.quantity, d, r.commit_id, r.id, s.idx");
  q.bind(1, f.metric).bind(2, f.dataset).bind(3, f.variant).bind(4, f.key).bind(5, since_date);
  q.bind(6, f.machine).bind(7, std::int64_t{f.timing});
  std::vector<HistorySeries> out;
  std::set<std::int64_t> runs_of_point;
  while (q.step()) {
    const std::string key = q.text(0), quantity = q.text(3), commit = q.text(5);
    if (out.empty() || out.back().key != key || out.back().quantity != quantity) {
      HistorySeries s;
      s.key = key;
      s.dataset = q.text(1);
      s.variant = q.text(2);
      s.quantity = quantity;
      s.direction = static_cast<int>(q.integer(4));
      out.push_back(std::move(s));
    }
    auto& pts = out.back().points;
    if (pts.empty() || pts.back().commit != commit) {
      pts.push_back({commit, q.text(6), 0, {}});
      runs_of_point.clear();
    }
    if (runs_of_point.insert(q.integer(7)).second) ++pts.back().runs;
    const double v = q.real(8);
    if (std::isfinite(v)) pts.back().samples.push_back(v);
  }
  return out;
}

// ---- change points ----------------------------------------------------------------------------

namespace {

/// 1.4826 x the median absolute deviation of each sample from its own side's median, pooled:
/// a robust standard deviation of the noise that a step between the sides does not inflate.
double pooled_noise(const std::vector<double>& a, double ma, const std::vector<double>& b,
                    double mb) {
  std::vector<double> dev;
  for (double x : a)
    dev.push_back(std::abs(x - ma));
  for (double x : b)
    dev.push_back(std::abs(x - mb));
  return 1.4826 * median(dev);
}

}  // namespace

std::vector<ChangePoint> find_change_points(const std::vector<std::vector<double>>& commits,
                                            const ChangeOptions& o) {
  const std::size_t n = commits.size(), w = static_cast<std::size_t>(std::max(1, o.window));
  std::vector<ChangePoint> candidates;
  for (std::size_t i = 1; i < n; ++i) {
    std::vector<double> a, b;
    for (std::size_t k = i > w ? i - w : 0; k < i; ++k)
      a.insert(a.end(), commits[k].begin(), commits[k].end());
    for (std::size_t k = i; k < std::min(n, i + w); ++k)
      b.insert(b.end(), commits[k].begin(), commits[k].end());
    if (static_cast<int>(a.size()) < o.min_samples || static_cast<int>(b.size()) < o.min_samples) {
      continue;
    }
    ChangePoint c;
    c.index = i;
    c.before = median(a);
    c.after = median(b);
    c.step = c.after - c.before;
    c.rel_step = c.before != 0 ? c.step / std::abs(c.before) : 0.0;
    c.noise = pooled_noise(a, c.before, b, c.after);
    c.p = mann_whitney_u(a, b).p;
    const double size = std::abs(c.step);
    if (c.p < o.alpha && size > o.sigmas * c.noise && size > o.min_rel * std::abs(c.before) &&
        size > o.min_abs) {
      candidates.push_back(c);
    }
  }
  // Near a step the neighbouring splits mix both levels and may also pass; the true split
  // separates the windows best (smallest p), then has the largest step.
  std::sort(candidates.begin(), candidates.end(), [](const ChangePoint& x, const ChangePoint& y) {
    if (x.p != y.p) return x.p < y.p;
    if (std::abs(x.step) != std::abs(y.step)) return std::abs(x.step) > std::abs(y.step);
    return x.index < y.index;
  });
  std::vector<ChangePoint> kept;
  for (const auto& c : candidates) {
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const ChangePoint& k) {
      return (c.index > k.index ? c.index - k.index : k.index - c.index) < w;
    });
    if (!near) kept.push_back(c);
  }
  std::sort(kept.begin(), kept.end(),
            [](const ChangePoint& x, const ChangePoint& y) { return x.index < y.index; });
  return kept;
}

// ---- timing verdicts against the same machine's history ---------------------------------------

namespace {

double robust_sd(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = median(v);
  std::vector<double> dev;
  for (double x : v)
    dev.push_back(std::abs(x - m));
  return 1.4826 * median(dev);
}

/// Per (job key, time quantity): the samples of each earlier run on the machine, oldest first.
using RunSamples = std::map<std::pair<std::string, std::string>, std::vector<std::vector<double>>>;

RunSamples machine_timings(Db& db, const std::string& machine, const std::string& exclude) {
  Stmt q(db,
         "SELECT j.key, s.quantity, r.id, s.value FROM samples s JOIN jobs j ON j.id = s.job "
         "JOIN runs r ON r.id = j.run_id WHERE r.machine = ?1 AND r.identity <> ?2 AND "
         "j.status = 'ok' AND s.quantity LIKE 'time.%' AND s.quantity <> 'time.cpu' "
         "ORDER BY j.key, s.quantity, COALESCE(r.commit_date, r.started), r.started, r.id, s.idx");
  q.bind(1, machine).bind(2, exclude);
  RunSamples out;
  std::int64_t last_run = -1;
  while (q.step()) {
    auto& runs = out[{q.text(0), q.text(1)}];
    const std::int64_t run = q.integer(2);
    if (runs.empty() || run != last_run) runs.emplace_back();
    last_run = run;
    const double v = q.real(3);
    if (std::isfinite(v)) runs.back().push_back(v);
  }
  return out;
}

Verdict timing_verdict(const std::string& key, const std::string& q,
                       const std::vector<std::vector<double>>& runs, const std::vector<double>& now,
                       const TimingHistoryOptions& o) {
  Verdict v;
  v.key = key;
  v.quantity = q;
  v.kind = "time";
  v.now = median(now);
  std::vector<double> medians, recent;
  for (const auto& r : runs)
    if (!r.empty()) medians.push_back(median(r));
  const std::size_t first = runs.size() > static_cast<std::size_t>(o.window)
                                ? runs.size() - static_cast<std::size_t>(o.window)
                                : 0;
  for (std::size_t i = first; i < runs.size(); ++i)
    recent.insert(recent.end(), runs[i].begin(), runs[i].end());
  v.base = medians.empty() ? std::nan("") : median(medians);
  v.change = v.base > 0 ? (v.now - v.base) / v.base : 0.0;
  if (static_cast<int>(medians.size()) < o.min_runs) {
    v.verdict = "n/a";
    v.note = fmt::format("{} earlier runs of this job on this machine (< {})", medians.size(),
                         o.min_runs);
    return v;
  }
  if (std::max(v.base, v.now) < o.min_time_s) {
    v.verdict = "n/a";
    v.note = fmt::format("below the {} s floor: too short to judge", o.min_time_s);
    return v;
  }
  const double noise = std::hypot(robust_sd(medians), robust_sd(now));
  const double limit = std::max(o.sigmas * noise, o.threshold * v.base);
  v.p = mann_whitney_u(recent, now).p;
  const bool significant = std::abs(v.now - v.base) > limit && v.p < o.alpha;
  v.verdict = !significant ? "same" : (v.now > v.base ? "regression" : "improvement");
  v.note = fmt::format("machine history: {} runs, level {:.4g} s, noise {:.3g} s, limit {:.3g} s",
                       medians.size(), v.base, noise, limit);
  return v;
}

}  // namespace

TimingHistoryResult history_timing_verdicts(const fs::path& db_file,
                                            const std::vector<Json>& records,
                                            const std::string& exclude_identity,
                                            const std::string& machine,
                                            const TimingHistoryOptions& o) {
  TimingHistoryResult res;
  res.machine = machine;
  if (res.machine.empty() && !records.empty()) {
    res.machine = machine_identity(records.front().value("context", Json::object()));
  }
  Db db(db_file, false);
  Stmt count(db, "SELECT COUNT(*) FROM runs WHERE machine = ?1 AND identity <> ?2");
  count.bind(1, res.machine).bind(2, exclude_identity);
  res.history_runs = static_cast<int>(count.step_int());
  if (res.history_runs < o.min_runs) return res;
  res.machine_known = true;
  const RunSamples hist = machine_timings(db, res.machine, exclude_identity);
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") continue;
    const std::string key = r.value("key", std::string());
    std::vector<std::string> quantities{"time.total"};
    const Json phases = r.value("timing", Json::object()).value("phases", Json::object());
    for (const auto& [phase, s] : phases.items())
      quantities.push_back("time." + phase);
    for (const auto& q : quantities) {
      const std::vector<double> now = record_samples(r, q);
      if (now.empty()) continue;
      auto it = hist.find({key, q});
      static const std::vector<std::vector<double>> none;
      res.verdicts.push_back(timing_verdict(key, q, it == hist.end() ? none : it->second, now, o));
    }
  }
  return res;
}

void judge_timings_by_history(CompareResult& res, const fs::path& db,
                              const std::vector<Json>& records, const std::string& exclude_identity,
                              const TimingHistoryOptions& o) {
  const TimingHistoryResult t = history_timing_verdicts(db, records, exclude_identity, {}, o);
  if (!t.machine_known) {
    res.notes.push_back(fmt::format(
        "timings not judged: {} earlier runs on machine \"{}\" in {} (a verdict needs {}); "
        "accuracy judged against the baseline",
        t.history_runs, t.machine, db.string(), o.min_runs));
    return;
  }
  res.notes.push_back(fmt::format(
      "timings judged against {} earlier runs of machine \"{}\" in {} (not the baseline)",
      t.history_runs, t.machine, db.string()));
  for (const auto& v : t.verdicts) {
    if (v.verdict == "regression") {
      ++res.regressions;
    } else if (v.verdict == "improvement") {
      ++res.improvements;
    } else {
      ++res.unchanged;
    }
    res.verdicts.push_back(v);
  }
}

// ---- the report's History section -----------------------------------------------------------

std::vector<HistoryPlot> history_plots(const fs::path& db_file, const std::vector<Json>& records,
                                       const std::vector<std::string>& metrics,
                                       const std::string& baseline_commit) {
  std::vector<HistoryPlot> plots;
  std::set<std::pair<std::string, std::string>> seen;
  const std::string machine =
      records.empty() ? "" : machine_identity(records.front().value("context", Json::object()));
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") continue;
    const std::string dataset = label_of(r, "dataset"), variant = label_of(r, "variant");
    if (!seen.insert({dataset, variant}).second) continue;  // the first job of the pair
    std::vector<std::string> quantities = metrics;
    quantities.push_back("time.total");
    for (const auto& q : quantities) {
      HistoryFilter f;
      f.key = r.value("key", std::string());
      f.metric = q;
      if (q.rfind("time.", 0) == 0) f.machine = machine;  // timings: this machine only
      const auto series = history_series(db_file, f);
      if (series.empty() || series.front().points.size() < 2) continue;
      HistoryPlot p;
      p.title = fmt::format("{} / {}: {}", dataset, variant, q);
      p.ylabel = q;
      std::vector<std::vector<double>> per_commit;
      for (const auto& pt : series.front().points) {
        p.commits.push_back(pt.commit);
        p.samples.push_back(pt.samples);
        if (!baseline_commit.empty() && pt.commit == baseline_commit) {
          p.baseline = static_cast<long>(p.commits.size()) - 1;
        }
      }
      for (const auto& c : find_change_points(p.samples, ChangeOptions{}))
        p.changes.push_back(c.index);
      plots.push_back(std::move(p));
    }
  }
  return plots;
}

}  // namespace scanbench::harness
