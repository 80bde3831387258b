#pragma once
// Surface metrics of a mesh output O against the ground-truth mesh G (metrics that score a mesh;
// evaluate_mesh runs them). S = the seeded area-uniform samples of O (surface_sampling.h; count
// and seed from evaluate_mesh: stream "eval.mesh_samples", 100000 by default, the sample count
// of accuracy.chamfer), each with the unit normal of its face of O.
//
//  surface.chamfer  The accuracy.chamfer scores with the one definition of chamfer.h
//    (chamfer_scores): accuracy = mean over s in S of d(s, G) (exact oracle, or the field path);
//    completeness = mean over the fixed seeded samples g of G (the same samples and count as for
//    points) of d(g, O), here the exact distance to the output SURFACE (closest point on O through
//    a GroundTruth built on O) rather than to the nearest output point; chamfer = accuracy +
//    completeness (means); hausdorff = max of both maxima; precision, recall, fscore at tau.
//    Same keys as accuracy.chamfer.
//  surface.normals  The normals.angle scores (normal_angle.h) of S: the unoriented angle
//    arccos |n_O(s) . n_G(p)| between the face normal of O at s and the face normal of G at the
//    closest point p of s. Same keys as normals.angle (normal_angle_mean_deg, _rms_deg, pgp5, 10).
//  surface.input_distance  The GPS paper's reconstruction error (Preiner et al. 2019, sec. 7.2,
//    Fig. 13): the distance of each input point to O, exact. Which points (`of`):
//      "scan"        the chain's input scan (the default, what existing configs measure);
//      "step_input"  the points the reconstruction consumed (MetricInput::step_input: e.g. the
//                    CLOP particles of `resample.clop -> normals.pca -> reconstruct.poisson` or
//                    of `resample.clop -> mixture.hem -> ...`), the fair quantity when two chains
//                    reconstruct from differently consolidated points; NotApplicable when the
//                    chain holds no points.
//    The effective `of` is recorded with the other parameters in the record's metric_params.
//    Reported: input_distance_mean, input_distance_rms (the RMSE of Fig. 14; both statistics,
//    neither is the verdict), input_distance_max (lengths, with _rel), the point count
//    input_distance_points, and the histogram "input_distance". The paper's input is a
//    consolidated scan without outliers; the scanner simulator marks its outliers (property
//    "outlier"), which are left out by default (skip_outliers) from whichever cloud is measured
//    when it carries the property. A consolidation's output carries no such marks; its residual
//    outliers (which dominate the RMSE) can be left out by `max_truth_distance` (0 = off): the
//    points farther than it from the ground truth (fraction of the diagonal), the same for every
//    chain. NotApplicable without the cloud asked for; InputError when no point is left.
#include <string>

#include "scanbench/core/run_context.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

/// The samples S of an output mesh as evaluate_mesh draws them (seed stream "eval.mesh_samples"
/// of ctx), so a heatmap drawn on them shows the samples the metrics scored. No properties.
PointCloud output_surface_samples(const TriangleMesh& mesh, Eigen::Index count,
                                  const RunContext& ctx);
/// The seed output_surface_samples draws with (recorded in a record's "scoring").
std::uint64_t output_surface_samples_seed(const RunContext& ctx);

struct InputDistanceParams {
  std::string of = "scan";  ///< "scan" or "step_input" (see above)
  bool skip_outliers = true;
  double max_truth_distance = 0.0;  ///< fraction of the diagonal; 0 = keep every point
  double hist_max = 0.01;           ///< histogram range, fraction of the diagonal
  int bins = 50;
  static void declare(ParamDeclarer<InputDistanceParams>& d) {
    d.choice("of", &InputDistanceParams::of, {"scan", "step_input"},
             "whose points are measured: the chain's input scan, or the points the "
             "reconstruction step consumed (the chain's points when it ended)");
    d.flag("skip_outliers", &InputDistanceParams::skip_outliers,
           "leave out the points the scanner marked as outliers (property \"outlier\") "
           "of the cloud measured");
    d.real("max_truth_distance", &InputDistanceParams::max_truth_distance, Range::at_least(0.0),
           "diag",
           "leave out the points farther than this from the ground truth (residual outliers of "
           "a consolidated step input, which carry no outlier marks); 0 = keep every point");
    d.real("hist_max", &InputDistanceParams::hist_max, Range::above(0.0), "diag",
           "upper end of the input distance histogram");
    d.integer("bins", &InputDistanceParams::bins, Range::closed(1, 10000), "", "histogram bins");
  }
};

struct ChamferParams;
struct NormalAngleParams;

/// Metric "surface.chamfer" (needs in.output_mesh and in.output_oracle).
Json surface_chamfer_metric(const MetricInput& in, const ChamferParams& p);
/// Metric "surface.normals".
Json surface_normals_metric(const MetricInput& in, const NormalAngleParams& p);
/// Metric "surface.input_distance" (needs in.output_oracle, and in.scan or in.step_input).
Json input_distance_metric(const MetricInput& in, const InputDistanceParams& p);

}  // namespace scanbench::metrics
