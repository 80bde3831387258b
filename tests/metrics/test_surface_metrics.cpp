// Surface metrics of mesh outputs (surface.h, mesh_facts.h) on analytic cases, and the declared
// direction of every key every registered metric can emit (registry.h).
#include <gtest/gtest.h>

#include <array>
#include <set>

#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/mesh_facts.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface_sampling.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

using testing::grid;
using testing::icosphere;

const GroundTruthOptions kCoarseSurface{1.0 / 128.0, 3.0f};

// A sphere of radius 1 + d scored against the unit sphere (both icospheres of level 5, the outer
// one the inner one scaled): every face of the outer mesh lies d h outside the matching inner
// face, h = the distance of the face planes from the centre (1 - 1.6e-4 at level 5), so accuracy,
// completeness, Hausdorff and the input distance of points on the unit sphere are d up to h and
// the edge regions; the face normals agree.
TEST(SurfaceMetrics, SphereOfRadiusOnePlusDAgainstTheUnitSphere) {
  const double d = 0.01;
  const TriangleMesh unit = icosphere(5, 1.0f);
  const TriangleMesh outer = icosphere(5, static_cast<float>(1.0 + d));
  GroundTruth gt(unit, 3, kCoarseSurface);
  PointCloud scan = sample_surface(unit, 5000, 17);
  scan.properties.clear();
  RunContext ctx(5);
  const Json r = evaluate_mesh(gt, outer, &scan, {}, Json::object(), ctx);
  EXPECT_NEAR(r["accuracy"].get<double>(), d, 0.01 * d);
  EXPECT_NEAR(r["completeness"].get<double>(), d, 0.001 * d);
  EXPECT_NEAR(r["chamfer"].get<double>(), 2 * d, 0.02 * d);
  EXPECT_NEAR(r["hausdorff"].get<double>(), d, 0.03 * d);
  EXPECT_NEAR(r["accuracy_rel"].get<double>(), d / gt.diagonal(), 0.01 * d);
  EXPECT_EQ(r["precision"].get<double>(), 1.0);  // d < tau = 0.005 x diagonal = 0.017
  EXPECT_EQ(r["recall"].get<double>(), 1.0);
  EXPECT_EQ(r["fscore"].get<double>(), 1.0);
  EXPECT_EQ(r["chamfer_samples"].get<int>(), 100000);  // the point metric's sample count
  EXPECT_EQ(r["output_mesh_samples"].get<int>(), 100000);
  // Normal consistency: the same faces, ~0 degrees (samples whose closest point lies on an edge,
  // about 3%, may take the neighbour's normal, 1.9 degrees apart).
  EXPECT_LT(r["normal_angle_mean_deg"].get<double>(), 0.1);
  EXPECT_EQ(r["normal_pgp5"].get<double>(), 1.0);
  // GPS sec. 7.2 error: points on the unit sphere are d from the output.
  EXPECT_NEAR(r["input_distance_mean"].get<double>(), d, 0.001 * d);
  EXPECT_NEAR(r["input_distance_rms"].get<double>(), d, 0.001 * d);
  EXPECT_NEAR(r["input_distance_max"].get<double>(), d, 0.001 * d);
  EXPECT_EQ(r["input_distance_points"].get<int>(), 5000);
  EXPECT_EQ(r["histograms"]["input_distance"]["count"].get<int>(), 5000);
  EXPECT_NEAR(r["volume_iou"].get<double>(), 1.0 / ((1 + d) * (1 + d) * (1 + d)), 0.01);
  EXPECT_EQ(r["mesh_vertices"].get<int>(), outer.num_vertices());
  EXPECT_EQ(r["mesh_faces"].get<int>(), 20480);
  EXPECT_TRUE(r["mesh_closed"].get<bool>());
  EXPECT_EQ(r["mesh_bytes"].get<int>(), 12 * outer.num_vertices() + 12 * 20480);
  // Point metrics do not score a mesh: skipped with the reason.
  for (const char* m : {"accuracy.p2plane", "accuracy.chamfer", "regularity.nn_dist",
                        "normals.angle", "outliers.residue"}) {
    ASSERT_TRUE(r["skipped"].contains(m)) << m;
    EXPECT_NE(r["skipped"][m].get<std::string>().find("this output is a mesh"), std::string::npos);
  }
  EXPECT_FALSE(r.contains("output_points"));
  EXPECT_FALSE(r.contains("p2plane_mean"));

  // A shrunken sphere is scored the same way from inside.
  const Json s = evaluate_mesh(gt, icosphere(5, static_cast<float>(1.0 - d)), &scan,
                               {"surface.chamfer", "surface.input_distance"}, Json::object(), ctx);
  EXPECT_NEAR(s["completeness"].get<double>(), d, 0.002 * d);
  EXPECT_NEAR(s["input_distance_mean"].get<double>(), d, 0.002 * d);
}

