// End to end (issue 50, GPS paper sec. 7.2, Fig. 13): surface.input_distance of=step_input
// measures the points the chain's reconstruction consumed, not the raw scan. The chain's first
// step (external.points) replaces the scan of the unit sphere by four known points; its second
// (external.mesh) writes the cube [-2, 2]^3. The four points lie 0.5, 0.2, 0.1 and 0.4 outside
// the cube's faces (mean 0.3, RMSE sqrt(0.115)); every scan point lies 1 to 2 - 1/sqrt(3) inside.
// `eval --from-record` scores the saved mesh and carried points again to the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "cli_test_util.h"
#include "scanbench/core/params.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

Json config(const std::string& of) {
  Json c = Json::parse(R"({
    "scanbench_experiment": 1, "name": "step-input", "seed": 3, "repeats": 1,
    "datasets": [{"name": "sphere", "params": {"resolution": 8}}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [{"label": "known", "chain": [
      {"algorithm": "external.points", "params": {"extension": ".off", "command":
        "printf 'OFF\\n4 0 0\\n2.5 0 0\\n-2.2 0 0\\n0 2.1 0\\n0 0 -2.4\\n' > {out}"}},
      {"algorithm": "external.mesh", "params": {"extension": ".off", "command":
        "printf 'OFF\\n8 6 0\\n-2 -2 -2\\n2 -2 -2\\n-2 2 -2\\n2 2 -2\\n-2 -2 2\\n2 -2 2\\n-2 2 2\\n2 2 2\\n4 0 4 6 2\\n4 1 3 7 5\\n4 0 1 5 4\\n4 2 6 7 3\\n4 0 2 3 1\\n4 4 5 7 6\\n' > {out}"}}
    ]}],
    "metrics": ["surface.input_distance"]
  })");
  if (!of.empty()) c["metric_params"] = {{"surface.input_distance", {{"of", of}}}};
  return c;
}

/// Runs the config in DIR/<tag> and returns its one record.
Json run(const TempDir& dir, const std::string& tag, const Json& cfg) {
  const fs::path file = dir / (tag + ".json");
  write(file, cfg.dump());
  const auto r = sh(sb() + " run " + file.string() + " -o " + (dir / tag).string() + " -q");
  EXPECT_EQ(r.code, 0) << r.out;
  const auto recs = read_jsonl(dir / tag / "runs.jsonl");
  EXPECT_EQ(recs.size(), 1u);
  return recs.empty() ? Json::object() : recs[0];
}

}  // namespace

TEST(InputDistanceE2E, StepInputIsWhatTheReconstructionConsumed) {
  const TempDir dir("stepinput");
  const Json step = run(dir, "step", config("step_input"));
  ASSERT_EQ(step["status"], "ok") << step.dump();
  const Json& m = step["metrics"];
  EXPECT_EQ(m["input_distance_points"], 4) << m.dump();
  EXPECT_NEAR(m["input_distance_mean"].get<double>(), 0.3, 1e-6);
  EXPECT_NEAR(m["input_distance_rms"].get<double>(), std::sqrt(0.115), 1e-6);
  EXPECT_NEAR(m["input_distance_max"].get<double>(), 0.5, 1e-6);
  EXPECT_EQ(step["metric_params"]["surface.input_distance"]["of"], "step_input");

  // The default measures the scan: all its points, each at least 1 inside the cube.
  const Json scan = run(dir, "scan", config(""));
  ASSERT_EQ(scan["status"], "ok") << scan.dump();
  EXPECT_EQ(scan["metric_params"]["surface.input_distance"]["of"], "scan");
  EXPECT_EQ(scan["metrics"]["input_distance_points"], scan["sizes"]["scan_points"]);
  EXPECT_GT(scan["metrics"]["input_distance_mean"].get<double>(), 0.99);

  // Scored again from the saved mesh and the carried points (artifacts.output).
  ASSERT_TRUE(step["artifacts"].contains("output")) << step["artifacts"].dump();
  const auto again =
      sh(sb() + " eval --from-record " + (dir / "step" / "runs.jsonl").string() + " --id " +
         step["id"].get<std::string>() + " -o " + (dir / "again.json").string());
  ASSERT_EQ(again.code, 0) << again.out;
  const Json a = Json::parse(slurp(dir / "again.json"));
  for (const auto& [k, v] : m.items())
    EXPECT_EQ(a[k], v) << k;
}
