// Every registered algorithm and every registered metric on data far from the world origin: the
// data of each kind (a noisy sphere scan with PCA normals, its HEM mixture, the sphere mesh and a
// covariance mesh on it) written translated by (1e6, -2e6, 5e5) in world coordinates (double PLY)
// and read back, run as `scanbench run` and `algo` run it (each step's input in the local frame at
// origin zero, the origin put back on the result), agrees with the same data at the origin.
//
// Why not bit for bit: a far file holds origin + x in double, which is exact for every coordinate
// above 2^-9 in magnitude and off by at most 2^-33 (half a double spacing at 2e6) below; those few
// coordinates move by ~1e-10 of the diagonal. The tolerance below bounds what such a perturbation
// may become; before local origins, float32 moved every coordinate by up to 0.06.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "registry_fixtures.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

const Eigen::Vector3d kT(1e6, -2e6, 5e5);
constexpr double kRelTolerance = 1e-3;

TriangleMesh test_sphere() {
  SphereParams sp;
  sp.resolution = 8;
  return make_sphere(sp);
}

PointCloud small_scan() {
  scanner::ScannerParams p;
  p.views = 4;
  p.resolution = 40;
  p.noise_sigma = 0.002;
  p.outlier_fraction = 0.02;
  RunContext ctx(11, 2);
  return scanner::scan(test_sphere(), p, ctx).cloud;
}

StageData every_kind() {
  return algorithms::fixtures::every_kind(small_scan(), test_sphere());
}

/// `d` written with origin kT (world coordinates, double) kind by kind, and read back.
StageData far_copy(const StageData& d, const fs::path& dir) {
  StageData w = d;
  w.set_origin(kT);
  StageData r;
  int i = 0;
  for (DataKind k :
       {DataKind::Points, DataKind::Mixture, DataKind::Mesh, DataKind::CovarianceMesh}) {
    if (!w.kinds().has(k)) continue;
    const fs::path p = dir / ("k" + std::to_string(i++) + ".ply");
    write_stage_kind(w, k, p);
    StageData one = read_stage_file(p);
    EXPECT_EQ(one.origin(p.string()), kT) << kind_name(k);
    r = StageData::carry(std::move(one), r, k);
  }
  return r;
}

/// What the runner does: the input in the local frame at origin zero, the origin back on the
/// result.
StageData run_local(const RegistryEntry<algorithms::Algorithm>& e, StageData in, const Json& params,
                    RunContext& ctx) {
  const Eigen::Vector3d o = in.origin("test");
  in.set_origin(Eigen::Vector3d::Zero());
  StageData out = e.fn(in, params, ctx);
  out.set_origin(o);
  return out;
}

/// Size and mean distance of the output's positions to the unit sphere (the ground truth), in
/// double: a frame-free summary of what an algorithm produced.
std::pair<Eigen::Index, double> summary(const StageData& d, DataKind primary) {
  Eigen::Matrix3Xd p;
  switch (primary) {
    case DataKind::Mesh:
      p = d.mesh->vertices.cast<double>();
      break;
    case DataKind::CovarianceMesh:
      p = d.covariance_mesh->means;
      break;
    case DataKind::Mixture:
      p = d.mixture->means.cast<double>();
      break;
    default:
      p = d.points.positions.cast<double>();
  }
  double s = 0.0;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    s += std::abs(p.col(i).norm() - 1.0);
  return {p.cols(), p.cols() > 0 ? s / static_cast<double>(p.cols()) : 0.0};
}

/// The entries whose output follows heap addresses (a job runs them in a fresh process).
bool address_ordered(const std::string& name) {
  return algorithms::registry().at(name).fn.own_process;
}

