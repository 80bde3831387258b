#pragma once
// normals.pca: k-nearest-neighbour PCA normals (Hoppe et al. 1992): the normal of point p is the
// eigenvector of the smallest eigenvalue of the covariance of its k nearest neighbours (p itself
// included), found through core's KdTree.
//
// Orientation (parameter `orientation`):
//  - "sensor": n points toward the sensor that saw the point, (sensor_origins[scan_id] - p).n >= 0.
//    Needs scan_ids and sensor_origins (throws InputError otherwise).
//  - "propagate": Hoppe-style consistent propagation along a minimum spanning tree of the
//    symmetrised k-nearest-neighbour graph with edge cost 1 - |n_i.n_j| (Prim's algorithm, ties
//    broken by index). Each connected component starts at its point farthest from the cloud's
//    centroid, oriented away from the centroid (on a closed surface the farthest point's outward
//    normal points away from the centroid); every other normal is flipped to agree with its tree
//    parent. Serial (deterministic).
//  - "centroid": n points away from the centroid of the cloud (correct for star-shaped objects
//    only; cheap).
//  - "none": the eigenvector's sign as computed (arbitrary but deterministic).
//  - "auto" (default): "sensor" when scan_ids and sensor_origins are present, else "propagate".
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::algorithms {

struct PcaNormalsParams {
  /// Neighbours per point, the point itself included.
  int k = 16;
  /// One of auto, sensor, propagate, centroid, none (see above).
  std::string orientation = "auto";

  static void declare(ParamDeclarer<PcaNormalsParams>& d) {
    d.integer("k", &PcaNormalsParams::k, Range::closed(3, 1000), "",
              "nearest neighbours (the point included) whose covariance gives the normal");
    d.choice("orientation", &PcaNormalsParams::orientation,
             {"auto", "sensor", "propagate", "centroid", "none"},
             "auto = toward the sensor when scan_ids and sensor_origins are known, else "
             "propagate (MST over the k-NN graph, seeded outward at the point farthest from the "
             "centroid)");
  }
};

/// The input with unit normals set (every other attribute kept). Phase timers "pca" and
/// "orient". Throws InputError for fewer than 3 points, non-finite input, or "sensor"
/// orientation without scan ids and sensor origins.
PointCloud pca_normals(const PointCloud& input, const PcaNormalsParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
