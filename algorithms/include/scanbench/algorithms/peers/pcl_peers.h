#pragma once
// Peers: the Point Cloud Library 1.13 through its command-line programs (Debian's pcl-tools; the
// PCL development package would pull about 284 packages, mostly VTK and Qt). Each step runs the
// programs with the one external-program runner of reconstruct.poisson (run_program.h: private
// temporary directory, own process group, timeout, stderr tail in the error, exit 0 with no or
// an empty output file is an Error):
//   the input points -> binary PLY (x y z [nx ny nz], gray colours; io.h write_point_cloud_rgb)
//   -> pcl_ply2pcd -> the PCL program -> a PCD file (points) or a VTK file (pcl_poisson_
//   reconstruction) -> pcl_vtk2ply -> PLY mesh (read_mesh). pcl_outlier_removal writes LZF-
//   compressed PCD, which pcl_convert_pcd_ascii_binary turns into binary PCD first.
// Point outputs are read from the program's PCD directly (binary or ascii PCD v0.7: fields x y z
// and, when present, normal_x normal_y normal_z), not through pcl_pcd2ply: PCL's PointNormal
// carries unnamed padding fields, which pcl_pcd2ply writes as PLY list properties "_".
//
// A program missing from PATH is an Error before anything runs: "<step>: <program> not found in
// PATH; install the Debian package pcl-tools". Lengths are fractions of the input's bounding-box
// diagonal, multiplied by it for PCL. Timers: "pcl" (the program runs, conversions included).
//
// Threads: the programs used here are serial (one thread whatever the harness's count), so their
// bytes do not depend on it.
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// The installed pcl-tools package version (dpkg-query, asked once per process), or
/// "not installed" / "unknown"; for the run context's library list.
std::string pcl_tools_version();

// peer.pcl_mls: pcl_mls_smoothing (pcl::MovingLeastSquares, Alexa et al. 2003 as PCL implements
// it: a local plane by weighted PCA, then a polynomial of `polynomial_order` fitted over it, the
// point projected onto the polynomial). The neighbour weight is exp(-r^2/sqr_gauss_param) with
// sqr_gauss_param = radius^2 (PCL's recommended value, fixed by this adapter). Output: the
// projected points with PCL's MLS normals; points with too few neighbours for the fit are
// dropped by PCL, so the output may be smaller than the input and loses the other attributes.
// Upsampling (MovingLeastSquares::setUpsamplingMethod: sample local plane, random uniform density,
// voxel grid dilation) is not offered by the command-line program and is therefore not a
// parameter here.
struct PclMlsParams {
  double radius = 0.03;
  int polynomial_order = 2;
  double timeout_s = 600.0;

  static void declare(ParamDeclarer<PclMlsParams>& d) {
    d.real("radius", &PclMlsParams::radius, Range::open_min(0.0, 1.0), "diag",
           "search radius as a fraction of the bbox diagonal (pcl_mls_smoothing -radius; "
           "-sqr_gauss_param = radius^2)");
    d.integer("polynomial_order", &PclMlsParams::polynomial_order, Range::closed(0, 5), "",
              "order of the fitted polynomial (-polynomial_order; 0 or 1 = plane only)");
    d.real("timeout_s", &PclMlsParams::timeout_s, Range::open_min(0.0, 1e6), "s",
           "wall seconds before each PCL program is killed");
  }
};

// peer.pcl_outlier_removal: pcl_outlier_removal, -method statistical (pcl::StatisticalOutlier
// Removal: removed when the mean distance to the k nearest neighbours exceeds the global mean by
// more than std_ratio standard deviations) or radius (pcl::RadiusOutlierRemoval: removed when
// fewer than min_points OTHER points lie within radius). PCL keeps the input order, so the kept
// points are matched back to the input (bitwise positions) and keep every attribute.
struct PclOutlierParams {
  std::string method = "statistical";
  int k = 20;
  double std_ratio = 2.0;
  double radius = 0.02;
  int min_points = 8;
  double timeout_s = 600.0;

  static void declare(ParamDeclarer<PclOutlierParams>& d) {
    d.choice("method", &PclOutlierParams::method, {"statistical", "radius"},
             "pcl_outlier_removal -method");
    d.integer("k", &PclOutlierParams::k, Range::closed(1, 1000), "",
              "statistical: nearest neighbours of the mean distance (-mean_k)");
    d.real("std_ratio", &PclOutlierParams::std_ratio, Range::open_min(0.0, 100.0), "",
           "statistical: standard deviations above the mean (-std_dev_mul)");
    d.real("radius", &PclOutlierParams::radius, Range::open_min(0.0, 1.0), "diag",
           "radius: search radius as a fraction of the bbox diagonal (-radius)");
    d.integer("min_points", &PclOutlierParams::min_points, Range::closed(1, 100000), "",
              "radius: fewest other points within the radius (-min_pts)");
    d.real("timeout_s", &PclOutlierParams::timeout_s, Range::open_min(0.0, 1e6), "s",
           "wall seconds before each PCL program is killed");
  }
};

// peer.pcl_poisson: pcl_poisson_reconstruction (pcl::Poisson: PCL's own copy of an older
// PoissonRecon, pcl/surface/3rdparty/poisson4, screened by point_weight; manifold output, no
// density values and so no trimming). Needs oriented normals (chain normals.pca ->
// peer.pcl_poisson). The program's solver_divide and iso_divide (block solvers) keep their
// defaults (8), samples per node PCL's default.
struct PclPoissonParams {
  int depth = 8;
  double point_weight = 4.0;
  double timeout_s = 600.0;

  static void declare(ParamDeclarer<PclPoissonParams>& d) {
    d.integer("depth", &PclPoissonParams::depth, Range::closed(2, 14), "",
              "maximum octree depth (pcl_poisson_reconstruction -depth)");
    d.real("point_weight", &PclPoissonParams::point_weight, Range::closed(0.0, 1e6), "",
           "screening weight alpha (Kazhdan and Hoppe 2013; -point_weight; 0 = unscreened)");
    d.real("timeout_s", &PclPoissonParams::timeout_s, Range::open_min(0.0, 1e6), "s",
           "wall seconds before each PCL program is killed");
  }
};

/// peer.pcl_mls. Throws InputError for fewer than 3 points, Error when a program fails.
PointCloud pcl_mls(const PointCloud& in, const PclMlsParams& p, RunContext& ctx);
/// peer.pcl_outlier_removal. Throws InputError for empty input, Error when a program fails or its
/// output is not a subset of the input in order.
PointCloud pcl_outlier_removal(const PointCloud& in, const PclOutlierParams& p, RunContext& ctx);
/// peer.pcl_poisson. Throws InputError without normals, Error when a program fails.
StageData pcl_poisson(const StageData& in, const PclPoissonParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
