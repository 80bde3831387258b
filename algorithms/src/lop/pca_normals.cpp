#include "scanbench/algorithms/lop/pca_normals.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <numeric>
#include <queue>
#include <tuple>
#include <vector>

#include "input_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms {

namespace {

constexpr const char* kPcaStage = "normals.pca";

// Orients along a minimum spanning tree of the symmetrised k-NN graph (Hoppe et al. 1992).
void propagate(const Eigen::Matrix3Xf& pts, const std::vector<Eigen::Index>& knn, int k,
               Eigen::Matrix3Xf& normals) {
  const Eigen::Index n = pts.cols();
  // Symmetric adjacency in CSR form.
  std::vector<Eigen::Index> degree(static_cast<std::size_t>(n) + 1, 0);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int a = 0; a < k; ++a) {
      const Eigen::Index j = knn[static_cast<std::size_t>(i * k + a)];
      if (j < 0 || j == i) continue;
      ++degree[static_cast<std::size_t>(i) + 1];
      ++degree[static_cast<std::size_t>(j) + 1];
    }
  }
  std::partial_sum(degree.begin(), degree.end(), degree.begin());
  std::vector<Eigen::Index> adj(static_cast<std::size_t>(degree.back()));
  std::vector<Eigen::Index> fill(degree.begin(), degree.end() - 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int a = 0; a < k; ++a) {
      const Eigen::Index j = knn[static_cast<std::size_t>(i * k + a)];
      if (j < 0 || j == i) continue;
      adj[static_cast<std::size_t>(fill[static_cast<std::size_t>(i)]++)] = j;
      adj[static_cast<std::size_t>(fill[static_cast<std::size_t>(j)]++)] = i;
    }
  }

  const Eigen::Vector3f centroid = pts.rowwise().mean();
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  Eigen::VectorXf dist = (pts.colwise() - centroid).colwise().squaredNorm().transpose();
  std::stable_sort(order.begin(), order.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return dist[a] > dist[b]; });

  std::vector<char> done(static_cast<std::size_t>(n), 0);
  // (cost, node, parent); smallest cost first, then smallest node index.
  using Item = std::tuple<float, Eigen::Index, Eigen::Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
  for (const Eigen::Index seed : order) {
    if (done[static_cast<std::size_t>(seed)]) continue;
    if (normals.col(seed).dot(pts.col(seed) - centroid) < 0.0f) normals.col(seed) *= -1.0f;
    heap.emplace(0.0f, seed, seed);
    while (!heap.empty()) {
      const auto [cost, v, parent] = heap.top();
      heap.pop();
      if (done[static_cast<std::size_t>(v)]) continue;
      done[static_cast<std::size_t>(v)] = 1;
      if (v != parent && normals.col(v).dot(normals.col(parent)) < 0.0f) normals.col(v) *= -1.0f;
      for (auto e = degree[static_cast<std::size_t>(v)];
           e < degree[static_cast<std::size_t>(v) + 1]; ++e) {
        const Eigen::Index w = adj[static_cast<std::size_t>(e)];
        if (done[static_cast<std::size_t>(w)]) continue;
        heap.emplace(1.0f - std::abs(normals.col(v).dot(normals.col(w))), w, v);
      }
    }
  }
}

}  // namespace

PointCloud pca_normals(const PointCloud& input, const PcaNormalsParams& p, RunContext& ctx) {
  detail::check_points(input, kPcaStage, 3);
  const Eigen::Index n = input.size();
  std::string mode = p.orientation;
  const bool has_sensor = input.has_scan_ids() && input.sensor_origins.cols() > 0;
  if (mode == "auto") mode = has_sensor ? "sensor" : "propagate";
  if (mode == "sensor" && !has_sensor) {
    throw InputError(fmt::format(
        "{}: orientation 'sensor' needs scan_ids and sensor_origins in the input", kPcaStage));
  }

  const Eigen::Matrix3Xf& pts = input.positions;
  const int k = static_cast<int>(std::min<Eigen::Index>(p.k, n));
  PointCloud out = input;
  out.normals.resize(3, n);
  std::vector<Eigen::Index> knn(static_cast<std::size_t>(n * k), -1);
  {
    auto timer = ctx.phase("pca");
    const KdTree tree(pts);
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 512), [&](const auto& range) {
      std::vector<Eigen::Index> idx;
      std::vector<float> d2;
      for (Eigen::Index i = range.begin(); i != range.end(); ++i) {
        tree.knn(pts.col(i), k, idx, d2);
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const Eigen::Index j : idx)
          mean += pts.col(j).cast<double>();
        mean /= static_cast<double>(idx.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const Eigen::Index j : idx) {
          const Eigen::Vector3d d = pts.col(j).cast<double>() - mean;
          cov += d * d.transpose();
        }
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        out.normals.col(i) = eig.eigenvectors().col(0).cast<float>().normalized();
        for (std::size_t a = 0; a < idx.size(); ++a)
          knn[static_cast<std::size_t>(i * k) + a] = idx[a];
      }
    });
  }
  auto timer = ctx.phase("orient");
  if (mode == "sensor") {
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3f to_sensor = input.sensor_origins.col(input.scan_ids[i]) - pts.col(i);
      if (out.normals.col(i).dot(to_sensor) < 0.0f) out.normals.col(i) *= -1.0f;
    }
  } else if (mode == "centroid") {
    const Eigen::Vector3f c = pts.rowwise().mean();
    for (Eigen::Index i = 0; i < n; ++i) {
      if (out.normals.col(i).dot(pts.col(i) - c) < 0.0f) out.normals.col(i) *= -1.0f;
    }
  } else if (mode == "propagate") {
    propagate(pts, knn, k, out.normals);
  }
  return out;
}

}  // namespace scanbench::algorithms
