// The published evaluators' conventions (metrics/conventions.h) against the evaluators' own
// code: ScoreDenoise's scores against tests/reference/scoredenoise_eval.py, a line-by-line numpy
// port of score-denoise's models/utils.py and PyTorch3D 0.5.0's chamfer_distance and
// point_mesh_face_distance (brute force), on three shapes and both of PyTorch3D's triangle-area
// thresholds; the identities the convention implies (invariance to where and how large the
// shape is; the larger threshold never lowers p2f); the dsr-benchmark's point scores against
// tests/reference/dsr_eval.py (its dsrb/eval.py, brute force); PD-Flow's against
// tests/reference/pdflow_eval.py (its eval/evaluation.py with sklearn); Tanks and Temples' against
// tests/reference/tnt_eval.py (the toolbox's steps on Debian's python3-open3d); DTU's against
// tests/reference/dtu_eval.py (DTUeval-python's eval.py with sklearn); the metrics through the
// registry and every metric's convention mark.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/metrics/conventions.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"
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

/// Three shapes for the reference comparisons: a sphere, a torus and a cube.
std::vector<std::pair<const char*, TriangleMesh>> three_shapes() {
  TorusParams torus;
  torus.major_segments = 48;
  torus.minor_segments = 24;
  CubeParams cube;
  cube.resolution = 6;
  return {{"icosphere(4)", icosphere(4)}, {"torus", make_torus(torus)}, {"cube", make_cube(cube)}};
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
  std::uint64_t seed = 11;
  for (const auto& [name, mesh] : three_shapes()) {
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

/// The generalized winding number of a closed mesh at q (van Oosterom and Strackee's solid
/// angle of each face, summed, over 4 pi): about 1 inside, 0 outside. The oracle of contains().
double winding_number(const TriangleMesh& m, const Eigen::Vector3d& q) {
  double w = 0.0;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.vertices.col(m.faces(0, f)).cast<double>() - q,
                          b = m.vertices.col(m.faces(1, f)).cast<double>() - q,
                          c = m.vertices.col(m.faces(2, f)).cast<double>() - q;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    w += 2.0 * std::atan2(a.dot(b.cross(c)),
                          la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return w / (4.0 * M_PI);
}

TEST(ConventionDsr, ContainsAgreesWithTheWindingNumber) {
  TorusParams torus;
  torus.major_segments = 32;
  torus.minor_segments = 16;
  CubeParams cube;
  cube.resolution = 3;
  const std::pair<const char*, TriangleMesh> shapes[] = {
      {"icosphere(3)", icosphere(3)}, {"torus", make_torus(torus)}, {"cube", make_cube(cube)}};
  for (const auto& [name, mesh] : shapes) {
    GroundTruth gt(mesh, 3);
    ASSERT_TRUE(gt.closed()) << name;
    // Queries in the box grown by 20 %, and on grid lines through vertices (rays along z through
    // shared edges and vertices).
    const BoundingBox box = mesh.bbox();
    Rng rng(7);
    Eigen::Matrix3Xf q(3, 3000);
    for (Eigen::Index i = 0; i < q.cols(); ++i)
      for (int a = 0; a < 3; ++a)
        q(a, i) = static_cast<float>(
            rng.uniform(1.2 * box.min(a) - 0.2 * box.max(a), 1.2 * box.max(a) - 0.2 * box.min(a)));
    for (Eigen::Index i = 0; i < 300 && i < mesh.num_vertices(); ++i) {
      q.col(i) = mesh.vertices.col(i);
      q(2, i) = static_cast<float>(rng.uniform(box.min(2), box.max(2)));
    }
    const std::vector<std::uint8_t> in = gt.contains(q);
    int inside = 0, checked = 0;
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      const Eigen::Vector3d p = q.col(i).cast<double>();
      if (gt.closest_point(q.col(i)).distance < 1e-4) continue;  // on the surface: either
      const double w = winding_number(mesh, p);
      ++checked;
      inside += in[static_cast<std::size_t>(i)];
      EXPECT_EQ(in[static_cast<std::size_t>(i)] != 0, w > 0.5)
          << name << " at " << p.transpose() << " winding " << w;
    }
    EXPECT_GT(inside, checked / 10) << name;
    EXPECT_LT(inside, checked) << name;
  }
}

TEST(ConventionDsr, IouOfTheSameQueriesOnBothMeshes) {
  const TriangleMesh mesh = icosphere(3);
  GroundTruth gt(mesh, 3);
  RunContext ctx(1);
  const Json params = {{"convention.dsr", {{"reference_points", 2000}, {"iou_points", 20000}}}};
  // Itself: 1. Moved out of the query box: 0. A larger sphere: the queries' own ratio.
  EXPECT_EQ(evaluate_mesh(gt, mesh, nullptr, {"convention.dsr"}, params, ctx, 2000)["dsr_iou"],
            1.0);
  TriangleMesh away = mesh;
  away.vertices.array() += 5.0f;
  EXPECT_EQ(evaluate_mesh(gt, away, nullptr, {"convention.dsr"}, params, ctx, 2000)["dsr_iou"],
            0.0);
  const TriangleMesh big = icosphere(3, 1.1f);
  const Json r = evaluate_mesh(gt, big, nullptr, {"convention.dsr"}, params, ctx, 2000);
  DsrParams p;
  p.iou_points = 20000;
  const Eigen::Matrix3Xf q = dsr_iou_queries(gt, p);
  ASSERT_EQ(q.cols(), 20000);
  GroundTruth big_gt(big, 3);
  const std::vector<std::uint8_t> a = big_gt.contains(q), b = gt.contains(q);
  EXPECT_EQ(r["dsr_iou"].get<double>(), occupancy_iou(a, b));
  std::size_t in_small = 0, in_big = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    in_small += b[i];
    in_big += a[i];
    EXPECT_TRUE(a[i] || !b[i]) << "the small sphere is inside the big one";
  }
  EXPECT_DOUBLE_EQ(r["dsr_iou"].get<double>(),
                   static_cast<double>(in_small) / static_cast<double>(in_big));
  // The queries: half in the box grown by 10 %, half within a few sigma of the surface; seeded by
  // the ground truth, so the same for every output.
  const BoundingBox box = mesh.bbox();
  for (Eigen::Index i = 0; i < 10000; ++i)
    for (int k = 0; k < 3; ++k) {
      ASSERT_GE(q(k, i), 1.1f * box.min(k) - 1e-6f);
      ASSERT_LE(q(k, i), 1.1f * box.max(k) + 1e-6f);
    }
  double sq = 0.0;
  for (Eigen::Index i = 10000; i < 20000; ++i)
    sq += std::pow(gt.closest_point(q.col(i)).distance, 2);
  // E|offset|^2 = 3 sigma^2 for an offset N(0, sigma^2 I), sigma = 0.05 diag; the distance to
  // the sphere is about the normal component only: E = sigma^2.
  const double sigma = 0.05 * gt.diagonal();
  EXPECT_NEAR(sq / 10000.0, sigma * sigma, 0.1 * sigma * sigma);
  EXPECT_EQ(q, dsr_iou_queries(gt, p));
  // An open ground truth has no inside: null.
  TriangleMesh open = mesh;
  open.faces.conservativeResize(3, open.faces.cols() - 1);
  GroundTruth open_gt(open, 3);
  EXPECT_TRUE(
      evaluate_mesh(open_gt, mesh, nullptr, {"convention.dsr"}, params, ctx, 2000)["dsr_iou"]
          .is_null());
}

TEST(ConventionPdflow, EqualsThePortOfItsEvaluator) {
  std::uint64_t seed = 31;
  for (const auto& [name, mesh] : three_shapes()) {
    const Eigen::Matrix3Xf pred = noisy(mesh, 1500, seed, 0.01);
    const PointCloud gt = sample_surface(mesh, 1200, seed + 3);
    seed += 100;
    const PdflowScores s = pdflow_scores(pred, gt);
    const Json r = run_reference(
        "pdflow_eval.py",
        {pred.cast<double>(), gt.positions.cast<double>(), gt.normals.cast<double>()});
    ASSERT_TRUE(r.contains("P2S")) << name;
    EXPECT_NEAR(s.cd, r["CD"].get<double>(), 1e-6 * r["CD"].get<double>()) << name;
    EXPECT_NEAR(s.hd, r["HD"].get<double>(), 1e-6 * r["HD"].get<double>()) << name;
    EXPECT_NEAR(s.p2s, r["P2S"].get<double>(), 1e-6 * r["P2S"].get<double>()) << name;
    // The nearest of 16 planes is never farther than the nearest point.
    EXPECT_GT(s.p2s, 0.0);
    EXPECT_LT(s.p2s, s.cd);
  }
}

TEST(ConventionPdflow, TheMetricScoresInTheUnitSphereUnlessAskedNot) {
  const TriangleMesh mesh = icosphere(3, 2.0f);  // radius 2: the unit sphere halves lengths
  GroundTruth gt(mesh, 3);
  PointCloud out;
  out.positions = noisy(mesh, 800, 41, 0.02);
  RunContext ctx(1);
  const Json unit = evaluate(gt, out, nullptr, {"convention.pdflow"}, Json::object(), ctx);
  const Json raw = evaluate(gt, out, nullptr, {"convention.pdflow"},
                            Json{{"convention.pdflow", {{"normalize", false}}}}, ctx);
  const PdflowScores s = pdflow_scores(out.positions, gt.surface_samples(800));
  EXPECT_EQ(raw["pdflow_cd"].get<double>(), s.cd);
  EXPECT_EQ(raw["pdflow_p2s"].get<double>(), s.p2s);
  EXPECT_EQ(raw["pdflow_hd"].get<double>(), s.hd);
  EXPECT_NEAR(unit["pdflow_cd"].get<double>(), raw["pdflow_cd"].get<double>() / 2.0,
              0.01 * unit["pdflow_cd"].get<double>());
  EXPECT_EQ(unit["pdflow_reference_points"].get<long>(), 800);
}

/// Runs a command, its standard output and error.
std::string run_command(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen((cmd + " 2>&1").c_str(), "r")) {
    char buf[4096];
    while (std::fgets(buf, sizeof buf, p))
      out += buf;
    pclose(p);
  }
  return out;
}

