#pragma once
// Internal to the algorithms module (hem.cpp, clop.cpp, csw.cpp): neighbour search over the
// components of a Gaussian mixture, and cell-batched WLOP density weights.
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

/// WLOP density v_j = 1 + sum_{j' != j, |p_j - p_j'| <= cutoff} theta_h(|p_j - p_j'|) of every
/// point (theta_h(r) = exp(-16 r^2 / h^2); `tree` indexes `pts`).
/// Points are batched by cells of width cutoff/4: the points within h + the cell's half diagonal of
/// the cell centre are gathered once into contiguous arrays, then every point of the cell sums
/// its kernel over them in one vectorised expression (the same sum as a per-point radius query,
/// without a kd-tree traversal per point). Thread-independent: a point's sum depends only on its
/// cell's candidate list.
inline std::vector<double> cell_density(const Eigen::Matrix3Xf& pts, const KdTree& tree, float h,
                                        float cutoff) {
  const Eigen::Index n = pts.cols();
  std::vector<double> v(static_cast<std::size_t>(n), 1.0);
  const float cell = cutoff / 4.0f;
  const Eigen::Vector3f lo = pts.rowwise().minCoeff();
  auto coord = [&](float x, float l) {
    return static_cast<std::uint64_t>(
        std::clamp(std::floor((x - l) / cell), 0.0f, static_cast<float>((1 << 21) - 1)));
  };
  std::vector<std::pair<std::uint64_t, Eigen::Index>> keys(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    keys[static_cast<std::size_t>(i)] = {(coord(pts(0, i), lo.x()) << 42) |
                                             (coord(pts(1, i), lo.y()) << 21) |
                                             coord(pts(2, i), lo.z()),
                                         i};
  std::sort(keys.begin(), keys.end());
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (i == 0 || keys[i].first != keys[i - 1].first) starts.push_back(i);
  starts.push_back(keys.size());
  const float radius = cutoff + 0.5f * std::sqrt(3.0f) * cell;
  const float c2 = cutoff * cutoff;
  const float k_theta = -16.0f / (h * h);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, starts.size() - 1, 1), [&](const auto& rr) {
    std::vector<std::pair<Eigen::Index, float>> hits;
    Eigen::ArrayXf cx, cy, cz, d2;
    for (std::size_t c = rr.begin(); c != rr.end(); ++c) {
      const std::uint64_t key = keys[starts[c]].first;
      const Eigen::Vector3f center =
          lo + cell * (Eigen::Vector3f(static_cast<float>(key >> 42),
                                       static_cast<float>((key >> 21) & ((1u << 21) - 1)),
                                       static_cast<float>(key & ((1u << 21) - 1))) +
                       Eigen::Vector3f::Constant(0.5f));
      tree.radius(center, radius, hits);
      const Eigen::Index m = static_cast<Eigen::Index>(hits.size());
      cx.resize(m);
      cy.resize(m);
      cz.resize(m);
      for (Eigen::Index k = 0; k < m; ++k) {
        const Eigen::Index i = hits[static_cast<std::size_t>(k)].first;
        cx[k] = pts(0, i);
        cy[k] = pts(1, i);
        cz[k] = pts(2, i);
      }
      for (std::size_t pi = starts[c]; pi < starts[c + 1]; ++pi) {
        const Eigen::Index j = keys[pi].second;
        d2 = (cx - pts(0, j)).square() + (cy - pts(1, j)).square() + (cz - pts(2, j)).square();
        // The point itself is among the candidates (theta(0) = 1): it stands for the leading 1.
        v[static_cast<std::size_t>(j)] =
            static_cast<double>((d2 <= c2).select((k_theta * d2).exp(), 0.0f).sum());
      }
    }
  });
  return v;
}

}  // namespace scanbench::algorithms::detail
