// Plugins (docs/plugins.md; scanbench/plugin.h, harness/plugins.h) through the real binary:
//  - the installed package: `cmake --install` into a temporary prefix, every scanbench header it
//    includes installed too, examples/plugin configured and built against it by a separate CMake
//    run, an experiment mixing its smooth.mls with resample.clop and resample.wlop, its records
//    (plugin path and SHA-256, checked against coreutils' sha256sum), `table` and `list --json`;
//  - the bad plugins of tests/plugins: wrong ABI version, missing registration symbol, a
//    duplicate name, a throwing registration (one line naming the file, exit 2, nothing added),
//    and a plugin algorithm that crashes inside a job (only that job fails).
// The sanitizer tree (scripts/sanitize.sh) runs the same tests: the example plugin is built
// plainly with the tree's compiler and loads into the sanitized binary beside the sanitized
// libraries (one copy of each, by soname).
#include <gtest/gtest.h>

#include <regex>

#include "cli_test_util.h"

namespace scanbench::test {
namespace {

std::string plugin(const std::string& name) {
  return std::string(SCANBENCH_TEST_PLUGIN_DIR) + "/libtest_plugin_" + name + ".so";
}

std::string q(const fs::path& p) {
  return "'" + p.string() + "'";
}

int lines(const std::string& s) {
  int n = 0;
  for (char c : s)
    n += c == '\n';
  return n + (!s.empty() && s.back() != '\n');
}

// A refused plugin: exit 2 and exactly one line, naming the file and saying why.
void expect_refused(const std::string& file, const std::string& why) {
  const auto r = sh(sb() + " --plugin " + q(file) + " list algorithms");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(lines(r.out), 1) << r.out;
  EXPECT_NE(r.out.find(file), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(why), std::string::npos) << r.out;
}

TEST(Plugins, WrongAbiVersionIsOneLine) {
  expect_refused(plugin("bad_abi"), "built against scanbench ABI version");
}

TEST(Plugins, MissingSymbolIsOneLine) {
  expect_refused(plugin("no_register"), "no symbol scanbench_plugin_register");
  expect_refused("/nonexistent/dir/lib.so", "no such file");
}

TEST(Plugins, DuplicateNameAddsNothing) {
  expect_refused(plugin("duplicate"), "algorithm 'resample.clop' is already registered (built in)");
  // The same plugin named twice loads once.
  const auto r = sh(sb() + " --plugin " + q(plugin("crash")) + " --plugin " + q(plugin("crash")) +
                    " list algorithms --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const Json j = Json::parse(r.out);
  int n = 0;
  for (const auto& e : j["algorithms"])
    n += e["name"] == "test_plugin.crash";
  EXPECT_EQ(n, 1);
}

TEST(Plugins, ThrowingRegistrationAddsNothing) {
  expect_refused(plugin("throwing"), "its registration threw: registration failed on purpose");
}

TEST(Plugins, BadPluginInExperimentAndPath) {
  const fs::path dir = make_temp_dir("plugins-bad");
  write(dir / "e.json", R"({"scanbench_experiment": 1, "plugins": [")" + plugin("bad_abi") +
                            R"("], "datasets": [{"name": "sphere"}],
       "variants": [{"label": "w", "algorithm": "resample.wlop"}]})");
  auto r = sh(sb() + " run " + q(dir / "e.json") + " -o " + q(dir / "out") + " -q");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(lines(r.out), 1) << r.out;
  EXPECT_NE(r.out.find(plugin("bad_abi")), std::string::npos) << r.out;
  write(dir / "e2.json", R"({"scanbench_experiment": 1, "plugins": "x.so",
       "datasets": [{"name": "sphere"}], "variants": [{"label": "w", "algorithm": "resample.wlop"}]})");
  r = sh(sb() + " run " + q(dir / "e2.json") + " -o " + q(dir / "out") + " -q");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("e2.json: /plugins: expected a list"), std::string::npos) << r.out;
  r = sh("SCANBENCH_PLUGIN_PATH=" + q(plugin("throwing")) + " " + sb() + " list metrics");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(plugin("throwing")), std::string::npos) << r.out;
  fs::remove_all(dir);
}