/// What uniformity.cpp wrote in `dir`/eval/uniformity: the radii, the mapped points and the disks.
UniformityDisks read_reference_disks(const fs::path& dir) {
  UniformityDisks r;
  std::ifstream radius(dir / "eval/uniformity/pc_radius.txt");
  for (double& x : r.radius)
    radius >> x;
  std::ifstream mapped(dir / "eval/uniformity/pc_point2mesh_distance.txt");
  std::vector<double> v;
  for (double x[7]; mapped >> x[0] >> x[1] >> x[2] >> x[3] >> x[4] >> x[5] >> x[6];)
    v.insert(v.end(), {x[4], x[5], x[6]});
  r.mapped = Eigen::Map<Eigen::Matrix3Xd>(v.data(), 3, static_cast<Eigen::Index>(v.size() / 3));
  std::ifstream disks(dir / "eval/uniformity/pc_disk_idx.txt");
  for (std::string line; std::getline(disks, line);) {
    std::istringstream in(line.substr(line.find(':') + 1));
    r.members.emplace_back();
    for (Eigen::Index i; in >> i;)
      r.members.back().push_back(i);
  }
  return r;
}

// PU-GAN's uniformity: scanbench's disks against PD-Flow's own uniformity.cpp (built from
// tests/reference/pdflow_uniformity, given the same centres through its centres-file argument),
// disk by disk; then the five values against tests/reference/pdflow_uniform.py (uniform.py) run
// on the original's files.
TEST(ConventionPdflow, UniformityEqualsTheOriginalProgramAndItsPort) {
  std::uint64_t seed = 61;
  for (const auto& [name, mesh] : three_shapes()) {
    const Eigen::Matrix3Xd points = noisy(mesh, 3000, seed, 0.005).cast<double>();
    const Eigen::Matrix3Xd vertices = mesh.vertices.cast<double>();
    Rng rng(seed);
    seed += 100;
    const std::vector<UniformityCentre> centres =
        pdflow_uniformity_centres(vertices, mesh.faces, 60, rng);
    const UniformityDisks disks = pdflow_uniformity_disks(points, vertices, mesh.faces, centres);
    const std::array<double, 5> u = pdflow_uniformity_scores(disks);

    const test::TempDir dir("uniformity");
    fs::create_directories(dir / "eval/uniformity");
    {
      std::ofstream off(dir / "mesh.off"), xyz(dir / "pred.xyz"), at(dir / "centres.txt");
      off.precision(17);
      xyz.precision(17);
      at.precision(17);
      off << "OFF\n" << vertices.cols() << " " << mesh.faces.cols() << " 0\n";
      for (Eigen::Index i = 0; i < vertices.cols(); ++i)
        off << vertices(0, i) << " " << vertices(1, i) << " " << vertices(2, i) << "\n";
      for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f)
        off << "3 " << mesh.faces(0, f) << " " << mesh.faces(1, f) << " " << mesh.faces(2, f)
            << "\n";
      for (Eigen::Index i = 0; i < points.cols(); ++i)
        xyz << points(0, i) << " " << points(1, i) << " " << points(2, i) << "\n";
      for (const UniformityCentre& c : centres)
        at << c.face << " " << c.barycentric(0) << " " << c.barycentric(1) << " "
           << c.barycentric(2) << "\n";
    }
    const std::string log =
        run_command("cd " + dir.path.string() + " && " + SCANBENCH_PDFLOW_UNIFORMITY +
                    " mesh.off pred.xyz centres.txt");
    const UniformityDisks ref = read_reference_disks(dir.path);
    ASSERT_EQ(ref.members.size(), disks.members.size()) << name << ": " << log;
    for (std::size_t k = 0; k < 5; ++k)  // floats, written with 9 digits
      EXPECT_EQ(disks.radius[k], static_cast<float>(ref.radius[k])) << name;
    ASSERT_EQ(ref.mapped.cols(), points.cols()) << name;
    EXPECT_EQ((disks.mapped - ref.mapped).cwiseAbs().maxCoeff(), 0.0) << name;
    std::size_t differ = 0, points_in = 0, scored = 0;
    for (std::size_t d = 0; d < ref.members.size(); ++d) {
      differ += disks.members[d] != ref.members[d];
      points_in += ref.members[d].size();
      scored += ref.members[d].size() >= 5;
    }
    EXPECT_EQ(differ, 0u) << name;
    EXPECT_GT(scored, ref.members.size() / 2) << name;  // the comparison covers most disks

    const std::string py = "/usr/bin/python3 " + std::string(SCANBENCH_TEST_DATA) +
                           "/../reference/pdflow_uniform.py " + dir.path.string();
    const std::string out = run_command(py);
    const Json r = Json::parse(out, nullptr, false);
    ASSERT_TRUE(r.is_object() && r.contains("uniformity")) << name << ": " << out;
    double worst = 0.0;
    for (std::size_t k = 0; k < 5; ++k) {
      const double want = r["uniformity"][k].get<double>();
      EXPECT_GT(want, 0.0) << name;
      EXPECT_NEAR(u[k], want, 1e-6 * want) << name << " share " << kUniformityShares[k];
      worst = std::max(worst, std::abs(u[k] - want) / want);
    }
    std::printf("[ uniformity ] %s: %zu points in %zu disks (%zu scored); %s; relative %.2g\n",
                name, points_in, ref.members.size(), scored, r["uniformity"].dump().c_str(), worst);
  }
}

