// The published evaluators' conventions (metrics/conventions.h) against the evaluators' own
// code: ScoreDenoise's scores against tests/reference/scoredenoise_eval.py, a line-by-line numpy
// port of score-denoise's models/utils.py and PyTorch3D 0.5.0's chamfer_distance and
// point_mesh_face_distance (brute force), on three shapes and both of PyTorch3D's triangle-area
// thresholds; the identities the convention implies (invariance to where and how large the
// shape is; the larger threshold never lowers p2f); the metric through the registry.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

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

struct Reference {
  double cd_sph = 0, hd_sph = 0, p2f = 0;
};

/// The numpy port's three scores on the same inputs (float32 values written exactly).
Reference reference(const Eigen::Matrix3Xf& gen, const Eigen::Matrix3Xf& ref,
                    const TriangleMesh& mesh, double area) {
  const test::TempDir dir("conventions");
  write_rows(dir / "gen.txt", gen.cast<double>());
  write_rows(dir / "ref.txt", ref.cast<double>());
  write_rows(dir / "verts.txt", mesh.vertices.cast<double>());
  write_rows(dir / "faces.txt", mesh.faces.cast<double>());
  const std::string script =
      std::string(SCANBENCH_TEST_DATA) + "/../reference/scoredenoise_eval.py";
  const std::string cmd = "/usr/bin/python3 " + script + " " + (dir / "gen.txt").string() + " " +
                          (dir / "ref.txt").string() + " " + (dir / "verts.txt").string() + " " +
                          (dir / "faces.txt").string() + " " + std::to_string(area) + " 2>&1";
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[4096];
    while (std::fgets(buf, sizeof buf, p))
      out += buf;
    pclose(p);
  }
  const Json j = Json::parse(out, nullptr, false);
  EXPECT_TRUE(j.is_object()) << "the numpy reference failed (python3-numpy, scripts/setup.sh): "
                             << out;
  if (!j.is_object()) return {};
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

}  // namespace
}  // namespace scanbench::metrics
