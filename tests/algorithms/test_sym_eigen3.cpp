// The batched symmetric 3x3 eigen decomposition (algorithms/src/mixtures/sym_eigen3.h) against
// the definition (A v = lambda v, V orthonormal, ascending values) and Eigen's iterative solver,
// and its lane independence: a matrix decomposes to the same bits in any batch, at any place, on
// every ISA path.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <vector>

#include "mixtures/sym_eigen3.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd.h"

namespace scanbench::algorithms {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d random_rotation(Rng& rng) {
  const Eigen::Quaterniond q(rng.normal(0.0, 1.0), rng.normal(0.0, 1.0), rng.normal(0.0, 1.0),
                             rng.normal(0.0, 1.0));
  return q.normalized().toRotationMatrix();
}

// Symmetric test matrices: random, covariances of flat and linear point sets (HEM's cases),
// repeated and zero eigenvalues, diagonal, exactly rank one, tiny and huge scales.
std::vector<Matrix3d> test_matrices() {
  Rng rng(17);
  std::vector<Matrix3d> out;
  for (int i = 0; i < 200; ++i) {
    Matrix3d a;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        a(r, c) = rng.normal(0.0, 1.0);
    out.push_back(a + a.transpose());
  }
  const std::vector<Vector3d> spectra = {
      {1e-8, 1.0, 2.0},      {1e-12, 0.5, 0.5}, {1.0, 1.0, 1.0},    {0.0, 0.0, 1.0},
      {0.0, 0.0, 0.0},       {-1.0, 0.0, 1.0},  {3.0, 3.0, 3.0001}, {1e-300, 1e-299, 1e-298},
      {1e150, 2e150, 3e150}, {1e-6, 1e-6, 5.0}};
  for (const Vector3d& s : spectra)
    for (int i = 0; i < 20; ++i) {
      const Matrix3d r = random_rotation(rng);
      out.push_back(r * s.asDiagonal() * r.transpose());
    }
  out.push_back(Vector3d(3.0, 1.0, 2.0).asDiagonal());
  out.push_back(Matrix3d::Zero());
  return out;
}

TEST(SymEigen3, SolvesTheEigenProblem) {
  const std::vector<Matrix3d> ms = test_matrices();
  const std::size_t n = ms.size();
  std::vector<Vector3d> values(n);
  std::vector<Matrix3d> vectors(n);
  detail::sym_eigen3(ms.data(), n, values.data(), vectors.data());
  const double eps = std::numeric_limits<double>::epsilon();
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3d& a = ms[i];
    // The Frobenius norm scaled by the largest entry (no underflow at 1e-300; Eigen 3.4's
    // stableNorm() of a fixed-size matrix trips its own assertion in debug builds).
    const double big = a.cwiseAbs().maxCoeff();
    const double norm = big > 0.0 ? big * (a / big).norm() : 0.0;
    const Eigen::SelfAdjointEigenSolver<Matrix3d> es(a);
    EXPECT_LE(values[i](0), values[i](1)) << i;
    EXPECT_LE(values[i](1), values[i](2)) << i;
    EXPECT_LE((vectors[i].transpose() * vectors[i] - Matrix3d::Identity()).norm(), 20 * eps) << i;
    for (int c = 0; c < 3; ++c) {
      EXPECT_LE(std::abs(values[i](c) - es.eigenvalues()(c)), 20 * eps * norm) << i;
      const Vector3d v = vectors[i].col(c);
      EXPECT_LE((a * v - values[i](c) * v).norm(), 20 * eps * norm) << i << " column " << c;
    }
  }
}

TEST(SymEigen3, EigenvaluesOnlyEqualTheFullDecomposition) {
  const std::vector<Matrix3d> ms = test_matrices();
  std::vector<Vector3d> full(ms.size()), only(ms.size());
  std::vector<Matrix3d> vectors(ms.size());
  detail::sym_eigen3(ms.data(), ms.size(), full.data(), vectors.data());
  detail::sym_eigen3(ms.data(), ms.size(), only.data(), nullptr);
  for (std::size_t i = 0; i < ms.size(); ++i)
    EXPECT_EQ(full[i], only[i]) << i;
}

// The same bits for a matrix alone, among others at every place of a packet group, and on every
// ISA path of this machine.
TEST(SymEigen3, ALaneDoesNotDependOnItsBatch) {
  const std::vector<Matrix3d> ms = test_matrices();
  const std::size_t n = ms.size();
  std::vector<Vector3d> values(n);
  std::vector<Matrix3d> vectors(n);
  detail::sym_eigen3(ms.data(), n, values.data(), vectors.data());
  for (const simd::Isa isa : simd::available()) {
    simd::ScopedIsa scoped(isa);
    for (std::size_t shift = 0; shift < 5; ++shift) {  // every place in a group of up to 32
      std::vector<Matrix3d> shifted(shift, Matrix3d::Identity() * 7.0);
      shifted.insert(shifted.end(), ms.begin(), ms.end());
      std::vector<Vector3d> v(shifted.size());
      std::vector<Matrix3d> w(shifted.size());
      detail::sym_eigen3(shifted.data(), shifted.size(), v.data(), w.data());
      for (std::size_t i = 0; i < n; ++i) {
        EXPECT_EQ(v[shift + i], values[i]) << simd::name(isa) << " " << i;
        EXPECT_EQ(w[shift + i], vectors[i]) << simd::name(isa) << " " << i;
      }
    }
    for (std::size_t i = 0; i < n; i += 7) {
      Vector3d v;
      Matrix3d w;
      detail::sym_eigen3(&ms[i], 1, &v, &w);
      EXPECT_EQ(v, values[i]) << simd::name(isa) << " " << i;
      EXPECT_EQ(w, vectors[i]) << simd::name(isa) << " " << i;
    }
  }
}

TEST(SymEigen3, NonFiniteMatricesFallBackWithoutHanging) {
  Matrix3d bad = Matrix3d::Identity();
  bad(0, 1) = bad(1, 0) = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Matrix3d> ms = {Matrix3d::Identity(), bad, Matrix3d::Identity() * 2.0};
  std::vector<Vector3d> values(3);
  std::vector<Matrix3d> vectors(3);
  detail::sym_eigen3(ms.data(), 3, values.data(), vectors.data());
  EXPECT_EQ(values[0], Vector3d(1.0, 1.0, 1.0));
  EXPECT_EQ(values[2], Vector3d(2.0, 2.0, 2.0));
  EXPECT_FALSE(values[1].allFinite());
}

}  // namespace
}  // namespace scanbench::algorithms
