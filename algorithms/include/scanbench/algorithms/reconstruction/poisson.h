#pragma once
// reconstruct.poisson: screened Poisson surface reconstruction (Kazhdan and Hoppe 2013, the
// baseline of the GPS paper sec. 6, Fig. 13-14, there at octree depth 8) through COLMAP 3.8's
// `colmap poisson_mesher`, which bundles PoissonRecon 8.0 and its SurfaceTrimmer (Debian's
// colmap package; the program is run, not linked).
//
// Input: points with oriented normals (chain `normals.pca -> reconstruct.poisson`); InputError
// naming the missing normals and that chain otherwise. The points are written as a binary PLY
// with uchar red green blue (gray): COLMAP's reader finds no points without colours, writes
// nothing and exits 0. Output: the triangle mesh (the points ride along).
//
// The program runs in a private temporary directory with a timeout; a non-zero exit, a signal,
// the timeout, and exit 0 with no, empty or faceless output are Errors naming the step and
// ending with the program's last log lines (detail::run_program).
//
// Parameters (COLMAP 3.8 exposes only these of PoissonRecon's options; there is no
// samples_per_node):
//  - depth: maximum octree depth (PoissonRecon --depth).
//  - point_weight: the screening weight alpha of Kazhdan and Hoppe 2013 eq. 5 / sec. 4
//  (PoissonRecon
//    --pointWeight; 0 = unscreened Poisson). Default 4, PoissonRecon 8.0's own default (COLMAP's
//    own default is 1).
//  - trim: SurfaceTrimmer's --trim, an absolute threshold on PoissonRecon's per-vertex sampling
//    density value (log2-scaled; it depends on depth and sampling density); 0 = no trimming.
//    Our default is 0 because COLMAP's default 10 removed every vertex of a 20K-point unit
//    sphere at depth 8 (its density values lie in [5.6, 6.6]; trim 7 also leaves nothing).
//  - timeout_s: wall seconds before the program is killed.
// Determinism: PoissonRecon's output depends on its thread count (63520 vs 63523 vertices on
// that sphere with 1 vs 2 threads), so it always runs with one thread (--PoissonMeshing.
// num_threads 1): results are identical at any harness thread count. Timer: "poisson".
//
// Non-finite vertices (a defect of PoissonRecon 8.0, fixed upstream; COLMAP 4.0 bundles
// PoissonRecon 18.75): when the implicit function at a cube corner equals the iso-value exactly
// (in float), the Hermite fit along a crossing edge has its root at t = 1; COLMAP's build
// (-ffast-math) computes it a rounding step above 1, IsoSurface's GetIsoVertex keeps no root in
// [0, 1] and divides 0 by 0, and the clamp to [0, 1] lets the NaN through; the barycentre
// vertices of the polygons around it (added to triangulate them) are NaN too. Later PoissonRecon
// falls back to the linear root, t = 1: the corner, where the edge's other vertices lie. Seen on
// an ordinary scan: fandisk_block, preset moderate, seed 9, PCA normals, depth 8 (3 of 158841
// vertices). The handling, the same for every input: every vertex with a non-finite coordinate
// and every face using one are dropped (read_poisson_mesh), and a one-line note on stderr (the
// job's log in a run) gives the numbers; the mesh then has a hole there (boundary edges in
// mesh.facts). Nothing else is changed.
#include <filesystem>

#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::algorithms {

struct PoissonParams {
  int depth = 8;
  double point_weight = 4.0;
  double trim = 0.0;
  double timeout_s = 600.0;

  static void declare(ParamDeclarer<PoissonParams>& d) {
    d.integer("depth", &PoissonParams::depth, Range::closed(1, 14), "",
              "maximum octree depth (PoissonRecon --depth; the GPS paper's comparison used 8)");
    d.real("point_weight", &PoissonParams::point_weight, Range::closed(0.0, 1e6), "",
           "screening weight alpha (Kazhdan and Hoppe 2013; PoissonRecon --pointWeight; 0 = "
           "unscreened)");
    d.real("trim", &PoissonParams::trim, Range::closed(0.0, 100.0), "",
           "SurfaceTrimmer density threshold (absolute, log2 sampling density; 0 = keep all; "
           "COLMAP's 10 removes every vertex of a 20K-point sphere at depth 8)");
    d.real("timeout_s", &PoissonParams::timeout_s, Range::open_min(0.0, 1e6), "s",
           "wall seconds before colmap is killed");
  }
};

/// reconstruct.poisson. Throws InputError for points without normals, Error when colmap fails
/// (see above). The result holds the mesh.
StageData poisson(const StageData& in, const PoissonParams& p, RunContext& ctx);

/// A mesh read from PoissonRecon's output, less its non-finite vertices.
struct PoissonMesh {
  TriangleMesh mesh;
  Eigen::Index read_vertices = 0;     ///< vertices in the file
  Eigen::Index read_faces = 0;        ///< faces in the file
  Eigen::Index dropped_vertices = 0;  ///< vertices with a non-finite coordinate, dropped
  Eigen::Index dropped_faces = 0;     ///< faces using one of them, dropped
};

/// Reads colmap poisson_mesher's output `ply` (PoissonRecon's PLY: binary little endian, element
/// vertex with float x y z and any further scalars, element face with a list of vertex indices;
/// triangles only) and drops every vertex with a non-finite coordinate and every face that uses
/// one (drop_nonfinite_vertices). A file without such vertices gives read_mesh's mesh. Throws
/// IoError("<ply>: ...") for a missing, truncated or malformed file, a non-triangle face or an
/// index out of range. The mesh is not validated (it may have no face left).
PoissonMesh read_poisson_mesh(const std::filesystem::path& ply);

/// Removes every vertex of `mesh` with a non-finite coordinate and every face that uses one; the
/// other vertices keep their order and the faces are renumbered. Sets the dropped_* counts of the
/// result; the caller's `mesh` is moved into it.
PoissonMesh drop_nonfinite_vertices(TriangleMesh mesh);

}  // namespace scanbench::algorithms
