// The only translation unit that includes Open3D (its headers are heavy and carry their own
// usage requirements; see algorithms/CMakeLists.txt).
#include "scanbench/algorithms/peers/open3d_peers.h"

#include <fmt/format.h>
#include <omp.h>
#include <open3d/Open3DConfig.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/utility/Logging.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include "input_checks.h"
#include "scanbench/core/errors.h"

namespace scanbench::algorithms {

const char* open3d_version() {
  return OPEN3D_VERSION;
}

namespace {

namespace o3d = open3d::geometry;

void quiet_open3d() {
  static std::once_flag once;
  std::call_once(
      once, [] { open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error); });
}

/// The OpenMP thread count of the calling thread: the run's (see open3d_peers.h).
void pin_threads(const RunContext& ctx) {
  const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  omp_set_num_threads(ctx.threads() > 0 ? ctx.threads() : hw);
}

/// Runs `f`, turning Open3D's exceptions into one-line Errors naming the step.
template <class F>
auto guarded(std::string_view stage, F&& f) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    std::string what = e.what();
    std::replace(what.begin(), what.end(), '\n', ' ');
    throw Error(fmt::format("{}: Open3D: {}", stage, what));
  }
}

using detail::checked_diagonal;

o3d::PointCloud to_open3d(const PointCloud& in, bool with_normals) {
  o3d::PointCloud out;
  out.points_.resize(static_cast<std::size_t>(in.size()));
  for (Eigen::Index i = 0; i < in.size(); ++i)
    out.points_[static_cast<std::size_t>(i)] = in.positions.col(i).cast<double>();
  if (with_normals) {
    const Eigen::Matrix3Xf n = detail::unit_normals(in);
    out.normals_.resize(out.points_.size());
    for (Eigen::Index i = 0; i < in.size(); ++i)
      out.normals_[static_cast<std::size_t>(i)] = n.col(i).cast<double>();
  }
  return out;
}

/// The Open3D mesh's vertices and triangles (unreferenced vertices dropped, indices compacted).
StageData to_stage_mesh(const o3d::TriangleMesh& m, std::string_view stage) {
  std::vector<int> remap(m.vertices_.size(), -1);
  int used = 0;
  for (const auto& t : m.triangles_) {
    for (int c = 0; c < 3; ++c) {
      if (t(c) < 0 || static_cast<std::size_t>(t(c)) >= remap.size()) {
        throw Error(fmt::format("{}: Open3D returned a face with vertex {} of {}", stage, t(c),
                                remap.size()));
      }
      if (remap[static_cast<std::size_t>(t(c))] < 0) remap[static_cast<std::size_t>(t(c))] = used++;
    }
  }
  if (m.triangles_.empty()) throw Error(fmt::format("{}: Open3D returned no face", stage));
  TriangleMesh mesh;
  mesh.vertices.resize(3, used);
  for (std::size_t v = 0; v < remap.size(); ++v) {
    if (remap[v] >= 0) mesh.vertices.col(remap[v]) = m.vertices_[v].cast<float>();
  }
  mesh.faces.resize(3, static_cast<Eigen::Index>(m.triangles_.size()));
  for (std::size_t f = 0; f < m.triangles_.size(); ++f) {
    for (int c = 0; c < 3; ++c)
      mesh.faces(c, static_cast<Eigen::Index>(f)) =
          remap[static_cast<std::size_t>(m.triangles_[f](c))];
  }
  StageData out;
  out.mesh = std::move(mesh);
  return out;
}

std::vector<Eigen::Index> as_indices(const std::vector<std::size_t>& kept) {
  return {kept.begin(), kept.end()};
}

}  // namespace

StageData open3d_poisson(const StageData& in, const Open3dPoissonParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.open3d_poisson";
  checked_diagonal(in.points, stage, 4);
  detail::require_unit_normals(in.points, stage, "normals.pca -> peer.open3d_poisson");
  quiet_open3d();
  const o3d::PointCloud cloud = to_open3d(in.points, true);
  auto timer = ctx.phase("open3d");
  return guarded(stage, [&] {
    // One solver thread: Open3D's Poisson output depends on its thread count.
    auto [mesh, densities] = o3d::TriangleMesh::CreateFromPointCloudPoisson(
        cloud, static_cast<std::size_t>(p.depth), 0, static_cast<float>(p.scale), p.linear_fit, 1);
    if (p.density_trim > 0.0 && !densities.empty()) {
      std::vector<double> sorted = densities;
      const auto q = static_cast<std::size_t>(p.density_trim * static_cast<double>(sorted.size()));
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(q),
                       sorted.end());
      const double threshold = sorted[q];
      std::vector<bool> remove(densities.size());
      for (std::size_t v = 0; v < densities.size(); ++v)
        remove[v] = densities[v] < threshold;
      mesh->RemoveVerticesByMask(remove);
    }
    return to_stage_mesh(*mesh, stage);
  });
}

