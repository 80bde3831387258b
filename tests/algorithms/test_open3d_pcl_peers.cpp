// The Open3D and PCL peers on a scanned unit sphere: each gives the expected kind and size of
// output; each Poisson (COLMAP's, Open3D's, PCL's) closes the sphere (every edge in exactly two
// faces) within one finest octree cell of it; normals agree with the sphere's; outlier removal
// removes far outliers and keeps every attribute; bytes are identical at 1 and 2 threads; a bad
// parameter and a missing program are one-line errors.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <utility>

#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/algorithms/peers/open3d_peers.h"
#include "scanbench/algorithms/peers/pcl_peers.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::algorithms {
namespace {

/// A noisy scan of the unit sphere (8 views of 64 x 64 rays) with PCA normals (outward).
const PointCloud& scanned_sphere() {
  static const PointCloud cloud = [] {
    SphereParams sp;
    sp.resolution = 16;
    scanner::ScannerParams p;
    p.views = 8;
    p.resolution = 64;
    p.noise_sigma = 0.002;
    RunContext ctx(17, 1);
    PointCloud scan = scanner::scan(make_sphere(sp), p, ctx).cloud;
    return pca_normals(scan, PcaNormalsParams{}, ctx);
  }();
  return cloud;
}

StageData run(const std::string& name, const Json& params, const StageData& in, int threads = 1) {
  const auto& e = registry().at(name);
  RunContext ctx(5, threads);
  return e.fn(in, e.params.validate(params, name), ctx);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

/// Edges used by other than exactly two faces (0 for a closed 2-manifold surface).
int open_or_nonmanifold_edges(const TriangleMesh& m) {
  std::map<std::pair<int, int>, int> uses;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = m.faces(c, f), b = m.faces((c + 1) % 3, f);
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  }
  int bad = 0;
  for (const auto& [edge, n] : uses)
    bad += n != 2;
  return bad;
}

double max_radial_error(const Eigen::Matrix3Xf& v) {
  return (v.colwise().norm().array() - 1.0f).abs().maxCoeff();
}

// Each Poisson at depth 6: the reconstruction cube is about 1.1 x the bounding cube (side 2), so
// one finest cell is 2.2 / 2^6 = 0.034; every vertex lies within one cell of the unit sphere.
constexpr int kDepth = 6;
constexpr double kCell = 2.2 / (1 << kDepth);

class Poissons : public ::testing::TestWithParam<const char*> {};

TEST_P(Poissons, CloseTheSphereWithinOneCell) {
  const std::string name = GetParam();
  const StageData out = run(name, Json{{"depth", kDepth}}, StageData{scanned_sphere()});
  ASSERT_TRUE(out.mesh.has_value());
  const TriangleMesh& m = *out.mesh;
  EXPECT_GT(m.num_faces(), 1000);
  EXPECT_EQ(open_or_nonmanifold_edges(m), 0);
  // Euler characteristic 2: one closed genus-0 surface (V - E + F with E = 3F/2).
  EXPECT_EQ(m.num_vertices() - 3 * m.num_faces() / 2 + m.num_faces(), 2);
  EXPECT_LT(max_radial_error(m.vertices), kCell) << name;
}

INSTANTIATE_TEST_SUITE_P(ThreePoissons, Poissons,
                         ::testing::Values("reconstruct.poisson", "peer.open3d_poisson",
                                           "peer.pcl_poisson"));

TEST(Open3dPeers, PoissonDensityTrimRemovesTheLowestQuantile) {
  const StageData all =
      run("peer.open3d_poisson", Json{{"depth", kDepth}}, StageData{scanned_sphere()});
  const StageData trimmed =
      run("peer.open3d_poisson", Json{{"depth", kDepth}, {"density_trim", 0.2}},
          StageData{scanned_sphere()});
  const double kept = static_cast<double>(trimmed.mesh->num_vertices()) /
                      static_cast<double>(all.mesh->num_vertices());
  // At least 80 % stay (ties at the threshold stay too); some are removed.
  EXPECT_GE(kept, 0.8);
  EXPECT_LT(kept, 1.0);
}

TEST(Open3dPeers, BallPivotingAndAlphaShapeInterpolateTheScan) {
  const PointCloud& in = scanned_sphere();
  for (const char* name : {"peer.open3d_ball_pivoting", "peer.open3d_alpha_shape"}) {
    SCOPED_TRACE(name);
    const StageData out = run(name, Json::object(), StageData{in});
    ASSERT_TRUE(out.mesh.has_value());
    const TriangleMesh& m = *out.mesh;
    // No more vertices than the scan, faces about 2 per vertex.
    EXPECT_LE(m.num_vertices(), in.size());
    EXPECT_GT(m.num_vertices(), in.size() / 2);
    EXPECT_GT(m.num_faces(), m.num_vertices());
    // Interpolating: every vertex is a scan point (float -> double -> float is exact).
    std::set<std::array<float, 3>> points;
    for (Eigen::Index i = 0; i < in.size(); ++i)
      points.insert({in.positions(0, i), in.positions(1, i), in.positions(2, i)});
    int foreign = 0;
    for (Eigen::Index v = 0; v < m.num_vertices(); ++v)
      foreign += !points.count({m.vertices(0, v), m.vertices(1, v), m.vertices(2, v)});
    EXPECT_EQ(foreign, 0);
  }
}

TEST(Open3dPeers, NormalsAgreeWithTheSphereAndPointOutward) {
  PointCloud in = scanned_sphere();
  in.normals.resize(3, 0);  // estimated from scratch
  const PointCloud out = run("peer.open3d_normals", Json::object(), StageData{in}).points;
  ASSERT_EQ(out.size(), in.size());
  ASSERT_TRUE(out.has_normals());
  EXPECT_TRUE(out.positions == in.positions);
  int outward = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i)
    outward += out.normals.col(i).dot(in.positions.col(i).normalized()) > 0.95f;
  EXPECT_EQ(outward, out.size());
}

