#pragma once
// Outlier residue: the share of output points whose exact distance to the ground truth exceeds
// `multiple` x the scan noise sigma. sigma is the declared `noise` (fraction of the diagonal)
// or, when that is 0, estimated from the scan: the RMS of |p - clean| over its points with
// outlier == 0, where clean = (clean_x, clean_y, clean_z) is the noise-free hit point the scanner
// records (the range noise is along the ray, so RMS |p - clean| = sigma). Also reported:
// outlier_threshold and scan_noise (lengths) and scan_outlier_share, the same share for the scan
// itself (what the algorithm started from). NotApplicable when noise = 0 and there is no scan
// with clean positions.
#include <optional>
#include <vector>

#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct OutlierResidueParams {
  double multiple = 3.0;  ///< threshold in units of the scan noise sigma
  double noise = 0.0;     ///< scan noise sigma, fraction of the diagonal; 0 = estimate from scan
  static void declare(ParamDeclarer<OutlierResidueParams>& d) {
    d.real("multiple", &OutlierResidueParams::multiple, Range::above(0.0), "",
           "a point is residual outlier when farther than multiple x noise sigma");
    d.real("noise", &OutlierResidueParams::noise, Range::at_least(0.0), "diag",
           "scan noise sigma; 0 estimates it from the scan's clean_x/y/z properties");
  }
};

/// The scan's inliers (points with outlier == 0; every point without that property) and their
/// noise-free hits: index[k] is the point, clean.col(k) its (clean_x, clean_y, clean_z). Nothing
/// when the scan lacks clean_x/y/z. Shared by the noise estimate and the observed samples
/// (chamfer.h).
struct CleanHits {
  std::vector<Eigen::Index> index;
  Eigen::Matrix3Xf clean;
};
std::optional<CleanHits> clean_hits(const PointCloud& scan);

/// The scan noise sigma estimated from the scan: RMS |p - clean| over its points with
/// outlier == 0 (all points without the property); NaN when the scan lacks clean_x/y/z or has no
/// inlier. Also the noise of edges.p2plane's band_noise_multiple (sharp_edges.h).
double scan_noise_rms(const PointCloud& scan);

/// Metric "outliers.residue".
Json outlier_residue_metric(const MetricInput& in, const OutlierResidueParams& p);

}  // namespace scanbench::metrics