TEST(ConventionPdflow, UniformityIsSeededFromTheRunAndTheSameAtAnyThreadCount) {
  const TriangleMesh mesh = icosphere(3, 2.0f);  // radius 2: the unit sphere halves lengths
  GroundTruth gt(mesh, 3);
  PointCloud out;
  out.positions = noisy(mesh, 2000, 43, 0.01);
  const Json raw_params = {
      {"convention.pdflow",
       {{"normalize", false}, {"uniformity", true}, {"uniformity_disks", 200}}}};
  const Json unit_params = {
      {"convention.pdflow", {{"uniformity", true}, {"uniformity_disks", 200}}}};
  RunContext ctx(5);
  const Json raw = evaluate(gt, out, nullptr, {"convention.pdflow"}, raw_params, ctx);
  Json one_thread;
  {
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    RunContext same(5);
    one_thread = evaluate(gt, out, nullptr, {"convention.pdflow"}, raw_params, same);
  }
  RunContext other(6);
  const Json reseeded = evaluate(gt, out, nullptr, {"convention.pdflow"}, raw_params, other);
  const Json unit = evaluate(gt, out, nullptr, {"convention.pdflow"}, unit_params, ctx);

  // The metric in the mesh's frame is the three functions on the centres of "metric.pdflow".
  Rng rng = ctx.rng("metric.pdflow");
  const Eigen::Matrix3Xd v = mesh.vertices.cast<double>();
  const std::array<double, 5> direct = pdflow_uniformity_scores(
      pdflow_uniformity_disks(out.positions.cast<double>(), v, mesh.faces,
                              pdflow_uniformity_centres(v, mesh.faces, 200, rng)));
  for (std::size_t k = 0; k < 5; ++k) {
    const char* key = kUniformityKeys[k];
    ASSERT_TRUE(raw[key].is_number()) << key;
    EXPECT_EQ(raw[key].get<double>(), direct[k]) << key;
    EXPECT_EQ(one_thread[key].get<double>(), raw[key].get<double>()) << key;
    EXPECT_NE(reseeded[key].get<double>(), raw[key].get<double>()) << key;
    // A length: the unit sphere (radius 2 -> 1) halves it, up to disks whose members move.
    EXPECT_NEAR(unit[key].get<double>(), raw[key].get<double>() / 2.0,
                0.05 * unit[key].get<double>())
        << key;
  }
}

