// The results history (history.h, `scanbench history`): change points on synthetic series
// (a planted step found at its commit, none in pure noise), and through the real binary:
// idempotent imports, imports killed with SIGKILL at random points, two imports at once, a newer
// schema and a corrupt file refused, show/changes, the report's History section in Chromium,
// and timing verdicts against the same machine's history.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <random>
#include <thread>
#include <vector>

#include "cli_test_util.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::test {
namespace {

using harness::ChangeOptions;
using harness::find_change_points;

std::vector<std::vector<double>> noise_series(std::mt19937& rng, int commits, int repeats,
                                              double level, double sd) {
  std::normal_distribution<double> n(level, sd);
  std::vector<std::vector<double>> out(commits);
  for (auto& c : out)
    for (int r = 0; r < repeats; ++r)
      c.push_back(n(rng));
  return out;
}

TEST(HistoryChanges, FindsAPlantedStepAtItsCommit) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    auto s = noise_series(rng, 40, 5, 1.0, 0.02);
    for (int i = 23; i < 40; ++i)
      for (double& x : s[i])
        x += 0.15;  // a step of 7.5 noise SDs
    const auto cps = find_change_points(s, ChangeOptions{});
    ASSERT_EQ(cps.size(), 1u) << "seed " << seed;
    EXPECT_EQ(cps[0].index, 23u);
    EXPECT_NEAR(cps[0].step, 0.15, 0.03);
    EXPECT_NEAR(cps[0].noise, 0.02, 0.01);
  }
}

TEST(HistoryChanges, NoneInPureNoise) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    EXPECT_TRUE(find_change_points(noise_series(rng, 60, 5, 1.0, 0.05), ChangeOptions{}).empty())
        << "seed " << seed;
    // One sample per commit (an accuracy metric run once per commit).
    EXPECT_TRUE(find_change_points(noise_series(rng, 60, 1, 1.0, 0.05), ChangeOptions{}).empty())
        << "seed " << seed;
  }
}

TEST(HistoryChanges, DeterministicMetricStepAndBelowFloor) {
  std::vector<std::vector<double>> s(20);
  for (int i = 0; i < 20; ++i)
    s[i] = {i < 12 ? 0.004 : 0.005};
  auto cps = find_change_points(s, ChangeOptions{});
  ASSERT_EQ(cps.size(), 1u);
  EXPECT_EQ(cps[0].index, 12u);
  EXPECT_NEAR(cps[0].rel_step, 0.25, 1e-9);
  // A step below min_rel of the level (float rounding across ISAs) is no change.
  for (int i = 12; i < 20; ++i)
    s[i] = {0.004 * (1 + 1e-6)};
  EXPECT_TRUE(find_change_points(s, ChangeOptions{}).empty());
}

// ---- synthetic results folders ---------------------------------------------------------------

struct SynthRun {
  std::string commit, date, host = "testhost";
  double metric = 0.004;
  std::vector<double> times{1.0, 1.01, 0.99, 1.0, 1.02};
  int jobs = 2;
  int extra_metrics = 0;  ///< more metric keys per job (a large import)
};

void write_run(const fs::path& dir, const SynthRun& r) {
  fs::create_directories(dir);
  std::string jsonl;
  for (int j = 0; j < r.jobs; ++j) {
    const std::string variant = j % 2 ? "clop" : "wlop";
    Json rec = {{"id", fmt::format("job{:05d}", j)},
                {"key", fmt::format("sphere|moderate|{}|p={}|seed=1", variant, j / 2)},
                {"experiment", "synthetic"},
                {"status", "ok"},
                {"error", ""},
                {"dataset", {{"label", "sphere"}}},
                {"scanner", {{"label", "moderate"}}},
                {"variant",
                 {{"label", variant},
                  {"chain", Json::array({{{"algorithm", "resample." + variant},
                                          {"label", "resample." + variant},
                                          {"params", Json::object()}}})}}},
                {"point_label", fmt::format("p={}", j / 2)},
                {"seed", 1},
                {"repeats", r.times.size()},
                {"metrics", {{"p2plane_mean_rel", r.metric}}},
                {"timing", {{"total_s", r.times}, {"job_wall_s", 1.0}}},
                {"context",
                 {{"commit", r.commit},
                  {"date", r.date},
                  {"host", r.host},
                  {"cpu", "Test CPU"},
                  {"hardware_threads", 2},
                  {"isa", "avx2"},
                  {"compiler", "gcc 12"}}}};
    for (int m = 0; m < r.extra_metrics; ++m)
      rec["metrics"][fmt::format("extra_{}", m)] = m * 0.5 + j;
    jsonl += rec.dump() + "\n";
  }
  write(dir / "runs.jsonl", jsonl);
}

