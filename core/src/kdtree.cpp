#include "scanbench/core/kdtree.h"

#include <algorithm>
#include <nanoflann.hpp>

namespace scanbench {

namespace {
// nanoflann dataset adaptor over the columns of a 3 x n matrix (no copy).
struct ColumnAdaptor {
  const Eigen::Matrix3Xf& pts;
  std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(pts.cols()); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const {
    return pts(static_cast<Eigen::Index>(d), static_cast<Eigen::Index>(i));
  }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, ColumnAdaptor>,
                                                 ColumnAdaptor, 3, std::size_t>;

// Sort by (distance, index) so equal distances come out in a fixed order.
template <class Pair>
void sort_pairs(std::vector<Pair>& v) {
  std::sort(v.begin(), v.end(), [](const Pair& a, const Pair& b) {
    return a.second != b.second ? a.second < b.second : a.first < b.first;
  });
}
}  // namespace

struct KdTree::Impl {
  explicit Impl(const Eigen::Matrix3Xf& p, int leaf)
      : adaptor{p},
        tree(3, adaptor,
             nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<std::size_t>(leaf))) {
    tree.buildIndex();
  }
  ColumnAdaptor adaptor;
  Tree tree;
};

KdTree::KdTree(const Eigen::Matrix3Xf& points, int leaf_size)
    : impl_(std::make_unique<Impl>(points, leaf_size)) {}
KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

Eigen::Index KdTree::size() const {
  return impl_->adaptor.pts.cols();
}

void KdTree::knn(const Eigen::Vector3f& q, int k, std::vector<Eigen::Index>& indices,
                 std::vector<float>& dist2) const {
  indices.clear();
  dist2.clear();
  const auto n = static_cast<std::size_t>(std::min<Eigen::Index>(k, size()));
  if (n == 0) return;
  std::vector<std::size_t> idx(n);
  std::vector<float> d(n);
  const std::size_t found = impl_->tree.knnSearch(q.data(), n, idx.data(), d.data());
  std::vector<std::pair<Eigen::Index, float>> pairs(found);
  for (std::size_t i = 0; i < found; ++i)
    pairs[i] = {static_cast<Eigen::Index>(idx[i]), d[i]};
  sort_pairs(pairs);
  indices.reserve(found);
  dist2.reserve(found);
  for (const auto& [i, dd] : pairs) {
    indices.push_back(i);
    dist2.push_back(dd);
  }
}

Eigen::Index KdTree::nearest(const Eigen::Vector3f& q, float* dist2) const {
  if (size() == 0) return -1;
  std::size_t idx = 0;
  float d = 0.0f;
  nanoflann::KNNResultSet<float, std::size_t> rs(1);
  rs.init(&idx, &d);
  impl_->tree.findNeighbors(rs, q.data(), nanoflann::SearchParams());
  if (dist2 != nullptr) *dist2 = d;
  return static_cast<Eigen::Index>(idx);
}

void KdTree::radius(const Eigen::Vector3f& q, float r,
                    std::vector<std::pair<Eigen::Index, float>>& out, bool sorted) const {
  out.clear();
  std::vector<std::pair<std::size_t, float>> found;
  nanoflann::SearchParams sp;
  sp.sorted = false;
  impl_->tree.radiusSearch(q.data(), r * r, found, sp);
  out.reserve(found.size());
  for (const auto& [i, d] : found)
    out.emplace_back(static_cast<Eigen::Index>(i), d);
  if (sorted) sort_pairs(out);
}

}  // namespace scanbench
