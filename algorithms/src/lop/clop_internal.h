#pragma once
// Internal to the algorithms module: clop_project with two of its mechanisms switchable, for
// the tests that they do not change the result (tests/algorithms/test_clop_oracle.cpp).
#include <Eigen/Core>

#include "scanbench/algorithms/lop/clop.h"

namespace scanbench::algorithms::detail {

/// How clop_project runs; neither choice changes a bit of the result.
struct ClopInternals {
  /// The particles stored during the iterations in a spatial order (what clop_project does) or
  /// in index order: the storage order only changes which memory the passes touch.
  bool spatial_order = true;
  /// Each particle's attraction visits only the packets of candidates its reach bound admits
  /// (what clop_project does), or every packet of its cell: the skipped terms are all out of
  /// reach, so they would add nothing.
  bool skip_out_of_reach = true;
};

/// clop_project (what it computes: clop.h) run as `how` says.
void clop_project_stored(const GaussianMixture& m, Eigen::Matrix3Xf& particles, const ClopParams& p,
                         double h_abs, RunContext& ctx, const ClopInternals& how);

}  // namespace scanbench::algorithms::detail
