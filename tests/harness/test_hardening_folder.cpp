// Issue 48, the results folder as a database, through the real binary: one writer per folder,
// another experiment refused, nothing written through links, leftovers removed, runs.jsonl
// checked against jobs/, a job's daemonised children ended with it, environment errors as exit 2,
// failed jobs as exit 4 with their reasons last.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include "cli_test_util.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

/// A small config of `n` quick jobs (test.subsample on a coarse sphere scan), `busy_ms` of work
/// each so that a second process has time to meet the first.
std::string small_config(const std::string& name, int n, int busy_ms = 0) {
  Json c = Json::parse(R"({"scanbench_experiment": 1, "seed": 5, "timeout_s": 120,
    "save_outputs": true, "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 30}}],
    "metrics": ["accuracy.p2plane"]})");
  c["name"] = name;
  c["variants"] = Json::array();
  for (int i = 0; i < n; ++i) {
    c["variants"].push_back({{"label", "s" + std::to_string(i + 2)},
                             {"algorithm", "test.subsample"},
                             {"params", {{"stride", i + 2}, {"work_ms", busy_ms}}}});
  }
  return c.dump(1);
}

std::string run_cmd(const fs::path& config, const fs::path& out, const std::string& extra = "") {
  return sb() + " run " + config.string() + " -o " + out.string() + " -q " + extra;
}

int count_lines(const std::string& text) {
  int n = 0;
  for (char c : text)
    n += c == '\n';
  return n;
}

/// The one stderr line of a refused command (its last non-empty line).
std::string last_line(std::string s) {
  while (!s.empty() && s.back() == '\n')
    s.pop_back();
  const auto nl = s.rfind('\n');
  return nl == std::string::npos ? s : s.substr(nl + 1);
}

std::vector<std::string> job_ids(const fs::path& out) {
  std::vector<std::string> ids;
  const Json plan = Json::parse(slurp(out / "plan.json"));
  for (const auto& j : plan["jobs"])
    ids.push_back(j["id"].get<std::string>());
  return ids;
}

}  // namespace

