// Point datasets in an experiment (experiment.h, DatasetSpec::points), end to end through
// `scanbench run`: a sparse model that the real COLMAP wrote (model_converter turns a text model
// into COLMAP's binary files) as the input, scored against a point-cloud ground truth given with
// an alignment and a crop box, with the metrics checked against a hand computation; the same
// model against a mesh ground truth; and the config errors of a point dataset.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "cli_test_util.h"
#include "experiment_test_util.h"
#include "scanbench/core/colmap.h"
#include "scanbench/core/io.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

constexpr int kPoints = 200;

// kPoints Fibonacci points on the unit sphere, each seen by both of two cameras.
scanbench::colmap::Model sphere_model() {
  scanbench::colmap::Model m;
  m.cameras.push_back({1, "PINHOLE", 640, 480, {500, 500, 320, 240}});
  for (std::uint32_t k = 1; k <= 2; ++k) {
    scanbench::colmap::Image im;
    im.id = k;
    im.camera_id = 1;
    im.name = "view_" + std::to_string(k) + ".png";
    im.translation = Eigen::Vector3d(0, 0, 3.0 + k);
    m.images.push_back(im);
  }
  const double golden = std::acos(-1.0) * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < kPoints; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / kPoints, r = std::sqrt(1.0 - z * z);
    scanbench::colmap::Point p;
    p.id = static_cast<std::uint64_t>(i + 1);
    p.xyz = Eigen::Vector3d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    p.error = 0.5;
    for (auto& im : m.images) {
      p.track.emplace_back(im.id, static_cast<std::uint32_t>(i));
      im.xy.emplace_back(1.0 * i, 2.0);
      im.point3d_ids.push_back(static_cast<std::int64_t>(p.id));
    }
    m.points.push_back(p);
  }
  return m;
}

// Writes the model as text, then has COLMAP convert it to its binary format in `bin`.
void write_colmap_bin(const scanbench::colmap::Model& m, const fs::path& dir, const fs::path& bin) {
  scanbench::colmap::write_model_text(m, dir);
  fs::create_directories(bin);
  const std::string cmd = "colmap model_converter --input_path '" + dir.string() +
                          "' --output_path '" + bin.string() +
                          "' --output_type BIN >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ASSERT_TRUE(fs::exists(bin / "points3D.bin"));
}

TEST(PointDatasetE2E, ColmapModelAgainstPointTruthMatchesTheHandComputation) {
  ASSERT_EQ(std::system("colmap help >/dev/null 2>&1"), 0)
      << "colmap not installed (scripts/setup.sh installs it)";
  const fs::path dir = make_temp_dir("pointds");
  const scanbench::colmap::Model model = sphere_model();
  write_colmap_bin(model, dir / "txt", dir / "sparse");
  // Ground truth: the model's points plus one far point g* = (0, 0, 3), stored turned by -90 deg
  // about z, (x, y, z) -> (y, -x, z); gt_transform turns it back (exact in float: a swap and a
  // sign). The crop box of the second dataset leaves g* out.
  scanbench::PointCloud gt;
  gt.resize(kPoints + 1);
  for (int i = 0; i < kPoints; ++i) {
    const Eigen::Vector3f p = model.points[i].xyz.cast<float>();
    gt.positions.col(i) = Eigen::Vector3f(p.y(), -p.x(), p.z());
  }
  gt.positions.col(kPoints) = Eigen::Vector3f(0, 0, 3);
  scanbench::write_point_cloud(gt, dir / "gt.ply");
  write(dir / "exp.json", R"({
    "scanbench_experiment": 1, "name": "pointds", "seed": 3, "threads": 2,
    "datasets": [
      {"label": "whole", "points": "sparse", "gt_points": "gt.ply",
       "gt_transform": "0 -1 0 0  1 0 0 0  0 0 1 0  0 0 0 1"},
      {"label": "cropped", "points": "sparse", "gt_points": "gt.ply",
       "gt_transform": "0 -1 0 0  1 0 0 0  0 0 1 0  0 0 0 1", "gt_crop": "-2,-2,-2,2,2,2"}],
    "variants": [{"label": "same", "algorithm": "test.subsample", "params": {"stride": 1}}]
  })");
  const fs::path out = dir / "out";
  const auto [code, text] =
      sh(sb() + " run " + (dir / "exp.json").string() + " -o " + out.string());
  ASSERT_EQ(code, 0) << text;
  std::map<std::string, Json> rec;
  for (const Json& r : read_jsonl(out / "runs.jsonl"))
    rec[r["dataset"]["label"].get<std::string>()] = r;
  ASSERT_EQ(rec.size(), 2u);
  // Hand computation: every output point lies on a GT point (accuracy 0, precision 1); the GT
  // points but g* lie on output points, g* is d* from the nearest (the pole point).
  double dstar = 1e9;
  for (const auto& p : model.points)
    dstar = std::min(dstar,
                     static_cast<double>((p.xyz.cast<float>() - Eigen::Vector3f(0, 0, 3)).norm()));
  for (const auto& [label, r] : rec) {
    SCOPED_TRACE(label);
    ASSERT_EQ(r["status"], "ok") << r.dump();
    const Json& m = r["metrics"];
    EXPECT_EQ(r["sizes"]["scan_points"], kPoints);
    EXPECT_EQ(m["accuracy"].get<double>(), 0.0);
    EXPECT_EQ(m["precision"].get<double>(), 1.0);
    const int n_gt = label == "whole" ? kPoints + 1 : kPoints;
    EXPECT_EQ(m["chamfer_samples"].get<int>(), n_gt);
    const double completeness = label == "whole" ? dstar / n_gt : 0.0;
    EXPECT_NEAR(m["completeness"].get<double>(), completeness, 1e-6);
    EXPECT_NEAR(m["recall"].get<double>(), label == "whole" ? 1.0 * kPoints / n_gt : 1.0, 1e-12);
    // Metrics that need a mesh are recorded as not applicable, not as errors.
    // (accuracy.p2plane too: these GT points have no normals.)
    ASSERT_TRUE(r.contains("skipped")) << r.dump();
    EXPECT_TRUE(r["skipped"].contains("accuracy.p2plane")) << r["skipped"].dump();
    EXPECT_GE(r["skipped"].size(), 2u) << r["skipped"].dump();
    EXPECT_FALSE(m.contains("p2plane_rms")) << m.dump();
  }
  fs::remove_all(dir);
}

