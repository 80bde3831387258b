// `scanbench run --executor slurm`, `status` and `merge` on a real single-node Slurm cluster
// (scripts/slurm-local.sh: slurm-wlm and munge, started and stopped by the environment below).
// Where the cluster cannot start (no root, no packages) every test FAILS with the reason: the
// Slurm executor is not tested by skipping it.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "cli_test_util.h"
#include "scanbench/core/params.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

const std::string kScript = std::string(SCANBENCH_SOURCE_DIR) + "/scripts/slurm-local.sh";

std::vector<std::string> keys_of(const Json& j) {
  std::vector<std::string> k;
  for (const auto& [key, v] : j.items())
    k.push_back(key);
  return k;
}

Json status_of(const fs::path& dir) {
  const Result r = sh(sb() + " status " + dir.string() + " --json", false);
  if (r.code != 0) return Json();
  return Json::parse(r.out, nullptr, false);
}

/// Polls `status --json` until nothing of the folder is running, pending or in the queue.
Json wait_until_idle(const fs::path& dir, int seconds = 240) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  Json s;
  while (std::chrono::steady_clock::now() < deadline) {
    s = status_of(dir);
    if (s.is_object() && s["counts"]["running"] == 0 && s["counts"]["pending"] == 0 &&
        s["other_jobs"].empty() && s["queue_error"] == "") {
      return s;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return s;
}

int count_submissions(const fs::path& dir) {
  int n = 0;
  if (fs::is_directory(dir / "slurm"))
    for (const auto& e : fs::directory_iterator(dir / "slurm"))
      n += e.is_directory();
  return n;
}

/// The cluster for the whole test program: started once, stopped at the end.
class SlurmCluster : public ::testing::Environment {
 public:
  static inline bool up = false;
  static inline std::string why;

  void SetUp() override {
    const Result r = sh("bash " + kScript + " start");
    up = r.code == 0;
    why = r.out;
    const Result env = sh("bash " + kScript + " env", false);
    const auto eq = env.out.find('=');
    if (up && eq != std::string::npos) {
      std::string conf = env.out.substr(eq + 1);
      while (!conf.empty() && conf.back() == '\n')
        conf.pop_back();
      setenv("SLURM_CONF", conf.c_str(), 1);
    }
  }
  void TearDown() override { sh("bash " + kScript + " stop"); }
};

#define REQUIRE_CLUSTER()                                                                \
  ASSERT_TRUE(SlurmCluster::up) << "the single-node Slurm cluster did not start "        \
                                   "(scripts/slurm-local.sh needs root and apt-get): \n" \
                                << SlurmCluster::why

/// A sweep of `n` cheap jobs: test.subsample over stride 1..n on a small sphere scan.
std::string sweep_config(int n, double work_ms, const std::string& extra_variants = "") {
  return R"({
    "scanbench_experiment": 1, "name": "slurm-sweep", "seed": 3, "save_outputs": false,
    "timeout_s": 120, "memory_limit_mb": 2048,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [{"label": "sub", "algorithm": "test.subsample",
                  "params": {"work_ms": )" +
         std::to_string(work_ms) + R"(},
                  "sweep": {"test.subsample.stride": {"from": 1, "to": )" +
         std::to_string(n) + R"(, "step": 1}}})" + extra_variants + R"(],
    "metrics": ["accuracy.p2plane", "regularity.nn_dist"]
  })";
}

}  // namespace

// A 12-job sweep as one array limited to 2 tasks at a time: the merged records equal a local run
// of the same config (same ids in the same order, same keys, metrics bit for bit); one scan in
// the shared cache; tables and report written by the merge job.
TEST(SlurmE2E, ArrayOfTwelveJobsEqualsLocalRun) {
  REQUIRE_CLUSTER();
  const fs::path dir = make_temp_dir("slurm-eq");
  write(dir / "sweep.json", sweep_config(12, 0));
  const std::string cfg = (dir / "sweep.json").string();
  const auto local = sh(sb() + " run " + cfg + " -o " + (dir / "local").string() + " -j 2 -q");
  ASSERT_EQ(local.code, 0) << local.out;
  const auto r = sh(sb() + " run " + cfg + " -o " + (dir / "slurm").string() +
                    " --executor slurm --array-limit 2 --wait");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("12 submitted"), std::string::npos) << r.out;

  const auto a = read_jsonl(dir / "local" / "runs.jsonl");
  const auto b = read_jsonl(dir / "slurm" / "runs.jsonl");
  ASSERT_EQ(a.size(), 12u);
  ASSERT_EQ(b.size(), 12u) << r.out;
  std::set<std::string> ids;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b[i]["id"], a[i]["id"]) << i;
    EXPECT_EQ(b[i]["status"], "ok") << b[i].dump();
    EXPECT_EQ(keys_of(b[i]), keys_of(a[i])) << i;
    EXPECT_EQ(b[i]["metrics"], a[i]["metrics"]) << b[i]["key"];  // bit for bit
    EXPECT_EQ(b[i]["params"], a[i]["params"]);
    EXPECT_EQ(b[i]["sizes"], a[i]["sizes"]);
    ids.insert(b[i]["id"].get<std::string>());
  }
  EXPECT_EQ(ids.size(), 12u);
  // runs.csv: same columns; the rows agree up to the timing columns.
  const std::string csv_a = slurp(dir / "local" / "runs.csv"),
                    csv_b = slurp(dir / "slurm" / "runs.csv");
  EXPECT_EQ(csv_a.substr(0, csv_a.find('\n')), csv_b.substr(0, csv_b.find('\n')));

  // One scan shared by the 12 tasks, no private temporary left, the same bytes as the local run.
  std::vector<fs::path> plys;
  for (const auto& e : fs::directory_iterator(dir / "slurm" / "scans")) {
    EXPECT_NE(e.path().filename().string()[0], '.') << "leftover " << e.path();
    if (e.path().extension() == ".ply") plys.push_back(e.path());
  }
  ASSERT_EQ(plys.size(), 1u);
  EXPECT_EQ(slurp(plys[0]), slurp(dir / "local" / "scans" / plys[0].filename()));

  // The submission: sbatch options from the config's limits, the merge job's outputs.
  const Json sub = Json::parse(slurp(dir / "slurm" / "slurm" / "001" / "submission.json"));
  const std::string array_cmd = sub["sbatch"][0].dump();
  EXPECT_NE(array_cmd.find("--array=0-11%2"), std::string::npos) << array_cmd;
  EXPECT_NE(array_cmd.find("--time=3\""), std::string::npos) << array_cmd;  // 120 s + 60 s
  EXPECT_NE(array_cmd.find("--mem=2048M"), std::string::npos) << array_cmd;
  EXPECT_NE(
      sub["sbatch"][1].dump().find("--dependency=afterany:" + sub["array_job"].get<std::string>()),
      std::string::npos);
  for (const char* f : {"tables.md", "index.html"})
    EXPECT_TRUE(fs::exists(dir / "slurm" / f)) << f;
  EXPECT_NE(slurp(dir / "slurm" / "slurm" / "001" / "merge.out").find("merged 12 records"),
            std::string::npos);
  for (int t = 0; t < 12; ++t)
    EXPECT_TRUE(
        fs::exists(dir / "slurm" / "slurm" / "001" / ("task-" + std::to_string(t) + ".out")));

  // status: everything done, for the Slurm folder and for the local one.
  for (const char* d : {"slurm", "local"}) {
    const Json s = status_of(dir / d);
    ASSERT_TRUE(s.is_object()) << d;
    EXPECT_EQ(s["counts"]["done"], 12) << s.dump();
    EXPECT_EQ(s["counts"]["failed"], 0);
    EXPECT_EQ(s["counts"]["without_record"], 0);
  }
  // A second --resume submits nothing.
  const auto again = sh(sb() + " run " + cfg + " -o " + (dir / "slurm").string() +
                        " --executor slurm --resume --wait");
  EXPECT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("nothing to submit"), std::string::npos) << again.out;
  EXPECT_EQ(count_submissions(dir / "slurm"), 1);
  fs::remove_all(dir);
}

