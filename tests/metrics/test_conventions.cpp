// The published evaluators' conventions (metrics/conventions.h) against the evaluators' own
// code: ScoreDenoise's scores against tests/reference/scoredenoise_eval.py, a line-by-line numpy
// port of score-denoise's models/utils.py and PyTorch3D 0.5.0's chamfer_distance and
// point_mesh_face_distance (brute force), on three shapes and both of PyTorch3D's triangle-area
// thresholds; the identities the convention implies (invariance to where and how large the
// shape is; the larger threshold never lowers p2f); the dsr-benchmark's point scores against
// tests/reference/dsr_eval.py (its dsrb/eval.py, brute force); the metrics through the registry.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/metrics/conventions.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/surface_sampling.h"
#include "temp_dir.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

namespace fs = std::filesystem;
using testing::icosphere;

/// Surface samples of `mesh` moved along random directions by N(0, sigma) (a noisy cloud).
Eigen::Matrix3Xf noisy(const TriangleMesh& mesh, Eigen::Index n, std::uint64_t seed, double sigma) {
  Eigen::Matrix3Xf p = sample_surface(mesh, n, seed).positions;
  Rng rng(seed + 1);
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    for (int a = 0; a < 3; ++a)
      p(a, i) += static_cast<float>(rng.normal(0.0, sigma));
  return p;
}

void write_rows(const fs::path& f, const Eigen::MatrixXd& m) {
  std::ofstream out(f);
  out.precision(17);
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      out << (i ? " " : "") << m(i, j);
    out << "\n";
  }
}

/// Runs tests/reference/SCRIPT (Debian's python3 with numpy) on the matrices, written as text
/// files with every float32 value exact, and the extra arguments; its JSON output.
Json run_reference(const std::string& script, const std::vector<Eigen::MatrixXd>& inputs,
                   const std::string& extra = "") {
  const test::TempDir dir("conventions");
  std::string cmd =
      "/usr/bin/python3 " + std::string(SCANBENCH_TEST_DATA) + "/../reference/" + script;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const fs::path f = dir / ("in" + std::to_string(k) + ".txt");
    write_rows(f, inputs[k]);
    cmd += " " + f.string();
  }
  cmd += " " + extra + " 2>&1";
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[4096];
    while (std::fgets(buf, sizeof buf, p))
      out += buf;
    pclose(p);
  }
  const Json j = Json::parse(out, nullptr, false);
  EXPECT_TRUE(j.is_object()) << script << " failed (python3-numpy, scripts/setup.sh): " << out;
  return j.is_object() ? j : Json::object();
}

struct Reference {
  double cd_sph = 0, hd_sph = 0, p2f = 0;
};

/// The numpy port's three scores on the same inputs.
Reference reference(const Eigen::Matrix3Xf& gen, const Eigen::Matrix3Xf& ref,
                    const TriangleMesh& mesh, double area) {
  const Json j = run_reference("scoredenoise_eval.py",
                               {gen.cast<double>(), ref.cast<double>(),
                                mesh.vertices.cast<double>(), mesh.faces.cast<double>()},
                               std::to_string(area));
  if (!j.contains("p2f")) return {};
  return {j["cd_sph"].get<double>(), j["hd_sph"].get<double>(), j["p2f"].get<double>()};
}

TEST(ConventionScoreDenoise, EqualsTheNumpyPortOfItsEvaluator) {
  TorusParams torus;
  torus.major_segments = 48;
  torus.minor_segments = 24;
  CubeParams cube;
  cube.resolution = 6;
  const std::pair<const char*, TriangleMesh> shapes[] = {
      {"icosphere(4)", icosphere(4)}, {"torus", make_torus(torus)}, {"cube", make_cube(cube)}};
  std::uint64_t seed = 11;
  for (const auto& [name, mesh] : shapes) {
    const Eigen::Matrix3Xf gen = noisy(mesh, 1500, seed, 0.01),
                           ref = noisy(mesh, 1200, seed + 7, 0.0);
    seed += 100;
    // PyTorch3D 0.5.0's threshold (ScoreDenoise's) and 0.6.2's.
    for (const double area : {1e-5, 5e-3}) {
      const ScoreDenoiseScores s = scoredenoise_scores(gen, ref, mesh, area);
      const Reference r = reference(gen, ref, mesh, area);
      EXPECT_NEAR(s.cd_sph, r.cd_sph, 1e-6 * r.cd_sph) << name;
      EXPECT_NEAR(s.hd_sph, r.hd_sph, 1e-6 * r.hd_sph) << name;
      EXPECT_NEAR(s.p2f, r.p2f, 1e-6 * r.p2f) << name << " min area " << area;
      EXPECT_GT(r.p2f, 0.0) << name;
    }
  }
}