/// The scanned sphere's positions with weights (an attribute to carry: the point's index) and
/// 40 far outliers (at radius 2.5, more than 0.5 apart) appended.
PointCloud with_far_outliers() {
  const PointCloud& scan = scanned_sphere();
  const Eigen::Index n = scan.size();
  constexpr int kOutliers = 40;
  PointCloud c;
  c.positions.resize(3, n + kOutliers);
  c.positions.leftCols(n) = scan.positions;
  Rng rng(99);
  for (int i = 0; i < kOutliers; ++i) {
    const Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                            static_cast<float>(rng.normal()));
    c.positions.col(n + i) = 2.5f * d.normalized();
  }
  c.weights =
      Eigen::VectorXf::LinSpaced(n + kOutliers, 0.0f, static_cast<float>(n + kOutliers - 1));
  return c;
}

class OutlierRemoval : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(OutlierRemoval, RemovesFarOutliersAndKeepsAttributes) {
  const auto [name, method] = GetParam();
  const PointCloud in = with_far_outliers();
  const Eigen::Index surface = in.size() - 40;
  // radius 0.02 of the diagonal (about 0.17 with the outliers): dozens of scan points, no
  // outlier neighbour.
  const PointCloud out = run(name, Json{{"method", method}}, StageData{in}).points;
  ASSERT_TRUE(out.has_weights());
  int outliers_kept = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const auto src = static_cast<Eigen::Index>(out.weights(i));
    ASSERT_TRUE(out.positions.col(i) == in.positions.col(src)) << "point " << i;  // attributes ride
    if (i > 0) {
      ASSERT_GT(out.weights(i), out.weights(i - 1));  // input order kept
    }
    outliers_kept += src >= surface;
  }
  EXPECT_EQ(outliers_kept, 0);
  EXPECT_GT(out.size(), surface * 9 / 10);
}

INSTANTIATE_TEST_SUITE_P(OpenAndPcl, OutlierRemoval,
                         ::testing::Values(std::pair{"peer.open3d_outlier_removal", "statistical"},
                                           std::pair{"peer.open3d_outlier_removal", "radius"},
                                           std::pair{"peer.pcl_outlier_removal", "statistical"},
                                           std::pair{"peer.pcl_outlier_removal", "radius"}));

TEST(PclPeers, MlsMovesPointsTowardTheSphereWithNormals) {
  const PointCloud& in = scanned_sphere();
  const PointCloud out = run("peer.pcl_mls", Json::object(), StageData{in}).points;
  EXPECT_LE(out.size(), in.size());
  EXPECT_GT(out.size(), in.size() * 9 / 10);
  ASSERT_TRUE(out.has_normals());
  auto mean_error = [](const Eigen::Matrix3Xf& p) {
    return (p.colwise().norm().array() - 1.0f).abs().cast<double>().mean();
  };
  EXPECT_LT(mean_error(out.positions), mean_error(in.positions));
  for (Eigen::Index i = 0; i < out.size(); ++i)
    ASSERT_NEAR(std::abs(out.normals.col(i).dot(out.positions.col(i).normalized())), 1.0, 0.05);
}

