#pragma once
// Two-sided distances between the output points O and a fixed, seeded set S of uniform
// area-weighted ground-truth surface samples (GroundTruth::surface_samples):
//   accuracy     = mean over o in O of d(o, mesh)            (exact oracle, or the field path)
//   completeness = mean over s in S of min_o |s - o|          (kd-tree over O)
//   chamfer      = accuracy + completeness                    (means, not sums)
//   hausdorff    = max(max_o d(o, mesh), max_s min_o |s - o|)
//   precision    = share of O with d(o, mesh) < tau, recall = share of S with min_o |s-o| < tau,
//   fscore       = 2 P R / (P + R) (0 when both are 0)        (Tanks and Temples style)
// Lengths are reported absolute and as fractions of the diagonal (`_rel`); tau is a fraction of
// the ground-truth diagonal.
//
// Over what the scanner saw: a sample s is observed when a noise-free hit of the chain's scan
// (its clean_x/y/z, the scanner's outliers left out) lies within observed_radius of it; S_obs is
// the observed samples. completeness_observed and recall_observed are completeness and recall
// over S_obs, chamfer_observed = accuracy + completeness_observed, fscore_observed from precision
// and recall_observed; observed_share = |S_obs| / |S|. A sample the scanner never came near
// (a concavity, the underside) then counts against no method, as ETH3D and DTU mask unobserved
// space. Absent when the chain has no scan with clean positions; null when no sample is observed.
#include <cstdint>
#include <optional>
#include <vector>

#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct ChamferParams {
  double tau = 0.005;             ///< F-score threshold, fraction of the diagonal
  std::int64_t samples = 100000;  ///< surface samples for completeness and recall
  std::string path = "exact";     ///< accuracy distances: "exact" or "field"
  double observed_radius = 0.01;  ///< a sample is observed within this of a clean hit, diag
  double hist_max = 0.02;         ///< histogram range, fraction of the diagonal
  int bins = 50;
  static void declare(ParamDeclarer<ChamferParams>& d) {
    d.real("tau", &ChamferParams::tau, Range::above(0.0), "diag",
           "F-score distance threshold (Tanks and Temples style)");
    d.integer("samples", &ChamferParams::samples, Range::closed(1, 1e8), "",
              "fixed seeded uniform surface samples for completeness and recall");
    d.choice("path", &ChamferParams::path, {"exact", "field"},
             "oracle for output-to-surface distances (field: OpenVDB band, exact outside it)");
    d.real("observed_radius", &ChamferParams::observed_radius, Range::above(0.0), "diag",
           "a ground-truth sample counts as observed (the _observed scores) when a noise-free "
           "hit of the scan lies within this distance");
    d.real("hist_max", &ChamferParams::hist_max, Range::above(0.0), "diag",
           "upper end of the accuracy/completeness histograms");
    d.integer("bins", &ChamferParams::bins, Range::closed(1, 10000), "", "histogram bins");
  }
};

/// The scores above from the two one-sided distance sets, the one definition shared by
/// accuracy.chamfer (points) and surface.chamfer (mesh outputs, surface.h): acc[i] = distance
/// of output element i to the ground truth, comp[j] = distance of ground-truth sample j to the
/// output. `fallbacks` is reported as chamfer_field_fallbacks. Both vectors must be non-empty.
/// With `observed` (one flag per sample, observed_samples) the _observed scores are added.
Json chamfer_scores(const Eigen::VectorXf& acc, const Eigen::VectorXf& comp, double diag,
                    const ChamferParams& p, Eigen::Index fallbacks,
                    const std::vector<std::uint8_t>* observed = nullptr);

/// Which of `samples` the chain's scan observed: 1 where a clean hit of an inlier of in.scan
/// lies within radius (absolute length). Nothing when there is no scan or it has no clean_x/y/z
/// (a COLMAP or point-set input), or no inlier.
std::optional<std::vector<std::uint8_t>> observed_samples(const MetricInput& in,
                                                          const PointCloud& samples, double radius);

/// The accuracy distances of in.output by p.path (the shared closest points when exact);
/// *fallbacks receives the field path's fallback count.
Eigen::VectorXf accuracy_distances(const MetricInput& in, const ChamferParams& p,
                                   Eigen::Index* fallbacks);

/// Metric "accuracy.chamfer". Throws InputError for an empty output.
Json chamfer_metric(const MetricInput& in, const ChamferParams& p);

}  // namespace scanbench::metrics