TEST(ConventionPdflow, UniformityIsNullWhenOffAndAbsentOnAPointGroundTruth) {
  const TriangleMesh mesh = icosphere(2);
  GroundTruth gt(mesh, 3);
  PointCloud out;
  out.positions = noisy(mesh, 500, 47, 0.01);
  RunContext ctx(1);
  const Json off = evaluate(gt, out, nullptr, {"convention.pdflow"}, Json::object(), ctx);
  for (const char* key : kUniformityKeys) {
    ASSERT_TRUE(off.contains(key)) << key;
    EXPECT_TRUE(off[key].is_null()) << key;
  }
  EXPECT_TRUE(off["pdflow_cd"].is_number());
  // A point-cloud ground truth: convention.pdflow is not point-capable, so it is skipped whole.
  const Json points = evaluate_point_truth(gt.surface_samples(800), out, {}, Json::object(), ctx);
  for (const char* key : kUniformityKeys)
    EXPECT_FALSE(points.contains(key)) << key;
  EXPECT_TRUE(points["skipped"].contains("convention.pdflow")) << points["skipped"].dump();
}

TEST(ConventionTnt, EqualsTheToolboxOnOpen3d) {
  std::uint64_t seed = 51;
  for (const auto& [name, mesh] : three_shapes()) {
    const Eigen::Matrix3Xf out = noisy(mesh, 3000, seed, 0.01),
                           truth = noisy(mesh, 4000, seed + 5, 0.0);
    seed += 100;
    const double tau = 0.015, voxel = 0.0075;
    const TntScores s = tnt_scores(out, truth, tau, voxel);
    const Json r = run_reference("tnt_eval.py", {out.cast<double>(), truth.cast<double>()},
                                 fmt::format("{:.17g} {:.17g}", tau, voxel));
    ASSERT_TRUE(r.contains("fscore")) << name << " (python3-open3d, scripts/setup.sh)";
    // The downsampling merges points, and the same cells as Open3D's.
    EXPECT_LT(s.precision_distances.size(), 3000u) << name;
    EXPECT_EQ(s.precision_distances.size(), r["source_points"].get<std::size_t>()) << name;
    EXPECT_EQ(s.recall_distances.size(), r["target_points"].get<std::size_t>()) << name;
    EXPECT_NEAR(s.precision, r["precision"].get<double>(), 1e-12) << name;
    EXPECT_NEAR(s.recall, r["recall"].get<double>(), 1e-12) << name;
    EXPECT_NEAR(s.fscore, r["fscore"].get<double>(), 1e-12) << name;
    EXPECT_GT(s.precision, 0.05) << name;
    EXPECT_LT(s.precision, 0.95) << name;
  }
}

