#pragma once
// Meshes built inside the tests (no files needed): icosphere, square grid, random triangle soup;
// and a field-sampling helper shared by the field tests.
#include <map>
#include <utility>
#include <vector>

#include "scanbench/core/rng.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/metrics/distance_field.h"

namespace scanbench::metrics::testing {

/// Closed, outward-oriented icosphere of the given radius (20 * 4^level faces).
inline TriangleMesh icosphere(int level, float radius = 1.0f) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v)
    p.normalize();
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<Eigen::Vector3i> nf;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]),
                c = midpoint(tri[2], tri[0]);
      nf.push_back({tri[0], a, c});
      nf.push_back({tri[1], b, a});
      nf.push_back({tri[2], c, b});
      nf.push_back({a, b, c});
    }
    f = std::move(nf);
  }
  TriangleMesh m;
  m.vertices.resize(3, static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    m.vertices.col(static_cast<Eigen::Index>(i)) = radius * v[i];
  m.faces.resize(3, static_cast<Eigen::Index>(f.size()));
  for (std::size_t i = 0; i < f.size(); ++i)
    m.faces.col(static_cast<Eigen::Index>(i)) = f[i];
  return m;
}

/// Open square grid [0, size]^2 at z = 0 with n x n cells, normals +z.
inline TriangleMesh grid(int n, float size = 1.0f) {
  TriangleMesh m;
  m.vertices.resize(3, (n + 1) * (n + 1));
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      m.vertices.col(j * (n + 1) + i) = Eigen::Vector3f(size * i / n, size * j / n, 0.0f);
  m.faces.resize(3, 2 * n * n);
  int k = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.faces.col(k++) = Eigen::Vector3i(a, b, d);
      m.faces.col(k++) = Eigen::Vector3i(a, d, c);
    }
  return m;
}

/// Random triangle soup in [-1, 1]^3 (some triangles tiny or nearly degenerate).
inline TriangleMesh random_soup(int faces, std::uint64_t seed) {
  Rng rng(seed);
  TriangleMesh m;
  m.vertices.resize(3, 3 * faces);
  m.faces.resize(3, faces);
  for (int f = 0; f < faces; ++f) {
    const Eigen::Vector3f c(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const float s = static_cast<float>(rng.uniform(0.01, 0.4));
    for (int k = 0; k < 3; ++k) {
      m.vertices.col(3 * f + k) =
          c + s * Eigen::Vector3f(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
      m.faces(k, f) = 3 * f + k;
    }
  }
  return m;
}

/// Runs f.distances(q, out, outside) and returns one flag per query: 1 when it was listed
/// outside the band.
inline std::vector<char> field_outside_flags(const DistanceField& f, const Eigen::Matrix3Xf& q,
                                             Eigen::VectorXf& out) {
  std::vector<Eigen::Index> outside;
  f.distances(q, out, outside);
  std::vector<char> flags(static_cast<std::size_t>(q.cols()), 0);
  for (const Eigen::Index i : outside)
    flags[static_cast<std::size_t>(i)] = 1;
  return flags;
}

}  // namespace scanbench::metrics::testing