std::string commit_of(int i) {
  return fmt::format("{:012x}", 0xabc000000000ULL + static_cast<unsigned>(i));
}
std::string date_of(int i) {
  return fmt::format("2026-11-{:02d}T{:02d}:00:00Z", 1 + i / 24, i % 24);
}

/// Runs a SQL query on the database; the first column of each row.
std::vector<std::string> query(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  std::vector<std::string> out;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(h);
    return {"open failed"};
  }
  sqlite3_busy_timeout(h, 10000);
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
    out.push_back(std::string("prepare failed: ") + sqlite3_errmsg(h));
  } else {
    while (sqlite3_step(s) == SQLITE_ROW) {
      const unsigned char* t = sqlite3_column_text(s, 0);
      out.push_back(t ? reinterpret_cast<const char*>(t) : "NULL");
    }
  }
  sqlite3_finalize(s);
  sqlite3_close(h);
  return out;
}

std::string one(const fs::path& db, const std::string& sql) {
  const auto rows = query(db, sql);
  return rows.empty() ? "" : rows.front();
}

/// Starts `scanbench ARGS...` as a child process (fork + exec of the real binary).
pid_t spawn(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string exe = sb();
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

TEST(HistoryDb, SameRunTwiceAddsNothing) {
  const fs::path dir = make_temp_dir("hist-twice");
  const fs::path db = dir / "h.sqlite";
  write_run(dir / "r1", {commit_of(1), date_of(1)});
  const auto a = sh(sb() + " history add " + (dir / "r1").string() + " --db " + db.string());
  ASSERT_EQ(a.code, 0) << a.out;
  EXPECT_NE(a.out.find("added run"), std::string::npos) << a.out;
  const std::string counts =
      "SELECT (SELECT COUNT(*) FROM runs) || '/' || (SELECT COUNT(*) FROM "
      "jobs) || '/' || (SELECT COUNT(*) FROM samples)";
  const std::string before = one(db, counts);
  EXPECT_EQ(before, "1/2/12");  // 2 jobs x (1 metric + 5 time.total samples)
  const auto b = sh(sb() + " history add " + (dir / "r1").string() + " --db " + db.string());
  EXPECT_EQ(b.code, 0) << b.out;
  EXPECT_NE(b.out.find("nothing changed"), std::string::npos) << b.out;
  EXPECT_EQ(one(db, counts), before);
  EXPECT_EQ(one(db, "PRAGMA user_version"), std::to_string(harness::kHistorySchema));
  EXPECT_EQ(one(db, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(one(db, "SELECT commit_id || ' ' || machine || ' ' || started FROM runs"),
            commit_of(1) + " testhost / Test CPU / 2 threads / avx2 " + date_of(1));
  EXPECT_EQ(one(db, "SELECT direction FROM samples WHERE quantity = 'p2plane_mean_rel'"), "-1");
  fs::remove_all(dir);
}

TEST(HistoryDb, RealRunAddsItselfAndClaimsFolderAddsVerdicts) {
  const fs::path dir = make_temp_dir("hist-run");
  const fs::path db = dir / "h.sqlite";
  write(dir / "tiny.json", R"({
    "scanbench_experiment": 1, "name": "tiny", "seed": 3, "repeats": 2, "save_outputs": false,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 32}}],
    "variants": [{"label": "sub2", "algorithm": "test.subsample", "params": {"stride": 2}}],
    "metrics": ["accuracy.p2plane"]
  })");
  const auto r = sh(sb() + " run " + (dir / "tiny.json").string() + " -q -o " +
                    (dir / "out").string() + " --db " + db.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("history: added run"), std::string::npos) << r.out;
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM jobs WHERE status = 'ok'"), "1");
  EXPECT_EQ(one(db, "SELECT config_name FROM runs"), "tiny");
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM samples WHERE quantity = 'time.total'"), "2");
  const auto rec = read_jsonl(dir / "out" / "runs.jsonl").front();
  const double stored =
      std::stod(one(db, "SELECT value FROM samples WHERE quantity = 'p2plane_mean_rel'"));
  EXPECT_NEAR(stored, rec["metrics"]["p2plane_mean_rel"].get<double>(), 1e-12 * stored);

  // nightly --db: adds itself; with no history on this machine the timings are not judged
  // (accuracy and status still are, against the baseline).
  const std::string nightly = sb() + " nightly --no-claims -q --config " +
                              (dir / "tiny.json").string() + " --baseline " +
                              (dir / "base").string() + " --db " + db.string();
  const auto n1 = sh(nightly + " -o " + (dir / "n1").string() + " --update-baseline");
  ASSERT_EQ(n1.code, 0) << n1.out;
  const auto n2 = sh(nightly + " -o " + (dir / "n2").string());
  ASSERT_EQ(n2.code, 0) << n2.out;
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM runs"), "3");
  const Json cmp = Json::parse(slurp(dir / "n2" / "compare.json"));
  EXPECT_NE(cmp["notes"].dump().find("timings not judged: 2 earlier runs on machine"),
            std::string::npos)
      << cmp["notes"];
  int accuracy = 0;
  for (const auto& v : cmp["comparisons"]) {
    EXPECT_NE(v["kind"], "time") << v.dump();
    accuracy += v["kind"] == "accuracy";
  }
  EXPECT_GT(accuracy, 0);
  EXPECT_NE(slurp(dir / "n2" / "index.html").find("<h2>History</h2>"), std::string::npos);
  // A claims-only folder (scanbench claims -o DIR): a run without jobs, the verdicts.
  fs::create_directories(dir / "claims");
  write(dir / "claims" / "claims.json", R"({"scanbench_claims": 1, "context": {"commit":
    "abc000000001", "date": "2026-11-02T00:00:00Z", "host": "h"}, "claims": [
    {"id": "a", "verdict": "held", "reason": ""}, {"id": "b", "verdict": "failed",
     "reason": "x > y does not hold"}]})");
  const auto c = sh(sb() + " history add " + (dir / "claims").string() + " --db " + db.string());
  ASSERT_EQ(c.code, 0) << c.out;
  EXPECT_EQ(one(db, "SELECT group_concat(claim || '=' || verdict) FROM claims"), "a=held,b=failed");
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM runs"), "4");
  fs::remove_all(dir);
}

