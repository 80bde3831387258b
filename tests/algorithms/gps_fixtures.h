#pragma once
// Small control meshes for the subdivision tests: closed and open triangle and quad meshes,
// regular lattices sampling a height function, and the cone of GPS Fig. 10.
#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <vector>

#include "scanbench/algorithms/gps/gps.h"
#include "scanbench/core/procedural.h"

namespace scanbench::algorithms::fixtures {

struct Mesh {
  Eigen::Matrix3Xd positions;
  PolygonFaces faces;
};

/// Keeps the vertices used by `faces` (renumbered in order of first use).
inline Mesh compact(const Eigen::Matrix3Xd& p, const PolygonFaces& faces) {
  std::vector<int> map(p.cols(), -1);
  Mesh m;
  m.faces = faces;
  int n = 0;
  for (int& v : m.faces.indices) {
    if (map[v] < 0) map[v] = n++;
    v = map[v];
  }
  m.positions.resize(3, n);
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    if (map[i] >= 0) m.positions.col(map[i]) = p.col(i);
  return m;
}

/// Cube-sphere of radius 1 (core's make_sphere) at a coarse resolution: a closed control mesh
/// of a known smooth original, with valences 3 to 6.
inline Mesh coarse_sphere(int resolution) {
  SphereParams sp;
  sp.resolution = resolution;
  const TriangleMesh t = make_sphere(sp);
  return {t.vertices.cast<double>(), faces_of(t)};
}

/// The coarse sphere without its faces above z = 0.4: an open mesh with one boundary loop.
inline Mesh open_sphere(int resolution) {
  const Mesh s = coarse_sphere(resolution);
  PolygonFaces kept;
  for (int f = 0; f < s.faces.num_faces(); ++f) {
    const int b = s.faces.offsets[f];
    const double z = (s.positions(2, s.faces.indices[b]) + s.positions(2, s.faces.indices[b + 1]) +
                      s.positions(2, s.faces.indices[b + 2])) /
                     3;
    if (z < 0.4) kept.add({s.faces.indices[b], s.faces.indices[b + 1], s.faces.indices[b + 2]});
  }
  return compact(s.positions, kept);
}

inline Mesh octahedron() {
  Mesh m;
  m.positions.resize(3, 6);
  m.positions << 1, -1, 0, 0, 0, 0, 0, 0, 1, -1, 0, 0, 0, 0, 0, 0, 1, -1;
  const int f[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                       {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (const auto& t : f)
    m.faces.add({t[0], t[1], t[2]});
  return m;
}

/// The octahedron with a fin: a third triangle {0, 2, 6} on edge 0-2 (face 8, non-manifold).
inline Mesh octahedron_with_fin() {
  Mesh m = octahedron();
  m.positions.conservativeResize(3, 7);
  m.positions.col(6) << 2, 2, 2;
  m.faces.add({0, 2, 6});
  return m;
}

/// The unit cube [-1, 1]^3 as 6 outward quads (GPS Fig. 9's control mesh).
inline Mesh quad_cube() {
  Mesh m;
  m.positions.resize(3, 8);
  for (int i = 0; i < 8; ++i)
    m.positions.col(i) << (i & 1 ? 1 : -1), (i & 2 ? 1 : -1), (i & 4 ? 1 : -1);
  m.faces.add({0, 2, 3, 1});  // z = -1
  m.faces.add({4, 5, 7, 6});  // z = +1
  m.faces.add({0, 1, 5, 4});  // y = -1
  m.faces.add({2, 6, 7, 3});  // y = +1
  m.faces.add({0, 4, 6, 2});  // x = -1
  m.faces.add({1, 3, 7, 5});  // x = +1
  return m;
}

/// The cube without its top face: an open quad mesh.
inline Mesh open_quad_cube() {
  Mesh c = quad_cube();
  PolygonFaces f;
  for (int i = 0; i < c.faces.num_faces(); ++i)
    if (i != 1) {
      const int b = c.faces.offsets[i];
      f.add({c.faces.indices[b], c.faces.indices[b + 1], c.faces.indices[b + 2],
             c.faces.indices[b + 3]});
    }
  return compact(c.positions, f);
}

/// (2k+1)^2 lattice vertices (i, j) in [-k, k]^2, index (j + k)(2k+1) + (i + k).
inline int lattice_centre(int k) {
  return k * (2 * k + 1) + k;
}

/// Regular triangle lattice: vertex (i, j) at h (i + j/2, j sqrt(3)/2) with height z(x, y);
/// every interior vertex has valence 6 and neighbour k at angle 60k degrees.
template <class Z>
Mesh triangle_lattice(int k, double h, Z z) {
  const int n = 2 * k + 1;
  Mesh m;
  m.positions.resize(3, n * n);
  for (int j = -k; j <= k; ++j)
    for (int i = -k; i <= k; ++i) {
      const double x = h * (i + 0.5 * j), y = h * j * std::sqrt(3.0) / 2;
      m.positions.col((j + k) * n + (i + k)) << x, y, z(x, y);
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      m.faces.add({a, b, c});
      m.faces.add({b, d, c});
    }
  return m;
}

/// Regular quad lattice: vertex (i, j) at h (i, j) with height z(x, y).
template <class Z>
Mesh quad_lattice(int k, double h, Z z) {
  const int n = 2 * k + 1;
  Mesh m;
  m.positions.resize(3, n * n);
  for (int j = -k; j <= k; ++j)
    for (int i = -k; i <= k; ++i)
      m.positions.col((j + k) * n + (i + k)) << h * i, h * j, z(h * i, h * j);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      m.faces.add({a, a + 1, a + n + 1, a + n});
    }
  return m;
}

}  // namespace scanbench::algorithms::fixtures
