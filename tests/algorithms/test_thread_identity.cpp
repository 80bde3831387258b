// Determinism over thread counts: the virtual scanner, every registered algorithm (iterating the
// registry, so new entries are covered) and every registered metric give bit-identical results at
// 1, 2 and 7 worker threads (7: more threads than cores and than most work splits, an odd count
// that exposes per-thread partial sums). Outputs are compared as raw bytes: every matrix of every
// kind an algorithm returns (CGAL's peers included; the one whose ties depend on heap addresses
// through the binary, one process per run), and each metric record as JSON text (doubles
// printed round-trip).
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <string>

#include "../harness/cli_test_util.h"
#include "registry_fixtures.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "scanbench/harness/exec/chain.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench {
namespace {

constexpr int kThreads[] = {1, 2, 7};

template <class M>
std::string raw(const M& m) {
  return std::string(reinterpret_cast<const char*>(m.data()),
                     static_cast<std::size_t>(m.size()) * sizeof(typename M::Scalar)) +
         "|" + std::to_string(m.rows()) + "x" + std::to_string(m.cols());
}

/// Every array of the stage data by name, as bytes.
std::map<std::string, std::string> blobs(const StageData& d) {
  std::map<std::string, std::string> b;
  const PointCloud& p = d.points;
  b["points.positions"] = raw(p.positions);
  b["points.normals"] = raw(p.normals);
  b["points.weights"] = raw(p.weights);
  b["points.scan_ids"] = raw(p.scan_ids);
  b["points.sensor_origins"] = raw(p.sensor_origins);
  for (const auto& [name, v] : p.properties)
    b["points.property." + name] = raw(v);
  if (d.mixture) {
    b["mixture.weights"] = raw(d.mixture->weights);
    b["mixture.means"] = raw(d.mixture->means);
    b["mixture.covariances"] = raw(d.mixture->covariances);
    b["mixture.normal_axes"] = raw(d.mixture->normal_axes);
    b["mixture.normal_spreads"] = raw(d.mixture->normal_spreads);
  }
  if (d.mesh) {
    b["mesh.vertices"] = raw(d.mesh->vertices);
    b["mesh.faces"] = raw(d.mesh->faces);
  }
  if (d.covariance_mesh) {
    const CovarianceMesh& c = *d.covariance_mesh;
    b["covmesh.means"] = raw(c.means);
    b["covmesh.covariances"] = raw(c.covariances);
    b["covmesh.face_offsets"] = std::string(reinterpret_cast<const char*>(c.faces.offsets.data()),
                                            c.faces.offsets.size() * sizeof(c.faces.offsets[0]));
    b["covmesh.face_vertices"] = std::string(reinterpret_cast<const char*>(c.faces.indices.data()),
                                             c.faces.indices.size() * sizeof(c.faces.indices[0]));
  }
  return b;
}

void expect_same_bits(const std::map<std::string, std::string>& a,
                      const std::map<std::string, std::string>& b, int threads) {
  ASSERT_EQ(a.size(), b.size()) << threads << " threads";
  for (const auto& [name, bytes] : a) {
    const auto it = b.find(name);
    ASSERT_NE(it, b.end()) << name << " missing at " << threads << " threads";
    EXPECT_TRUE(it->second == bytes) << name << " differs between 1 and " << threads << " threads";
  }
}

TriangleMesh test_sphere() {
  SphereParams sp;
  sp.resolution = 8;
  return make_sphere(sp);
}

/// A small noisy scan with outliers and two misaligned views (the artifacts that have their own
/// random streams), at `threads` threads.
scanner::Scan small_scan(int threads, const TriangleMesh& mesh = test_sphere()) {
  scanner::ScannerParams p;
  p.views = 4;
  p.resolution = 40;
  p.noise_sigma = 0.002;
  p.outlier_fraction = 0.02;
  p.flying_pixel_prob = 0.01;
  p.misalign_fraction = 0.5;
  p.misalign_deg = 0.5;
  RunContext ctx(11, threads);
  return scanner::scan(mesh, p, ctx);
}

TEST(ThreadIdentity, ScannerAt1_2_7Threads) {
  const auto ref = blobs(StageData{small_scan(1).cloud});
  ASSERT_GT(StageData{small_scan(1).cloud}.points.size(), 500);
  for (int t : kThreads)
    expect_same_bits(ref, blobs(StageData{small_scan(t).cloud}), t);
}

StageData every_kind() {
  return algorithms::fixtures::every_kind(small_scan(1).cloud, test_sphere());
}

// CGAL's advancing-front meshing (Cohen-Steiner and Da 2004; CGAL 5.5) breaks ties between
// candidate facets by handle address, and the scale-space reconstruction's alpha-shape mesher
// (force_manifold) iterates maps keyed by vertex and union-find handles: a second call in the
// same process (another heap history) can give another mesh. These entries are `own_process`
// (a job runs them in a fresh process) and are compared as the bytes of `scanbench algo`
// outputs, each run in a fresh process at 1, 2 and 7 threads.
bool address_ordered(const std::string& name) {
  return algorithms::registry().at(name).fn.own_process;
}

/// The output file of `scanbench algo name` on `input` at `threads` threads, as bytes.
std::string algo_bytes(const std::string& name, const Json& params,
                       const std::filesystem::path& input, const std::filesystem::path& dir,
                       int threads) {
  const std::filesystem::path out = dir / ("out" + std::to_string(threads) + ".ply");
  std::string cmd = test::sb() + " algo " + name + " -i " + input.string() + " -o " + out.string() +
                    " --seed 5 --threads " + std::to_string(threads);
  for (const auto& [k, v] : params.items())
    cmd += " --set '" + k + "=" + (v.is_string() ? v.get<std::string>() : v.dump()) + "'";
  const test::Result r = test::sh(cmd);
  EXPECT_EQ(r.code, 0) << cmd << "\n" << r.out;
  return test::slurp(out);
}

TEST(ThreadIdentity, EveryAlgorithmAt1_2_7Threads) {
  const StageData all = every_kind();
  int n = 0;
  for (const auto& e : algorithms::registry().entries()) {
    SCOPED_TRACE(e.name);
    const Json params = e.params.validate(algorithms::fixtures::required_params(e.name), e.name);
    StageData in;
    if (e.fn.io.consumes.has(DataKind::Points)) in.points = all.points;
    if (e.fn.io.consumes.has(DataKind::Mixture)) in.mixture = all.mixture;
    if (e.fn.io.consumes.has(DataKind::Mesh)) in.mesh = all.mesh;
    if (e.fn.io.consumes.has(DataKind::CovarianceMesh)) in.covariance_mesh = all.covariance_mesh;
    std::map<std::string, std::string> ref;
    for (int t : kThreads) {
      RunContext ctx(5, t);
      StageData out;
      ASSERT_NO_THROW(out = e.fn(in, params, ctx)) << t << " threads";
      auto b = blobs(out);
      if (address_ordered(e.name)) {
        ASSERT_TRUE(out.mesh && out.mesh->num_faces() > 0);
        continue;
      }
      if (t == 1) {
        ref = b;
      } else {
        expect_same_bits(ref, b, t);
      }
    }
    if (address_ordered(e.name)) {
      // Points in, as the harness would pass them: one fresh process per thread count.
      ASSERT_TRUE(e.fn.io.consumes.has(DataKind::Points));
      const std::filesystem::path dir = test::make_temp_dir("thread-identity");
      write_point_cloud(all.points, dir / "in.ply");
      const Json set = algorithms::fixtures::required_params(e.name);
      const std::string one = algo_bytes(e.name, set, dir / "in.ply", dir, 1);
      ASSERT_GT(one.size(), 100u);
      for (int t : {2, 7})
        EXPECT_TRUE(algo_bytes(e.name, set, dir / "in.ply", dir, t) == one)
            << "output file differs between 1 and " << t << " threads";
      std::filesystem::remove_all(dir);
    }
    ++n;
  }
  EXPECT_EQ(n, static_cast<int>(algorithms::registry().entries().size()));
}

// A job's chain hands an own-process step to `scanbench algo` in a fresh process (harness
// chain.h): PCA normals on 1, 2 and 7 threads, then each CGAL mesher, give the same mesh bytes on
// the fandisk block whose scale-space mesh differed between in-process runs (docs: the
// reconstruction family page). Not every in-process run differs, so this pins the invariant, and
// that the step ran out of process.
TEST(ThreadIdentity, OwnProcessStepsInAChainRepeatAt1_2_7Threads) {
  ASSERT_EQ(setenv("SCANBENCH_EXE", test::sb().c_str(), 1), 0);
  FandiskBlockParams fp;
  const StageData scan{small_scan(2, make_fandisk_block(fp)).cloud};
  ASSERT_GT(scan.points.size(), 500);
  int own = 0;
  for (const auto& e : algorithms::registry().entries()) {
    if (!e.fn.own_process) continue;
    SCOPED_TRACE(e.name);
    ++own;
    const auto& pca = algorithms::registry().at("normals.pca");
    Json chain = Json::array();
    chain.push_back({{"algorithm", "normals.pca"},
                     {"label", "pca"},
                     {"params", pca.params.validate(Json::object(), "pca")}});
    chain.push_back(
        {{"algorithm", e.name},
         {"label", "mesh"},
         {"params", e.params.validate(algorithms::fixtures::required_params(e.name), e.name)}});
    std::map<std::string, std::string> ref;
    for (int t : kThreads) {
      RunContext ctx(9, t);
      const harness::ChainRun r = harness::run_chain(chain, scan, ctx, false);
      ASSERT_TRUE(r.output.mesh && r.output.mesh->num_faces() > 0) << t << " threads";
      // The last step ran as a program (its peak memory noted), not in this process.
      EXPECT_GT(ctx.program_peak_rss_kb(), 0) << t << " threads";
      if (t == 1) {
        ref = blobs(r.output);
      } else {
        expect_same_bits(ref, blobs(r.output), t);
      }
    }
  }
  EXPECT_EQ(own, 2);  // peer.cgal_advancing_front, peer.cgal_scale_space
  unsetenv("SCANBENCH_EXE");
}

/// What a metric is scored on: a ground truth, an output cloud (with PCA normals), the scan and a
/// slightly perturbed copy of the ground truth as a "reconstruction" for the mesh metrics.
struct MetricCase {
  TriangleMesh truth;
  metrics::GroundTruth gt;
  PointCloud output;
  PointCloud scan;
  TriangleMesh recon;
  MetricCase(const TriangleMesh& t, PointCloud out, PointCloud sc)
      : truth(t), gt(truth, 9), output(std::move(out)), scan(std::move(sc)), recon(t) {
    recon.vertices *= 1.01f;
  }
};

/// The metric's record on `c` at `threads` threads (NotApplicable passes through).
Json score(const RegistryEntry<metrics::Metric>& e, const MetricCase& c, int threads) {
  RunContext ctx(7, threads);
  if (metrics::scores_mesh(e.fn.scores)) {
    return metrics::evaluate_mesh(c.gt, c.recon, &c.scan, {e.name}, Json::object(), ctx, 20000);
  }
  return metrics::evaluate(c.gt, c.output, &c.scan, {e.name}, Json::object(), ctx);
}

TEST(ThreadIdentity, EveryMetricAt1_2_7Threads) {
  // The sphere for every metric; the cube for those with nothing to score on a smooth shape (the
  // sharp-edge metrics).
  const MetricCase sphere(test_sphere(), every_kind().points, small_scan(1).cloud);
  CubeParams cp;
  cp.resolution = 8;
  const TriangleMesh cube_mesh = make_cube(cp);
  const PointCloud cube_scan = small_scan(1, cube_mesh).cloud;
  RunContext nctx(3, 1);
  const auto& pca = algorithms::registry().at("normals.pca");
  const MetricCase cube(
      cube_mesh,
      pca.fn(StageData{cube_scan}, pca.params.validate(Json::object(), "t"), nctx).points,
      cube_scan);
  int n = 0;
  for (const auto& e : metrics::registry().entries()) {
    SCOPED_TRACE(e.name);
    const MetricCase* c = &sphere;
    try {
      score(e, sphere, 1);
    } catch (const metrics::NotApplicable&) {
      c = &cube;
    }
    std::string ref;
    for (int t : kThreads) {
      Json rec;
      ASSERT_NO_THROW(rec = score(e, *c, t)) << t << " threads";
      // The metric ran (not skipped) and produced its declared keys.
      ASSERT_TRUE(rec.contains(e.fn.keys.front().key)) << rec.dump();
      if (t == 1) {
        ref = rec.dump();
      } else {
        EXPECT_EQ(rec.dump(), ref) << "metric record differs between 1 and " << t << " threads";
      }
    }
    ++n;
  }
  EXPECT_GE(n, 8);
}

}  // namespace
}  // namespace scanbench