TEST(HistoryDb, SigkillMidImportKeepsThePreviousState) {
  const fs::path dir = make_temp_dir("hist-kill");
  const fs::path db = dir / "h.sqlite";
  write_run(dir / "small", {commit_of(1), date_of(1)});
  SynthRun big{commit_of(2), date_of(2)};
  big.jobs = 3000;
  big.extra_metrics = 30;  // 3000 jobs x 36 samples
  write_run(dir / "big", big);
  ASSERT_EQ(sh(sb() + " history add " + (dir / "small").string() + " --db " + db.string()).code, 0);
  // Every trial starts from this one-run state: once an import has completed, another import of
  // the same run finds it there and ends at once, so later kills would not land mid-import.
  const fs::path before = dir / "before";
  fs::create_directories(before);
  const auto files = [](const fs::path& base) {
    return std::vector<fs::path>{base, base.string() + "-wal", base.string() + "-shm"};
  };
  for (const fs::path& f : files(db))
    if (fs::exists(f)) fs::copy_file(f, before / f.filename());
  const auto restore = [&] {
    for (const fs::path& f : files(db)) {
      fs::remove(f);
      if (fs::exists(before / f.filename())) fs::copy_file(before / f.filename(), f);
    }
  };
  // How long a whole import takes here, on a scratch copy.
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(wait_exit(spawn({"history", "add", (dir / "big").string(), "--db",
                             (dir / "scratch.sqlite").string()})),
            0);
  const double full_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> at(0.0, full_ms);
  int killed = 0;
  for (int trial = 0; trial < 8; ++trial) {
    restore();
    const pid_t pid = spawn({"history", "add", (dir / "big").string(), "--db", db.string()});
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<long>(1000 * at(rng))));
    kill(pid, SIGKILL);
    killed += wait_exit(pid) == -SIGKILL;
    EXPECT_EQ(one(db, "PRAGMA integrity_check"), "ok");
    const std::string runs = one(db, "SELECT COUNT(*) FROM runs");
    // Either the previous state or the whole run: never a part of it.
    if (runs == "1") {
      EXPECT_EQ(one(db, "SELECT COUNT(*) FROM jobs"), "2");
    } else {
      EXPECT_EQ(runs, "2");
      EXPECT_EQ(one(db, "SELECT COUNT(*) FROM jobs"), "3002");
      EXPECT_EQ(one(db, "SELECT COUNT(*) FROM samples"), std::to_string(12 + 3000 * 36));
    }
  }
  EXPECT_GE(killed, 3) << "the imports ended before the kill: full import " << full_ms << " ms";
  ASSERT_EQ(sh(sb() + " history add " + (dir / "big").string() + " --db " + db.string()).code, 0);
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM runs"), "2");
  EXPECT_EQ(one(db, "PRAGMA integrity_check"), "ok");
  fs::remove_all(dir);
}

