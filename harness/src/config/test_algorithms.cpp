#include "scanbench/harness/config/test_algorithms.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

#include "scanbench/core/procedural.h"

namespace scanbench::harness {

namespace {

struct CrashParams {
  double delay_s = 0.0;
  static void declare(ParamDeclarer<CrashParams>& d) {
    d.real("delay_s", &CrashParams::delay_s, Range::closed(0, 60), "s", "wait before crashing");
  }
};

struct HangParams {
  static void declare(ParamDeclarer<HangParams>&) {}
};

struct OomParams {
  int chunk_mb = 64;
  static void declare(ParamDeclarer<OomParams>& d) {
    d.integer("chunk_mb", &OomParams::chunk_mb, Range::closed(1, 4096), "MB", "allocation step");
  }
};

struct SubsampleParams {
  int stride = 2;
  double work_ms = 0.0;
  static void declare(ParamDeclarer<SubsampleParams>& d) {
    d.integer("stride", &SubsampleParams::stride, Range::closed(1, 1000), "",
              "keep points 0, stride, 2 stride, ...");
    d.real("work_ms", &SubsampleParams::work_ms, Range::closed(0, 10000), "ms",
           "busy wait per call (phase \"work\"), for timing tests");
  }
};

struct SphereMeshParams {
  int resolution = 16;
  static void declare(ParamDeclarer<SphereMeshParams>& d) {
    d.integer("resolution", &SphereMeshParams::resolution, Range::closed(1, 256), "",
              "grid cells per cube-face side of the output cube-sphere (12 n^2 triangles)");
  }
};

using algorithms::AlgorithmOutput;

AlgorithmOutput only(PointCloud pc) {
  AlgorithmOutput out;
  out.points = std::move(pc);
  return out;
}

AlgorithmOutput crash(const PointCloud&, const CrashParams& p, RunContext&) {
  std::this_thread::sleep_for(std::chrono::duration<double>(p.delay_s));
  std::raise(SIGSEGV);
  return only({});
}

AlgorithmOutput hang(const PointCloud&, const HangParams&, RunContext&) {
  for (;;)
    std::this_thread::sleep_for(std::chrono::seconds(1));
}

AlgorithmOutput oom(const PointCloud&, const OomParams& p, RunContext&) {
  std::vector<std::unique_ptr<char[]>> blocks;
  const std::size_t chunk = static_cast<std::size_t>(p.chunk_mb) << 20;
  for (;;) {
    blocks.emplace_back(new char[chunk]);  // throws std::bad_alloc at the limit
    std::memset(blocks.back().get(), 1, chunk);
  }
}

AlgorithmOutput subsample(const PointCloud& in, const SubsampleParams& p, RunContext& ctx) {
  std::vector<Eigen::Index> keep;
  {
    auto t = ctx.phase("select");
    for (Eigen::Index i = 0; i < in.size(); i += p.stride)
      keep.push_back(i);
  }
  if (p.work_ms > 0) {
    auto t = ctx.phase("work");
    const auto until =
        std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(p.work_ms);
    while (std::chrono::steady_clock::now() < until) {
    }
  }
  return only(in.subset(keep));
}

// The cube-sphere (core/procedural.h) of the least-squares sphere through the points (the
// algebraic fit |p|^2 = 2 c.p + (r^2 - |c|^2), exact for points on a sphere however partial the
// coverage): for a scan of the procedural sphere, a mesh close to the ground truth.
TriangleMesh fitted_sphere(const PointCloud& in, int resolution) {
  if (in.size() < 4) throw InputError("test.sphere_mesh: needs at least 4 points");
  Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
  Eigen::Vector4d atb = Eigen::Vector4d::Zero();
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    const Eigen::Vector3d p = in.positions.col(i).cast<double>();
    const Eigen::Vector4d a(2 * p.x(), 2 * p.y(), 2 * p.z(), 1.0);
    ata += a * a.transpose();
    atb += a * p.squaredNorm();
  }
  const Eigen::Vector4d x = ata.ldlt().solve(atb);
  const Eigen::Vector3d c = x.head<3>();
  SphereParams sp;
  sp.radius = std::sqrt(std::max(1e-12, x[3] + c.squaredNorm()));
  sp.resolution = resolution;
  TriangleMesh m = make_sphere(sp);
  m.vertices.colwise() += c.cast<float>();
  return m;
}

AlgorithmOutput sphere_mesh(const PointCloud& in, const SphereMeshParams& p, RunContext&) {
  AlgorithmOutput out;
  out.mesh = fitted_sphere(in, p.resolution);
  return out;
}

// The same sphere as a covariance mesh: isotropic covariances (radius / 100)^2 I per vertex.
AlgorithmOutput sphere_covmesh(const PointCloud& in, const SphereMeshParams& p, RunContext&) {
  const TriangleMesh m = fitted_sphere(in, p.resolution);
  CovarianceMesh cm;
  cm.resize(m.num_vertices());
  cm.means = m.vertices.cast<double>();
  const double s = (m.vertices.col(0) - m.vertices.rowwise().mean()).norm() / 100.0;
  for (Eigen::Index i = 0; i < cm.num_vertices(); ++i)
    cm.set_covariance(i, s * s * Eigen::Matrix3d::Identity());
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    const int t[3] = {m.faces(0, f), m.faces(1, f), m.faces(2, f)};
    cm.faces.add(t);
  }
  AlgorithmOutput out;
  out.covariance_mesh = std::move(cm);
  return out;
}

}  // namespace

bool test_algorithms_enabled() {
  const char* v = std::getenv("SCANBENCH_TEST_ALGORITHMS");
  return v != nullptr && std::strcmp(v, "1") == 0;
}

const algorithms::AlgorithmRegistry& test_algorithms() {
  static const algorithms::AlgorithmRegistry r = [] {
    algorithms::AlgorithmRegistry reg("test algorithm");
    reg.add(algorithms::make_entry<CrashParams>("test.crash", "raises SIGSEGV (isolation tests)",
                                                crash));
    reg.add(algorithms::make_entry<HangParams>("test.hang", "never returns (timeout tests)", hang));
    reg.add(algorithms::make_entry<OomParams>(
        "test.oom", "allocates until allocation fails (memory-limit tests)", oom));
    reg.add(algorithms::make_entry<SubsampleParams>(
        "test.subsample", "keeps every stride-th point; optional busy work (harness tests)",
        subsample));
    reg.add(algorithms::make_entry<SphereMeshParams>(
        "test.sphere_mesh",
        "cube-sphere mesh through the points' centroid with their mean distance as radius "
        "(mesh-output harness tests)",
        sphere_mesh, algorithms::StageIo{DataKind::Points, DataKind::Mesh, DataKind::Mesh}));
    reg.add(algorithms::make_entry<SphereMeshParams>(
        "test.sphere_covmesh",
        "test.sphere_mesh as a covariance mesh with isotropic covariances (radius/100)^2 I",
        sphere_covmesh,
        algorithms::StageIo{DataKind::Points, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
    return reg;
  }();
  return r;
}

const algorithms::AlgorithmRegistry::Entry& algorithm_entry(std::string_view name) {
  if (const auto* e = algorithms::registry().find(name)) return *e;
  if (test_algorithms_enabled()) {
    if (const auto* e = test_algorithms().find(name)) return *e;
  }
  return algorithms::registry().at(name);  // throws with the known names
}

}  // namespace scanbench::harness
