#pragma once
// The algorithm registry: every algorithm variant by dotted name ("normals.pca", "resample.clop",
// "peer.cgal_wlop", ...), with its declared parameters. An algorithm maps a point cloud to a point
// cloud, and may also produce a Gaussian mixture (mixture.hem) or a mesh (reconstructions).
#include <functional>
#include <optional>

#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::algorithms {

struct AlgorithmOutput {
  PointCloud points;                       ///< always set (the input cloud for mesh-only methods)
  std::optional<GaussianMixture> mixture;  ///< set by mixture producers
  std::optional<TriangleMesh> mesh;        ///< set by reconstructions
};

/// Runs the algorithm on `input` with effective parameters `params` (already validated against
/// the entry's schema; the function parses them into its parameter struct).
using AlgorithmFn =
    std::function<AlgorithmOutput(const PointCloud& input, const Json& params, RunContext& ctx)>;
using AlgorithmRegistry = Registry<AlgorithmFn>;

/// Every registered algorithm, in one explicit list (algorithms/src/registry.cpp).
const AlgorithmRegistry& registry();

/// Builds an entry from a free function `PointCloud f(const PointCloud&, const P&, RunContext&)`
/// or `AlgorithmOutput f(...)` and its declared parameter struct P.
template <class P, class F>
AlgorithmRegistry::Entry make_entry(std::string name, std::string doc, F f) {
  AlgorithmFn fn = [f, name](const PointCloud& in, const Json& params, RunContext& ctx) {
    P p = params_from_json<P>(params, name);
    return AlgorithmOutput{f(in, p, ctx)};
  };
  return {std::move(name), std::move(doc), schema_of<P>(), std::move(fn)};
}

}  // namespace scanbench::algorithms
