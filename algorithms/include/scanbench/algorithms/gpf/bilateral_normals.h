#pragma once
// normals.bilateral: bilateral filtering of point normals (Huang et al. 2013, "Edge-aware point
// set resampling", section 4), the normal smoothing step of the GPF paper's pipeline (Lu et al.
// 2017, section 3 and Fig. 2(b): PCA normals -> bilateral normals -> GPF -> EAR upsampling).
//
// Every iteration replaces each normal n_i, simultaneously (Jacobi update: the result does not
// depend on the thread count), by
//   n_i' = normalise( sum_j theta(|p_i - p_j|) psi(n_i, s_ij n_j) s_ij n_j ),
//   psi(n_i, n_j) = exp( -((1 - n_i . n_j) / (1 - cos sigma_n))^2 ),
// over the points j within h of p_i (p_i itself included), with
//  - theta(r) = exp(-16 r^2 / h^2), scanbench's kernel convention (theta(h) = exp(-16)); Huang et
//    al. write theta(r) = exp(-r^2 / sigma_p^2), i.e. sigma_p = h / 4;
//  - signs aligned first: s_ij = sign(n_i . n_j) flips n_j into n_i's hemisphere, so PCA normals
//    with arbitrary signs are filtered as axes (the EAR paper assumes oriented normals); the
//    result keeps the sign of the input n_i.
// The points do not move: only the normals change. (CGAL's bilateral_smooth_point_set, scanbench's
// peer.cgal_bilateral, implements the same paper but also moves every point onto its neighbours'
// tangent planes; it is a different operator and is compared to as a peer.)
//
// If the weighted sum vanishes (only possible for exactly opposite normals cancelling after a
// tie in the alignment, never for a single neighbour) the input normal is kept.
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::algorithms {

struct BilateralNormalsParams {
  /// Spatial kernel width h as a fraction of the input bbox diagonal (theta = exp(-16 r^2/h^2)).
  double h = 0.05;
  /// Normal sharpness sigma_n of psi, degrees.
  double sigma_n = 30.0;
  /// Jacobi iterations.
  int iterations = 3;

  static void declare(ParamDeclarer<BilateralNormalsParams>& d) {
    d.real("h", &BilateralNormalsParams::h, Range::open_min(0.0, 1.0), "diag",
           "spatial kernel width as a fraction of the bbox diagonal; theta(r) = exp(-16 r^2/h^2) "
           "(Huang et al. 2013 sigma_p = h/4), neighbours within h");
    d.real("sigma_n", &BilateralNormalsParams::sigma_n, Range::open_min(0.0, 90.0), "deg",
           "normal sharpness sigma_n of psi = exp(-((1 - n_i.n_j)/(1 - cos sigma_n))^2)");
    d.integer("iterations", &BilateralNormalsParams::iterations, Range::closed(1, 100), "",
              "Jacobi iterations (all normals updated simultaneously)");
  }
};

/// The input with its normals filtered (positions and every other attribute unchanged).
/// Phase timer "bilateral". Throws InputError when the input has no normals (naming the chain
/// normals.pca -> normals.bilateral that supplies them), a normal of zero length or a non-finite
/// value, or when the bounding box has a zero diagonal with more than one point (all points
/// identical). A single point keeps its normal.
PointCloud bilateral_normals(const PointCloud& input, const BilateralNormalsParams& p,
                             RunContext& ctx);

}  // namespace scanbench::algorithms
