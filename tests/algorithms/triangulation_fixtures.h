#pragma once
// Fixtures shared by the triangulate.bhattacharyya tests (test_triangulation.cpp,
// test_triangulation_candidates.cpp): surface mixtures, the thin sheets of GPS Fig. 8b, topology.
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <utility>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::algorithms::test {

// One Gaussian per vertex of `mesh`, flat in the tangent plane of the vertex normal (area-weighted
// face normals): spread `s` along the surface, 0.05 s across it.
inline GaussianMixture surface_mixture(const TriangleMesh& mesh, double s) {
  Eigen::Matrix3Xd n = Eigen::Matrix3Xd::Zero(3, mesh.num_vertices());
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f)).cast<double>();
    const Eigen::Vector3d b = mesh.vertices.col(mesh.faces(1, f)).cast<double>();
    const Eigen::Vector3d c = mesh.vertices.col(mesh.faces(2, f)).cast<double>();
    const Eigen::Vector3d fn = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k)
      n.col(mesh.faces(k, f)) += fn;
  }
  GaussianMixture m;
  m.resize(mesh.num_vertices());
  m.means = mesh.vertices;
  m.weights.setConstant(1.0f / static_cast<float>(mesh.num_vertices()));
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    const Eigen::Vector3d u = n.col(i).normalized();
    const Eigen::Matrix3d c = s * s * (Eigen::Matrix3d::Identity() - u * u.transpose()) +
                              0.0025 * s * s * u * u.transpose();
    m.set_covariance(i, c.cast<float>());
  }
  return m;
}

// `n` points on the unit sphere (normalised Gaussian triples). One draw per statement, z first:
// the order of a constructor's argument evaluations is unspecified, and GCC's (right to left)
// gave the data these tests were written against.
inline PointCloud unit_sphere_points(Eigen::Index n, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud pc;
  pc.positions.resize(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto z = static_cast<float>(rng.normal());
    const auto y = static_cast<float>(rng.normal());
    const auto x = static_cast<float>(rng.normal());
    pc.positions.col(i) = Eigen::Vector3f(x, y, z).normalized();
  }
  return pc;
}

// The chain points -> mixture.hem (defaults) -> triangulate.bhattacharyya (`params`) through the
// registry, at `threads` threads.
inline CovarianceMesh hem_then_triangulate(const PointCloud& pc, const Json& params, int threads) {
  const auto& hem = registry().at("mixture.hem");
  const auto& tri = registry().at("triangulate.bhattacharyya");
  RunContext ctx(9, threads);
  StageData d = hem.fn(pc, hem.params.validate(Json::object(), "t"), ctx);
  d = tri.fn(d, tri.params.validate(params, "t"), ctx);
  return d.covariance_mesh.value();
}

struct Topology {
  Eigen::Index v = 0, e = 0, f = 0, boundary = 0, over = 0;
  long euler() const { return static_cast<long>(v - e + f); }
};

inline Topology topology(const CovarianceMesh& m) {
  std::map<std::pair<int, int>, int> edges;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    const auto t = m.faces.face(f);
    for (int k = 0; k < 3; ++k) {
      const int a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      ++edges[{std::min(a, b), std::max(a, b)}];
    }
  }
  Topology t;
  t.v = m.num_vertices();
  t.f = m.num_faces();
  t.e = static_cast<Eigen::Index>(edges.size());
  for (const auto& [k, c] : edges) {
    t.boundary += c == 1;
    t.over += c > 2;
  }
  return t;
}

// GPS Fig. 8b: two parallel sheets closer to each other (0.05) than neighbouring means on a sheet
// (0.1), each Gaussian flat along its sheet (11 x 11 means per sheet).
inline GaussianMixture thin_cuboid_sheets() {
  const int g = 11;
  GaussianMixture m;
  m.resize(2 * g * g);
  m.weights.setConstant(1.0f / static_cast<float>(m.size()));
  const Eigen::Matrix3f c = Eigen::Vector3f(0.01f, 0.01f, 2.5e-5f).asDiagonal();
  for (int s = 0; s < 2; ++s)
    for (int i = 0; i < g; ++i)
      for (int j = 0; j < g; ++j) {
        const Eigen::Index k = (s * g + i) * g + j;
        m.means.col(k) = Eigen::Vector3f(0.1f * static_cast<float>(i), 0.1f * static_cast<float>(j),
                                         0.05f * static_cast<float>(s));
        m.set_covariance(k, c);
      }
  return m;
}

}  // namespace scanbench::algorithms::test
