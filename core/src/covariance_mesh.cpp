#include "scanbench/core/covariance_mesh.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "scanbench/core/errors.h"

namespace scanbench {

void CovarianceMesh::resize(Eigen::Index v) {
  means.resize(3, v);
  covariances.resize(6, v);
  faces.clear();
}

Eigen::Matrix3d CovarianceMesh::covariance(Eigen::Index i) const {
  const auto c = covariances.col(i);
  Eigen::Matrix3d m;
  m << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
  return m;
}

void CovarianceMesh::set_covariance(Eigen::Index i, const Eigen::Matrix3d& c) {
  covariances.col(i) << c(0, 0), 0.5 * (c(0, 1) + c(1, 0)), 0.5 * (c(0, 2) + c(2, 0)), c(1, 1),
      0.5 * (c(1, 2) + c(2, 1)), c(2, 2);
}

void CovarianceMesh::validate(std::string_view where) const {
  const Eigen::Index v = num_vertices();
  if (v == 0) throw InputError(fmt::format("{}: covariance mesh has no vertices", where));
  if (covariances.cols() != v) {
    throw InputError(fmt::format("{}: covariance mesh has {} means, {} covariances", where, v,
                                 covariances.cols()));
  }
  if (faces.offsets.empty() || faces.offsets.front() != 0 ||
      static_cast<std::size_t>(faces.offsets.back()) != faces.indices.size()) {
    throw InputError(fmt::format("{}: covariance mesh face offsets are inconsistent", where));
  }
  for (Eigen::Index i = 0; i < v; ++i) {
    if (!means.col(i).allFinite() || !covariances.col(i).allFinite()) {
      throw InputError(fmt::format("{}: vertex {}: mean or covariance is not finite", where, i));
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariance(i), Eigen::EigenvaluesOnly);
    const Eigen::Vector3d ev = es.eigenvalues();
    // Positive definite relative to the largest eigenvalue's rounding: a covariance whose smallest
    // eigenvalue is not resolvable in double cannot be inverted by the dual map (GPS eq. 10).
    if (!(ev[0] > 0.0) || ev[0] <= 1e-15 * ev[2]) {
      throw InputError(fmt::format(
          "{}: vertex {}: covariance is not symmetric positive definite (eigenvalues {:g}, {:g}, "
          "{:g})",
          where, i, ev[0], ev[1], ev[2]));
    }
  }
  for (Eigen::Index f = 0; f < num_faces(); ++f) {
    const auto fv = faces.face(f);
    if (fv.size() < 3) {
      throw InputError(
          fmt::format("{}: face {} has {} vertices (at least 3 needed)", where, f, fv.size()));
    }
    for (std::size_t a = 0; a < fv.size(); ++a) {
      if (fv[a] < 0 || fv[a] >= v) {
        throw InputError(
            fmt::format("{}: face {}: vertex index {} out of range [0, {})", where, f, fv[a], v));
      }
      for (std::size_t b = 0; b < a; ++b) {
        if (fv[a] == fv[b]) {
          throw InputError(fmt::format("{}: face {}: vertex {} repeated", where, f, fv[a]));
        }
      }
    }
  }
}

TriangleMesh CovarianceMesh::mean_mesh() const {
  TriangleMesh m;
  m.vertices = means.cast<float>();
  m.origin = origin;
  Eigen::Index t = 0;
  for (Eigen::Index f = 0; f < num_faces(); ++f)
    t += faces.size(f) - 2;
  m.faces.resize(3, t);
  t = 0;
  for (Eigen::Index f = 0; f < num_faces(); ++f) {
    const auto fv = faces.face(f);
    for (std::size_t k = 1; k + 1 < fv.size(); ++k)
      m.faces.col(t++) << fv[0], fv[k], fv[k + 1];
  }
  return m;
}

}  // namespace scanbench
