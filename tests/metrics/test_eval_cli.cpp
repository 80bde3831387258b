// End to end: `scanbench eval` and `scanbench bench distance` as a user runs them, checked
// against brute force (every output point against every face; every sample against every
// output point). Skipped when the scanbench binary has not been built.
#include <gtest/gtest.h>

#include <OpenImageIO/imagebuf.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>

#include "scanbench/core/datasets.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/metrics/closest_point.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"
#include "scanbench/metrics/surface_sampling.h"

namespace scanbench::metrics {
namespace {

namespace fs = std::filesystem;

int run(const std::string& args, const fs::path& log) {
  const std::string cmd =
      std::string(SCANBENCH_BINARY) + " " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

Json read_json(const fs::path& p) {
  std::ifstream f(p);
  return Json::parse(f);
}

class EvalCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(SCANBENCH_BINARY)) GTEST_SKIP() << "scanbench binary not built";
    dir_ = fs::temp_directory_path() / ("scanbench_eval_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(EvalCli, MetricsMatchBruteForceAndFilesOpen) {
  const TriangleMesh mesh = load_dataset("sphere");
  write_mesh(mesh, dir_ / "gt.ply");
  // Output: surface samples moved along the normal by a seeded N(0, 0.003) offset, with normals
  // tilted by a known amount.
  PointCloud out = sample_surface(mesh, 3000, 5);
  out.properties.clear();
  Rng rng(9);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    out.positions.col(i) += static_cast<float>(rng.normal(0.0, 0.003)) * out.normals.col(i);
    out.normals.col(i) = (out.normals.col(i) + Eigen::Vector3f(0.05f, 0, 0)).normalized();
  }
  write_point_cloud(out, dir_ / "out.ply");
  const PointCloud written = read_point_cloud(dir_ / "out.ply");

  const std::string args =
      "eval --mesh " + (dir_ / "gt.ply").string() + " --points " + (dir_ / "out.ply").string() +
      " --seed 4 --set accuracy.chamfer.samples=20000 --heatmap " + (dir_ / "img").string() +
      " --vdb " + (dir_ / "vdb").string() + " -o " + (dir_ / "m.json").string();
  ASSERT_EQ(run(args, dir_ / "log.txt"), 0) << std::ifstream(dir_ / "log.txt").rdbuf();
  const Json m = read_json(dir_ / "m.json");
  for (const char* k : {"p2plane_mean",
                        "p2plane_rms",
                        "p2plane_max",
                        "p2plane_p50",
                        "p2plane_p90",
                        "p2plane_p99",
                        "nn_dist_var",
                        "nn_dist_cv",
                        "accuracy",
                        "completeness",
                        "chamfer",
                        "hausdorff",
                        "fscore",
                        "precision",
                        "recall",
                        "normal_angle_mean_deg",
                        "normal_angle_rms_deg",
                        "normal_pgp5",
                        "normal_pgp10",
                        "p2plane_mean_rel",
                        "chamfer_rel"})
    ASSERT_TRUE(m.contains(k) && m[k].is_number()) << k;

  // Brute force: every output point against every face.
  const double diag = mesh.bbox().diagonal();
  double acc = 0, e_sum = 0, e_max = 0, ang = 0;
  std::int64_t prec = 0;
  for (Eigen::Index i = 0; i < written.size(); ++i) {
    const Eigen::Vector3d q = written.positions.col(i).cast<double>();
    double best = 1e300;
    Eigen::Index bf = -1;
    Eigen::Vector3d bp = Eigen::Vector3d::Zero();
    for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
      const Eigen::Vector3d p =
          closest_point_on_triangle(q, mesh.vertices.col(mesh.faces(0, f)).cast<double>(),
                                    mesh.vertices.col(mesh.faces(1, f)).cast<double>(),
                                    mesh.vertices.col(mesh.faces(2, f)).cast<double>());
      if ((p - q).squaredNorm() < best) {
        best = (p - q).squaredNorm();
        bf = f;
        bp = p;
      }
    }
    const Eigen::Vector3d n = mesh.face_normal(bf).cast<double>();
    const double e = std::abs((q - bp).dot(n));
    acc += std::sqrt(best);
    e_sum += e;
    e_max = std::max(e_max, e);
    prec += std::sqrt(best) < 0.005 * diag;
    ang += std::acos(std::min(1.0, std::abs(n.dot(written.normals.col(i).cast<double>())))) *
           180.0 / M_PI;
  }
  const double n = static_cast<double>(written.size());
  EXPECT_NEAR(m["accuracy"].get<double>(), acc / n, 1e-7);
  EXPECT_NEAR(m["p2plane_mean"].get<double>(), e_sum / n, 1e-7);
  EXPECT_NEAR(m["p2plane_max"].get<double>(), e_max, 1e-6);
  EXPECT_NEAR(m["precision"].get<double>(), prec / n, 1e-12);
  EXPECT_NEAR(m["normal_angle_mean_deg"].get<double>(), ang / n, 1e-3);
  EXPECT_NEAR(m["accuracy_rel"].get<double>(), acc / n / diag, 1e-7);