TEST(Plugins, CrashInsideAJobFailsOnlyThatJob) {
  const fs::path dir = make_temp_dir("plugins-crash");
  fs::copy_file(plugin("crash"), dir / "crash.so");
  // "plugins" relative to the config's folder.
  write(dir / "e.json", R"({
    "scanbench_experiment": 1, "name": "crash", "seed": 3, "save_outputs": false,
    "plugins": ["crash.so"],
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 32}}],
    "variants": [
      {"label": "crash", "algorithm": "test_plugin.crash"},
      {"label": "wlop", "algorithm": "resample.wlop", "params": {"iterations": 2}}
    ],
    "metrics": ["accuracy.p2plane"]
  })");
  const auto r = sh(sb() + " run " + q(dir / "e.json") + " -o " + q(dir / "out") + " --jobs 2 -q");
  ASSERT_EQ(r.code, 4) << r.out;  // a job failed (docs/cli.md, exit codes)
  auto m = by_variant(read_jsonl(dir / "out" / "runs.jsonl"));
  EXPECT_EQ(m["crash"]["status"], "crash") << m["crash"].dump();
  EXPECT_EQ(m["wlop"]["status"], "ok") << m["wlop"].dump();
  for (const char* v : {"crash", "wlop"}) {
    const Json& p = m[v]["context"]["plugins"];
    ASSERT_EQ(p.size(), 1u) << m[v]["context"].dump();
    EXPECT_EQ(p[0]["path"], (dir / "crash.so").string());
    EXPECT_EQ(p[0]["algorithms"], Json::array({"test_plugin.crash"}));
  }
  // A job child refuses a plugin file whose hash differs from the one its run started with.
  const Json spec = {
      {"plugins",
       Json::array({{{"path", (dir / "crash.so").string()}, {"sha256", std::string(64, '0')}}})},
      {"job", Json::object()},
      {"out", dir.string()}};
  write(dir / "spec.json", spec.dump());
  ASSERT_EQ(sh(sb() + " job " + q(dir / "spec.json") + " " + q(dir / "result.json")).code, 0);
  const Json result = Json::parse(slurp(dir / "result.json"));
  EXPECT_EQ(result["status"], "error");
  EXPECT_NE(result["error"].get<std::string>().find("changed since the run started"),
            std::string::npos)
      << result.dump();
  fs::remove_all(dir);
}

// The SHA-256 of a file by coreutils (an implementation independent of the loader's OpenSSL).
std::string sha256sum(const fs::path& f) {
  const auto r = sh("sha256sum " + q(f), false);
  return r.out.substr(0, 64);
}

