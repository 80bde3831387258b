#pragma once
// Ground truth as a point cloud (a laser scan, as in Tanks and Temples, Knapitsch et al. 2017, and
// ETH3D) instead of a mesh. A metric declares that it can run on one by giving
// Metric::run_point_truth (registry.h); every other metric needs a mesh and is recorded under
// "skipped" as not applicable. The point-capable ones:
//   accuracy.chamfer  with d(o, GT) = distance of output point o to its nearest GT point and
//                     d(g, O) = distance of GT point g to its nearest output point (both through
//                     the kd-tree): accuracy = mean d(o, GT), completeness = mean d(g, O),
//                     chamfer = their sum, hausdorff = the larger maximum, precision = share of O
//                     with d(o, GT) < tau, recall = share of GT with d(g, O) < tau, fscore =
//                     2PR/(P+R): Tanks and Temples' precision, recall and F-score at tau (the
//                     same chamfer_scores() as the mesh path; tau a fraction of the GT diagonal;
//                     chamfer_samples = the GT point count; `samples` and `path` do not apply).
//   accuracy.p2plane  when the GT points have normals: |<o - g, n_g>| with g the nearest GT point
//                     of o and n_g its normal (else not applicable).
//   regularity.nn_dist the output's nearest-neighbour spacing (regularity.h): no ground truth
//                     needed, the diagonal below only for `_rel`.
// The unit of every `_rel` value is the diagonal of the (cropped) GT points' bounding box.
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/bbox.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::metrics {

/// What a point-capable metric sees.
struct PointTruthInput {
  const PointCloud& truth;   ///< GT points (optional normals), aligned and cropped
  const PointCloud& output;  ///< output points, cropped like the truth
  double diagonal = 0.0;     ///< bbox diagonal of `truth`
};

/// The 4 x 4 alignment: a file holding 16 numbers (row-major, e.g. Tanks and Temples'
/// <scene>_trans.txt) or the 16 numbers themselves (commas or spaces). Throws ParamError naming
/// `where` for another count, a non-number or a last row other than 0 0 0 1.
Eigen::Matrix4d parse_transform(const std::string& text_or_file, const std::string& where);
/// Axis-aligned crop box "xmin,ymin,zmin,xmax,ymax,zmax" (in the aligned GT frame). ParamError
/// for another count or min > max.
BoundingBox parse_crop(const std::string& text, const std::string& where);

/// Applies x -> M x to positions (and normals by the inverse transpose of M's linear part,
/// renormalised); world coordinates (origin + local) are used and the result has origin zero.
PointCloud transformed(const PointCloud& c, const Eigen::Matrix4d& m);
/// The points inside the box (boundary included), with their attributes.
PointCloud cropped(const PointCloud& c, const BoundingBox& box);

/// accuracy.chamfer and accuracy.p2plane on a point-cloud ground truth (above), for registry.cpp.
/// p2plane throws NotApplicable when the truth has no normals.
Json point_truth_chamfer(const PointTruthInput& in, const Json& params, RunContext& ctx);
Json point_truth_p2plane(const PointTruthInput& in, const Json& params, RunContext& ctx);

/// The evaluate() of a point-cloud ground truth: the point-capable metrics' keys, "histograms",
/// "metric_params", "skipped" (every other metric: "not applicable: needs a ground-truth mesh"),
/// "output_points", "gt_points", "gt_diagonal". Names and parameters as evaluate() (evaluate.h);
/// a metric named explicitly that cannot run throws NotApplicable. InputError for empty inputs.
Json evaluate_point_truth(const PointCloud& truth, const PointCloud& output,
                          const std::vector<std::string>& metric_names, const Json& metric_params,
                          RunContext& ctx);

}  // namespace scanbench::metrics