  // Completeness: the same seeded samples against every output point.
  const RunContext ctx(4);
  const PointCloud s = sample_surface(mesh, 20000, ctx.stream_seed(kGroundTruthSamplesStream));
  double comp = 0;
  std::int64_t rec = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    const float d = std::sqrt(
        (written.positions.colwise() - s.positions.col(i)).colwise().squaredNorm().minCoeff());
    comp += d;
    rec += d < 0.005 * diag;
  }
  EXPECT_NEAR(m["completeness"].get<double>(), comp / s.size(), 1e-7);
  EXPECT_NEAR(m["recall"].get<double>(), static_cast<double>(rec) / s.size(), 1e-12);

  // Images and fields open.
  const fs::path heat = dir_ / "img" / "heatmap_p2plane.png";
  OIIO::ImageBuf img(heat.string());
  ASSERT_TRUE(img.init_spec(heat.string(), 0, 0));
  EXPECT_EQ(img.spec().width, heatmap_size(HeatmapParams{}).x());
  EXPECT_EQ(img.spec().height, heatmap_size(HeatmapParams{}).y());
  EXPECT_TRUE(fs::exists(dir_ / "img" / "histogram_p2plane.png"));
  if (std::system("command -v oiiotool > /dev/null 2>&1") == 0) {
    EXPECT_EQ(std::system(("oiiotool --info " + heat.string() + " > /dev/null").c_str()), 0);
  }
  const VdbInfo v = read_vdb_info(dir_ / "vdb" / "ground_truth.vdb");
  EXPECT_EQ(v.name, "ground_truth");
  EXPECT_GT(v.active_voxels, 0u);
}

TEST_F(EvalCli, ObservedScoresEqualThePlainOnesOnlyWhenEverySideWasScanned) {
  // Real scans (the clean scanner, Embree) of the sphere, scored as a method's output: from a
  // Fibonacci spiral of 24 views every sample is observed and the _observed scores equal the
  // plain ones bit for bit; from four sensors above, the lower half was never seen, and the
  // _observed scores leave it out (a smaller completeness, a higher recall). The observed share
  // and completeness against a brute-force oracle (every sample against every clean hit).
  const auto scan_and_eval = [&](const std::string& name, const std::string& scanner_args) {
    const fs::path scan = dir_ / (name + ".ply"), m = dir_ / (name + ".json");
    EXPECT_EQ(run("scan --dataset sphere --preset clean " + scanner_args + " --seed 3 -o " +
                      scan.string(),
                  dir_ / "log.txt"),
              0)
        << std::ifstream(dir_ / "log.txt").rdbuf();
    EXPECT_EQ(run("eval --dataset sphere --points " + scan.string() + " --scan " + scan.string() +
                      " --metrics accuracy.chamfer --set accuracy.chamfer.samples=3000 --seed 2 "
                      "-o " +
                      m.string(),
                  dir_ / "log.txt"),
              0)
        << std::ifstream(dir_ / "log.txt").rdbuf();
    return read_json(m);
  };
  const Json all = scan_and_eval("all", "--set views=24 --set resolution=128");
  ASSERT_TRUE(all.contains("observed_share")) << all.dump();
  EXPECT_EQ(all["observed_share"].get<double>(), 1.0);
  for (const char* k : {"completeness", "chamfer", "recall", "fscore"})
    EXPECT_EQ(all[std::string(k) + "_observed"], all[k]) << k;

  const Json top =
      scan_and_eval("top",
                    "--set views=4 --set resolution=128 --set \"poses=0.6 0 0.8; -0.6 0 0.8; 0 0.6 "
                    "0.8; 0 -0.6 0.8\"");
  const double share = top["observed_share"].get<double>();
  EXPECT_GT(share, 0.3);
  EXPECT_LT(share, 0.8);
  EXPECT_LT(top["completeness_observed"].get<double>(), top["completeness"].get<double>() / 2);
  EXPECT_GT(top["recall_observed"].get<double>(), top["recall"].get<double>());
  EXPECT_EQ(top["chamfer_observed"].get<double>(),
            top["accuracy"].get<double>() + top["completeness_observed"].get<double>());

  // The oracle: the same 3,000 ground-truth samples (the recorded seed), every one against
  // every clean hit of the scan's inliers and every point of the output (here the scan).
  TriangleMesh mesh = load_dataset("sphere");
  const GroundTruth gt(mesh, top["scoring"]["ground_truth_samples_seed"].get<std::uint64_t>());
  const PointCloud& samples = gt.surface_samples(3000);
  PointCloud scan = read_point_cloud(dir_ / "top.ply");
  rebase(scan, mesh.origin);
  const double radius = top["observed_radius"].get<double>();
  const auto& cx = scan.properties.at("clean_x");
  const auto& cy = scan.properties.at("clean_y");
  const auto& cz = scan.properties.at("clean_z");
  Eigen::Index seen = 0;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < samples.size(); ++i) {
    const Eigen::Vector3f s = samples.positions.col(i);
    bool observed = false;
    for (Eigen::Index j = 0; j < scan.size() && !observed; ++j)
      observed = (Eigen::Vector3f(cx[j], cy[j], cz[j]) - s).norm() <= radius;
    if (!observed) continue;
    ++seen;
    float best = std::numeric_limits<float>::infinity();
    for (Eigen::Index j = 0; j < scan.size(); ++j)
      best = std::min(best, (scan.positions.col(j) - s).norm());
    sum += best;
  }
  EXPECT_NEAR(share, static_cast<double>(seen) / 3000.0, 2.0 / 3000.0);
  EXPECT_NEAR(top["completeness_observed"].get<double>(), sum / static_cast<double>(seen),
              1e-3 * sum / static_cast<double>(seen));
}