class LocalOriginAll : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("sb_local_origin_all_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(LocalOriginAll, EveryAlgorithmFarAgreesWithAtOrigin) {
  const StageData near_all = every_kind();
  const StageData far_all = far_copy(near_all, dir_);
  int n = 0;
  for (const auto& e : algorithms::registry().entries()) {
    SCOPED_TRACE(e.name);
    const Json params = e.params.validate(algorithms::fixtures::required_params(e.name), e.name);
    StageData in0, in1;
    if (e.fn.io.consumes.has(DataKind::Points)) {
      in0.points = near_all.points;
      in1.points = far_all.points;
    }
    if (e.fn.io.consumes.has(DataKind::Mixture)) {
      in0.mixture = near_all.mixture;
      in1.mixture = far_all.mixture;
    }
    if (e.fn.io.consumes.has(DataKind::Mesh)) {
      in0.mesh = near_all.mesh;
      in1.mesh = far_all.mesh;
    }
    if (e.fn.io.consumes.has(DataKind::CovarianceMesh)) {
      in0.covariance_mesh = near_all.covariance_mesh;
      in1.covariance_mesh = far_all.covariance_mesh;
    }
    RunContext c0(5, 2), c1(5, 2);
    StageData out0, out1;
    ASSERT_NO_THROW(out0 = run_local(e, in0, params, c0));
    ASSERT_NO_THROW(out1 = run_local(e, in1, params, c1));
    ++n;
    const DataKind primary = e.fn.io.primary;
    EXPECT_EQ(out1.origin("far"), kT);      // the origin is back on every kind of the result
    if (address_ordered(e.name)) continue;  // see test_thread_identity.cpp
    const auto [n0, d0] = summary(out0, primary);
    const auto [n1, d1] = summary(out1, primary);
    std::printf("%-32s %8ld %8ld  %.9g %.9g\n", e.name.c_str(), static_cast<long>(n0),
                static_cast<long>(n1), d0, d1);
    EXPECT_LE(std::abs(static_cast<double>(n0 - n1)), kRelTolerance * static_cast<double>(n0));
    EXPECT_LE(std::abs(d0 - d1), kRelTolerance * d0 + 1e-9);
  }
  EXPECT_EQ(n, static_cast<int>(algorithms::registry().entries().size()));
}

TEST_F(LocalOriginAll, EveryMetricFarAgreesWithAtOrigin) {
  const StageData near_all = every_kind();
  TriangleMesh recon = test_sphere();
  recon.vertices *= 1.01f;
  StageData truth;
  truth.mesh = test_sphere();
  StageData recon_data;
  recon_data.mesh = recon;
  StageData scan_data{small_scan()};
  for (const char* sub : {"t", "r", "s", "o"})
    fs::create_directories(dir_ / sub);
  const StageData far_truth = far_copy(truth, dir_ / "t");
  const StageData far_recon = far_copy(recon_data, dir_ / "r");
  const StageData far_scan = far_copy(scan_data, dir_ / "s");
  StageData out_points;
  out_points.points = near_all.points;
  const StageData far_out = far_copy(out_points, dir_ / "o");
  // Each metric in the frame of the ground truth (what `eval` does with rebase()).
  const metrics::GroundTruth gt0(*truth.mesh, 9);
  const metrics::GroundTruth gt1(*far_truth.mesh, 9);
  int n = 0;
  for (const auto& e : metrics::registry().entries()) {
    SCOPED_TRACE(e.name);
    RunContext c0(7, 2), c1(7, 2);
    Json r0, r1;
    try {
      if (metrics::scores_mesh(e.fn.scores)) {
        r0 = metrics::evaluate_mesh(gt0, recon, &scan_data.points, {e.name}, Json::object(), c0,
                                    20000);
        r1 = metrics::evaluate_mesh(gt1, *far_recon.mesh, &far_scan.points, {e.name},
                                    Json::object(), c1, 20000);
      } else {
        r0 = metrics::evaluate(gt0, out_points.points, &scan_data.points, {e.name}, Json::object(),
                               c0);
        r1 = metrics::evaluate(gt1, far_out.points, &far_scan.points, {e.name}, Json::object(), c1);
      }
    } catch (const metrics::NotApplicable&) {
      continue;  // nothing to score on a sphere (sharp-edge metrics): the same at any origin
    }
    ++n;
    int keys = 0;
    for (const auto& [k, v] : r0.items()) {
      if (!v.is_number()) continue;
      ASSERT_TRUE(r1.contains(k)) << k;
      const double a = v.get<double>();
      const double b = r1[k].get<double>();
      EXPECT_LE(std::abs(a - b), kRelTolerance * std::abs(a) + 1e-9)
          << k << ": at origin " << a << ", far " << b;
      if (a != b) std::printf("%-28s %-28s %.9g %.9g\n", e.name.c_str(), k.c_str(), a, b);
      ++keys;
    }
    EXPECT_GT(keys, 0) << r0.dump();
  }
  EXPECT_GE(n, 8);
}

}  // namespace
}  // namespace scanbench
