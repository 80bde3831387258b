// The GPF paper's claims (Lu et al. 2017, section 5 and 6) measured on our scans, at one kernel
// width h for every method (scanbench's convention; GPF's h is h/2), every method at its
// defaults otherwise, no tuning per case:
//  - sharp edges (Fig. 7 cube 3% noise, Fig. 8 block 1.5% noise, Fig. 17): near a sharp edge
//    GPF's output has a lower point-to-plane error and a lower normal error than WLOP's and
//    CLOP's;
//  - outliers (Fig. 18, second row): with 20% uniform outliers GPF's outlier residue is below
//    WLOP's.
// "Near a sharp edge": the output point's closest ground-truth point lies within 0.02 of the
// bbox diagonal of a mesh edge whose dihedral angle exceeds 30 degrees (metrics::near_sharp_edges,
// the region of the edges.* metrics). Normal error: the angle
// arccos|n . N_p| to the closest face's normal, with n the PCA normal (k = 16) of the output
// cloud for every method (WLOP and CLOP carry no normals; the same estimator for all measures
// the geometry, not the carried normals). The figures are printed for the record.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "scanbench/algorithms/bilateral_normals.h"
#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/gpf.h"
#include "scanbench/algorithms/lop.h"
#include "scanbench/algorithms/pca_normals.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/sharp_edges.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::algorithms {
namespace {

// One kernel width for every method, by the paper's rule (section 4.3): h_GPF in [3 h0, 12 h0],
// h0 = d_bb / sqrt(N), "increased with the growing noise level": h_GPF = 400 noise h0 (12 h0 at
// the cube's 3%, 6 h0 at the block's 1.5%), i.e. scanbench's h = 2 h_GPF = 800 noise / sqrt(N)
// as a fraction of the diagonal. Fixed before measuring, the same for GPF, WLOP and CLOP.
double kernel_width(double noise, Eigen::Index n) {
  return 800.0 * noise / std::sqrt(static_cast<double>(n));
}

struct EdgeErrors {
  double p2plane = 0.0;     // mean |<q - p, N_p>| / diag over the points near a sharp edge
  double normal_deg = 0.0;  // mean arccos|n . N_p| (PCA normal of the output) near a sharp edge
  long points = 0;
  double residue = 0.0;  // share of all output points farther than 3 sigma from the surface
};

EdgeErrors measure(const metrics::GroundTruth& gt, const PointCloud& out, double sigma) {
  RunContext ctx(1);
  PcaNormalsParams pp;
  pp.orientation = "none";
  const PointCloud with_normals = pca_normals(out, pp, ctx);
  const auto cps = gt.closest_points(out.positions);
  // The region of the edges.* metrics (30 degrees, 0.02 of the diagonal).
  const std::vector<bool> near = metrics::near_sharp_edges(gt, cps, metrics::SharpEdgeParams{});
  const float diag = gt.diagonal();
  EdgeErrors e;
  long far = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const auto& cp = cps[static_cast<std::size_t>(i)];
    if (cp.distance > 3.0 * sigma) ++far;
    if (!near[static_cast<std::size_t>(i)]) continue;
    e.p2plane += std::abs((out.positions.col(i) - cp.point).dot(cp.normal)) / diag;
    e.normal_deg +=
        std::acos(std::min(1.0f, std::abs(with_normals.normals.col(i).dot(cp.normal)))) * 180.0 /
        M_PI;
    ++e.points;
  }
  if (e.points > 0) {
    e.p2plane /= static_cast<double>(e.points);
    e.normal_deg /= static_cast<double>(e.points);
  }
  e.residue = static_cast<double>(far) / static_cast<double>(out.size());
  return e;
}

PointCloud scan_of(const TriangleMesh& mesh, double noise, double outliers, std::uint64_t seed) {
  scanner::ScannerParams p;
  p.views = 8;
  p.resolution = 64;
  p.noise_sigma = noise;
  p.max_incidence_deg = 80.0;
  p.outlier_fraction = outliers;
  RunContext ctx(seed);
  return scanner::scan(mesh, p, ctx).cloud;
}

PointCloud run_gpf(const PointCloud& scan, double h, const std::string& s2_update = "eq11") {
  RunContext ctx(1);
  const PointCloud pca = pca_normals(scan, {}, ctx);
  BilateralNormalsParams bp;
  const PointCloud bil = bilateral_normals(pca, bp, ctx);
  GpfParams gp;
  gp.h = h;
  gp.s2_update = s2_update;
  return gpf(bil, gp, ctx);
}

