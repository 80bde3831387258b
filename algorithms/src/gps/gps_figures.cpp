#include <cmath>
#include <numbers>

#include "scanbench/algorithms/gps/gps.h"

namespace scanbench::algorithms {

namespace {

CovarianceMesh cone(const Eigen::Matrix3d& apex) {
  constexpr int n = 8;
  Eigen::Matrix3Xd p(3, 1 + 2 * n);
  p.col(0) << 0, 1, 0;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    p.col(1 + i) << 0.5 * std::cos(a), 0.5, -0.5 * std::sin(a);
    p.col(1 + n + i) << std::cos(a), 0.0, -std::sin(a);
  }
  // Outward (counter-clockwise seen from outside, y up).
  PolygonFaces f;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    f.add({0, 1 + i, 1 + j});
    f.add({1 + i, 1 + n + i, 1 + n + j});
    f.add({1 + i, 1 + n + j, 1 + j});
  }
  CovarianceMesh m;
  m.means = p;
  m.covariances = vech(0.01 * Eigen::Matrix3d::Identity()).replicate(1, p.cols());
  m.covariances.col(0) = vech(apex);
  m.faces = std::move(f);
  return m;
}

template <class Cov>
CovarianceMesh cube(Cov cov) {
  Eigen::Matrix3Xd p(3, 8);
  for (int i = 0; i < 8; ++i)
    p.col(i) << (i & 1 ? 1 : -1), (i & 2 ? 1 : -1), (i & 4 ? 1 : -1);
  PolygonFaces f;
  f.add({0, 2, 3, 1});
  f.add({4, 5, 7, 6});
  f.add({0, 1, 5, 4});
  f.add({2, 6, 7, 3});
  f.add({0, 4, 6, 2});
  f.add({1, 3, 7, 5});
  CovarianceMesh m;
  m.means = p;
  m.covariances.resize(6, 8);
  for (int i = 0; i < 8; ++i)
    m.covariances.col(i) = vech(cov(Eigen::Vector3d(p.col(i))));
  m.faces = std::move(f);
  return m;
}

}  // namespace

std::vector<FigureInput> gps_figure_inputs() {
  using M = Eigen::Matrix3d;
  using V = Eigen::Vector3d;
  const M I = M::Identity();
  std::vector<FigureInput> out;
  out.push_back({"cone_isotropic", "Fig. 10: apex 0.01 I (ordinary Loop)", cone(0.01 * I)});
  out.push_back({"cone_singular", "Fig. 10: apex 1e-5 I (pointy apex)", cone(1e-5 * I)});
  out.push_back({"cone_vertical", "Fig. 10: apex diag(.001, .01, .01) (concave ridge)",
                 cone(V(0.001, 0.01, 0.01).asDiagonal())});
  out.push_back({"cone_horizontal", "Fig. 10: apex diag(.01, .001, .01) (smooth plateau)",
                 cone(V(0.01, 0.001, 0.01).asDiagonal())});
  out.push_back({"cone_flat", "Fig. 10: apex diag(1, 1e-5, 1) (sharp plateau)",
                 cone(V(1.0, 1e-5, 1.0).asDiagonal())});
  out.push_back({"cube_isotropic", "Fig. 9: 0.1 I everywhere (= Catmull-Clark, eq. 14)",
                 cube([&](const V&) -> M { return 0.1 * I; })});
  out.push_back({"cube_flat_diagonal", "Fig. 9: corners flat across their diagonal d",
                 cube([&](const V& c) -> M {
                   const V d = c.normalized();
                   return 0.1 * (I - 0.99 * d * d.transpose());
                 })});
  out.push_back({"cube_needle_diagonal", "Fig. 9: corners elongated along their diagonal d",
                 cube([&](const V& c) -> M {
                   const V d = c.normalized();
                   return 0.1 * (0.01 * I + d * d.transpose());
                 })});
  out.push_back({"cube_top_flat", "Fig. 9: top corners flat (diag(.1, .1, 1e-4)), bottom 0.1 I",
                 cube([&](const V& c) -> M {
                   return c.z() > 0 ? M(V(0.1, 0.1, 1e-4).asDiagonal()) : M(0.1 * I);
                 })});
  out.push_back({"cube_axis_z", "Fig. 9: corners at x > 0 elongated along z, the others 0.1 I",
                 cube([&](const V& c) -> M {
                   return c.x() > 0 ? M(V(0.001, 0.001, 0.1).asDiagonal()) : M(0.1 * I);
                 })});
  return out;
}

}  // namespace scanbench::algorithms
