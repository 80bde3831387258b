#pragma once
// The output mesh's own facts (metric "mesh.facts"; all Better::None except non-manifold edges):
//   mesh_vertices, mesh_faces            counts as stored (a covariance mesh: its polygons);
//   mesh_unreferenced_vertices           vertices no face uses;
//   mesh_degenerate_faces                faces with a repeated index or zero area (triangles);
//   mesh_boundary_edges                  undirected edges used by exactly one face;
//   mesh_nonmanifold_edges               undirected edges used by three or more faces (a defect of
//                                        any surface: Better::Lower);
//   mesh_components                      connected components of the faces, two faces being
//                                        connected when they share a vertex;
//   mesh_closed                          every edge used by exactly two faces (and faces exist);
//   mesh_edges                           undirected edges;
//   mesh_euler                           Euler characteristic V - E + F, V counting the
//                                        referenced vertices (2 for a sphere, 0 for a torus, 1
//                                        for a disk, summed over components);
//   mesh_genus                           (2 C - chi) / 2 for a closed mesh (C components: the
//                                        number of handles; every closed surface embedded in
//                                        3-space is orientable); null for an open mesh, and
//                                        when 2 C - chi is odd or negative (sheets touching at
//                                        a vertex);
//   mesh_bytes                           bytes of the mesh representation, counted as the GPS
//                                        paper's table counts it (sec. 7.2, Fig. 13c): float32
//                                        x, y, z per vertex (12 B) and one int32 per face corner
//                                        (12 B per triangle); a covariance mesh adds 6 float32
//                                        per vertex (its symmetric covariance, 24 B). Headers and
//                                        polygon sizes are not counted.
// Edges of a polygon are its consecutive vertex pairs (cyclic). A covariance mesh's facts are
// those of its polygons, not of the fan triangulation scored by the other metrics.
#include <cstdint>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct MeshFacts {
  std::int64_t vertices = 0, faces = 0, unreferenced_vertices = 0, degenerate_faces = 0;
  std::int64_t boundary_edges = 0, nonmanifold_edges = 0, components = 0, edges = 0, euler = 0;
  bool closed = false;
  std::int64_t bytes = 0;
};

MeshFacts mesh_facts(const TriangleMesh& mesh);
MeshFacts mesh_facts(const CovarianceMesh& mesh);

struct MeshFactsParams {
  static void declare(ParamDeclarer<MeshFactsParams>&) {}
};

/// Metric "mesh.facts" (of in.output_covariance_mesh when set, else in.output_mesh).
Json mesh_facts_metric(const MetricInput& in, const MeshFactsParams& p);

}  // namespace scanbench::metrics
