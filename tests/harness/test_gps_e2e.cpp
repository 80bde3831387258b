// The ground_truth input (experiment.h) and the shipped configs/gps-subdivision.json:
//  - configs type-check chains against the input their datasets give (a scan's points, or the
//    ground-truth mesh), naming the step and the input; ground_truth takes no parameters;
//  - end to end: a reduced copy of the shipped config (small sphere and torus, levels 2-3, the
//    same variants and chains) runs with every job ok, scores the subdivided surface against the
//    undecimated ground truth, writes no scan, and `scanbench table` shows both schemes per level.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "../algorithms/triangulation_fixtures.h"
#include "cli_test_util.h"
#include "experiment_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/config/experiment.h"

namespace fs = std::filesystem;

namespace scanbench::harness {
namespace {

using test::make_temp_dir;
using test::sb;
using test::sh;
using test::slurp;

Json config(const Json& scanners, const Json& variant) {
  Json c = Json::parse(R"({"scanbench_experiment": 1, "name": "t", "seed": 3,
                           "datasets": [{"name": "sphere"}]})");
  c["scanners"] = scanners;
  c["variants"] = Json::array({variant});
  return c;
}

const Json kMeshChain = Json::parse(R"({"label": "loop", "chain": [
    {"algorithm": "mesh.decimate", "params": {"faces": 100}}, {"algorithm": "subdivide.loop"}]})");

TEST(GroundTruthInput, ChainsAreCheckedAgainstTheInputTheyGet) {
  // A mesh chain loads with the ground_truth input and expands to one job per level.
  Json ok = config(Json::array({"ground_truth"}), kMeshChain);
  ok["variants"][0]["sweep"] = {{"subdivide.loop.levels", {2, 3}}};
  const Plan plan = expand(parse_experiment(ok, "cfg.json"));
  ASSERT_EQ(plan.jobs.size(), 2u);
  EXPECT_EQ(plan.jobs[0].scanner_preset, "ground_truth");
  EXPECT_EQ(plan.jobs[0].scanner_params, Json::object());
  EXPECT_NE(plan.jobs[0].id, plan.jobs[1].id);
  // The same chain on a scan: mesh.decimate finds only points.
  std::string e = test::experiment_load_error(config(Json::array({"clean"}), kMeshChain));
  EXPECT_NE(e.find("cfg.json: /variants/0/chain/0"), std::string::npos) << e;
  EXPECT_NE(e.find("(mesh.decimate) consumes mesh"), std::string::npos) << e;
  EXPECT_NE(e.find("input: the points of scanner 'clean'"), std::string::npos) << e;
  // Both inputs in one config: each variant must take both.
  e = test::experiment_load_error(config(Json::array({"clean", "ground_truth"}), kMeshChain));
  EXPECT_NE(e.find("scanner 'clean'"), std::string::npos) << e;
  // A points chain on the ground-truth mesh.
  e = test::experiment_load_error(
      config(Json::array({"ground_truth"}),
             Json::parse(R"({"label": "pca", "algorithm": "normals.pca"})")));
  EXPECT_NE(e.find("(normals.pca) consumes points"), std::string::npos) << e;
  EXPECT_NE(e.find("input: the ground-truth mesh of scanner 'ground_truth'"), std::string::npos)
      << e;
  // ground_truth takes no parameters, neither in the entry nor from a sweep.
  e = test::experiment_load_error(
      config(Json::parse(R"([{"preset": "ground_truth", "params": {"views": 3}}])"), kMeshChain));
  EXPECT_NE(e.find("cfg.json: /scanners/0/params"), std::string::npos) << e;
  Json swept = config(Json::array({"ground_truth"}), kMeshChain);
  swept["sweep"] = {{"scanner.views", {3}}};
  EXPECT_THROW(expand(parse_experiment(swept, "cfg.json")), ParamError);
}

TEST(GpsSubdivisionConfig, ShippedConfigLoadsWithBothSchemesPerLevel) {
  const Experiment e = load_experiment(config_root() / "gps-subdivision.json");
  std::set<std::string> labels;
  for (const auto& v : e.variants)
    labels.insert(v.label);
  EXPECT_EQ(labels, (std::set<std::string>{"gp_loop", "loop"}));
  for (const auto& d : e.datasets) {
    ASSERT_EQ(d.scanners.size(), 1u);
    EXPECT_EQ(d.scanners[0].preset, "ground_truth");
  }
}

