#pragma once
// Internal to the algorithms module (clop.cpp, csw.cpp): neighbour search over the components of
// a Gaussian mixture.
//
// MixtureIndex: neighbour search over the components of a Gaussian mixture for kernels of the form
// exp(-(mu_s - q)^T (Sigma_s + v I)^-1 (mu_s - q) / 2).
//
// Components are grouped in size classes (largest covariance eigenvalue within a factor 2 of each
// other), each with its own kd-tree over the means. For a query with extra variance v, class c is
// searched within sqrt(32 (lambda_c + v)), lambda_c its largest eigenvalue: beyond it the
// exponent is below -16 for every component of the class (since x^T A^-1 x >= |x|^2 /
// lambda_max(A)), the e^-16 truncation of LOP's support radius h. Large components (few) get
// their own large radius without widening the search for the many small ones.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms::detail {

class MixtureIndex {
 public:
  /// Largest-eigenvalue ratio spanned by one size class.
  static constexpr double kClassRatio = 2.0;

  /// `base` (> 0) is the variance unit of the size classes (e.g. the smallest kernel variance).
  MixtureIndex(const GaussianMixture& m, double base) {
    const Eigen::Index k = m.size();
    std::vector<double> lmax(static_cast<std::size_t>(k));
    std::vector<int> cls(static_cast<std::size_t>(k));
    int max_cls = 0;
    for (Eigen::Index s = 0; s < k; ++s) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m.covariance(s).cast<double>(),
                                                        Eigen::EigenvaluesOnly);
      const double l = std::max(es.eigenvalues()(2), 0.0);
      lmax[static_cast<std::size_t>(s)] = l;
      int c =
          l <= base ? 0 : static_cast<int>(std::ceil(std::log(l / base) / std::log(kClassRatio)));
      c = std::clamp(c, 0, 48);
      cls[static_cast<std::size_t>(s)] = c;
      max_cls = std::max(max_cls, c);
    }
    std::vector<std::vector<Eigen::Index>> ids(static_cast<std::size_t>(max_cls + 1));
    std::vector<double> bound(static_cast<std::size_t>(max_cls + 1), 0.0);
    for (Eigen::Index s = 0; s < k; ++s) {
      const auto c = static_cast<std::size_t>(cls[static_cast<std::size_t>(s)]);
      ids[c].push_back(s);
      bound[c] = std::max(bound[c], lmax[static_cast<std::size_t>(s)]);
    }
    for (std::size_t c = 0; c < ids.size(); ++c) {
      if (ids[c].empty()) continue;
      auto b = std::make_unique<Bucket>();
      b->ids = std::move(ids[c]);
      b->bound = bound[c];
      b->centers.resize(3, static_cast<Eigen::Index>(b->ids.size()));
      for (std::size_t i = 0; i < b->ids.size(); ++i)
        b->centers.col(static_cast<Eigen::Index>(i)) = m.means.col(b->ids[i]);
      b->tree = std::make_unique<KdTree>(b->centers);
      buckets_.push_back(std::move(b));
    }
  }

  /// Search radius of every class for extra variance v (pass to for_each_near).
  std::vector<float> radii(double v) const {
    std::vector<float> r;
    for (const auto& b : buckets_)
      r.push_back(static_cast<float>(std::sqrt(32.0 * (b->bound + v)) * 1.001));
    return r;
  }

  /// Calls f(component index) for every component within its class radius of q, class by class
  /// in a fixed order (deterministic). `hits` is scratch space.
  template <class F>
  void for_each_near(const Eigen::Vector3f& q, const std::vector<float>& radii,
                     std::vector<std::pair<Eigen::Index, float>>& hits, F&& f) const {
    for (std::size_t c = 0; c < buckets_.size(); ++c) {
      const Bucket& b = *buckets_[c];
      b.tree->radius(q, radii[c], hits);
      for (const auto& h : hits)
        f(b.ids[static_cast<std::size_t>(h.first)]);
    }
  }

 private:
  struct Bucket {
    Eigen::Matrix3Xf centers;
    std::vector<Eigen::Index> ids;
    std::unique_ptr<KdTree> tree;
    double bound = 0.0;
  };
  std::vector<std::unique_ptr<Bucket>> buckets_;
};

}  // namespace scanbench::algorithms::detail