TEST(ConventionScoreDenoise, InvariantToPlaceAndSizeAndTheLargerAreaNeverLowersP2f) {
  const TriangleMesh mesh = icosphere(4);
  const Eigen::Matrix3Xf gen = noisy(mesh, 2000, 5, 0.02), ref = noisy(mesh, 2000, 9, 0.0);
  const ScoreDenoiseScores a = scoredenoise_scores(gen, ref, mesh, 1e-5);
  // The unit sphere undoes a move and a scaling of everything (up to float rounding).
  TriangleMesh moved = mesh;
  const Eigen::Vector3f t(3.0f, -1.0f, 0.5f);
  moved.vertices = (mesh.vertices * 4.0f).colwise() + t;
  const ScoreDenoiseScores b =
      scoredenoise_scores((gen * 4.0f).colwise() + t, (ref * 4.0f).colwise() + t, moved, 1e-5);
  EXPECT_NEAR(b.cd_sph, a.cd_sph, 1e-5 * a.cd_sph);
  EXPECT_NEAR(b.hd_sph, a.hd_sph, 1e-5 * a.hd_sph);
  EXPECT_NEAR(b.p2f, a.p2f, 1e-5 * a.p2f);
  // PyTorch3D >= 0.6.2 measures a face below 5e-3 by its edges, never nearer than its plane:
  // on this mesh (5,120 faces of about 2.5e-3 in the unit sphere) p2f grows.
  const ScoreDenoiseScores c = scoredenoise_scores(gen, ref, mesh, 5e-3);
  EXPECT_GT(c.p2f, a.p2f * 1.01);
  EXPECT_EQ(c.cd_sph, a.cd_sph);
  // A cloud on the reference itself: 0 Chamfer; points on the mesh's vertices: p2f 0 one way.
  EXPECT_EQ(scoredenoise_scores(ref, ref, mesh, 1e-5).cd_sph, 0.0);
  EXPECT_THROW(scoredenoise_scores(Eigen::Matrix3Xf(3, 0), ref, mesh, 1e-5), InputError);
}

TEST(ConventionScoreDenoise, TheMetricPrintsTheScaleOfThePapers) {
  const TriangleMesh mesh = icosphere(3);
  GroundTruth gt(mesh, 3);
  PointCloud out;
  out.positions = noisy(mesh, 800, 21, 0.01);
  RunContext ctx(1);
  const Json r = evaluate(gt, out, nullptr, {"convention.scoredenoise"}, Json::object(), ctx);
  const ScoreDenoiseScores s =
      scoredenoise_scores(out.positions, gt.surface_samples(800).positions, mesh, 1e-5);
  EXPECT_EQ(r["sd_cd_sph_x1e4"].get<double>(), s.cd_sph * 1e4);
  EXPECT_EQ(r["sd_p2f_x1e4"].get<double>(), s.p2f * 1e4);
  EXPECT_EQ(r["sd_hd_sph"].get<double>(), s.hd_sph);
  EXPECT_EQ(r["sd_reference_points"].get<long>(), 800);
  const Json r2 = evaluate(gt, out, nullptr, {"convention.scoredenoise"},
                           Json{{"convention.scoredenoise", {{"reference_points", 300}}}}, ctx);
  EXPECT_EQ(r2["sd_reference_points"].get<long>(), 300);
}