// Two running tasks (chunks of 2 jobs) are stopped: one by scancel (its running job is recorded
// as interrupted by the task, with Slurm's CANCELLED line), one killed outright like on a node
// failure (SIGKILL to the task: the merge job records its running job from scontrol). The
// chunks' second jobs have no record: the merge job lists them with the command that resubmits.
// A submission into the busy folder is refused. --resume then completes the folder with nothing
// lost or duplicated, equal to a local run.
TEST(SlurmE2E, ScancelOneTaskThenResumeCompletesTheFolder) {
  REQUIRE_CLUSTER();
  const fs::path dir = make_temp_dir("slurm-cancel");
  // Each job works 5 s: the victims below must still be in their first job when scancel and
  // the kill reach them, after a `scanbench status` poll that takes seconds in a sanitizer
  // build on a loaded machine (with 1.5 s, a victim once finished its first job in between).
  write(dir / "sweep.json", sweep_config(12, 5000));
  const std::string cfg = (dir / "sweep.json").string();
  const fs::path out = dir / "slurm";
  const auto r = sh(sb() + " run " + cfg + " -o " + out.string() +
                    " --executor slurm --array-limit 2 --chunk 2");
  ASSERT_EQ(r.code, 0) << r.out;
  const Json sub = Json::parse(slurp(out / "slurm" / "001" / "submission.json"));
  const std::vector<std::string> jobs = sub["jobs"].get<std::vector<std::string>>();
  ASSERT_EQ(jobs.size(), 12u);
  auto index_of = [&](const std::string& id) {
    return static_cast<std::size_t>(std::find(jobs.begin(), jobs.end(), id) - jobs.begin());
  };

  // Wait for two tasks running the first job of their chunk at the same time.
  std::vector<std::pair<std::string, std::string>> victims;  // (job id, Slurm task "12_3")
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (victims.size() < 2 && std::chrono::steady_clock::now() < deadline) {
    victims.clear();
    const Json s = status_of(out);
    if (s.is_object()) {
      for (const auto& item : s["running"]) {
        const std::string id = item["id"].get<std::string>();
        std::smatch m;
        const std::string detail = item["detail"].get<std::string>();
        if (index_of(id) % 2 == 0 &&
            std::regex_search(detail, m, std::regex("Slurm job (\\d+_\\d+)"))) {
          victims.emplace_back(id, m[1]);
        }
      }
    }
    if (victims.size() < 2) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(victims.size(), 2u) << "two tasks were not seen running at once";

  const Json marker = Json::parse(slurp(out / "slurm" / "001" / "started" / victims[1].first));
  ASSERT_EQ(sh("scancel " + victims[0].second).code, 0);
  ASSERT_EQ(sh("kill -KILL " + std::to_string(marker["pid"].get<int>())).code, 0);

  // The folder is still busy (the other tasks, the merge job): another submission is refused,
  // with one line and exit 2.
  const auto busy = sh(sb() + " run " + cfg + " -o " + out.string() + " --executor slurm --resume");
  EXPECT_EQ(busy.code, 2) << busy.out;
  EXPECT_NE(busy.out.find("still writing this folder"), std::string::npos) << busy.out;
  EXPECT_EQ(std::count(busy.out.begin(), busy.out.end(), '\n'), 1) << busy.out;
  EXPECT_EQ(count_submissions(out), 1);

  const Json idle = wait_until_idle(out);
  ASSERT_TRUE(idle.is_object());
  EXPECT_EQ(idle["counts"]["done"], 8) << idle.dump(1);
  EXPECT_EQ(idle["counts"]["failed"], 2) << idle.dump(1);
  EXPECT_EQ(idle["counts"]["without_record"], 2) << idle.dump(1);
  const Json cancelled = Json::parse(slurp(out / "jobs" / (victims[0].first + ".json")));
  EXPECT_EQ(cancelled["status"], "interrupted") << cancelled.dump();
  EXPECT_NE(cancelled["error"].get<std::string>().find("CANCELLED AT"), std::string::npos)
      << cancelled["error"];
  const Json killed = Json::parse(slurp(out / "jobs" / (victims[1].first + ".json")));
  EXPECT_EQ(killed["status"], "interrupted") << killed.dump();
  EXPECT_NE(killed["error"].get<std::string>().find(victims[1].second + " ended in state "),
            std::string::npos)
      << killed["error"];
  const std::string merge_log = slurp(out / "slurm" / "001" / "merge.out");
  EXPECT_NE(merge_log.find("2 jobs without a record"), std::string::npos) << merge_log;
  for (const auto& [id, task] : victims) {
    const std::string never_started = jobs[index_of(id) + 1];
    EXPECT_FALSE(fs::exists(out / "jobs" / (never_started + ".json")));
    EXPECT_NE(merge_log.find(never_started), std::string::npos) << merge_log;
  }
  EXPECT_NE(merge_log.find("--executor slurm --resume"), std::string::npos) << merge_log;
  EXPECT_EQ(read_jsonl(out / "runs.jsonl").size(), 10u);

  // --resume submits the interrupted jobs and those without a record, and nothing else.
  const auto resumed = sh(sb() + " run " + cfg + " -o " + out.string() +
                          " --executor slurm --array-limit 2 --resume --wait");
  ASSERT_EQ(resumed.code, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("8 already done, 4 submitted"), std::string::npos) << resumed.out;
  const auto local = sh(sb() + " run " + cfg + " -o " + (dir / "local").string() + " -j 2 -q");
  ASSERT_EQ(local.code, 0) << local.out;
  const auto a = read_jsonl(dir / "local" / "runs.jsonl");
  const auto b = read_jsonl(out / "runs.jsonl");
  ASSERT_EQ(b.size(), 12u) << resumed.out;
  ASSERT_EQ(a.size(), 12u);
  std::set<std::string> ids;
  for (std::size_t i = 0; i < b.size(); ++i) {
    EXPECT_EQ(b[i]["status"], "ok") << b[i].dump();
    EXPECT_EQ(b[i]["id"], a[i]["id"]);
    EXPECT_EQ(b[i]["metrics"], a[i]["metrics"]);
    ids.insert(b[i]["id"].get<std::string>());
  }
  EXPECT_EQ(ids.size(), 12u);
  const Json s = status_of(out);
  EXPECT_EQ(s["counts"]["done"], 12) << s.dump(1);
  fs::remove_all(dir);
}

// A task over its memory limit and one past its timeout fail alone; the others complete.
TEST(SlurmE2E, MemoryBlowUpAndHangFailOnlyTheirTasks) {
  REQUIRE_CLUSTER();
  const fs::path dir = make_temp_dir("slurm-oom");
  write(dir / "iso.json", sweep_config(2, 0, R"(,
      {"label": "oom", "algorithm": "test.oom", "params": {"chunk_mb": 32},
       "memory_limit_mb": 1024},
      {"label": "hang", "algorithm": "test.hang", "timeout_s": 3})"));
  const auto r = sh(sb() + " run " + (dir / "iso.json").string() + " -o " + (dir / "out").string() +
                    " --executor slurm --array-limit 2 --wait");
  ASSERT_EQ(r.code, 4) << r.out;  // jobs failed (docs/cli.md, exit codes)
  std::map<std::string, Json> by_variant;
  for (const auto& rec : read_jsonl(dir / "out" / "runs.jsonl"))
    by_variant[rec["variant"]["label"].get<std::string>() + rec["point_label"].get<std::string>()] =
        rec;
  ASSERT_EQ(by_variant.size(), 4u) << r.out;
  const std::string oom = by_variant["oom"]["status"].get<std::string>();
  EXPECT_TRUE(oom == "memory" || oom == "crash") << by_variant["oom"].dump();
  EXPECT_EQ(by_variant["hang"]["status"], "timeout") << by_variant["hang"].dump();
  EXPECT_EQ(by_variant["substride=1"]["status"], "ok");
  EXPECT_EQ(by_variant["substride=2"]["status"], "ok");
  const Json s = status_of(dir / "out");
  EXPECT_EQ(s["counts"]["done"], 2);
  EXPECT_EQ(s["counts"]["failed"], 2);
  fs::remove_all(dir);
}

// No sbatch, a controller that does not answer, an unknown partition, Slurm options without
// --executor slurm: one line naming the cause, exit 2, nothing submitted.
TEST(SlurmE2E, BadSetupExitsTwoAndSubmitsNothing) {
  REQUIRE_CLUSTER();
  const fs::path dir = make_temp_dir("slurm-bad");
  write(dir / "sweep.json", sweep_config(2, 0));
  const std::string run = sb() + " run " + (dir / "sweep.json").string() + " -o ";
  auto check = [&](const std::string& cmd, const std::string& what, const fs::path& out) {
    const Result r = sh(cmd);
    EXPECT_EQ(r.code, 2) << cmd << "\n" << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_EQ(count_submissions(out), 0) << cmd;
    EXPECT_FALSE(fs::exists(out / "runs.jsonl")) << cmd;
  };
  check("env PATH=/nonexistent " + run + (dir / "a").string() + " --executor slurm",
        "sbatch not found on PATH", dir / "a");
  check(run + (dir / "b").string() + " --executor slurm --partition nosuch",
        "unknown partition 'nosuch' (the cluster has: debug)", dir / "b");
  // A controller nobody listens for: the cluster's config with another port.
  std::string conf = slurp(std::getenv("SLURM_CONF"));
  conf = std::regex_replace(conf, std::regex("SlurmctldPort=\\d+"), "SlurmctldPort=1");
  write(dir / "down.conf", conf);
  check("SLURM_CONF=" + (dir / "down.conf").string() + " " + run + (dir / "c").string() +
            " --executor slurm",
        "controller does not answer", dir / "c");
  check(run + (dir / "d").string() + " --partition debug", "needs --executor slurm", dir / "d");
  // merge on a folder whose jobs have no record: lists them, says how to resubmit, exit 1.
  const auto plan_only = sh(run + (dir / "e").string() + " --filter 'stride=1\\|'");
  ASSERT_EQ(plan_only.code, 0) << plan_only.out;
  const auto merged = sh(sb() + " merge " + (dir / "e").string());
  EXPECT_EQ(merged.code, 1) << merged.out;
  EXPECT_NE(merged.out.find("1 job without a record"), std::string::npos) << merged.out;
  // The folder was run locally: the command that completes it is a local one.
  EXPECT_NE(merged.out.find("/e' --resume"), std::string::npos) << merged.out;
  EXPECT_EQ(merged.out.find("--executor slurm"), std::string::npos) << merged.out;
  fs::remove_all(dir);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new SlurmCluster);
  return RUN_ALL_TESTS();
}