TEST(ConventionTnt, VoxelMeansAndTheMetricsKeys) {
  // Two points in one cell average; a third in its own cell stays.
  Eigen::Matrix3Xd p(3, 3);
  p << 0.0, 0.2, 1.0,  //
      0.0, 0.1, 1.0,   //
      0.0, 0.2, 1.0;
  const Eigen::Matrix3Xd d = voxel_down_sample(p, 0.5);
  ASSERT_EQ(d.cols(), 2);
  EXPECT_EQ(d.col(0), Eigen::Vector3d(0.1, 0.05, 0.1));
  EXPECT_EQ(d.col(1), Eigen::Vector3d(1.0, 1.0, 1.0));
  const TriangleMesh mesh = icosphere(3);
  GroundTruth gt(mesh, 3);
  PointCloud out = sample_surface(mesh, 2000, 3);
  RunContext ctx(1);
  const Json r = evaluate(gt, out, nullptr, {"convention.tnt"},
                          Json{{"convention.tnt", {{"reference_points", 20000}}}}, ctx);
  EXPECT_NEAR(r["tnt_tau_rel"].get<double>(), 0.005, 1e-12);
  EXPECT_GT(r["tnt_precision"].get<double>(), 0.99);  // samples on the surface itself
  const Json& h = r["histograms"]["tnt_precision"];
  EXPECT_EQ(h["bins"].get<int>(), 500);
  EXPECT_EQ(h["unit"].get<std::string>(), "tau");
}