TEST(HistoryDb, TwoImportsAtOnce) {
  const fs::path dir = make_temp_dir("hist-two");
  const fs::path db = dir / "h.sqlite";
  for (int i = 0; i < 3; ++i) {
    SynthRun r{commit_of(i), date_of(i)};
    r.jobs = 400;
    r.extra_metrics = 20;
    write_run(dir / fmt::format("r{}", i), r);
  }
  // Two different runs, and the same run twice, at the same time (the database starts missing:
  // both processes create the schema).
  const pid_t a = spawn({"history", "add", (dir / "r0").string(), "--db", db.string()});
  const pid_t b = spawn({"history", "add", (dir / "r1").string(), "--db", db.string()});
  const pid_t c = spawn({"history", "add", (dir / "r1").string(), "--db", db.string()});
  const pid_t d = spawn({"history", "add", (dir / "r2").string(), "--db", db.string()});
  EXPECT_EQ(wait_exit(a), 0);
  EXPECT_EQ(wait_exit(b), 0);
  EXPECT_EQ(wait_exit(c), 0);
  EXPECT_EQ(wait_exit(d), 0);
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM runs"), "3");
  EXPECT_EQ(one(db, "SELECT COUNT(*) FROM jobs"), "1200");
  EXPECT_EQ(one(db, "PRAGMA integrity_check"), "ok");
  fs::remove_all(dir);
}