TEST(SurfaceMetrics, IndependentOfThreadCountAndSeeded) {
  const TriangleMesh unit = icosphere(3, 1.0f);
  const TriangleMesh out = icosphere(2, 1.02f);
  PointCloud scan = sample_surface(unit, 2000, 3);
  scan.properties.clear();
  std::string dumps[3];
  for (int t : {1, 2, 3}) {
    GroundTruth gt(unit, 1, kCoarseSurface);
    RunContext ctx(t == 3 ? 8 : 7, t == 3 ? 1 : t);
    dumps[t - 1] = evaluate_mesh(gt, out, &scan, {}, Json::object(), ctx, 20000).dump();
  }
  EXPECT_EQ(dumps[0], dumps[1]);
  EXPECT_NE(dumps[0], dumps[2]);  // another seed draws other output samples
}

TEST(SurfaceMetrics, SkipsAndRefusals) {
  const TriangleMesh m = icosphere(2);
  GroundTruth gt(m, 1, kCoarseSurface);
  PointCloud pts = sample_surface(m, 500, 5);
  pts.properties.clear();
  RunContext ctx(1);
  // Mesh metrics on points: skipped with the reason, also when named.
  const Json r =
      evaluate(gt, pts, nullptr, {"surface.chamfer", "accuracy.p2plane"}, Json::object(), ctx);
  EXPECT_TRUE(r.contains("p2plane_mean"));
  EXPECT_EQ(r["skipped"]["surface.chamfer"].get<std::string>(),
            "scores mesh; this output is points");
  // Named but not applicable (no scan): an error, as for the point metrics.
  EXPECT_THROW(evaluate_mesh(gt, m, nullptr, {"surface.input_distance"}, Json::object(), ctx, 100),
               NotApplicable);
  const Json all = evaluate_mesh(gt, m, nullptr, {}, Json::object(), ctx, 100);
  EXPECT_TRUE(all["skipped"].contains("surface.input_distance"));
  // A mesh without area is refused with a clear message.
  TriangleMesh flat = m;
  flat.vertices.row(2).setZero();
  flat.vertices.row(1).setZero();
  EXPECT_THROW(evaluate_mesh(gt, flat, nullptr, {}, Json::object(), ctx, 100), InputError);
}

// Every key any metric can emit has a declared direction, and every declared key is emitted.
TEST(MetricDirections, EveryEmittedKeyIsDeclaredAndEveryDeclaredKeyEmitted) {
  const TriangleMesh m = icosphere(2);
  GroundTruth gt(m, 1, kCoarseSurface);
  PointCloud pts = sample_surface(m, 800, 5);
  pts.properties.clear();
  PointCloud scan = pts;
  // Clean positions so outliers.residue estimates the noise from the scan.
  scan.properties["clean_x"] = scan.positions.row(0).transpose();
  scan.properties["clean_y"] = scan.positions.row(1).transpose();
  scan.properties["clean_z"] = scan.positions.row(2).transpose().array() + 1e-3f;
  scan.properties["outlier"] = Eigen::VectorXf::Zero(scan.size());
  scan.scan_ids = Eigen::VectorXi::Zero(scan.size());  // one scanner (convention.eth3d)
  scan.sensor_origins = Eigen::Matrix3Xf::Zero(3, 1);
  scan.sensor_origins(0, 0) = 3.0f;
  RunContext ctx(1);
  const Json params = {{"accuracy.chamfer", {{"samples", 1000}}},
                       {"surface.chamfer", {{"samples", 1000}}}};
  const Json rp = evaluate(gt, pts, &scan, {}, params, ctx);
  const Json rm = evaluate_mesh(gt, icosphere(1, 1.01f), &scan, {}, params, ctx, 1000);
  // The mesh metrics, and the sharp-edge metrics (a sphere has no sharp edge).
  EXPECT_TRUE(rp["skipped"].size() == 8u) << rp["skipped"].dump();
  EXPECT_TRUE(rm["skipped"].size() == 12u) << rm["skipped"].dump();  // the point metrics
  // The sharp-edge metrics on a truth that has sharp edges.
  const TriangleMesh cube = make_cube({});
  GroundTruth cgt(cube, 1, kCoarseSurface);
  PointCloud cpts = sample_surface(cube, 800, 5);
  cpts.properties.clear();
  const Json re = evaluate(cgt, cpts, nullptr, {"edges.p2plane", "edges.normals"}, params, ctx);
  // A point-cloud ground truth (the record's gt_points).
  const Json rt = evaluate_point_truth(sample_surface(m, 800, 6), pts, {}, params, ctx);
  std::set<std::string> emitted;
  for (const Json* r : {&rp, &rm, &re, &rt})
    for (const auto& [k, v] : r->items())
      if (!v.is_object()) emitted.insert(k);  // histograms, metric_params, skipped, scoring
  for (const auto& k : emitted)
    EXPECT_TRUE(key_direction(k).has_value()) << k << " has no declared direction";
  std::set<std::string> declared;
  for (const auto& e : registry().entries()) {
    EXPECT_FALSE(e.fn.keys.empty()) << e.name;
    std::set<std::string> own;
    for (const auto& k : e.fn.keys) {
      EXPECT_TRUE(own.insert(k.key).second) << e.name << " declares " << k.key << " twice";
      // A key declared by two metrics (surface.* reuse the point keys) has one direction.
      EXPECT_EQ(key_direction(k.key), k.better) << k.key;
      declared.insert(k.key);
    }
  }
  for (const auto& k : record_keys())
    declared.insert(k.key);
  for (const auto& k : declared)
    EXPECT_TRUE(emitted.count(k)) << k << " is declared but no metric emitted it";
  EXPECT_EQ(registry().entries().size(), 18u);
}