TEST(ConventionDsr, EqualsTheNumpyPortOfItsEvaluator) {
  // A "reconstruction" per shape: its vertices moved by N(0, 0.01); its surface samples with
  // their face normals against the shape's own samples with theirs.
  TorusParams torus;
  torus.major_segments = 32;
  torus.minor_segments = 16;
  CubeParams cube;
  cube.resolution = 4;
  const std::pair<const char*, TriangleMesh> shapes[] = {
      {"icosphere(3)", icosphere(3)}, {"torus", make_torus(torus)}, {"cube", make_cube(cube)}};
  std::uint64_t seed = 5;
  for (const auto& [name, mesh] : shapes) {
    TriangleMesh rec = mesh;
    Rng rng(seed);
    for (Eigen::Index i = 0; i < rec.vertices.size(); ++i)
      rec.vertices.data()[i] += static_cast<float>(rng.normal(0.0, 0.01));
    const PointCloud pred = sample_surface(rec, 1500, seed + 1),
                     tgt = sample_surface(mesh, 1200, seed + 2);
    seed += 10;
    const DsrScores s = dsr_scores(pred, tgt);
    const Json r =
        run_reference("dsr_eval.py", {pred.positions.cast<double>(), pred.normals.cast<double>(),
                                      tgt.positions.cast<double>(), tgt.normals.cast<double>()});
    ASSERT_TRUE(r.contains("Chamfer")) << name;
    const double scale = s.diag / 100.0;
    const std::pair<double, const char*> pairs[] = {
        {s.chamfer, "Chamfer"},     {s.cd_gt_r, "CD_gt->r"}, {s.cd_r_gt, "CD_r->gt"},
        {s.hausdorff, "Hausdorff"}, {s.hd_gt_r, "HD_gt->r"}, {s.hd_r_gt, "HD_r->gt"}};
    for (const auto& [mine, key] : pairs)
      EXPECT_NEAR(mine / scale, r[key].get<double>(), 1e-6 * r[key].get<double>())
          << name << " " << key;
    EXPECT_NEAR(s.normal_consistency, r["Normal Consistency"].get<double>(), 1e-9) << name;
    EXPECT_GT(s.chamfer, 0.0);
    EXPECT_LT(s.normal_consistency, 1.0);
  }
}

TEST(ConventionDsr, TheMetricScoresMeshOutputsAtTheTablesScale) {
  const TriangleMesh mesh = icosphere(3);
  GroundTruth gt(mesh, 3);
  RunContext ctx(1);
  const Json params = {{"convention.dsr", {{"reference_points", 2000}}}};
  // The ground truth itself as the output: a small Chamfer (sampling only), normals agreeing.
  const Json same = evaluate_mesh(gt, mesh, nullptr, {"convention.dsr"}, params, ctx, 2000);
  EXPECT_LT(same["dsr_chamfer_x1e2"].get<double>(), 2.0) << same.dump();
  EXPECT_GT(same["dsr_normal_consistency"].get<double>(), 0.99);
  EXPECT_EQ(
      same["dsr_hausdorff_x1e2"].get<double>(),
      std::max(same["dsr_hd_gt_r_x1e2"].get<double>(), same["dsr_hd_r_gt_x1e2"].get<double>()));
  EXPECT_NEAR(
      same["dsr_chamfer_x1e2"].get<double>(),
      0.5 * (same["dsr_cd_gt_r_x1e2"].get<double>() + same["dsr_cd_r_gt_x1e2"].get<double>()),
      1e-12);
  // A sphere of radius 1.05 against the unit sphere with dense ground-truth points (100,000: a
  // mean lateral spacing of about 0.006): output samples lie about 0.05 from the nearest, over
  // diag / 100 = 2 sqrt(3) / 100 (the samples' box is all but the unit sphere's).
  const Json big =
      evaluate_mesh(gt, icosphere(3, 1.05f), nullptr, {"convention.dsr"},
                    Json{{"convention.dsr", {{"reference_points", 100000}}}}, ctx, 2000);
  EXPECT_NEAR(big["dsr_cd_r_gt_x1e2"].get<double>(), 0.05 / (2 * std::sqrt(3.0) / 100), 0.03);
  // Point outputs are not its kind.
  PointCloud pts = sample_surface(mesh, 500, 1);
  const Json r = evaluate(gt, pts, nullptr, {}, params, ctx);
  EXPECT_TRUE(r["skipped"].contains("convention.dsr"));
}

}  // namespace
}  // namespace scanbench::metrics