TEST(HistoryDb, NewerSchemaAndCorruptFileAreRefusedUntouched) {
  const fs::path dir = make_temp_dir("hist-refuse");
  const fs::path db = dir / "h.sqlite";
  write_run(dir / "r1", {commit_of(1), date_of(1)});
  ASSERT_EQ(sh(sb() + " history add " + (dir / "r1").string() + " --db " + db.string()).code, 0);
  {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(h, "PRAGMA user_version=99; PRAGMA wal_checkpoint(TRUNCATE);", nullptr,
                           nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(h);
  }
  const std::string newer = slurp(db);
  for (const std::string& cmd :
       {" history add " + (dir / "r1").string(), std::string(" history show"),
        " report " + (dir / "r1").string()}) {
    const auto r = sh(sb() + cmd + " --db " + db.string());
    EXPECT_EQ(r.code, 2) << cmd << ": " << r.out;
    EXPECT_NE(r.out.find("h.sqlite: history schema version 99 is newer"), std::string::npos)
        << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
  EXPECT_EQ(slurp(db), newer);

  const fs::path bad = dir / "corrupt.sqlite";
  std::string garbage;
  std::mt19937 rng(7);
  for (int i = 0; i < 8192; ++i)
    garbage += static_cast<char>(rng() & 0xff);
  write(bad, garbage);
  for (const std::string& cmd :
       {" history add " + (dir / "r1").string(), std::string(" history changes")}) {
    const auto r = sh(sb() + cmd + " --db " + bad.string());
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find("corrupt.sqlite: "), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
  EXPECT_EQ(slurp(bad), garbage);
  EXPECT_FALSE(fs::exists(dir / "corrupt.sqlite-wal"));
  fs::remove_all(dir);
}

/// An example history: 12 runs over 12 commits, p2plane_mean_rel stepping up 20% at commit 7,
/// time.total stepping from 1 s to 1.5 s at commit 9 (repeats with 1% noise).
fs::path make_example_history(const fs::path& dir) {
  const fs::path db = dir / "history.sqlite";
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (int i = 0; i < 12; ++i) {
    SynthRun r{commit_of(i), date_of(i)};
    r.metric = i < 7 ? 0.004 : 0.0048;
    for (double& t : r.times)
      t = (i < 9 ? 1.0 : 1.5) * (1 + noise(rng));
    write_run(dir / fmt::format("run{:02d}", i), r);
    const auto a = sh(sb() + " history add " + (dir / fmt::format("run{:02d}", i)).string() +
                      " --db " + db.string());
    EXPECT_EQ(a.code, 0) << a.out;
  }
  return db;
}

TEST(HistoryCli, ShowAndChangesFindThePlantedSteps) {
  const fs::path dir = make_temp_dir("hist-cli");
  const fs::path db = make_example_history(dir);
  const auto show = sh(sb() + " history show --db " + db.string() +
                           " --metric p2plane_mean_rel --variant wlop --format csv",
                       false);
  ASSERT_EQ(show.code, 0) << show.out;
  EXPECT_EQ(std::count(show.out.begin(), show.out.end(), '\n'), 13) << show.out;
  EXPECT_NE(show.out.find(commit_of(6) + "," + date_of(6) + ",1,1,0.004,"), std::string::npos)
      << show.out;
  const auto since =
      sh(sb() + " history show --db " + db.string() +
             " --metric p2plane_mean_rel --variant wlop --format csv --since " + commit_of(10),
         false);
  EXPECT_EQ(std::count(since.out.begin(), since.out.end(), '\n'), 3) << since.out;

  const auto ch = sh(sb() + " history changes --db " + db.string() + " --format json", false);
  ASSERT_EQ(ch.code, 0) << ch.out;
  const Json cps = Json::parse(ch.out);
  ASSERT_EQ(cps.size(), 4u) << ch.out;  // 2 jobs x (metric step, time step)
  for (const auto& c : cps) {
    const bool time = c["quantity"] == "time.total";
    EXPECT_EQ(c["last_before"], commit_of(time ? 8 : 6)) << c.dump();
    EXPECT_EQ(c["first_after"], commit_of(time ? 9 : 7)) << c.dump();
    EXPECT_EQ(c["verdict"], "regression");
    EXPECT_NEAR(c["rel_step"].get<double>(), time ? 0.5 : 0.2, 0.03);
  }
  const auto bad = sh(sb() + " history show --db " + db.string() + " --since fedcba");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--since: fedcba is no commit"), std::string::npos) << bad.out;
  fs::remove_all(dir);
}

// SCANBENCH_HISTORY_EXAMPLE=DIR keeps the example history and its report in DIR (docs/history.md).
TEST(HistoryCli, ReportHistorySectionRendersInChromium) {
  const char* keep = std::getenv("SCANBENCH_HISTORY_EXAMPLE");
  const fs::path dir = keep ? fs::path(keep) : make_temp_dir("hist-report");
  if (keep) fs::create_directories(dir);
  const fs::path db = make_example_history(dir);
  const fs::path run = dir / "run11";
  const auto r = sh(sb() + " report " + run.string() + " --db " + db.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = slurp(run / "index.html");
  EXPECT_NE(html.find("<h2>History</h2>"), std::string::npos);
  EXPECT_NE(html.find("class=\"change\""), std::string::npos);
  ASSERT_TRUE(fs::exists("/usr/bin/chromium"))
      << "chromium not installed (scripts/setup.sh installs it)";
  const fs::path profile = make_temp_dir("chromium");
  const auto dom =
      sh("timeout 60 /usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-quic "
         "--no-first-run --disable-background-networking --disable-component-update --disable-sync "
         "--user-data-dir=" +
         profile.string() + " --dump-dom file://" + fs::absolute(run / "index.html").string() +
         " 2>/dev/null");
  const auto section = dom.out.find("id=\"history\"");
  ASSERT_NE(section, std::string::npos) << dom.out.substr(0, 500);
  std::size_t plots = 0;
  for (auto p = dom.out.find("<svg", section); p != std::string::npos;
       p = dom.out.find("<svg", p + 1))
    ++plots;
  EXPECT_EQ(plots, 4u);  // sphere / wlop and sphere / clop: p2plane_mean_rel and time.total
  EXPECT_NE(dom.out.find("<polyline", section), std::string::npos);
  EXPECT_NE(dom.out.find("change point: " + commit_of(6) + ".." + commit_of(7)), std::string::npos);
  fs::remove_all(profile);
  if (!keep) fs::remove_all(dir);
}

TEST(HistoryTiming, JudgedOnlyAgainstTheSameMachine) {
  const fs::path dir = make_temp_dir("hist-timing");
  const fs::path db = dir / "h.sqlite";
  for (int i = 0; i < 4; ++i) {
    write_run(dir / fmt::format("r{}", i), {commit_of(i), date_of(i)});
    ASSERT_EQ(harness::history_add(db, dir / fmt::format("r{}", i)).added, true);
  }
  auto records_of = [&](const std::string& host, std::vector<double> times) {
    SynthRun r{commit_of(9), date_of(9), host};
    r.times = std::move(times);
    write_run(dir / "now", r);
    return harness::load_records(dir / "now");
  };
  using harness::TimingHistoryOptions;
  // 50% slower on the same machine: a regression.
  auto slow = harness::history_timing_verdicts(
      db, records_of("testhost", {1.5, 1.51, 1.49, 1.5, 1.52}), "", "", TimingHistoryOptions{});
  ASSERT_TRUE(slow.machine_known);
  EXPECT_EQ(slow.history_runs, 4);
  ASSERT_EQ(slow.verdicts.size(), 2u);
  for (const auto& v : slow.verdicts)
    EXPECT_EQ(v.verdict, "regression") << v.note;
  // Within the noise: same.
  auto same = harness::history_timing_verdicts(
      db, records_of("testhost", {1.0, 1.02, 0.99, 1.01, 1.0}), "", "", TimingHistoryOptions{});
  for (const auto& v : same.verdicts)
    EXPECT_EQ(v.verdict, "same") << v.note;
  // Another machine: no history, nothing judged.
  auto other = harness::history_timing_verdicts(db, records_of("otherhost", {9, 9, 9, 9, 9}), "",
                                                "", TimingHistoryOptions{});
  EXPECT_FALSE(other.machine_known);
  EXPECT_TRUE(other.verdicts.empty());
  // Below the floor: too short to judge, even when 50% slower.
  TimingHistoryOptions floor;
  floor.min_time_s = 2.0;
  auto shorter =
      harness::history_timing_verdicts(db, records_of("testhost", {1.5, 1.5, 1.5}), "", "", floor);
  for (const auto& v : shorter.verdicts)
    EXPECT_EQ(v.verdict, "n/a") << v.note;
  fs::remove_all(dir);
}

/// A throwaway git repository whose scripts/build.sh "builds" a scanbench that writes one record
/// with p2plane_mean_rel = the value.txt of the commit it was built from (a file `broken` makes
/// the build fail). Returns the commit hashes, oldest first.
std::vector<std::string> make_bisect_repo(const fs::path& repo,
                                          const std::vector<std::string>& values, int broken_at) {
  fs::create_directories(repo / "scripts");
  fs::create_directories(repo / "configs");
  write(repo / "scripts" / "build.sh", R"SH(#!/usr/bin/env bash
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[[ -e "$here/broken" ]] && { echo "compile error" >&2; exit 1; }
v="$(cat "$here/value.txt")"
mkdir -p "$SCANBENCH_BUILD_DIR/harness"
cat > "$SCANBENCH_BUILD_DIR/harness/scanbench" <<EOS
#!/usr/bin/env bash
# run CONFIG -o OUT -q --filter RE
mkdir -p "\$4"
echo '{"id":"j1","key":"sphere|moderate|wlop||seed=1","status":"ok","metrics":{"p2plane_mean_rel":$v}}' > "\$4/runs.jsonl"
EOS
chmod +x "$SCANBENCH_BUILD_DIR/harness/scanbench"
)SH");
  write(repo / "configs" / "nightly.json", "{}\n");
  const std::string git = "git -C " + repo.string() + " ";
  EXPECT_EQ(
      sh(git + "init -q && " + git + "config user.email t@t && " + git + "config user.name t").code,
      0);
  std::vector<std::string> commits;
  for (std::size_t i = 0; i < values.size(); ++i) {
    write(repo / "value.txt", values[i] + "\n");
    if (static_cast<int>(i) == broken_at) {
      write(repo / "broken", "");
    } else {
      fs::remove(repo / "broken");
    }
    EXPECT_EQ(
        sh(git + "add -A && " + git + "commit -q --allow-empty -m c" + std::to_string(i)).code, 0);
    auto head = sh(git + "rev-parse HEAD", false).out;
    commits.push_back(head.substr(0, head.find('\n')));
  }
  return commits;
}

TEST(HistoryBisect, NamesThePlantedRegression) {
  const fs::path dir = make_temp_dir("hist-bisect");
  const auto c =
      make_bisect_repo(dir / "repo", {"1.0", "1.0", "1.01", "1.0", "2.0", "2.0", "2.1", "2.0"}, -1);
  const auto r = sh(sb() + " history bisect --metric p2plane_mean_rel --job " +
                    "'sphere|moderate|wlop||seed=1' --repo " + (dir / "repo").string() +
                    " --scratch " + (dir / "scratch").string() + " " + c[0] + " " + c[7]);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("first bad commit: " + c[4]), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "scratch" / "worktree"));  // removed at the end
  // A commit that does not build stops the search cleanly, naming the range left.
  const auto b = make_bisect_repo(dir / "repo2", {"1.0", "1.0", "1.0", "2.0", "2.0", "2.0"}, 2);
  const auto s = sh(sb() + " history bisect --metric p2plane_mean_rel --job " +
                    "'sphere|moderate|wlop||seed=1' --repo " + (dir / "repo2").string() +
                    " --scratch " + (dir / "scratch2").string() + " " + b[0] + " " + b[5]);
  EXPECT_EQ(s.code, 1) << s.out;
  EXPECT_NE(
      s.out.find(b[2] + " does not build; the first bad commit lies in " + b[0] + ".." + b[3]),
      std::string::npos)
      << s.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scanbench::test
