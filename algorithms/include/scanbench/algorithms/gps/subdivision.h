#pragma once
// One generic subdivision engine for Loop (Loop 1987) and Catmull-Clark (Catmull and Clark 1978)
// on polygon meshes, templated on the per-vertex value: 3-vectors (positions, the linear schemes)
// or the 9-vectors of the Gaussian-product dual space (GPS paper sec. 4, eq. 9-13, gps.h). The
// stencils (and their boundary rules) are written once as a sparse operator S per level, built
// from the connectivity alone and applied to any value dimension, so GP subdivision with equal
// isotropic covariances equals linear subdivision by construction (GPS eq. 14).
//
// Rules (every weight is non-negative, as the dual map requires, GPS sec. 5):
//  - Loop, interior vertex of valence n: (1 - n beta) v + beta sum(neighbours), with Loop's
//    beta = (5/8 - (3/8 + cos(2 pi/n)/4)^2)/n (Loop 1987; CGAL 5.5 Loop_mask_3), or Warren's
//    beta = 3/16 (n = 3), 3/(8n) (libigl's loop, used by the authors' demo). Interior edge
//    (a, b; opposite c, d): 3/8 (a + b) + 1/8 (c + d).
//  - Catmull-Clark, any polygon (triangles and n-gons are handled: after one level every face is
//    a quad): face point = face centroid; interior edge: (a + b + F0 + F1)/4; interior vertex
//    of valence n: (Q + 2R + (n - 3) v)/n with Q the mean of the adjacent face points and R the
//    mean of the edge midpoints (CGAL 5.5 CatmullClark_mask_3).
//  - Boundary (both schemes): edge point (a + b)/2; boundary vertex (p + 6 v + n)/8 with p, n its
//    two boundary neighbours: the boundary is the cubic B-spline of its polygon (Hoppe et al.
//    1994 without crease tags; CGAL's border_node). Interior edges and vertices next to the
//    boundary keep the interior rules.
//
// Vertex order of a refined mesh: the old vertices keep their indices (0..V-1), then one vertex
// per edge (V + e, edges in the order of their first corner), then (Catmull-Clark) one per face
// (V + E + f). So vertex i of a coarse level is vertex i of every finer level, which the limit
// tests use. Connectivity is a compact corner/twin table (CSR faces, one sort of the half-edge
// keys by core's radix sort) rather than CGAL's Surface_mesh: the dual map must stay within 2x
// of linear subdivision, and the table is rebuilt per level in a few linear passes.
//
// Limit analysis (limit_jets): limit position and first and second derivatives of the limit
// surface at every vertex of a mesh, by masks on the vertex values:
//  - Loop: limit (1 - n chi) v + chi sum p_j, chi = 1/(3/(8 beta) + n); tangents
//    (2/n) sum cos(2 pi j/n) p_j and (2/n) sum sin(2 pi j/n) p_j (neighbours counter-clockwise);
//    at regular vertices (valence 6) the surface is the quartic box spline, whose second
//    directional derivatives along the three lattice directions are the central differences
//    p_k + p_{k+3} - 2 v (k = 0, 1, 2), in a parameterisation (s, t) where neighbour k sits at
//    angle 60 k degrees at unit distance.
//  - Catmull-Clark (all faces at the vertex quads): limit (n^2 v + 4 sum e_j + sum d_j)/(n(n+5))
//    with e_j the edge and d_j the diagonal neighbours; tangents (Halstead et al. 1993)
//    sum A_n cos(2 pi j/n) e_j + (cos(2 pi j/n) + cos(2 pi (j+1)/n)) d_j (and sin), scaled by
//    1/(3n), A_n = 1 + cos(2 pi/n) + cos(pi/n) sqrt(2 (9 + cos(2 pi/n))); at regular vertices
//    (valence 4) the surface is the bicubic B-spline: value/derivative/second-derivative masks
//    (1,4,1)/6, (-1,0,1)/2, (1,-2,1) in each direction.
//  - Boundary vertices: limit (p + 4 v + n)/6 of the boundary B-spline, tangent (n - p)/2 along
//    it; the cross-boundary tangent is NOT an exact limit mask (the boundary rules above have no
//    exact one at irregular boundary vertices): the mean of the interior neighbours minus v.
//  Second derivatives are exact only at regular interior vertices (curvature of Loop and
//  Catmull-Clark surfaces is unbounded or zero at extraordinary points); elsewhere they are zero
//  and VertexKind says so.
#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

