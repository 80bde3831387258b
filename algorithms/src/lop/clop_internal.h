#pragma once
// Internal to the algorithms module: clop_project with the particles' storage order chosen, for
// the test that the order does not change the result (tests/algorithms/test_clop_oracle.cpp).
#include <Eigen/Core>

#include "scanbench/algorithms/clop.h"

namespace scanbench::algorithms::detail {

/// clop_project (what it computes: clop.h) with the particles stored during the iterations in
/// a spatial order (`spatial`, what clop_project does) or in index order. The result is the same
/// bit for bit: the storage order only changes which memory the passes touch.
void clop_project_stored(const GaussianMixture& m, Eigen::Matrix3Xf& particles, const ClopParams& p,
                         double h_abs, RunContext& ctx, bool spatial);

}  // namespace scanbench::algorithms::detail
