#pragma once
// mesh.decimate: edge-collapse simplification of a triangle mesh to a coarse control mesh (the
// input of covariance inference and subdivision, GPS paper sec. 6.1, Fig. 7 "a coarse triangle
// mesh"; the paper does not say how its coarse meshes were made), by CGAL 5.5's
// Surface_mesh_simplification (Debian's libcgal-dev; CGAL stays inside
// gps/cgal_decimation.cpp, in the scanbench_algorithms_cgal object library).
//
// Policy (cost and placement of each collapse), parameter `policy`:
//  - lindstrom_turk (default, CGAL's default): Lindstrom and Turk 1998/1999, "Fast and memory
//    efficient polygonal simplification" / "Evaluation of memoryless simplification": the new
//    vertex minimises a combination of volume, boundary and shape changes, memoryless (computed
//    on the current mesh); a collapse whose placement is undefined is skipped.
//  - garland_heckbert: Garland and Heckbert 1997 quadric error metrics (CGAL's
//    GarlandHeckbert_plane_policies: sums of squared distances to the planes of the original
//    faces around each vertex, optimal placement).
// CGAL collapses the cheapest edge first and only edges that satisfy the link condition, so
// the topology is kept: a closed manifold stays closed, the genus and the boundary loops do not
// change. The simplification stops once the face count is at most the target: `faces` when > 0,
// else round(ratio * input faces) (at least 4). On a closed mesh a collapse removes two faces,
// so the result has `target` or `target - 1` faces; it has more when no collapsible edge is
// left (a tetrahedron cannot shrink further) - the output then keeps what CGAL could reach.
//
// Bad input (InputError naming the face or vertex, checked before CGAL sees the mesh, by the
// same connectivity check as the subdivision engine): no faces, a non-finite vertex, an index
// out of range, a face repeating a vertex, a non-manifold edge or vertex, inconsistent
// orientation. ParamError: a target that is not below the input's face count. The output holds
// only the vertices of the remaining faces, in the order of their input indices; deterministic
// (CGAL's collapse order depends only on the mesh). Timer: "cgal".
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

struct DecimateParams {
  int faces = 0;
  double ratio = 0.1;
  std::string policy = "lindstrom_turk";

  static void declare(ParamDeclarer<DecimateParams>& d) {
    d.integer("faces", &DecimateParams::faces, Range::closed(0, 1000000000), "",
              "target face count (0: use ratio); must be below the input's face count");
    d.real("ratio", &DecimateParams::ratio, Range::open_min(0.0, 1.0), "",
           "target face count as a fraction of the input's (used when faces = 0)");
    d.choice("policy", &DecimateParams::policy, {"lindstrom_turk", "garland_heckbert"},
             "collapse cost and placement: lindstrom_turk (Lindstrom-Turk 1998, CGAL's default) "
             "or garland_heckbert (quadric error metrics, Garland-Heckbert 1997)");
  }
};

/// The registered step (mesh -> mesh).
StageData decimate_mesh(const StageData& in, const DecimateParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
