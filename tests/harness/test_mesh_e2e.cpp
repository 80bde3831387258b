// End to end: `scanbench run` on chains ending in a mesh and a covariance mesh (the test-only
// algorithms test.sphere_mesh and test.sphere_covmesh, SCANBENCH_TEST_ALGORITHMS=1) records the
// surface metrics, describes the mesh in `sizes`, draws the heatmap on the surface and checks
// repeat identity on the mesh; table and report show the surface metrics.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_test_util.h"
#include "scanbench/core/params.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

TEST(MeshE2E, RunRecordsSurfaceMetricsForMeshOutputs) {
  const fs::path dir = make_temp_dir("mesh");
  std::ofstream(dir / "mesh.json") << R"({
    "scanbench_experiment": 1, "name": "mesh", "seed": 3, "repeats": 2,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 3, "resolution": 40}}],
    "variants": [
      {"label": "mesh", "algorithm": "test.sphere_mesh", "params": {"resolution": 16}},
      {"label": "covmesh", "algorithm": "test.sphere_covmesh", "params": {"resolution": 8}},
      {"label": "points", "algorithm": "test.subsample", "params": {"stride": 2}}
    ]
  })";
  const fs::path out = dir / "out";
  const auto [code, text] = sh(std::string(SCANBENCH_BINARY) + " run " +
                               (dir / "mesh.json").string() + " -o " + out.string());
  ASSERT_EQ(code, 0) << text;
  std::map<std::string, Json> rec = by_variant(read_jsonl(out / "runs.jsonl"));
  ASSERT_EQ(rec.size(), 3u);
  for (const char* v : {"mesh", "covmesh"}) {
    const Json& r = rec[v];
    ASSERT_EQ(r["status"], "ok") << r.dump();
    EXPECT_EQ(r["output_kind"], std::string(v) == "mesh" ? "mesh" : "covariance_mesh") << v;
    const Json& m = r["metrics"];
    for (const char* k : {"accuracy_rel", "completeness_rel", "chamfer_rel", "hausdorff_rel",
                          "fscore", "normal_angle_mean_deg", "normal_pgp5", "input_distance_mean",
                          "input_distance_rms_rel", "volume_iou", "mesh_vertices", "mesh_faces",
                          "mesh_boundary_edges", "mesh_components", "mesh_closed", "mesh_bytes"})
      EXPECT_TRUE(m.contains(k)) << v << " lacks " << k << ": " << m.dump();
    // A sphere fitted to a clean scan of the unit sphere lies on it (to the tessellation).
    EXPECT_LT(m["accuracy_rel"].get<double>(), 0.002) << v;
    EXPECT_LT(m["input_distance_mean_rel"].get<double>(), 0.002) << v;
    EXPECT_GT(m["volume_iou"].get<double>(), 0.95) << v;
    EXPECT_TRUE(m["mesh_closed"].get<bool>()) << v;
    EXPECT_EQ(m["mesh_components"].get<int>(), 1) << v;
    EXPECT_FALSE(m.contains("p2plane_mean")) << v;
    EXPECT_TRUE(r["skipped"].contains("accuracy.p2plane")) << v;
    EXPECT_TRUE(r["histograms"].contains("input_distance")) << v;
    // sizes describe the mesh, not the carried points.
    EXPECT_EQ(r["sizes"]["mesh_vertices"], m["mesh_vertices"]) << v;
    EXPECT_EQ(r["sizes"]["mesh_faces"], m["mesh_faces"]) << v;
    EXPECT_FALSE(r["sizes"].contains("output_points")) << v;
    EXPECT_TRUE(r["repeat_outputs_identical"].get<bool>()) << v;
    EXPECT_TRUE(fs::exists(out / r["artifacts"]["heatmap"].get<std::string>())) << v;
  }
  // Cube-spheres: 12 n^2 triangles, 6 n^2 + 2 vertices.
  EXPECT_EQ(rec["mesh"]["metrics"]["mesh_faces"].get<int>(), 12 * 16 * 16);
  EXPECT_EQ(rec["mesh"]["metrics"]["mesh_bytes"].get<int>(),
            12 * (6 * 16 * 16 + 2) + 12 * 12 * 16 * 16);
  EXPECT_EQ(rec["covmesh"]["metrics"]["mesh_bytes"].get<int>(),
            36 * (6 * 8 * 8 + 2) + 12 * 12 * 8 * 8);
  // The points variant is scored on points; the mesh metrics are skipped there.
  EXPECT_TRUE(rec["points"]["metrics"].contains("p2plane_mean"));
  EXPECT_TRUE(rec["points"]["skipped"].contains("surface.chamfer"));
  EXPECT_GT(rec["points"]["sizes"]["output_points"].get<int>(), 0);

  const auto [tcode, table] = sh(std::string(SCANBENCH_BINARY) + " table " + out.string() +
                                 " --metric volume_iou --format md");
  ASSERT_EQ(tcode, 0) << table;
  EXPECT_NE(table.find("volume_iou (higher is better)"), std::string::npos) << table;
  const auto [rcode, rtext] = sh(std::string(SCANBENCH_BINARY) + " report " + out.string());
  ASSERT_EQ(rcode, 0) << rtext;
  const std::string html = slurp(out / "index.html");
  for (const char* k : {"chamfer_rel", "input_distance_rms_rel", "volume_iou", "mesh_bytes",
                        "input_distance histogram", "vertices,"})
    EXPECT_NE(html.find(k), std::string::npos) << k;
  const auto [ccode, ctext] =
      sh(std::string(SCANBENCH_BINARY) + " compare " + out.string() + " " + out.string());
  EXPECT_EQ(ccode, 0) << ctext;
  fs::remove_all(dir);
}

