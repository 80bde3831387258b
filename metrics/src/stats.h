#pragma once
// Private helpers shared by the metric sources: order statistics, histograms, and the
// absolute + "_rel" (fraction of the ground-truth diagonal) reporting convention.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::metrics::detail {

/// Quantile p in [0, 1] of sorted values by linear interpolation between order statistics
/// (Hyndman-Fan type 7, numpy's default). NaN for no values.
double quantile_sorted(const std::vector<float>& sorted, double p);

/// Sum in index order (double): deterministic whatever the thread count.
double ordered_sum(const Eigen::VectorXf& v);

/// {"unit", "min", "max", "bins", "counts": [...], "underflow", "overflow", "count"}: `bins`
/// equal bins over [lo, hi); values >= hi go to overflow, < lo to underflow.
Json histogram(const Eigen::VectorXf& values, double lo, double hi, int bins,
               const std::string& unit);

/// out[key] = v and out[key + "_rel"] = v / diag (null when diag is 0 or v is NaN).
void put_length(Json& out, const std::string& key, double v, double diag);
/// Number or null for NaN/inf.
Json number(double v);

}  // namespace scanbench::metrics::detail
