#pragma once
// The metric registry: every metric by dotted name with its declared parameters. A metric maps
// (ground truth, output) to a JSON object of named values (REFERENCE section 6 keys) and may add
// histograms under "histograms".
#include <functional>

#include "scanbench/core/point_cloud.h"
#include "scanbench/core/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {

class GroundTruth;  // metrics/ground_truth.h: the mesh with its distance oracles

struct MetricInput {
  const GroundTruth& truth;
  const PointCloud& output;                   ///< the algorithm's output points
  const PointCloud* scan = nullptr;           ///< the algorithm's input (for outlier residue)
  const TriangleMesh* output_mesh = nullptr;  ///< set for reconstructions
};

using MetricFn = std::function<Json(const MetricInput& in, const Json& params, RunContext& ctx)>;
using MetricRegistry = Registry<MetricFn>;

/// Every registered metric, in one explicit list (metrics/src/registry.cpp).
const MetricRegistry& registry();

}  // namespace scanbench::metrics
