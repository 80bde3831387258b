#pragma once
// Unoriented normal error: for output point q with unit normal n and the face normal
// n_gt of its exact closest ground-truth face, angle = arccos |n . n_gt| in degrees (0..90).
// Reported: normal_angle_mean_deg, normal_angle_rms_deg, normal_pgp5 and normal_pgp10 (share of
// points with angle < 5 and < 10 degrees), plus a histogram over 0..90 degrees. The output's
// normals are normalised first; NotApplicable when it has none, InputError for a zero normal.
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct NormalAngleParams {
  int bins = 90;
  static void declare(ParamDeclarer<NormalAngleParams>& d) {
    d.integer("bins", &NormalAngleParams::bins, Range::closed(1, 9000), "",
              "histogram bins over 0..90 degrees");
  }
};

/// Metric "normals.angle".
Json normal_angle_metric(const MetricInput& in, const NormalAngleParams& p);

}  // namespace scanbench::metrics
