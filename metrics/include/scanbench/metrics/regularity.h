#pragma once
// Regularity of the output points (Huang et al. 2009; CLOP paper sections 8 and 10.2): d_i =
// distance from output point i to its nearest other output point (kd-tree; coincident points give
// 0). Reported: nn_dist_mean (length), nn_dist_var (population variance, 1/n; `_rel` divides by
// diagonal^2) and nn_dist_cv = std / mean (scale free; null when the mean is 0). Needs at least 2
// points.
#include "scanbench/core/run_context.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct RegularityParams {
  double hist_max = 0.02;  ///< histogram range of d_i, fraction of the diagonal
  int bins = 50;
  static void declare(ParamDeclarer<RegularityParams>& d) {
    d.real("hist_max", &RegularityParams::hist_max, Range::above(0.0), "diag",
           "upper end of the nearest-neighbour distance histogram");
    d.integer("bins", &RegularityParams::bins, Range::closed(1, 10000), "", "histogram bins");
  }
};

/// d_i for every point of `points` (at least 2 columns; InputError otherwise).
Eigen::VectorXf nearest_neighbour_distances(const Eigen::Matrix3Xf& points);

/// Metric "regularity.nn_dist".
Json regularity_metric(const MetricInput& in, const RegularityParams& p);

/// The same on a point-cloud ground truth (point_truth.h): it needs no mesh, only the output
/// points and the ground truth's diagonal (of the cropped ground-truth points) for `_rel`.
struct PointTruthInput;
Json point_truth_regularity(const PointTruthInput& in, const Json& params, RunContext& ctx);

}  // namespace scanbench::metrics
