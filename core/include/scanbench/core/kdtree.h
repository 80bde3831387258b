#pragma once
// The one spatial index of scanbench: a static 3D kd-tree (nanoflann) over the columns of a
// 3 x n float matrix. The tree keeps a reference to the matrix, which must outlive it and stay
// unchanged. Queries are const and thread-safe. Ties in distance are broken by index, so results
// are deterministic.
#include <Eigen/Core>
#include <memory>
#include <utility>
#include <vector>

namespace scanbench {

class KdTree {
 public:
  explicit KdTree(const Eigen::Matrix3Xf& points, int leaf_size = 16);
  ~KdTree();
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;

  Eigen::Index size() const;

  /// The k nearest points to q (fewer if the tree is smaller), nearest first, with their squared
  /// distances. Clears and fills both vectors.
  void knn(const Eigen::Vector3f& q, int k, std::vector<Eigen::Index>& indices,
           std::vector<float>& dist2) const;
  /// Index of the nearest point (-1 for an empty tree); *dist2 gets its squared distance.
  Eigen::Index nearest(const Eigen::Vector3f& q, float* dist2 = nullptr) const;
  /// Every point within distance r of q (|p - q| <= r) as (index, squared distance), sorted by
  /// distance when `sorted`, otherwise in tree order. Clears and fills `out`.
  void radius(const Eigen::Vector3f& q, float r, std::vector<std::pair<Eigen::Index, float>>& out,
              bool sorted = false) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scanbench