PointCloud run_wlop(const PointCloud& scan, double h) {
  RunContext ctx(1);
  LopParams p;
  p.h = h;
  return wlop(scan, p, ctx);
}

PointCloud run_clop(const PointCloud& scan, double h) {
  RunContext ctx(1);
  ClopParams p;
  p.h = h;
  return clop(scan, p, ctx).points;
}

struct Compared {
  EdgeErrors gpf, gpf_fixed, wlop, clop, input;
};

Compared compare_on(const TriangleMesh& mesh, double noise, double outliers, bool with_clop) {
  const PointCloud scan = scan_of(mesh, noise, outliers, 3);
  const metrics::GroundTruth gt(mesh, 1);
  const double sigma = noise * gt.diagonal();
  Compared c;
  c.input = measure(gt, scan, sigma);
  const double h = kernel_width(noise, scan.size());
  c.gpf = measure(gt, run_gpf(scan, h), sigma);
  c.gpf_fixed = measure(gt, run_gpf(scan, h, "fixed"), sigma);
  c.wlop = measure(gt, run_wlop(scan, h), sigma);
  if (with_clop) c.clop = measure(gt, run_clop(scan, h), sigma);
  std::printf(
      "%zu scan points, noise %.3f, outliers %.2f, h %.4f\n"
      "  method  edge_points  p2plane_edge  normal_edge_deg  outlier_residue\n",
      static_cast<std::size_t>(scan.size()), noise, outliers, h);
  auto row = [](const char* name, const EdgeErrors& e) {
    std::printf("  %-12s  %11ld  %12.5f  %15.2f  %15.4f\n", name, e.points, e.p2plane, e.normal_deg,
                e.residue);
  };
  row("input", c.input);
  row("gpf", c.gpf);
  row("gpf_s2_fixed", c.gpf_fixed);
  row("wlop", c.wlop);
  if (with_clop) row("clop", c.clop);
  return c;
}

// Findings (the figures are printed; see also gpf.h, "s2 collapse"). With Algorithm 1 as
// written (s2 by eq. 11) the claim does NOT hold on our scans: s2 collapses below the sample
// spacing within two iterations, the E-step then gives each input to its nearest particle, the
// data term stops averaging and GPF's edge error ends above the input's, WLOP's and CLOP's. With
// s2 kept at s2_init (s2_update = fixed, the regime the paper describes in section 4.4), GPF has
// the lowest edge error on the cube (3% noise) but not on the block (1.5%), where WLOP and CLOP
// are lower. The normal error of the PCA normals of the outputs is dominated by the residual
// noise at these levels (40-47 degrees on the cube, 31-37 on the block for every method) and
// separates no method: it is printed, not asserted. The tests assert what holds.
TEST(GpfClaims, CubeThreePercentNoiseSharpEdges) {
  const Compared c = compare_on(make_cube({}), 0.03, 0.0, true);
  ASSERT_GT(c.gpf.points, 100);
  // Algorithm 1 with eq. 11: worse than both (finding, see above).
  EXPECT_GT(c.gpf.p2plane, c.wlop.p2plane);
  EXPECT_GT(c.gpf.p2plane, c.clop.p2plane);
  // s2 fixed at s2_init: the paper's claim holds.
  EXPECT_LT(c.gpf_fixed.p2plane, c.wlop.p2plane);
  EXPECT_LT(c.gpf_fixed.p2plane, c.clop.p2plane);
  EXPECT_LT(c.gpf_fixed.p2plane, c.input.p2plane);
}

TEST(GpfClaims, FandiskBlockOneAndAHalfPercentNoiseSharpEdges) {
  const Compared c = compare_on(make_fandisk_block({}), 0.015, 0.0, true);
  ASSERT_GT(c.gpf.points, 100);
  // The claim does not hold here with either s2 (finding, see above).
  EXPECT_GT(c.gpf.p2plane, c.wlop.p2plane);
  EXPECT_GT(c.gpf.p2plane, c.clop.p2plane);
  EXPECT_GT(c.gpf_fixed.p2plane, c.wlop.p2plane);
  EXPECT_LT(c.gpf_fixed.p2plane, c.input.p2plane);
}

TEST(GpfClaims, TwentyPercentOutliersResidueBelowWlop) {
  // The paper's claim (Fig. 18) holds with either s2.
  const Compared c = compare_on(make_cube({}), 0.01, 0.2, false);
  EXPECT_LT(c.gpf.residue, c.wlop.residue);
  EXPECT_LT(c.gpf_fixed.residue, c.wlop.residue);
}

}  // namespace
}  // namespace scanbench::algorithms
