#include "scanbench/metrics/regularity.h"

#include <tbb/parallel_for.h>

#include <cmath>

#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/point_truth.h"
#include "stats.h"

namespace scanbench::metrics {

Eigen::VectorXf nearest_neighbour_distances(const Eigen::Matrix3Xf& points) {
  if (points.cols() < 2) throw InputError("regularity.nn_dist: needs at least 2 output points");
  const KdTree tree(points);
  Eigen::VectorXf d(points.cols());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, points.cols(), 1024),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      std::vector<Eigen::Index> idx;
                      std::vector<float> d2;
                      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
                        tree.knn(points.col(i), 2, idx, d2);
                        // With duplicates the point itself need not come first.
                        const std::size_t k = idx[0] == i ? 1 : 0;
                        d[i] = std::sqrt(d2[k]);
                      }
                    });
  return d;
}

namespace {

Json regularity_scores(const Eigen::Matrix3Xf& points, double diag, const RegularityParams& p) {
  const Eigen::VectorXf d = nearest_neighbour_distances(points);
  const double n = static_cast<double>(d.size());
  const double mean = detail::ordered_sum(d) / n;
  double var = 0.0;
  for (Eigen::Index i = 0; i < d.size(); ++i)
    var += (d[i] - mean) * (d[i] - mean);
  var /= n;
  Json j = Json::object();
  detail::put_length(j, "nn_dist_mean", mean, diag);
  j["nn_dist_var"] = var;
  j["nn_dist_var_rel"] = var / (diag * diag);
  j["nn_dist_cv"] = mean > 0.0 ? Json(std::sqrt(var) / mean) : Json(nullptr);
  j["histograms"]["nn_dist"] =
      detail::histogram(d / static_cast<float>(diag), 0.0, p.hist_max, p.bins, "diag");
  return j;
}

}  // namespace

Json regularity_metric(const MetricInput& in, const RegularityParams& p) {
  return regularity_scores(in.output.positions, in.truth.diagonal(), p);
}

Json point_truth_regularity(const PointTruthInput& in, const Json& params, RunContext&) {
  return regularity_scores(in.output.positions, in.diagonal,
                           params_from_json<RegularityParams>(params, "metric regularity.nn_dist"));
}

}  // namespace scanbench::metrics
