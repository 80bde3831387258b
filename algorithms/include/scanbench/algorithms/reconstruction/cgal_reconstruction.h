#pragma once
// Reconstruction peers from CGAL 5.5 (Debian's libcgal-dev), wrapped as scanbench algorithms that
// consume points and produce a triangle mesh. CGAL stays inside cgal_reconstruction.cpp.
//
// peer.cgal_advancing_front: CGAL::advancing_front_surface_reconstruction, the greedy
// Delaunay-based surface of Cohen-Steiner and Da 2004 ("A greedy Delaunay-based surface
// reconstruction algorithm", The Visual Computer 20), the base of the GPS paper's triangulation of
// a mixture (GPS paper sec. 6). The surface grows from the Delaunay facet with the smallest
// circumradius; a candidate facet is rejected when its radius exceeds radius_ratio_bound times
// the radius of the facet it grows from, and beta is the maximal angle (radians) between
// adjacent facets for the "easy" cases of the paper. The mesh interpolates the input points.
//
// peer.cgal_scale_space: CGAL::Scale_space_surface_reconstruction_3 (Digne et al. 2011, "Scale
// space meshing of raw data point sets", Computer Graphics Forum 30(6)): the points are smoothed
// `iterations` times (the scale space), meshed at the coarsest scale, and the mesh is given on the
// original points (back-projection, the method of the paper; `original_positions` false keeps the
// smoothed ones). Smoothers: `weighted_pca` (projection onto the weighted PCA plane of the
// neighbours within a radius that CGAL estimates from `neighbors` and `samples` random points,
// fixed-seed) or `jet` (jet fitting, Cazals and Pouget 2005, `neighbors` nearest). Meshers:
// `alpha_shape` (the regular facets of the alpha shape of squared radius `radius`^2; radius 0 =
// the weighted_pca smoother's estimate, hence a ParamError with the jet smoother;
// `separate_shells`, `force_manifold`, `border_angle` as CGAL's Alpha_shape_mesher; our default
// force_manifold is true, CGAL's is false: then every facet whose two sides are both outside
// the alpha shape (every facet of a thin sampled surface) is output twice, once per orientation,
// and a sampled unit sphere comes out as two coincident layers of area 25.1 = 2 x 4 pi) or
// `advancing_front` (as above, radius_ratio_bound and beta; max_facet_length 0 = unbounded).
//
// Both return only the vertices referenced by a facet (in input order). Throws InputError for
// fewer than 4 points or invalid input, Error when CGAL returns no facet. Timer: "cgal".
#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

struct CgalAdvancingFrontParams {
  double radius_ratio_bound = 5.0;
  double beta = 0.52;

  static void declare(ParamDeclarer<CgalAdvancingFrontParams>& d) {
    d.real("radius_ratio_bound", &CgalAdvancingFrontParams::radius_ratio_bound, Range::above(0.0),
           "",
           "a candidate facet whose circumradius exceeds this multiple of its neighbour's is "
           "rejected (CGAL default 5)");
    d.real("beta", &CgalAdvancingFrontParams::beta, Range::open_min(0.0, 3.14159), "rad",
           "maximal angle between adjacent facets for the easy cases of Cohen-Steiner and Da "
           "2004 (CGAL default 0.52, about 30 deg)");
  }
};

struct CgalScaleSpaceParams {
  int iterations = 4;
  std::string smoother = "weighted_pca";
  int neighbors = 12;
  int samples = 300;
  std::string mesher = "alpha_shape";
  double radius = 0.0;
  bool separate_shells = false;
  bool force_manifold = true;
  double border_angle = 45.0;
  double max_facet_length = 0.0;
  double radius_ratio_bound = 5.0;
  double beta = 0.52;
  bool original_positions = true;

  static void declare(ParamDeclarer<CgalScaleSpaceParams>& d) {
    d.integer("iterations", &CgalScaleSpaceParams::iterations, Range::closed(1, 100), "",
              "smoothing steps of the scale space (increase_scale; CGAL example: 4)");
    d.choice("smoother", &CgalScaleSpaceParams::smoother, {"weighted_pca", "jet"},
             "weighted_pca (CGAL's default) or jet fitting");
    d.integer("neighbors", &CgalScaleSpaceParams::neighbors, Range::closed(3, 1000), "",
              "weighted_pca: mean neighbour count of the estimated radius; jet: k nearest");
    d.integer("samples", &CgalScaleSpaceParams::samples, Range::closed(1, 100000), "",
              "weighted_pca: points sampled (fixed seed) to estimate the radius");
    d.choice("mesher", &CgalScaleSpaceParams::mesher, {"alpha_shape", "advancing_front"},
             "alpha_shape (CGAL's default) or advancing_front");
    d.real("radius", &CgalScaleSpaceParams::radius, Range::closed(0.0, 1.0), "diag",
           "alpha_shape: ball radius (0 = the weighted_pca smoother's estimated radius)");
    d.flag("separate_shells", &CgalScaleSpaceParams::separate_shells,
           "alpha_shape: separate the surface into shells (CGAL)");
    d.flag("force_manifold", &CgalScaleSpaceParams::force_manifold,
           "alpha_shape: one layer (CGAL's force_manifold; its default false outputs each "
           "facet with exterior on both sides twice, once per orientation)");
    d.real("border_angle", &CgalScaleSpaceParams::border_angle, Range::closed(0.0, 180.0), "deg",
           "alpha_shape: angle limit of the border facets kept (CGAL)");
    d.real("max_facet_length", &CgalScaleSpaceParams::max_facet_length, Range::closed(0.0, 1.0),
           "diag", "advancing_front: longest facet edge (0 = unbounded)");
    d.real("radius_ratio_bound", &CgalScaleSpaceParams::radius_ratio_bound, Range::above(0.0), "",
           "advancing_front: as in peer.cgal_advancing_front");
    d.real("beta", &CgalScaleSpaceParams::beta, Range::open_min(0.0, 3.14159), "rad",
           "advancing_front: as in peer.cgal_advancing_front");
    d.flag("original_positions", &CgalScaleSpaceParams::original_positions,
           "the mesh connects the input points (Digne et al. 2011 back-projection); false: the "
           "smoothed points");
  }
};

/// peer.cgal_advancing_front.
StageData cgal_advancing_front(const StageData& in, const CgalAdvancingFrontParams& p,
                               RunContext& ctx);
/// peer.cgal_scale_space. ParamError for the jet smoother with alpha_shape and radius 0.
StageData cgal_scale_space(const StageData& in, const CgalScaleSpaceParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
