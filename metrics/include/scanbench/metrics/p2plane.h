#pragma once
// Point-to-plane error (CLOP paper section 10.2): for output point q with closest
// ground-truth point p (exact oracle) and N_p the unit normal of the closest face,
// E(q) = <q - p, N_p>. Reported over |E|: mean, RMS, max, p50, p90, p99 (type-7 quantiles), each
// absolute and as a fraction of the ground-truth diagonal (`_rel`), plus a histogram of |E|.
#include <Eigen/Core>
#include <vector>

#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct P2PlaneParams {
  double hist_max = 0.01;  ///< histogram range [0, hist_max) of |E|, fraction of the diagonal
  int bins = 50;
  static void declare(ParamDeclarer<P2PlaneParams>& d) {
    d.real("hist_max", &P2PlaneParams::hist_max, Range::above(0.0), "diag",
           "upper end of the |E| histogram (values above count as overflow)");
    d.integer("bins", &P2PlaneParams::bins, Range::closed(1, 10000), "", "histogram bins");
  }
};

/// Signed E(q) for each closest point (same order as the queries).
Eigen::VectorXf point_to_plane_errors(const Eigen::Matrix3Xf& q,
                                      const std::vector<ClosestPoint>& closest);

/// The scores above from |E| (non-empty) and the ground-truth diagonal; shared by the mesh and
/// the point-cloud ground truth (point_truth.h).
Json p2plane_scores(const Eigen::VectorXf& abs_e, double diag, const P2PlaneParams& p);
/// Metric "accuracy.p2plane". Throws InputError for an empty output.
Json p2plane_metric(const MetricInput& in, const P2PlaneParams& p);

}  // namespace scanbench::metrics