TEST(GpsSubdivisionConfig, ReducedCopyRunsWithEveryJobOk) {
  const fs::path dir = make_temp_dir("gps");
  // The shipped config with small procedural datasets and levels 2-3 (same variants, chains,
  // decimation target and metrics).
  Json c = Json::parse(slurp(config_root() / "gps-subdivision.json"), nullptr, true, true);
  c["datasets"] = Json::parse(R"([
      {"name": "sphere", "params": {"resolution": 12}},
      {"name": "torus", "params": {"major_segments": 40, "minor_segments": 20}}])");
  for (auto& v : c["variants"]) {
    for (auto& [key, values] : v["sweep"].items())
      values = Json::array({2, 3});
  }
  c["metric_params"]["surface.chamfer"]["samples"] = 20000;
  std::ofstream(dir / "gps.json") << c.dump(2);
  const fs::path out = dir / "out";
  const auto [code, text] = sh(std::string(SCANBENCH_BINARY) + " run " +
                               (dir / "gps.json").string() + " -o " + out.string() + " --jobs 2");
  ASSERT_EQ(code, 0) << text;
  std::map<std::string, Json> rec;  // "dataset variant levels" -> record
  std::istringstream lines(slurp(out / "runs.jsonl"));
  for (std::string l; std::getline(lines, l);) {
    if (l.empty()) continue;
    const Json r = Json::parse(l);
    ASSERT_EQ(r["status"], "ok") << r.dump();
    rec[r["dataset"]["label"].get<std::string>() + " " + r["variant"]["label"].get<std::string>() +
        " " + r["point_label"].get<std::string>()] = r;
  }
  EXPECT_EQ(rec.size(), 8u);
  for (const char* d : {"sphere", "torus"}) {
    for (const char* v : {"gp_loop", "loop"}) {
      for (int levels : {2, 3}) {
        const std::string k = std::string(d) + " " + v + " levels=" + std::to_string(levels);
        ASSERT_TRUE(rec.count(k)) << k;
        const Json& r = rec[k];
        const Json& m = r["metrics"];
        EXPECT_TRUE(m.contains("chamfer_rel")) << k << m.dump();
        EXPECT_TRUE(m.contains("hausdorff_rel")) << k;
        EXPECT_TRUE(m.value("mesh_closed", false)) << k;
        // Decimated to the config's target, then 4^levels triangles per control triangle.
        const int control = c["variants"][0]["chain"][0]["params"]["faces"].get<int>();
        const double faces = m["mesh_faces"].get<double>();
        EXPECT_LE(faces, control * std::pow(4.0, levels)) << k;
        EXPECT_GE(faces, (control - 1) * std::pow(4.0, levels)) << k;
        // Scored against the undecimated ground truth: a subdivided coarse sphere is near it.
        EXPECT_LT(m["chamfer_rel"].get<double>(), 0.02) << k;
        EXPECT_GT(r["sizes"]["input_mesh_faces"].get<double>(), 1500) << k;  // 1728 and 1600
        EXPECT_FALSE(r["sizes"].contains("scan_points")) << k;
      }
    }
  }
  EXPECT_FALSE(fs::exists(out / "scans") && !fs::is_empty(out / "scans"));
  const auto [tcode, table] = sh(std::string(SCANBENCH_BINARY) + " table " + out.string());
  ASSERT_EQ(tcode, 0) << table;
  for (const char* s : {"gp_loop", "loop", "levels=2", "levels=3", "ground_truth"})
    EXPECT_NE(table.find(s), std::string::npos) << s << "\n" << table;
  fs::remove_all(dir);
}

// The issue's check as a user runs it: a clean scan of the sphere -> mixture.hem (its default
// local-PCA kernels, no normals) -> triangulate.bhattacharyya writes a closed covariance mesh
// (Euler characteristic 2, no boundary edge, no edge with three faces). Without the closing of
// three-edge fronts this scan's mixture kept 15 triangular holes (Euler -13).
TEST(GpsReconstructionCli, ScannedSphereMixtureTriangulatesClosed) {
  const fs::path dir = make_temp_dir("gps_sphere");
  const std::string d = dir.string();
  ASSERT_EQ(sh(sb() + " scan --dataset sphere --preset clean --seed 3 -o " + d + "/s.ply").code, 0);
  ASSERT_EQ(sh(sb() + " algo mixture.hem -i " + d + "/s.ply -o " + d + "/m.ply").code, 0);
  const auto r = sh(sb() + " algo triangulate.bhattacharyya -i " + d + "/m.ply -o " + d + "/c.ply");
  ASSERT_EQ(r.code, 0) << r.out;
  const CovarianceMesh cm = read_covariance_mesh(dir / "c.ply");
  const auto t = algorithms::test::topology(cm);
  EXPECT_GT(t.f, 1000);
  EXPECT_EQ(t.boundary, 0);
  EXPECT_EQ(t.over, 0);
  EXPECT_EQ(t.euler(), 2);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scanbench::harness
