#include "scanbench/metrics/surface_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::metrics {

PointCloud sample_surface(const TriangleMesh& mesh, Eigen::Index count, std::uint64_t seed) {
  if (count < 0) throw InputError("surface sampling: negative sample count");
  const Eigen::Index nf = mesh.num_faces();
  std::vector<double> prefix(static_cast<std::size_t>(nf));
  double total = 0.0;
  for (Eigen::Index f = 0; f < nf; ++f) {
    total += mesh.face_area(f);
    prefix[static_cast<std::size_t>(f)] = total;
  }
  if (!(total > 0.0)) throw InputError("surface sampling: mesh has no positive area");

  PointCloud out;
  out.positions.resize(3, count);
  out.normals.resize(3, count);
  Eigen::VectorXf face(count);
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, count, 1024),
      [&](const tbb::blocked_range<Eigen::Index>& r) {
        for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
          Rng rng(derive_seed(seed, static_cast<std::uint64_t>(i)));
          const double t = rng.uniform() * total;
          auto it = std::upper_bound(prefix.begin(), prefix.end(), t);
          if (it == prefix.end()) --it;
          // upper_bound never lands on a zero-area face: its prefix equals its predecessor's.
          const Eigen::Index f = it - prefix.begin();
          const double u = std::sqrt(rng.uniform());
          const double v = rng.uniform();
          const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f)).cast<double>();
          const Eigen::Vector3d b = mesh.vertices.col(mesh.faces(1, f)).cast<double>();
          const Eigen::Vector3d c = mesh.vertices.col(mesh.faces(2, f)).cast<double>();
          out.positions.col(i) = ((1.0 - u) * a + u * (1.0 - v) * b + u * v * c).cast<float>();
          out.normals.col(i) = mesh.face_normal(f);
          face[i] = static_cast<float>(f);
        }
      });
  out.properties["face"] = std::move(face);
  return out;
}

}  // namespace scanbench::metrics