// Two `run` processes on one folder: the second is refused at once with the holder's pid and
// host, and every record of the first is intact (today's loss: the second deleted the first's
// tmp/<id>.spec.json, and its jobs ended as errors).
TEST(FolderLock, ASecondWriterIsRefusedAndTheFirstLosesNothing) {
  const fs::path dir = make_temp_dir("lock");
  write(dir / "a.json", small_config("locked", 4, 400));
  const fs::path out = dir / "out";
  const std::string log = (dir / "first.log").string();
  const pid_t first = fork();
  ASSERT_GE(first, 0);
  if (first == 0) {
    const std::string cmd =
        "SCANBENCH_TEST_ALGORITHMS=1 " + run_cmd(dir / "a.json", out) + " > " + log + " 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until the first run holds the folder (its lock file names it), then try a second.
  for (int i = 0; i < 600 && slurp(out / ".lock").find("scanbench run") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto second = sh(run_cmd(dir / "a.json", out, "--resume"));
  EXPECT_EQ(second.code, 2) << second.out;
  EXPECT_EQ(count_lines(second.out), 1) << second.out;
  EXPECT_TRUE(std::regex_search(second.out, std::regex("in use by pid [0-9]+ on host ")))
      << second.out;
  // The other writers are refused the same way while the run holds the folder.
  const auto report = sh(sb() + " report " + out.string());
  EXPECT_EQ(report.code, 2) << report.out;
  EXPECT_NE(report.out.find("in use by pid"), std::string::npos) << report.out;
  int status = 0;
  ASSERT_EQ(waitpid(first, &status, 0), first);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << slurp(log);
  const auto recs = read_jsonl(out / "runs.jsonl");
  ASSERT_EQ(recs.size(), 4u);
  for (const auto& r : recs)
    EXPECT_EQ(r["status"], "ok") << r.dump();
  // Released with its holder: a later writer gets the folder.
  EXPECT_EQ(sh(sb() + " report " + out.string()).code, 0);
}

// A different experiment into a folder that holds one is refused, naming where the configs differ;
// the folder's files are unchanged.
TEST(FolderLock, AnotherExperimentIsRefused) {
  const fs::path dir = make_temp_dir("other");
  write(dir / "a.json", small_config("first", 2));
  write(dir / "b.json", small_config("second", 2));
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  const std::string config = slurp(out / "config.json"), runs = slurp(out / "runs.jsonl");
  for (const char* extra : {"", "--resume"}) {
    const auto r = sh(run_cmd(dir / "b.json", out, extra));
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_EQ(count_lines(r.out), 1) << r.out;
    EXPECT_NE(r.out.find("holds the results of another experiment ('first'"), std::string::npos)
        << r.out;
  }
  EXPECT_EQ(slurp(out / "config.json"), config);
  EXPECT_EQ(slurp(out / "runs.jsonl"), runs);
  // The same experiment resumes as before.
  EXPECT_EQ(sh(run_cmd(dir / "a.json", out, "--resume")).code, 0);
}

// DIR/tmp as a link is refused before anything is deleted through it; a link in place of a
// job's log or output is replaced by the file, its target unchanged.
TEST(FolderLinks, NothingIsWrittenOrDeletedThroughALink) {
  const fs::path dir = make_temp_dir("links");
  write(dir / "a.json", small_config("links", 2));
  const fs::path out = dir / "out";
  const fs::path victim = dir / "victim";
  fs::create_directories(victim / "sub");
  write(victim / "keep.txt", "precious");
  fs::create_directories(out);
  fs::create_directory_symlink(victim, out / "tmp");
  const auto r = sh(run_cmd(dir / "a.json", out));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(last_line(r.out).find("tmp: is a symbolic link"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(victim / "keep.txt"), "precious");
  EXPECT_TRUE(fs::is_directory(victim / "sub"));

  // A finished run; then one job's record removed and its log and output replaced by links.
  fs::remove(out / "tmp");
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  const std::string id = job_ids(out).front();
  fs::remove(out / "jobs" / (id + ".json"));
  write(dir / "log-target", "log target");
  write(dir / "ply-target", "ply target");
  fs::remove(out / "logs" / (id + ".log"));
  fs::create_symlink(dir / "log-target", out / "logs" / (id + ".log"));
  std::string ply;
  for (const auto& e : fs::directory_iterator(out / "outputs"))
    if (e.path().filename().string().rfind(id, 0) == 0) ply = e.path().filename().string();
  ASSERT_FALSE(ply.empty());
  fs::remove(out / "outputs" / ply);
  fs::create_symlink(dir / "ply-target", out / "outputs" / ply);
  const auto again = sh(run_cmd(dir / "a.json", out, "--resume"));
  EXPECT_EQ(again.code, 0) << again.out;
  EXPECT_EQ(slurp(dir / "log-target"), "log target");
  EXPECT_EQ(slurp(dir / "ply-target"), "ply target");
  EXPECT_FALSE(fs::is_symlink(out / "logs" / (id + ".log")));
  EXPECT_FALSE(fs::is_symlink(out / "outputs" / ply));
  EXPECT_EQ(read_jsonl(out / "runs.jsonl").size(), 2u);
}

// A file where a folder should be, a read-only folder and a name too long: exit 2 with the path
// and the reason, not "internal error".
TEST(FolderLinks, EnvironmentErrorsAreExitTwoWithThePathAndTheReason) {
  const fs::path dir = make_temp_dir("env");
  write(dir / "a.json", small_config("env", 1));
  fs::create_directories(dir / "out");
  write(dir / "out" / "logs", "a file");
  auto r = sh(run_cmd(dir / "a.json", dir / "out"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("logs: is not a folder"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;

  r = sh(run_cmd(dir / "a.json", dir / std::string(300, 'x')));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("File name too long"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;

  // Read-only: a read-only bind mount stops root as it stops anyone.
  fs::create_directories(dir / "ro");
  ASSERT_EQ(sh("mount --bind " + (dir / "ro").string() + " " + (dir / "ro").string() +
               " && mount -o remount,bind,ro " + (dir / "ro").string())
                .code,
            0);
  r = sh(run_cmd(dir / "a.json", dir / "ro" / "out"));
  sh("umount " + (dir / "ro").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("Read-only file system"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
}

// What killed runs leave (tmp/ entries, temp files of records and scans) is removed by the next
// run; the lock file stays.
TEST(FolderLeftovers, TheNextRunRemovesThem) {
  const fs::path dir = make_temp_dir("leftovers");
  write(dir / "a.json", small_config("leftovers", 1));
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  write(out / "tmp" / "x.spec.json", "{}");
  write(out / "jobs" / ".x.json.tmp.123.0", "{");
  write(out / "scans" / ".abc.456.ply", "ply");
  write(out / ".runs.jsonl.tmp.789.1", "");
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out, "--resume")).code, 0);
  EXPECT_FALSE(fs::exists(out / "tmp" / "x.spec.json"));
  EXPECT_FALSE(fs::exists(out / "jobs" / ".x.json.tmp.123.0"));
  EXPECT_FALSE(fs::exists(out / "scans" / ".abc.456.ply"));
  EXPECT_FALSE(fs::exists(out / ".runs.jsonl.tmp.789.1"));
  EXPECT_TRUE(fs::exists(out / ".lock"));
}

// runs.jsonl that lost lines or holds one twice is not trusted: the tables come from jobs/ with a
// line saying why; a merged-only folder (a baseline) with a duplicated job is refused.
TEST(FolderRecords, ADamagedRunsJsonlIsCheckedAgainstJobs) {
  const fs::path dir = make_temp_dir("damaged");
  write(dir / "a.json", small_config("damaged", 4));
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  const std::string full = slurp(out / "runs.jsonl");
  const std::string table_csv = sh(sb() + " table " + out.string() + " --format csv", false).out;
  std::istringstream in(full);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    lines.push_back(l);
  ASSERT_EQ(lines.size(), 4u);

  write(out / "runs.jsonl", lines[0] + "\n" + lines[2] + "\n");  // two lines dropped
  auto r = sh(sb() + " table " + out.string() + " --format csv", false);
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, table_csv);
  r = sh("sh -c '" + sb() + " table " + out.string() + " --format csv 2>&1 >/dev/null'");
  EXPECT_NE(r.out.find("holds 2 records, jobs/ 4; using the records in jobs/"), std::string::npos)
      << r.out;

  write(out / "runs.jsonl", full + lines[1] + "\n");  // one line twice
  r = sh(sb() + " table " + out.string() + " --format csv", false);
  EXPECT_EQ(r.out, table_csv);
  // `merge` rewrites it from jobs/.
  ASSERT_EQ(sh(sb() + " merge " + out.string()).code, 0);
  EXPECT_EQ(slurp(out / "runs.jsonl"), full);

  // Without jobs/ (a committed baseline) a duplicated job is refused in one line.
  fs::create_directories(dir / "baseline");
  write(dir / "baseline" / "runs.jsonl", full + lines[1] + "\n");
  r = sh(sb() + " table " + (dir / "baseline").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("appears twice (also line 2)"), std::string::npos) << r.out;
}

// A job whose external step leaves a daemon behind (setsid: outside the step's process group)
// ends with it, on success and on the job's timeout.
TEST(JobProcesses, ADaemonisedChildOfAnExternalStepEndsWithItsJob) {
  const fs::path dir = make_temp_dir("daemon");
  const std::string marker = "scanbench-daemon-" + std::to_string(getpid());
  // The daemon: a shell that sleeps, named by the marker in its command line.
  write(dir / "daemon.sh", "#!/bin/sh\nsetsid sh -c 'sleep 300; : " + marker +
                               "' </dev/null >/dev/null 2>&1 &\n"
                               "[ \"$2\" = hang ] && sleep 300\ncp \"$1\" \"$3\"\n");
  fs::permissions(dir / "daemon.sh", fs::perms::owner_all);
  Json c = Json::parse(small_config("daemon", 0));
  c["variants"] = Json::array();
  const std::string cmd = (dir / "daemon.sh").string();
  c["variants"].push_back({{"label", "ok"},
                           {"algorithm", "external.points"},
                           {"params", {{"command", cmd + " {in} go {out}"}}}});
  c["variants"].push_back({{"label", "hang"},
                           {"algorithm", "external.points"},
                           {"timeout_s", 5},
                           {"params", {{"command", cmd + " {in} hang {out}"}}}});
  write(dir / "a.json", c.dump());
  const auto r = sh(run_cmd(dir / "a.json", dir / "out", "--allow-failures"));
  EXPECT_EQ(r.code, 0) << r.out;
  const auto recs = by_variant(read_jsonl(dir / "out" / "runs.jsonl"));
  EXPECT_EQ(recs.at("ok")["status"], "ok") << recs.at("ok").dump();
  EXPECT_EQ(recs.at("hang")["status"], "timeout") << recs.at("hang").dump();
  // "[d]" matches the daemon's command line but not this pattern in pgrep's own shell.
  const std::string pattern = "scanbench-[d]aemon-" + std::to_string(getpid());
  const auto left = sh("pgrep -af '" + pattern + "'");
  EXPECT_NE(left.code, 0) << "daemons left: " << left.out;
  sh("pkill -f '" + pattern + "'");
}

// A failed job makes `run` exit 4 with the failed jobs and their reasons last, and says how to run
// them again; --allow-failures exits 0.
TEST(RunExit, FailedJobsExitFourWithTheirReasonsLast) {
  const fs::path dir = make_temp_dir("exit");
  Json c = Json::parse(small_config("exit", 1));
  c["variants"].push_back({{"label", "boom"}, {"algorithm", "test.crash"}});
  write(dir / "a.json", c.dump());
  auto r = sh(run_cmd(dir / "a.json", dir / "out"), false);
  EXPECT_EQ(r.code, 4) << r.out;
  const auto at = r.out.find("failed jobs");
  ASSERT_NE(at, std::string::npos) << r.out;
  EXPECT_NE(r.out.find("crash", at), std::string::npos) << r.out;
#ifdef SCANBENCH_SANITIZE
  EXPECT_NE(r.out.find("AddressSanitizer: SEGV", at), std::string::npos) << r.out;
#else
  EXPECT_NE(r.out.find("signal 11", at), std::string::npos) << r.out;
#endif
  EXPECT_NE(r.out.find("--resume --retry-failed", at), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("--executor slurm"), std::string::npos) << r.out;
  // `status` suggests the executor the folder used: a local one here.
  r = sh(sb() + " status " + (dir / "out").string());
  EXPECT_NE(r.out.find("--resume"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("--executor slurm"), std::string::npos) << r.out;
  r = sh(run_cmd(dir / "a.json", dir / "out", "--resume --allow-failures"), false);
  EXPECT_EQ(r.code, 0) << r.out;
}

// Ctrl-C (SIGINT to the run): the running jobs are stopped and recorded "interrupted", the run
// exits 130 saying how to resume, and --resume completes it.
TEST(RunExit, InterruptedRunSaysHowToResume) {
  const fs::path dir = make_temp_dir("sigint");
  write(dir / "a.json", small_config("sigint", 3, 3000));
  const fs::path out = dir / "out";
  const std::string log = (dir / "run.log").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    setenv("SCANBENCH_TEST_ALGORITHMS", "1", 1);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    const std::string exe = sb(), cfg = (dir / "a.json").string(), o = out.string();
    execl(exe.c_str(), exe.c_str(), "run", cfg.c_str(), "-o", o.c_str(), "-q",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Once a job's child runs, interrupt.
  for (int i = 0; i < 1000 && !fs::exists(out / "tmp"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  bool started = false;
  for (int i = 0; i < 1000 && !started; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    started = fs::exists(out / "tmp") && !fs::is_empty(out / "tmp");
  }
  ASSERT_TRUE(started);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << slurp(log);
  EXPECT_EQ(WEXITSTATUS(status), 130) << slurp(log);
  const std::string text = slurp(log);
  EXPECT_NE(text.find("interrupted after"), std::string::npos) << text;
  EXPECT_NE(text.find("-o " + out.string() + " --resume"), std::string::npos) << text;
  int interrupted = 0;
  for (const auto& r : read_jsonl(out / "runs.jsonl"))
    interrupted += r["status"] == "interrupted";
  EXPECT_GE(interrupted, 1);
  const auto again = sh(run_cmd(dir / "a.json", out, "--resume"));
  EXPECT_EQ(again.code, 0) << again.out;
  const auto recs = read_jsonl(out / "runs.jsonl");
  ASSERT_EQ(recs.size(), 3u);
  for (const auto& r : recs)
    EXPECT_EQ(r["status"], "ok") << r.dump();
}

// `scanbench help [CMD]`, no arguments and an unknown command.
TEST(RunExit, HelpAndUnknownCommands) {
  auto r = sh(sb() + " help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("Subcommands:"), std::string::npos) << r.out;
  r = sh(sb() + " help run");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--allow-failures"), std::string::npos) << r.out;
  r = sh(sb());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("Subcommands:"), std::string::npos) << r.out;
  r = sh(sb() + " rnu x.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(last_line(r.out),
            "scanbench: unknown command 'rnu' (did you mean 'run'?); `scanbench help` lists the "
            "commands");
  r = sh(sb() + " help tabel");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("did you mean 'table'?"), std::string::npos) << r.out;
}

// A record in jobs/ nested 200,000 deep (a damaged or planted file): `merge` and `table` refuse
// it in one line naming the file, under a memory limit, and never crash.
TEST(FolderRecords, ADeepRecordIsRefusedInOneLine) {
  const fs::path dir = make_temp_dir("deep-record");
  write(dir / "a.json", small_config("deep", 1));
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  const std::string id = job_ids(out).front();
  write(out / "jobs" / (id + ".json"), std::string(200000, '[') + std::string(200000, ']'));
  for (const std::string cmd : {" merge ", " table "}) {
    const auto r = sh(memory_limit(2048) + sb() + cmd + out.string());
    EXPECT_EQ(r.code, 2) << cmd << r.out;
    EXPECT_EQ(count_lines(r.out), 1) << cmd << r.out;
    EXPECT_NE(r.out.find(id + ".json: JSON nested deeper than 100 levels"), std::string::npos)
        << cmd << r.out;
  }
}

// A record in jobs/ whose field has another JSON type than scanbench writes (a label that is a
// number, timing samples that are a string; the fuzzer's find of session 49): `merge`, `table`
// and `report` refuse it in one line naming the file and the field, and never crash.
TEST(FolderRecords, AFieldOfAnotherTypeIsRefusedInOneLine) {
  const fs::path dir = make_temp_dir("typed-record");
  write(dir / "a.json", small_config("typed", 1));
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(run_cmd(dir / "a.json", out)).code, 0);
  const std::string id = job_ids(out).front();
  const fs::path rec = out / "jobs" / (id + ".json");
  const std::string good = slurp(rec);
  struct Damage {
    const char* pointer;
    Json value;
    const char* says;
  };
  for (const Damage& d :
       {Damage{"/dataset/label", 5, "field \"dataset.label\" is a number, not a string"},
        Damage{"/timing/total_s", "x", "field \"timing.total_s\" is a string, not an array"},
        Damage{"/variant/chain/0/params", Json::array(),
               "field \"variant.chain[0].params\" is an array, not an object"}}) {
    Json r = Json::parse(good);
    r[Json::json_pointer(d.pointer)] = d.value;
    write(rec, r.dump());
    fs::remove(out / "runs.jsonl");
    for (const std::string cmd : {" merge ", " table ", " report "}) {
      const auto res = sh(sb() + cmd + out.string());
      EXPECT_EQ(res.code, 2) << cmd << res.out;
      EXPECT_EQ(count_lines(res.out), 1) << cmd << res.out;
      EXPECT_NE(res.out.find(id + ".json: " + d.says), std::string::npos) << cmd << res.out;
    }
  }
}