TEST(ConventionDtu, EqualsThePortOfItsEvaluator) {
  std::uint64_t seed = 71;
  for (const auto& [name, mesh] : three_shapes()) {
    const Eigen::Matrix3Xf out = noisy(mesh, 2500, seed, 0.01),
                           truth = noisy(mesh, 3000, seed + 5, 0.0);
    seed += 100;
    const double density = 0.04, max_dist = 0.02;
    const DtuScores s = dtu_scores(out, truth, density, max_dist);
    const Json r = run_reference("dtu_eval.py", {out.cast<double>(), truth.cast<double>()},
                                 fmt::format("{:.17g} {:.17g}", density, max_dist));
    ASSERT_TRUE(r.contains("over_all")) << name << " (python3-sklearn, scripts/setup.sh)";
    EXPECT_LT(s.thinned_points, 2500) << name;
    EXPECT_EQ(s.thinned_points, r["down_points"].get<Eigen::Index>()) << name;
    EXPECT_NEAR(s.accuracy, r["mean_d2s"].get<double>(), 1e-6 * s.accuracy) << name;
    EXPECT_NEAR(s.completeness, r["mean_s2d"].get<double>(), 1e-6 * s.completeness) << name;
    EXPECT_NEAR(s.overall, r["over_all"].get<double>(), 1e-6 * s.overall) << name;
  }
}