// The GPS reconstruction chain through `scanbench run` (GPS paper sec. 7.2): every step's working
// memory is recorded, the control covariance mesh's size is that of mesh.facts (36 bytes per
// vertex, 12 per triangle), and the report's cost section (Fig. 13c table, Fig. 14 plots) appears
// when the config asks for it.
TEST(MeshE2E, GpsChainRecordsStepMemoryControlMeshAndCostSection) {
  std::string tmpl = (fs::temp_directory_path() / "scanbench-gps-XXXXXX").string();
  ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
  const fs::path dir = tmpl;
  std::ofstream(dir / "gps.json") << R"({
    "scanbench_experiment": 1, "name": "gps", "seed": 3, "repeats": 1,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 4, "resolution": 60}}],
    "variants": [
      {"label": "gps", "chain": [
        {"algorithm": "mixture.hem", "params": {"sigma0": 0.02}},
        {"algorithm": "triangulate.bhattacharyya"},
        {"algorithm": "subdivide.gp_loop", "params": {"levels": 1}}]},
      {"label": "mesh", "algorithm": "test.sphere_mesh", "params": {"resolution": 8}}
    ],
    "metrics": ["surface.input_distance", "mesh.facts"],
    "report": {"cost": {"exclude_steps": ["subdivide.gp_loop"]}}
  })";
  const fs::path out = dir / "out";
  const auto [code, text] = sh(std::string(SCANBENCH_BINARY) + " run " +
                               (dir / "gps.json").string() + " -o " + out.string());
  ASSERT_EQ(code, 0) << text;
  std::map<std::string, Json> rec;
  std::istringstream lines(slurp(out / "runs.jsonl"));
  for (std::string l; std::getline(lines, l);)
    if (!l.empty()) {
      const Json r = Json::parse(l);
      rec[r["variant"]["label"].get<std::string>()] = r;
    }
  const Json& g = rec["gps"];
  ASSERT_EQ(g["status"], "ok") << g.dump();
  for (const char* step : {"mixture.hem", "triangulate.bhattacharyya", "subdivide.gp_loop"}) {
    EXPECT_GE(g["timing"]["step_work_mb"][step].get<double>(), 0.0) << step;
    EXPECT_GT(g["timing"]["step_peak_rss_mb"][step].get<double>(), 1.0) << step;
  }
  const auto v = g["sizes"]["covmesh_vertices"].get<long>();
  const auto f = g["sizes"]["covmesh_faces"].get<long>();
  EXPECT_GT(f, 100);
  EXPECT_EQ(g["sizes"]["covmesh_bytes"].get<long>(), 36 * v + 12 * f);
  // The subdivided surface (1 level) has 4x the control faces.
  EXPECT_EQ(g["sizes"]["mesh_faces"].get<long>(), 4 * f);
  EXPECT_FALSE(rec["mesh"]["sizes"].contains("covmesh_bytes"));
  const auto [rcode, rtext] = sh(std::string(SCANBENCH_BINARY) + " report " + out.string());
  ASSERT_EQ(rcode, 0) << rtext;
  const std::string html = slurp(out / "index.html");
  for (const char* k : {"Reconstruction cost", "build MB", "input RMSE vs seconds",
                        "input RMSE vs working memory", "without subdivide.gp_loop"})
    EXPECT_NE(html.find(k), std::string::npos) << k;
  fs::remove_all(dir);
}
