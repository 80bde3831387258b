// The far-from-origin comparison of issue "survey-scale coordinates", end to end through the real
// binary: a classic mesh (camel, the CLOP timing model of the resample bench) and a procedural
// shape (torus), each also written translated by (1e6, -2e6, 5e5) as a double PLY without any
// origin comment (as a user's UTM file would be), run by `scanbench run` with the `moderate`
// scanner (reduced resolution) and CLOP at h 0.03, every registered metric. The translated run
// records its origin, writes its output back in world coordinates, and scores the same *_rel
// metrics as the run at the origin, within kRelTolerance (see below for why not bit for bit).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "cli_test_util.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/io.h"
#include "scanbench/core/params.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

const Eigen::Vector3d kT(1e6, -2e6, 5e5);

// The two runs differ only by the rounding of world coordinates in double: the translated mesh
// file holds kT + v in double, exact for every vertex coordinate above 2^-9 in magnitude, off by at
// most 2^-33 (half a double spacing at 2e6) for smaller ones; the scan cache (world coordinates,
// double) likewise. A few points thus move by ~1e-10 of the diagonal. Continuous metrics (chamfer,
// accuracy, completeness, nn_dist_*, scan_noise) then agree to ~1e-8 relative, and most metrics bit
// for bit; the point-to-plane metrics use the plane of the closest ground-truth face, which jumps
// where the closest face changes, and moved by up to 2.4e-4 relative (p2plane_rms_rel, camel at
// full `moderate` resolution). Hence this tolerance, against the 10-70% changes float32 caused
// before local origins.
constexpr double kRelTolerance = 1e-3;

// Writes `mesh` translated by kT as binary PLY with double positions and no origin comment.
void write_translated(const scanbench::TriangleMesh& mesh, const fs::path& p) {
  scanbench::TriangleMesh far = mesh;
  far.origin = kT;
  scanbench::write_mesh(far, p);
  std::string bytes = slurp(p);
  const auto at = bytes.find("comment scanbench_origin");
  ASSERT_NE(at, std::string::npos);
  bytes.erase(at, bytes.find('\n', at) + 1 - at);
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
}

void compare_runs(const std::string& dataset) {
  const fs::path dir = make_temp_dir("origin-" + dataset);
  const scanbench::TriangleMesh mesh = scanbench::load_dataset(dataset);
  scanbench::write_mesh(mesh, dir / "near.ply");
  write_translated(mesh, dir / "far.ply");
  // The far file as read: the translation comes back as the origin (diagonal <= 4: origins on
  // multiples of 2, every component of kT is one).
  ASSERT_EQ(scanbench::read_mesh(dir / "far.ply").origin, kT);

  std::ofstream(dir / "exp.json") << R"({
    "scanbench_experiment": 1, "name": "origin", "seed": 4, "repeats": 1, "threads": 2,
    "save_outputs": true,
    "datasets": [{"name": ")" + (dir / "near.ply").string() +
                                         R"(", "label": "near"},
                 {"name": ")" + (dir / "far.ply").string() +
                                         R"(", "label": "far"}],
    "scanners": [{"preset": "moderate", "params": {"views": 6, "resolution": 96}}],
    "variants": [{"label": "clop", "algorithm": "resample.clop", "params": {"h": 0.03}}]
  })";
  const fs::path out = dir / "out";
  const auto [code, text] =
      sh(sb() + " run " + (dir / "exp.json").string() + " -o " + out.string());
  ASSERT_EQ(code, 0) << text;
  std::map<std::string, Json> rec;
  for (const Json& r : read_jsonl(out / "runs.jsonl"))
    rec[r["dataset"]["label"].get<std::string>()] = r;
  ASSERT_EQ(rec.size(), 2u);
  const Json& near = rec["near"];
  const Json& far = rec["far"];
  ASSERT_EQ(near["status"], "ok") << near.dump();
  ASSERT_EQ(far["status"], "ok") << far.dump();
  // The origin is recorded (and absent at the origin).
  EXPECT_FALSE(near.contains("dataset_origin"));
  ASSERT_TRUE(far.contains("dataset_origin")) << far.dump();
  EXPECT_EQ(far["dataset_origin"], Json::array({1e6, -2e6, 5e5}));
  // Same scan size, same metrics.
  EXPECT_EQ(near["sizes"]["scan_points"], far["sizes"]["scan_points"]);
  int compared = 0;
  for (const auto& [k, v] : near["metrics"].items()) {
    if (!v.is_number()) continue;
    ASSERT_TRUE(far["metrics"].contains(k)) << k;
    const double a = v.get<double>();
    const double b = far["metrics"][k].get<double>();
    if (k.ends_with("_rel") || k == "fscore" || k == "nn_dist_cv") {
      EXPECT_LE(std::abs(a - b), kRelTolerance * std::max(std::abs(a), 1e-12))
          << dataset << " " << k << ": at origin " << a << ", far " << b;
      ++compared;
    }
    std::printf("%s %s: at origin %.9g, far %.9g\n", dataset.c_str(), k.c_str(), a, b);
  }
  for (const char* k : {"chamfer_rel", "fscore", "nn_dist_cv"})
    EXPECT_TRUE(near["metrics"].contains(k)) << k << " not scored: " << near["metrics"].dump();
  EXPECT_GE(compared, 5);
  // The written output is back in world coordinates (double PLY with the origin comment).
  const fs::path output = out / far["artifacts"]["output"].get<std::string>();
  const std::string head = slurp(output).substr(0, 400);
  EXPECT_NE(head.find("comment scanbench_origin 1000000 -2000000 500000"), std::string::npos)
      << head;
  EXPECT_NE(head.find("property double x"), std::string::npos) << head;
  const scanbench::PointCloud o = scanbench::read_point_cloud(output);
  EXPECT_EQ(o.origin, kT);
  const Eigen::Vector3d centre = o.origin + o.bbox().center().cast<double>();
  EXPECT_LT((centre - kT).norm(), 1.0) << centre.transpose();
  // The scan cache is in world coordinates too, and the near run's output is not.
  const scanbench::PointCloud scan =
      scanbench::read_point_cloud(out / far["artifacts"]["scan"].get<std::string>());
  EXPECT_EQ(scan.origin, kT);
  EXPECT_TRUE(scanbench::read_point_cloud(out / near["artifacts"]["output"].get<std::string>())
                  .origin.isZero(0.0));
  fs::remove_all(dir);
}

TEST(LocalOriginE2E, ClassicMeshCamelAtOriginAndFar) {
  ASSERT_TRUE(scanbench::datasets().find("camel")->fn.available())
      << "data/meshes/camel.off missing (run scripts/setup.sh)";
  compare_runs("camel");
}

TEST(LocalOriginE2E, ProceduralTorusAtOriginAndFar) {
  compare_runs("torus");
}

}  // namespace