TEST(ConventionDtu, ThinningKeepsNoTwoPointsWithinTheDensityAndTheMetricIsSeeded) {
  const TriangleMesh mesh = icosphere(3);
  const Eigen::Matrix3Xd p = noisy(mesh, 3000, 3, 0.005).cast<double>();
  const std::vector<Eigen::Index> kept = dtu_thin(p, 0.05);
  for (std::size_t a = 0; a < kept.size(); ++a)
    for (std::size_t b = a + 1; b < kept.size(); ++b)
      ASSERT_GT((p.col(kept[a]) - p.col(kept[b])).norm(), 0.05);
  // Every dropped point has a kept point before it within the density.
  std::vector<char> is_kept(3000, 0);
  for (Eigen::Index k : kept)
    is_kept[static_cast<std::size_t>(k)] = 1;
  for (Eigen::Index i = 0; i < 3000; ++i) {
    if (is_kept[static_cast<std::size_t>(i)]) continue;
    bool covered = false;
    for (Eigen::Index k : kept)
      covered = covered || (k < i && (p.col(k) - p.col(i)).norm() <= 0.05);
    ASSERT_TRUE(covered) << i;
  }
  GroundTruth gt(mesh, 3);
  PointCloud out;
  out.positions = p.cast<float>();
  const Json params = {
      {"convention.dtu", {{"reference_points", 5000}, {"downsample_density", 0.01}}}};
  RunContext a(1), b(1), c(2);
  const Json ra = evaluate(gt, out, nullptr, {"convention.dtu"}, params, a);
  EXPECT_EQ(ra, evaluate(gt, out, nullptr, {"convention.dtu"}, params, b));
  EXPECT_NE(ra["dtu_points"],
            evaluate(gt, out, nullptr, {"convention.dtu"}, params, c)["dtu_points"]);
  EXPECT_NEAR(ra["dtu_overall"].get<double>(),
              0.5 * (ra["dtu_accuracy"].get<double>() + ra["dtu_completeness"].get<double>()),
              1e-15);
  // Nothing within max_dist: undefined, so not applicable (and said so).
  PointCloud far;
  far.positions = (p.cast<float>().array() + 10.0f).matrix();
  EXPECT_THROW(evaluate(gt, far, nullptr, {"convention.dtu"}, params, a), NotApplicable);
}

/// ETH3D-style ground truth: four scanners on a ring at distance 3, each with the surface samples
/// facing it (a convex shape's visible side; on the torus, the side facing it).
std::vector<Eth3dScan> ring_scans(const TriangleMesh& mesh, std::uint64_t seed) {
  const PointCloud samples = sample_surface(mesh, 2400, seed);
  std::vector<Eth3dScan> scans(4);
  for (int s = 0; s < 4; ++s) {
    const double a = M_PI / 2.0 * s + 0.3;
    scans[static_cast<std::size_t>(s)].origin = Eigen::Vector3f(
        static_cast<float>(3.0 * std::cos(a)), static_cast<float>(3.0 * std::sin(a)), 0.7f);
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < samples.size(); ++i)
      if (samples.normals.col(i).dot(scans[static_cast<std::size_t>(s)].origin -
                                     samples.positions.col(i)) > 0.0f)
        keep.push_back(i);
    Eigen::Matrix3Xf& pts = scans[static_cast<std::size_t>(s)].points;
    pts.resize(3, static_cast<Eigen::Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k)
      pts.col(static_cast<Eigen::Index>(k)) = samples.positions.col(keep[k]);
  }
  return scans;
}