TEST(PointDatasetE2E, ColmapModelAgainstAMesh) {
  ASSERT_EQ(std::system("colmap help >/dev/null 2>&1"), 0)
      << "colmap not installed (scripts/setup.sh installs it)";
  const fs::path dir = make_temp_dir("pointds-mesh");
  write_colmap_bin(sphere_model(), dir / "txt", dir / "sparse");
  write(dir / "exp.json", R"({
    "scanbench_experiment": 1, "name": "pointds", "seed": 3,
    "datasets": [{"name": "sphere", "points": "sparse"}],
    "variants": [{"label": "same", "algorithm": "test.subsample", "params": {"stride": 1}}]
  })");
  const auto [code, text] =
      sh(sb() + " run " + (dir / "exp.json").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(code, 0) << text;
  const auto rs = read_jsonl(dir / "out" / "runs.jsonl");
  ASSERT_EQ(rs.size(), 1u);
  ASSERT_EQ(rs[0]["status"], "ok") << rs[0].dump();
  EXPECT_EQ(rs[0]["dataset"]["label"], "sparse");
  EXPECT_EQ(rs[0]["scanner"]["label"], "points");
  // The points lie on the unit sphere; the mesh (resolution 32) is within its chordal error.
  EXPECT_LT(rs[0]["metrics"]["accuracy"].get<double>(), 5e-3);
  fs::remove_all(dir);
}

TEST(PointDatasetE2E, ConfigErrorsNameTheField) {
  const auto cfg = [](const Json& dataset) {
    return Json{{"scanbench_experiment", 1},
                {"name", "x"},
                {"datasets", Json::array({dataset})},
                {"variants", Json::array({{{"algorithm", "normals.pca"}}})}};
  };
  EXPECT_NE(experiment_load_error(cfg({{"points", "a.ply"}})).find("exactly one ground truth"),
            std::string::npos);
  EXPECT_NE(
      experiment_load_error(cfg({{"points", "a.ply"}, {"name", "sphere"}, {"gt_points", "g"}}))
          .find("exactly one ground truth"),
      std::string::npos);
  EXPECT_NE(experiment_load_error(cfg({{"name", "sphere"}, {"gt_points", "g.ply"}}))
                .find("/datasets/0/gt_points: a point ground truth needs \"points\""),
            std::string::npos);
  EXPECT_NE(experiment_load_error(
                cfg({{"points", "a.ply"}, {"gt_points", "g.ply"}, {"gt_crop", "1,2,3"}}))
                .find("gt_crop"),
            std::string::npos);
  EXPECT_NE(experiment_load_error(
                cfg({{"points", "a.ply"}, {"name", "sphere"}, {"scanners", {"moderate"}}}))
                .find("/datasets/0/scanners: a point dataset"),
            std::string::npos);
  EXPECT_EQ(experiment_load_error(cfg({{"points", "a.ply"}, {"gt_points", "g.ply"}})), "");
}

}  // namespace
