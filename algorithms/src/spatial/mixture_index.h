#pragma once
// Internal to the algorithms module (clop.cpp, csw.cpp): neighbour search over the components of
// a Gaussian mixture for kernels of the form exp(-(mu_s - q)^T (Sigma_s + v I)^-1 (mu_s - q) / 2).
//
// Components are grouped in size classes (largest covariance eigenvalue within a factor 2 of each
// other). For a query with extra variance v, class c is searched within sqrt(32 (lambda_c + v)),
// lambda_c its largest eigenvalue: beyond it the exponent is below -16 for every component of the
// class (since x^T A^-1 x >= |x|^2 / lambda_max(A)), the e^-16 truncation of LOP's support
// radius h. Large components (few) get their own large radius without widening the search for
// the many small ones.
//
// MixtureGrid: one uniform grid per class; the candidates come in the grid's order.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "scanbench/core/gaussian_mixture.h"
#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms::detail {

// The size classes of a mixture: components whose largest covariance eigenvalue lies within a
// factor kClassRatio of each other, in increasing size; `bound` is the class's largest eigenvalue.
struct SizeClass {
  std::vector<Eigen::Index> ids;  // increasing
  double bound = 0.0;
};

/// Largest-eigenvalue ratio spanned by one size class.
inline constexpr double kClassRatio = 2.0;

/// `base` (> 0) is the variance unit of the size classes (e.g. the smallest kernel variance).
inline std::vector<SizeClass> size_classes(const GaussianMixture& m, double base) {
  const Eigen::Index k = m.size();
  std::vector<double> lmax(static_cast<std::size_t>(k));
  std::vector<int> cls(static_cast<std::size_t>(k));
  int max_cls = 0;
  for (Eigen::Index s = 0; s < k; ++s) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m.covariance(s).cast<double>(),
                                                      Eigen::EigenvaluesOnly);
    const double l = std::max(es.eigenvalues()(2), 0.0);
    lmax[static_cast<std::size_t>(s)] = l;
    int c = l <= base ? 0 : static_cast<int>(std::ceil(std::log(l / base) / std::log(kClassRatio)));
    c = std::clamp(c, 0, 48);
    cls[static_cast<std::size_t>(s)] = c;
    max_cls = std::max(max_cls, c);
  }
  std::vector<SizeClass> classes(static_cast<std::size_t>(max_cls + 1));
  for (Eigen::Index s = 0; s < k; ++s) {
    SizeClass& c = classes[static_cast<std::size_t>(cls[static_cast<std::size_t>(s)])];
    c.ids.push_back(s);
    c.bound = std::max(c.bound, lmax[static_cast<std::size_t>(s)]);
  }
  classes.erase(std::remove_if(classes.begin(), classes.end(),
                               [](const SizeClass& c) { return c.ids.empty(); }),
                classes.end());
  return classes;
}

/// Search radius of a class for extra variance v: sqrt(32 (bound + v)) with a 0.1% margin.
inline float class_radius(double bound, double v) {
  return static_cast<float>(std::sqrt(32.0 * (bound + v)) * 1.001);
}

/// One uniform grid (NeighborGrid) of the means per size class: the means never move, and a
/// grid query is a few contiguous ranges found without a tree walk. Used by resample.clop's
/// attraction (one search per cell of particles) and normals.csw (one per particle).
class MixtureGrid {
 public:
  /// `base` (> 0) is the variance unit of the size classes (e.g. the smallest kernel variance);
  /// each class's grid has cells of half its radius for extra variance `v_cell` (> 0, the
  /// kernel variance of the searches).
  MixtureGrid(const GaussianMixture& m, double base, double v_cell) {
    for (SizeClass& c : size_classes(m, base)) {
      Eigen::Matrix3Xf centers(3, static_cast<Eigen::Index>(c.ids.size()));
      for (std::size_t i = 0; i < c.ids.size(); ++i)
        centers.col(static_cast<Eigen::Index>(i)) = m.means.col(c.ids[i]);
      const float cell = 0.5f * class_radius(c.bound, v_cell);
      Class cls{c.bound, NeighborGrid(centers, cell), {}};
      cls.sorted_ids.resize(c.ids.size());
      for (std::size_t k = 0; k < c.ids.size(); ++k)
        cls.sorted_ids[k] =
            c.ids[static_cast<std::size_t>(cls.grid.index(static_cast<Eigen::Index>(k)))];
      classes_.push_back(std::move(cls));
    }
  }

  /// Search radius of every class for extra variance v (pass to gather).
  std::vector<float> radii(double v) const {
    std::vector<float> r;
    for (const auto& c : classes_)
      r.push_back(class_radius(c.bound, v));
    return r;
  }

  /// Appends to `ids` every component within its class radius of q (|mu - q|^2 <= radius^2 in
  /// float), class by class, each in its grid's order (deterministic: depends only on q and the
  /// mixture), and to `d2` their squared distances |mu - q|^2 (dx^2 + (dy^2 + dz^2) in float,
  /// as Eigen's squaredNorm).
  /// `ranges` is scratch space.
  void gather(const Eigen::Vector3f& q, const std::vector<float>& radii,
              std::vector<GridRange>& ranges, std::vector<Eigen::Index>& ids,
              std::vector<float>& d2) const {
    for (std::size_t c = 0; c < classes_.size(); ++c) {
      const NeighborGrid& g = classes_[c].grid;
      const Eigen::Index* cls_ids = classes_[c].sorted_ids.data();
      const float r2 = radii[c] * radii[c];
      g.ranges_near(q, radii[c], ranges);
      std::size_t bound = ids.size();
      for (const GridRange& r : ranges)
        bound += static_cast<std::size_t>(r.end - r.begin);
      std::size_t m = ids.size();
      ids.resize(bound);
      d2.resize(bound);
      const float* x = g.x();
      const float* y = g.y();
      const float* z = g.z();
      for (const GridRange& r : ranges)
        for (Eigen::Index k = r.begin; k < r.end; ++k) {  // branch-free compaction
          const float dx = x[k] - q.x(), dy = y[k] - q.y(), dz = z[k] - q.z();
          ids[m] = cls_ids[k];
          d2[m] = dx * dx + (dy * dy + dz * dz);  // Eigen's squaredNorm order
          m += dx * dx + dy * dy + dz * dz <= r2 ? 1 : 0;
        }
      ids.resize(m);
      d2.resize(m);
    }
  }

 private:
  struct Class {
    double bound;
    NeighborGrid grid;
    std::vector<Eigen::Index> sorted_ids;  // component at each sorted position of the grid
  };
  std::vector<Class> classes_;
};

}  // namespace scanbench::algorithms::detail