StageData open3d_ball_pivoting(const StageData& in, const Open3dBallPivotingParams& p,
                               RunContext& ctx) {
  constexpr std::string_view stage = "peer.open3d_ball_pivoting";
  const double diag = checked_diagonal(in.points, stage, 3);
  detail::require_unit_normals(in.points, stage, "normals.pca -> peer.open3d_ball_pivoting");
  quiet_open3d();
  const o3d::PointCloud cloud = to_open3d(in.points, true);
  std::vector<double> radii;
  for (int l = 0; l < p.levels; ++l)
    radii.push_back(p.radius * diag * std::ldexp(1.0, l));
  auto timer = ctx.phase("open3d");
  return guarded(stage, [&] {
    const auto mesh = o3d::TriangleMesh::CreateFromPointCloudBallPivoting(cloud, radii);
    return to_stage_mesh(*mesh, stage);
  });
}

StageData open3d_alpha_shape(const StageData& in, const Open3dAlphaShapeParams& p,
                             RunContext& ctx) {
  constexpr std::string_view stage = "peer.open3d_alpha_shape";
  const double diag = checked_diagonal(in.points, stage, 4);
  quiet_open3d();
  const o3d::PointCloud cloud = to_open3d(in.points, false);
  auto timer = ctx.phase("open3d");
  return guarded(stage, [&] {
    const auto mesh = o3d::TriangleMesh::CreateFromPointCloudAlphaShape(cloud, p.alpha * diag);
    return to_stage_mesh(*mesh, stage);
  });
}

PointCloud open3d_outlier_removal(const PointCloud& in, const Open3dOutlierParams& p,
                                  RunContext& ctx) {
  constexpr std::string_view stage = "peer.open3d_outlier_removal";
  const double diag = checked_diagonal(in, stage, 2);
  quiet_open3d();
  const o3d::PointCloud cloud = to_open3d(in, false);
  pin_threads(ctx);
  auto timer = ctx.phase("open3d");
  const std::vector<std::size_t> kept = guarded(stage, [&] {
    if (p.method == "radius") {
      return std::get<1>(
          cloud.RemoveRadiusOutliers(static_cast<std::size_t>(p.min_points), p.radius * diag));
    }
    return std::get<1>(cloud.RemoveStatisticalOutliers(static_cast<std::size_t>(p.k), p.std_ratio));
  });
  PointCloud out = in.subset(as_indices(kept));
  out.validate(stage);
  return out;
}

PointCloud open3d_normals(const PointCloud& in, const Open3dNormalsParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.open3d_normals";
  const double diag = checked_diagonal(in, stage, 3);
  quiet_open3d();
  o3d::PointCloud cloud = to_open3d(in, false);  // from scratch: Open3D flips toward old normals
  pin_threads(ctx);
  {
    auto timer = ctx.phase("open3d");
    guarded(stage, [&] {
      if (p.radius > 0.0) {
        cloud.EstimateNormals(o3d::KDTreeSearchParamHybrid(p.radius * diag, p.k));
      } else {
        cloud.EstimateNormals(o3d::KDTreeSearchParamKNN(p.k));
      }
      if (p.orient == "tangent_plane") {
        cloud.OrientNormalsConsistentTangentPlane(static_cast<std::size_t>(p.orient_k));
      }
      return 0;
    });
  }
  PointCloud out = in;
  out.normals.resize(3, in.size());
  for (Eigen::Index i = 0; i < in.size(); ++i)
    out.normals.col(i) = cloud.normals_[static_cast<std::size_t>(i)].normalized().cast<float>();
  if (p.orient == "tangent_plane") {
    // The global sign, as normals.pca: outward at the point farthest from the centroid.
    const Eigen::Vector3f centroid = in.positions.rowwise().mean();
    Eigen::Index far = 0;
    (in.positions.colwise() - centroid).colwise().squaredNorm().maxCoeff(&far);
    if (out.normals.col(far).dot(in.positions.col(far) - centroid) < 0.0f) out.normals *= -1.0f;
  }
  out.validate(stage);
  return out;
}

}  // namespace scanbench::algorithms