TEST(MetricDirections, KnownKeys) {
  for (const char* k :
       {"fscore", "precision", "recall", "normal_pgp5", "normal_pgp10", "volume_iou"})
    EXPECT_EQ(key_direction(k), Better::Higher) << k;
  for (const char* k :
       {"accuracy", "accuracy_rel", "completeness", "chamfer_rel", "hausdorff", "p2plane_mean_rel",
        "p2plane_p99", "normal_angle_mean_deg", "nn_dist_cv", "outlier_residue",
        "input_distance_rms_rel", "volume_mean_abs_diff", "mesh_nonmanifold_edges"})
    EXPECT_EQ(key_direction(k), Better::Lower) << k;
  for (const char* k :
       {"mesh_vertices", "mesh_faces", "mesh_bytes", "mesh_components", "mesh_boundary_edges",
        "mesh_closed", "chamfer_samples", "output_points", "output_mesh_samples", "gt_diagonal",
        "fscore_tau_rel", "nn_dist_mean", "input_distance_points", "scan_noise"})
    EXPECT_EQ(key_direction(k), Better::None) << k;
  EXPECT_FALSE(key_direction("no_such_key").has_value());
  // What scores what.
  EXPECT_EQ(registry().at("normals.angle").fn.scores, Scores::Normals);
  EXPECT_EQ(registry().at("accuracy.p2plane").fn.scores, Scores::Points);
  for (const char* m : {"surface.chamfer", "surface.normals", "surface.input_distance",
                        "mesh.volume", "mesh.facts"})
    EXPECT_EQ(registry().at(m).fn.scores, Scores::Mesh) << m;
  Json j = registry().at("surface.chamfer").to_json();
  EXPECT_EQ(j["scores"], "mesh");
  EXPECT_EQ(j["keys"]["fscore"], "higher");
}

TriangleMesh without_face(TriangleMesh m, Eigen::Index f) {
  m.faces.col(f) = m.faces.col(m.num_faces() - 1);
  m.faces.conservativeResize(3, m.num_faces() - 1);
  return m;
}

TriangleMesh two_of(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh m;
  m.vertices.resize(3, a.num_vertices() + b.num_vertices());
  m.vertices << a.vertices, b.vertices;
  m.faces.resize(3, a.num_faces() + b.num_faces());
  m.faces << a.faces, (b.faces.array() + static_cast<int>(a.num_vertices())).matrix();
  return m;
}