#include "scanbench/core/polygon_faces.h"

namespace scanbench::algorithms {

enum class SubdivisionScheme { Loop, CatmullClark };
/// Loop's vertex weight beta: Loop 1987 (the default, CGAL's) or Warren's 3/(8n) (libigl).
enum class LoopBeta { Loop, Warren };

struct SubdivisionOptions {
  SubdivisionScheme scheme = SubdivisionScheme::Loop;
  LoopBeta beta = LoopBeta::Loop;
};

template <int D>
using ValueMatrix = Eigen::Matrix<double, D, Eigen::Dynamic>;

/// Refines `values` (D x V, one column per vertex) over `faces` `levels` times with the chosen
/// scheme; on return `values` and `faces` hold the refined mesh (vertex order: header comment).
/// `where` prefixes error messages. Throws InputError naming the face for an index out of range,
/// a face with fewer than 3 or repeated vertices, a non-manifold edge (more than two faces) or
/// vertex (two fans), inconsistent orientation, or a non-triangle given to Loop.
/// D = 3 and D = 9 are instantiated. Parallel over vertices (TBB); every output value is summed
/// in a fixed order, so results do not depend on the thread count.
template <int D>
void subdivide_values(ValueMatrix<D>& values, PolygonFaces& faces, int levels,
                      const SubdivisionOptions& options, std::string_view where);

/// The engine's connectivity check alone (used by mesh.decimate before CGAL sees a mesh): throws
/// InputError as subdivide_values for an index out of range, a face with fewer than 3 or repeated
/// vertices, a non-manifold edge or vertex, inconsistent orientation, or (triangles_only) a
/// non-triangle.
void check_polygon_mesh(const PolygonFaces& faces, int num_vertices, bool triangles_only,
                        std::string_view where);

/// Vertex and face counts after `levels` levels (for the memory check, before allocating).
struct SubdivisionCounts {
  double vertices = 0, faces = 0, corners = 0;
};
SubdivisionCounts subdivision_counts(const PolygonFaces& faces, int num_vertices, int levels,
                                     SubdivisionScheme scheme);
/// Throws ParamError("<where>.levels: ...") when `levels` levels of a mesh with these counts
/// would need more memory than the process may use (RLIMIT_AS, else the physical memory),
/// estimated at `bytes_per_vertex` per vertex plus the connectivity; called before allocating.
void check_subdivision_memory(const PolygonFaces& faces, int num_vertices, int levels,
                              SubdivisionScheme scheme, double bytes_per_vertex,
                              std::string_view where);

enum class VertexKind : std::uint8_t {
  Regular = 0,        ///< interior, valence 6 (Loop) or 4 quads (Catmull-Clark): every jet exact
  Extraordinary = 1,  ///< interior, other valence: value and tangents exact, no second derivatives
  Boundary = 2,       ///< on the boundary: value and boundary tangent exact, cross tangent not
  Isolated = 3,       ///< in no face: value = the vertex, no derivatives
};

/// Value, first and second derivatives of the limit surface at every vertex (see the header).
template <int D>
struct LimitJets {
  ValueMatrix<D> value, du, dv, duu, duv, dvv;
  std::vector<VertexKind> kind;
};

/// Limit jets at every vertex of the mesh `faces` with vertex values `values` (usually a mesh
/// refined by subdivide_values, so that extraordinary vertices are isolated). Catmull-Clark
/// needs every face quads (InputError naming the first other face; subdivide once first).
template <int D>
LimitJets<D> limit_jets(const ValueMatrix<D>& values, const PolygonFaces& faces,
                        const SubdivisionOptions& options, std::string_view where);

}  // namespace scanbench::algorithms