TEST_F(EvalCli, BadInputExitsWithOneLine) {
  EXPECT_EQ(run("eval --dataset sphere --points " + (dir_ / "missing.ply").string() + " -o " +
                    (dir_ / "m.json").string(),
                dir_ / "log.txt"),
            2);
  EXPECT_EQ(run("eval --dataset sphere --points x.ply --set accuracy.chamfer.tau=-1 -o " +
                    (dir_ / "m.json").string(),
                dir_ / "log2.txt"),
            2);
  std::ifstream f(dir_ / "log2.txt");
  std::string line;
  std::getline(f, line);
  EXPECT_NE(line.find("accuracy.chamfer"), std::string::npos) << line;
}

TEST_F(EvalCli, BenchDistanceWritesRatios) {
  ASSERT_EQ(run("bench distance --dataset sphere --points 20000 --repeats 2 --json " +
                    (dir_ / "b.json").string(),
                dir_ / "log.txt"),
            0)
      << std::ifstream(dir_ / "log.txt").rdbuf();
  const Json b = read_json(dir_ / "b.json");
  ASSERT_TRUE(b["ratios"]["exact_over_field"].is_number());
  ASSERT_TRUE(b["field_mean_deviation_voxels"].is_number());
  EXPECT_LT(b["field_mean_deviation_voxels"].get<double>(), 0.05);
  EXPECT_EQ(b["queries"].get<int>(), 20000);
  // The split of the field path is reported too.
  ASSERT_TRUE(b["field_sampling_median_seconds"].is_number());
  EXPECT_EQ(b["exact_seconds"].size(), 2u);
  EXPECT_TRUE(b["timed"].is_string());
  EXPECT_GE(b["fallbacks"].get<int>(), 300);  // the 2% far queries take the exact fallback
  // Each repeat is a pair: the summary is of the per-repeat ratios, and "every repeat" is judged
  // on the worst of them.
  const Json& r = b["ratios"];
  const Json& s = r["exact_over_field_summary"];
  ASSERT_EQ(r["exact_over_field_per_repeat"].size(), 2u);
  EXPECT_EQ(s["n"].get<int>(), 2);
  EXPECT_DOUBLE_EQ(s["min"].get<double>(), r["exact_over_field_min"].get<double>());
  EXPECT_LE(s["min"].get<double>(), s["median"].get<double>());
  EXPECT_LE(s["median"].get<double>(), s["max"].get<double>());
  EXPECT_LE(s["ci_low"].get<double>(), s["ci_high"].get<double>());
  EXPECT_EQ(r["verdict_every_repeat"].get<std::string>(),
            r["exact_over_field_min"].get<double>() >= 5.0 ? "met" : "missed");
  EXPECT_TRUE(r["verdict_median"].is_string());
  EXPECT_TRUE(b["load_before"].is_number());
}

}  // namespace
}  // namespace scanbench::metrics
