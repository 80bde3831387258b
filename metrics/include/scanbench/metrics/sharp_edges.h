#pragma once
// Errors near the sharp edges of the ground truth: the region where the GPF paper (Lu et al.
// 2017, Fig. 7-9 and 17) and the CLOP paper (Preiner et al. 2014, Fig. 16) compare feature
// preservation. Neither paper defines a number for it (they show images); ours:
//  - a sharp edge is a ground-truth mesh edge shared by two faces whose normals differ by more
//    than `angle_deg` (30 degrees);
//  - an output point is "near a sharp edge" when its exact closest ground-truth point lies within
//    `band` (a fraction of the ground-truth bbox diagonal, 0.02) of a sharp edge;
//  - `edges.p2plane`: edge_p2plane_mean (+ _rel) = mean |<q - p, N_p>| over those points (p the
//    closest point, N_p its face normal, as accuracy.p2plane), edge_points, edge_share;
//  - `edges.normals`: edge_normal_angle_mean_deg = mean arccos|n . N_p| over those points (the
//    output's own normals, as normals.angle), edge_normal_pgp10.
// NotApplicable when the ground truth has no sharp edge (nothing to score); edge_points 0 with NaN
// means would not be comparable, so a mean over no point is also NotApplicable. The edge search
// is exact: the sharp edges are cut into pieces no longer than `band`, the pieces' midpoints go
// into the kd-tree, and every piece within band + band/2 of the closest point is tested.
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct SharpEdgeParams {
  double angle_deg = 30.0;
  double band = 0.02;
  static void declare(ParamDeclarer<SharpEdgeParams>& d) {
    d.real("angle_deg", &SharpEdgeParams::angle_deg, Range::open_min(0.0, 180.0), "deg",
           "a ground-truth edge is sharp when its two face normals differ by more than this");
    d.real("band", &SharpEdgeParams::band, Range::open_min(0.0, 1.0), "diag",
           "points whose closest ground-truth point is within this distance of a sharp edge");
  }
};

/// Metric "edges.p2plane".
Json sharp_edge_p2plane_metric(const MetricInput& in, const SharpEdgeParams& p);
/// Metric "edges.normals".
Json sharp_edge_normals_metric(const MetricInput& in, const SharpEdgeParams& p);

/// For each closest point: true when it lies within p.band (fraction of the diagonal) of a sharp
/// edge of `truth`. Throws NotApplicable when the mesh has no sharp edge.
std::vector<bool> near_sharp_edges(const GroundTruth& truth, const std::vector<ClosestPoint>& cps,
                                   const SharpEdgeParams& p);

}  // namespace scanbench::metrics
