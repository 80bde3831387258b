// The only translation unit of scanner-sim that includes Open3D (its own object library in
// scanner-sim/CMakeLists.txt, as algorithms/src/peers/open3d_peers.cpp).
#include <fmt/format.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>

#include <mutex>
#include <vector>

#include "scanbench/core/errors.h"
#include "surface_samples.h"

namespace scanbench::scanner::detail {

SurfaceSamples poisson_disk_samples(const TriangleMesh& mesh, int n, std::uint32_t seed) {
  open3d::geometry::TriangleMesh m;
  m.vertices_.reserve(static_cast<std::size_t>(mesh.num_vertices()));
  for (Eigen::Index i = 0; i < mesh.num_vertices(); ++i)
    m.vertices_.push_back(mesh.vertices.col(i).cast<double>());
  m.triangles_.reserve(static_cast<std::size_t>(mesh.num_faces()));
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
    m.triangles_.push_back(mesh.faces.col(f));
  std::shared_ptr<open3d::geometry::PointCloud> pc;
  {
    // Open3D draws from one global engine (utility/Random.h): seeding and sampling under one
    // lock keep two scans of this process from interleaving their draws.
    static std::mutex lock;
    const std::lock_guard<std::mutex> guard(lock);
    open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
    open3d::utility::random::Seed(static_cast<int>(seed & 0x7fffffffu));
    pc = m.SamplePointsPoissonDisk(static_cast<std::size_t>(n), 5.0, nullptr, true);
  }
  if (!pc || pc->points_.size() != static_cast<std::size_t>(n) ||
      pc->normals_.size() != pc->points_.size()) {
    throw InputError(fmt::format("scan: Open3D's Poisson-disk sampler returned {} points, not {}",
                                 pc ? pc->points_.size() : 0, n));
  }
  SurfaceSamples s;
  s.points.resize(3, n);
  s.normals.resize(3, n);
  for (int i = 0; i < n; ++i) {
    s.points.col(i) = pc->points_[static_cast<std::size_t>(i)];
    s.normals.col(i) = pc->normals_[static_cast<std::size_t>(i)].normalized();
  }
  return s;
}

}  // namespace scanbench::scanner::detail