/// Every array of the stage data as bytes.
std::string bytes_of(const StageData& d) {
  auto raw = [](const auto& m) {
    return std::string(reinterpret_cast<const char*>(m.data()),
                       static_cast<std::size_t>(m.size()) * sizeof(*m.data()));
  };
  std::string b =
      raw(d.points.positions) + "|" + raw(d.points.normals) + "|" + raw(d.points.weights);
  if (d.mesh) b += "|" + raw(d.mesh->vertices) + "|" + raw(d.mesh->faces);
  return b;
}

TEST(OpenAndPclPeers, ByteIdenticalAtOneAndTwoThreads) {
  const StageData in{with_far_outliers()};
  const StageData with_normals{scanned_sphere()};
  for (const char* name :
       {"peer.open3d_poisson", "peer.open3d_ball_pivoting", "peer.open3d_alpha_shape",
        "peer.open3d_outlier_removal", "peer.open3d_normals", "peer.pcl_mls",
        "peer.pcl_outlier_removal", "peer.pcl_poisson"}) {
    SCOPED_TRACE(name);
    // The reconstructions take the scan with normals, the point filters the outlier cloud.
    const bool mesh = registry().at(name).fn.io.primary == DataKind::Mesh;
    const StageData& input = mesh ? with_normals : in;
    const Json p = std::string(name).find("poisson") != std::string::npos ? Json{{"depth", kDepth}}
                                                                          : Json::object();
    EXPECT_EQ(bytes_of(run(name, p, input, 1)), bytes_of(run(name, p, input, 2)));
  }
}

TEST(OpenAndPclPeers, BadParameterIsOneLineNamingIt) {
  for (const auto& entry : {std::pair{"peer.open3d_poisson", Json{{"depth", 1}}},
                            std::pair{"peer.open3d_ball_pivoting", Json{{"radius", 0.0}}},
                            std::pair{"peer.open3d_alpha_shape", Json{{"alpha", -1.0}}},
                            std::pair{"peer.open3d_outlier_removal", Json{{"method", "median"}}},
                            std::pair{"peer.open3d_normals", Json{{"k", 2}}},
                            std::pair{"peer.pcl_mls", Json{{"polynomial_order", 9}}},
                            std::pair{"peer.pcl_outlier_removal", Json{{"std_ratio", 0.0}}},
                            std::pair{"peer.pcl_poisson", Json{{"depth", 20}}}}) {
    // Named copies, not a structured binding: clang 14 cannot capture bindings in a lambda.
    const std::string name = entry.first;
    const Json& params = entry.second;
    SCOPED_TRACE(name);
    const std::string msg = error_of([&] { run(name, params, StageData{scanned_sphere()}); });
    EXPECT_NE(msg.find(std::string(name) + "." + params.begin().key()), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(PclPeers, MissingProgramIsOneLineNamingThePackage) {
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  const std::filesystem::path empty =
      std::filesystem::temp_directory_path() / ("scanbench-no-pcl-" + std::to_string(::getpid()));
  std::filesystem::create_directories(empty);
  ::setenv("PATH", empty.c_str(), 1);
  for (const char* name : {"peer.pcl_mls", "peer.pcl_outlier_removal", "peer.pcl_poisson"}) {
    const std::string msg =
        error_of([&] { run(name, Json::object(), StageData{scanned_sphere()}); });
    EXPECT_NE(msg.find(std::string(name) + ": pcl_ply2pcd not found in PATH; install the Debian "
                                           "package pcl-tools"),
              std::string::npos)
        << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  ::setenv("PATH", saved.c_str(), 1);
  std::filesystem::remove(empty);
}

TEST(OpenAndPclPeers, VersionsAreKnown) {
  EXPECT_EQ(std::string(open3d_version()).rfind("0.", 0), 0u);
  const std::string pcl = pcl_tools_version();
  EXPECT_NE(pcl, "unknown");
  EXPECT_NE(pcl, "not installed");  // the tests above need the programs
}

}  // namespace
}  // namespace scanbench::algorithms