TEST(MeshFacts, KnownMeshes) {
  const TriangleMesh s = icosphere(2);  // 162 vertices, 320 faces, 480 edges
  const MeshFacts c = mesh_facts(s);
  EXPECT_EQ(c.vertices, 162);
  EXPECT_EQ(c.faces, 320);
  EXPECT_EQ(c.boundary_edges, 0);
  EXPECT_EQ(c.nonmanifold_edges, 0);
  EXPECT_EQ(c.components, 1);
  EXPECT_EQ(c.unreferenced_vertices, 0);
  EXPECT_EQ(c.degenerate_faces, 0);
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.bytes, 162 * 12 + 320 * 12);

  const MeshFacts o = mesh_facts(without_face(s, 7));
  EXPECT_EQ(o.boundary_edges, 3);
  EXPECT_FALSE(o.closed);
  EXPECT_EQ(o.components, 1);

  TriangleMesh shifted = icosphere(1);
  shifted.vertices.row(0).array() += 5.0f;
  const MeshFacts two = mesh_facts(two_of(s, shifted));
  EXPECT_EQ(two.components, 2);
  EXPECT_TRUE(two.closed);

  // Euler characteristic and genus, known answers: a sphere 2 (genus 0), a torus 0 (genus 1),
  // two disjoint spheres 4 (genus 0), a cube with one face removed (a hole) 1 (a disk; open, no
  // genus).
  EXPECT_EQ(c.edges, 480);
  EXPECT_EQ(c.euler, 2);
  EXPECT_EQ(two.euler, 4);
  TorusParams tp;
  tp.major_segments = 24;
  tp.minor_segments = 12;
  const MeshFacts torus = mesh_facts(make_torus(tp));
  EXPECT_TRUE(torus.closed);
  EXPECT_EQ(torus.euler, 0);
  EXPECT_EQ(torus.faces, 2 * 24 * 12);
  const TriangleMesh box = make_cube({});
  EXPECT_EQ(mesh_facts(box).euler, 2);
  const MeshFacts holed = mesh_facts(without_face(box, 0));
  EXPECT_EQ(holed.euler, 1);
  EXPECT_EQ(holed.boundary_edges, 3);
  // The genus as the metric reports it.
  const auto genus = [](const TriangleMesh& mesh) {
    GroundTruth g(icosphere(1), 1, kCoarseSurface);
    RunContext ctx(1);
    return evaluate_mesh(g, mesh, nullptr, {"mesh.facts"}, Json::object(), ctx, 100)["mesh_genus"];
  };
  EXPECT_EQ(genus(s), 0);
  EXPECT_EQ(genus(make_torus(tp)), 1);
  EXPECT_EQ(genus(two_of(s, shifted)), 0);
  EXPECT_TRUE(genus(without_face(box, 0)).is_null());

  // Non-manifold: three triangles on one edge (0, 1).
  TriangleMesh fan;
  fan.vertices.resize(3, 5);
  fan.vertices << 0, 1, 0, 0, 0.5f,  //
      0, 0, 1, -1, 0.3f,             //
      0, 0, 0, 0, 1;
  fan.faces.resize(3, 3);
  fan.faces << 0, 1, 0,  //
      1, 0, 1,           //
      2, 3, 4;
  const MeshFacts nm = mesh_facts(fan);
  EXPECT_EQ(nm.nonmanifold_edges, 1);
  EXPECT_EQ(nm.boundary_edges, 6);
  EXPECT_FALSE(nm.closed);
  EXPECT_EQ(nm.components, 1);

  // An open grid: 4 n boundary edges; an unreferenced vertex; a degenerate face.
  TriangleMesh g = grid(3);
  EXPECT_EQ(mesh_facts(g).boundary_edges, 12);
  g.vertices.conservativeResize(3, g.num_vertices() + 1);
  g.vertices.col(g.num_vertices() - 1).setConstant(9.0f);
  g.faces.col(0) = Eigen::Vector3i(0, 0, 1);
  EXPECT_EQ(mesh_facts(g).unreferenced_vertices, 1);
  EXPECT_EQ(mesh_facts(g).degenerate_faces, 1);

  // A covariance mesh: a cube of six quads, 8 x (12 + 24) + 24 x 4 bytes (GPS sec. 7.2).
  CovarianceMesh cube;
  cube.resize(8);
  for (int v = 0; v < 8; ++v) {
    cube.means.col(v) = Eigen::Vector3d(v & 1, (v >> 1) & 1, (v >> 2) & 1);
    cube.set_covariance(v, 0.01 * Eigen::Matrix3d::Identity());
  }
  for (const auto& q : std::vector<std::array<int, 4>>{
           {0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}})
    cube.faces.add(q);
  const MeshFacts cf = mesh_facts(cube);
  EXPECT_EQ(cf.faces, 6);
  EXPECT_EQ(cf.boundary_edges, 0);
  EXPECT_TRUE(cf.closed);
  EXPECT_EQ(cf.bytes, 8 * 36 + 24 * 4);
  // Scored through its mean mesh, described as itself.
  GroundTruth gt(icosphere(2), 1, kCoarseSurface);
  RunContext ctx(1);
  const Json r = evaluate_covariance_mesh(gt, cube, nullptr, {"mesh.facts", "surface.chamfer"},
                                          Json{{"surface.chamfer", {{"samples", 500}}}}, ctx, 500);
  EXPECT_EQ(r["mesh_faces"].get<int>(), 6);
  EXPECT_EQ(r["mesh_bytes"].get<int>(), 8 * 36 + 24 * 4);
  EXPECT_GT(r["accuracy"].get<double>(), 0.0);
}

}  // namespace
}  // namespace scanbench::metrics