TEST(PluginPackage, ExampleBuiltAgainstTheInstalledPackageRunsBesideClopAndWlop) {
  const fs::path dir = make_temp_dir("plugins-install");
  const fs::path prefix = dir / "prefix", build = dir / "build";
  auto r = sh(std::string(SCANBENCH_CMAKE) + " --install " + q(SCANBENCH_BUILD_DIR) + " --prefix " +
              q(prefix));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"lib/cmake/scanbench/scanbenchConfig.cmake", "include/scanbench/plugin.h",
                        "include/scanbench/core/abi.h", "include/scanbench/core/kdtree.h",
                        "include/scanbench/algorithms/neighbor_grid.h"})
    EXPECT_TRUE(fs::exists(prefix / f)) << f;
  // Internals stay private.
  for (const char* f : {"include/scanbench/core/io.h", "include/scanbench/harness/exec/runner.h",
                        "include/scanbench/algorithms/lop/clop.h"})
    EXPECT_FALSE(fs::exists(prefix / f)) << f;
  // Every scanbench header an installed header includes is installed.
  const std::regex inc(R"(#include\s+"(scanbench/[^"]+)\")");
  for (const auto& e : fs::recursive_directory_iterator(prefix / "include")) {
    if (!e.is_regular_file()) continue;
    const std::string text = slurp(e.path());
    for (std::sregex_iterator it(text.begin(), text.end(), inc), end; it != end; ++it)
      EXPECT_TRUE(fs::exists(prefix / "include" / (*it)[1].str()))
          << e.path() << " includes " << (*it)[1] << ", which is not installed";
  }
  // A separate CMake run, as a user's project.
  r = sh(std::string(SCANBENCH_CMAKE) + " -S " +
         q(fs::path(SCANBENCH_SOURCE_DIR) / "examples" / "plugin") + " -B " + q(build) +
         " -DCMAKE_PREFIX_PATH=" + q(prefix) + " -DCMAKE_CXX_COMPILER=" + q(SCANBENCH_CXX));
  ASSERT_EQ(r.code, 0) << r.out;
  r = sh(std::string(SCANBENCH_CMAKE) + " --build " + q(build));
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path so = build / "scanbench_mls.so";
  ASSERT_TRUE(fs::exists(so));
  const std::string hash = sha256sum(so);
  ASSERT_EQ(hash.size(), 64u);

  // list --json: plugin entries beside the built-in ones, marked with their source; from
  // SCANBENCH_PLUGIN_PATH (a folder) here.
  r = sh("SCANBENCH_PLUGIN_PATH=" + q(build) + " " + sb() + " list --json", false);
  ASSERT_EQ(r.code, 0) << r.out;
  const Json list = Json::parse(r.out);
  auto find = [&](const char* kind, const char* name) {
    for (const auto& e : list[kind])
      if (e["name"] == name) return e;
    return Json();
  };
  const Json mls = find("algorithms", "smooth.mls");
  ASSERT_FALSE(mls.is_null());
  EXPECT_EQ(mls["source"], "plugin");
  EXPECT_EQ(mls["plugin"]["sha256"], hash);
  EXPECT_EQ(mls["params"][0]["name"], "h");
  EXPECT_EQ(mls["primary"], "points");
  EXPECT_EQ(find("algorithms", "resample.clop")["source"], "builtin");
  const Json met = find("metrics", "accuracy.p2s_quantiles");
  ASSERT_FALSE(met.is_null());
  EXPECT_EQ(met["source"], "plugin");
  EXPECT_EQ(met["keys"]["p2s_median_rel"], "lower");

  // The experiment: the plugin's algorithm and metric beside CLOP and WLOP.
  write(dir / "e.json", R"({
    "scanbench_experiment": 1, "name": "mix", "seed": 11, "save_outputs": false,
    "plugins": ["build/scanbench_mls.so"],
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "moderate", "params": {"views": 2, "resolution": 40}}],
    "variants": [
      {"label": "mls", "algorithm": "smooth.mls", "params": {"h": 0.03, "iterations": 2}},
      {"label": "clop", "algorithm": "resample.clop"},
      {"label": "wlop", "algorithm": "resample.wlop", "params": {"iterations": 3}}
    ],
    "metrics": ["accuracy.p2plane", "accuracy.p2s_quantiles"]
  })");
  r = sh(sb() + " run " + q(dir / "e.json") + " -o " + q(dir / "out") + " --jobs 2 -q");
  ASSERT_EQ(r.code, 0) << r.out;
  auto m = by_variant(read_jsonl(dir / "out" / "runs.jsonl"));
  ASSERT_EQ(m.size(), 3u);
  for (const char* v : {"mls", "clop", "wlop"}) {
    const Json& rec = m[v];
    EXPECT_EQ(rec["status"], "ok") << rec.dump();
    // Every record names the plugin, its path and the hash of the file.
    const Json& p = rec["context"]["plugins"];
    ASSERT_EQ(p.size(), 1u) << rec["context"].dump();
    EXPECT_EQ(p[0]["path"], so.string());
    EXPECT_EQ(p[0]["sha256"], hash);
    EXPECT_EQ(p[0]["metrics"], Json::array({"accuracy.p2s_quantiles"}));
    // The plugin metric scores every variant, built-in ones included; nearest-rank quantiles
    // of the same distances: median <= p95.
    ASSERT_TRUE(rec["metrics"].contains("p2s_median_rel")) << rec["metrics"].dump();
    EXPECT_LE(rec["metrics"]["p2s_median"].get<double>(), rec["metrics"]["p2s_p95"].get<double>());
    EXPECT_TRUE(rec["metrics"].contains("p2plane_mean_rel"));
  }
  // The plugin's declared parameters are recorded like a built-in algorithm's.
  EXPECT_EQ(m["mls"]["params"]["smooth.mls.iterations"], 2) << m["mls"]["params"].dump();

  // The table, with the plugin's metric (its direction known through the plugin).
  r = sh(sb() + " --plugin " + q(so) + " table " + q(dir / "out") + " --metric p2s_median_rel",
         false);
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* v : {"mls", "clop", "wlop"})
    EXPECT_NE(r.out.find(v), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("p2s_median_rel (lower is better)"), std::string::npos) << r.out;
  // Without the plugin its key's direction is unknown: the column is informational, no best.
  r = sh(sb() + " table " + q(dir / "out") + " --metric p2s_median_rel", false);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("p2s_median_rel (informational)"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scanbench::test