TEST(ConventionEth3d, EqualsThePortOfItsEvaluator) {
  std::uint64_t seed = 91;
  for (const auto& [name, mesh] : three_shapes()) {
    const std::vector<Eth3dScan> scans = ring_scans(mesh, seed);
    // The output: noisy surface points, a few floating in front of the surface (observed free
    // space: inaccurate) and a few deep inside (unobserved).
    Eigen::Matrix3Xf out = noisy(mesh, 400, seed + 1, 0.015);
    Rng rng(seed + 2);
    for (Eigen::Index i = 0; i < 40; ++i)
      out.col(i) *= static_cast<float>(1.25 + 0.1 * rng.uniform());
    for (Eigen::Index i = 40; i < 60; ++i)
      out.col(i) *= 0.3f;
    seed += 100;
    const double tol = 0.02, voxel = 0.1, beam = 0.03, div = 0.011;
    const Eth3dScores s = eth3d_scores(out, scans, tol, voxel, beam, div);
    Eigen::MatrixXd rows(4, 0), origins(3, 4);
    for (std::size_t k = 0; k < scans.size(); ++k) {
      const Eigen::Index n = rows.cols();
      rows.conservativeResize(4, n + scans[k].points.cols());
      rows.block(0, n, 1, scans[k].points.cols()).setConstant(static_cast<double>(k));
      rows.block(1, n, 3, scans[k].points.cols()) = scans[k].points.cast<double>();
      origins.col(static_cast<Eigen::Index>(k)) = scans[k].origin.cast<double>();
    }
    const Json r =
        run_reference("eth3d_eval.py", {out.cast<double>(), rows, origins},
                      fmt::format("{:.17g} {:.17g} {:.17g} {:.17g}", tol, voxel, beam, div));
    ASSERT_TRUE(r.contains("f1")) << name;
    EXPECT_EQ(s.accurate, r["accurate"].get<Eigen::Index>()) << name;
    EXPECT_EQ(s.inaccurate, r["inaccurate"].get<Eigen::Index>()) << name;
    EXPECT_EQ(s.unobserved, r["unobserved"].get<Eigen::Index>()) << name;
    EXPECT_NEAR(s.accuracy, r["accuracy"].get<double>(), 1e-6 * s.accuracy) << name;
    EXPECT_NEAR(s.completeness, r["completeness"].get<double>(), 1e-6 * s.completeness) << name;
    EXPECT_NEAR(s.f1, r["f1"].get<double>(), 1e-6 * s.f1) << name;
    // Every kind occurs: the floating points are seen through, the inner ones never seen.
    EXPECT_GT(s.inaccurate, 20) << name;
    EXPECT_GE(s.unobserved, 15) << name;
    EXPECT_GT(s.accurate, 20) << name;
  }
}

TEST(ConventionEth3d, UnobservedPointsCostNothing) {
  const TriangleMesh mesh = icosphere(4);
  const std::vector<Eth3dScan> scans = ring_scans(mesh, 5);
  Eigen::Matrix3Xf out = sample_surface(mesh, 1500, 6).positions;
  const Eth3dScores a = eth3d_scores(out, scans, 0.05, 0.1, 0.06, 0.011);
  // Points deep inside the sphere: no beam reaches them, so accuracy is unchanged.
  Eigen::Matrix3Xf more(3, out.cols() + 200);
  more << out, 0.2f * sample_surface(mesh, 200, 7).positions;
  const Eth3dScores b = eth3d_scores(more, scans, 0.05, 0.1, 0.06, 0.011);
  EXPECT_EQ(b.unobserved, a.unobserved + 200);
  EXPECT_EQ(b.accuracy, a.accuracy);
  // The same points floating outside in front of the scanners: seen through, inaccurate.
  more.rightCols(200) = 1.3f * sample_surface(mesh, 200, 7).positions;
  const Eth3dScores c = eth3d_scores(more, scans, 0.05, 0.1, 0.06, 0.011);
  EXPECT_LT(c.accuracy, a.accuracy);
  EXPECT_GT(c.inaccurate, a.inaccurate + 50)
      << a.accurate << " " << a.inaccurate << " " << a.unobserved << " | " << c.accurate << " "
      << c.inaccurate << " " << c.unobserved;
}

TEST(Conventions, EveryMetricNamesAKnownConventionAndListsIt) {
  for (const auto& e : registry().entries()) {
    const Convention& c = convention(e.fn.convention);
    EXPECT_FALSE(c.source.empty()) << e.name;
    Json j = Json::object();
    e.fn.describe(j);
    EXPECT_EQ(j["convention"]["name"], c.name) << e.name;
    for (const auto& k : e.fn.keys)
      EXPECT_EQ(j["key_conventions"][k.key], c.name) << e.name << " " << k.key;
    // A convention.* metric follows a published evaluator; the others scanbench's own.
    EXPECT_EQ(e.name.rfind("convention.", 0) == 0, c.name != "scanbench") << e.name;
  }
  EXPECT_EQ(key_convention("sd_cd_sph_x1e4"), std::optional<std::string>("scoredenoise"));
  EXPECT_EQ(key_convention("chamfer_rel"), std::optional<std::string>("scanbench"));
  EXPECT_EQ(key_convention("no_such_key"), std::nullopt);
  EXPECT_THROW(convention("nope"), Error);
}

}  // namespace
}  // namespace scanbench::metrics
