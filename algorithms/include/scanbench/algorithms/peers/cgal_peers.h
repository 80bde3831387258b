#pragma once
// Peers: CGAL 5.5 point-set processing functions wrapped as scanbench algorithms, to compare
// against (not to define) the methods of scanbench. CGAL stays inside cgal_peers.cpp.
//
// peer.cgal_wlop wraps CGAL::wlop_simplify_and_regularize_point_set (Huang et al. 2009 as
// implemented in CGAL), which differs from the WLOP the CLOP paper reviews (sections 3 and 7):
//  - its kernel is exp(-4 r^2 / R^2) with R = `neighbor_radius`, i.e. exp(-r^2/(R/2)^2);
//  scanbench's
//    kernel is exp(-16 r^2 / h^2) = exp(-r^2/(h/4)^2). The same kernel width therefore needs
//    R = h / 2: this adapter takes scanbench's h (fraction of the bbox diagonal) and passes
//    neighbor_radius = h/2 * diagonal. CGAL searches neighbours within R (= h/2, where its kernel
//    is exp(-4) ~ 0.018), scanbench within h.
//  - mu is hard-coded 0.45; the attraction weight is theta * (1 / v_j) without the 1/r of eq. 6 (an
//    L2 attraction), the repulsion weight is theta / r^2 * w; there is no L2 first iteration.
//  - particles: CGAL keeps floor(n * select_percentage / 100) points of a shuffle made with its own
//    fixed-seed rand48; the adapter shuffles the input first with the run's "particles" stream,
//    so the subset depends on the seed and is reproducible. Only shares in (0, 1] (no upsampling).
// peer.cgal_bilateral wraps CGAL::bilateral_smooth_point_set (Huang et al. 2013), run
// `iterations` times; it needs oriented normals: the input's own when present, else normals.pca
// with its defaults (toward the sensor when known). Its kernel radius is CGAL's own guess
// (0.95 x the largest k-NN distance), so it has no h. Each pass projects onto neighbours' tangent
// planes, which pushes points outward on convex parts: on a noisy unit sphere (5000 points, noise
// 1.5%) k = 30 with one pass halves the radial error, k = 60 with three passes doubles it, hence
// the modest defaults. It moves the points as well as the normals: scanbench's normals.bilateral
// (bilateral_normals.h) filters the normals of the same paper and leaves the points in place.
// peer.cgal_jet wraps CGAL::jet_smooth_point_set (Cazals and Pouget 2005 jet
// fitting): each point is projected onto the degree-`degree_fitting` jet fitted to its k nearest
// neighbours.
//
// All three run with CGAL::Parallel_tag (TBB) and double precision; bilateral and jet keep every
// attribute of the input (points move one to one), WLOP returns bare particles. Timers: "cgal".
// Throws InputError for empty or non-finite input (CGAL itself is never given invalid data).
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::algorithms {

struct CgalWlopParams {
  /// Kernel width in scanbench's convention (exp(-16 r^2/h^2)); passed to CGAL as h/2.
  double h = 0.04;
  int iterations = 10;
  /// Share of the input kept as particles, in (0, 1].
  double particles = 0.5;
  /// CGAL's require_uniform_sampling: the input density weights v_j of WLOP.
  bool uniform_sampling = true;

  static void declare(ParamDeclarer<CgalWlopParams>& d) {
    d.real("h", &CgalWlopParams::h, Range::open_min(0.0, 1.0), "diag",
           "kernel width in scanbench's convention exp(-16 r^2/h^2) as a fraction of the bbox "
           "diagonal; CGAL gets neighbor_radius = h/2 (its kernel is exp(-4 r^2/R^2))");
    d.integer("iterations", &CgalWlopParams::iterations, Range::closed(1, 1000), "",
              "CGAL number_of_iterations (no separate L2 first iteration)");
    d.real("particles", &CgalWlopParams::particles, Range::open_min(0.0, 1.0), "",
           "share of the input kept as particles (CGAL select_percentage / 100), seeded subset");
    d.flag("uniform_sampling", &CgalWlopParams::uniform_sampling,
           "CGAL require_uniform_sampling: use the input density weights v_j (WLOP)");
  }
};

struct CgalBilateralParams {
  int k = 30;
  double sharpness_angle = 25.0;
  int iterations = 1;

  static void declare(ParamDeclarer<CgalBilateralParams>& d) {
    d.integer("k", &CgalBilateralParams::k, Range::closed(3, 1000), "",
              "nearest neighbours (CGAL also derives its kernel radius from them)");
    d.real("sharpness_angle", &CgalBilateralParams::sharpness_angle, Range::open_min(0.0, 90.0),
           "deg",
           "normal sharpness angle sigma_n of the bilateral normal weight (Huang et al. 2013)");
    d.integer("iterations", &CgalBilateralParams::iterations, Range::closed(1, 100), "",
              "calls of bilateral_smooth_point_set");
  }
};

struct CgalJetParams {
  int k = 24;
  int degree_fitting = 2;
  int degree_monge = 2;

  static void declare(ParamDeclarer<CgalJetParams>& d) {
    d.integer("k", &CgalJetParams::k, Range::closed(6, 1000), "",
              "nearest neighbours of each jet fit (at least the jet's coefficient count)");
    d.integer("degree_fitting", &CgalJetParams::degree_fitting, Range::closed(1, 4), "",
              "degree of the fitted jet");
    d.integer("degree_monge", &CgalJetParams::degree_monge, Range::closed(1, 4), "",
              "degree of the Monge form (<= degree_fitting)");
  }
};

// peer.cgal_ear wraps CGAL::edge_aware_upsample_point_set (the upsampling step of EAR, Huang et
// al. 2013 section 5; the last step of the GPF paper's pipeline, Lu et al. 2017 Fig. 2(d)). It
// needs normals (filtered ones: normals.pca -> normals.bilateral, or filter.gpf's output) and
// never estimates them. CGAL returns only the NEW points: the adapter outputs the input points
// (first, unchanged, with their normals) followed by the new points with CGAL's normals.
//  - Kernel: CGAL's EAR kernel is exp(-4 r^2/R^2) with R = neighbor_radius (as its WLOP), so
//    scanbench's h maps to R = h/2 (h = 0 lets CGAL choose R = 3 x the average 6-NN spacing, which
//    CGAL also does whenever R is below that spacing). CGAL shrinks R by 0.75 per pass.
//  - Scale: EAR is known to misbehave on large coordinates (CGAL issue 4662): the input is centred
//    and scaled to a unit bbox diagonal before the call, and the new points scaled back.
//  - Points: `factor` x the input size, or `count` when > 0; either must exceed the input size.
//    CGAL stops after 20 passes, so fewer points may come back.
//  - CGAL's EAR is serial (ConcurrencyTag only reaches its spacing estimate) and deterministic.
struct CgalEarParams {
  double factor = 2.0;
  int count = 0;
  double sharpness_angle = 30.0;
  double edge_sensitivity = 1.0;
  double h = 0.0;

  static void declare(ParamDeclarer<CgalEarParams>& d) {
    d.real("factor", &CgalEarParams::factor, Range::above(1.0), "",
           "output size as a multiple of the input size (> 1; ignored when count > 0)");
    d.integer("count", &CgalEarParams::count, Range::at_least(0), "",
              "number of output points (input + new), > input size; 0 = use factor");
    d.real("sharpness_angle", &CgalEarParams::sharpness_angle, Range::closed(0.0, 90.0), "deg",
           "CGAL sharpness_angle: normal sharpness of the bilateral projection of new points");
    d.real("edge_sensitivity", &CgalEarParams::edge_sensitivity, Range::closed(0.0, 1.0), "",
           "CGAL edge_sensitivity: larger values insert more points near sharp edges");
    d.real("h", &CgalEarParams::h, Range::closed(0.0, 1.0), "diag",
           "kernel width in scanbench's convention exp(-16 r^2/h^2), fraction of the bbox "
           "diagonal; CGAL gets neighbor_radius = h/2; 0 = CGAL's own (3 x average spacing)");
  }
};

/// peer.cgal_ear. Output: input + new points, all with normals (other attributes dropped).
/// Throws InputError for fewer than 7 points, no or zero-length normals (naming the chain that
/// supplies them), a zero bbox diagonal, or an output size not above the input size.
PointCloud cgal_ear(const PointCloud& input, const CgalEarParams& p, RunContext& ctx);

/// peer.cgal_wlop. Throws InputError for bad input, ParamError when no particle remains.
PointCloud cgal_wlop(const PointCloud& input, const CgalWlopParams& p, RunContext& ctx);
/// peer.cgal_bilateral. Throws InputError for fewer than 3 points or bad input.
PointCloud cgal_bilateral(const PointCloud& input, const CgalBilateralParams& p, RunContext& ctx);
/// peer.cgal_jet. Throws InputError for fewer than k points or bad input, ParamError when
/// degree_monge > degree_fitting or k is below the jet's coefficient count.
PointCloud cgal_jet(const PointCloud& input, const CgalJetParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
