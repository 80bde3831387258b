// mesh.decimate (CGAL 5.5 edge collapse): the target face count is reached, the result is a
// consistently oriented manifold with the input's topology (closed stays closed, Euler
// characteristic and boundary kept, checked by metrics' independent mesh_facts), its vertices
// stay near the smooth original, runs are deterministic, and bad input is an error naming the
// face, vertex or parameter.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "gps_fixtures.h"
#include "scanbench/algorithms/gps/decimate.h"
#include "scanbench/algorithms/gps/gps.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/mesh_facts.h"

namespace scanbench::algorithms {
namespace {

TriangleMesh decimate(const TriangleMesh& m, int faces, double ratio = 0.1,
                      const char* policy = "lindstrom_turk") {
  RunContext ctx(1);
  DecimateParams p;
  p.faces = faces;
  p.ratio = ratio;
  p.policy = policy;
  StageData in;
  in.mesh = m;
  return *decimate_mesh(in, p, ctx).mesh;
}

std::int64_t euler(const metrics::MeshFacts& f) {
  const std::int64_t edges = (3 * f.faces + f.boundary_edges) / 2;
  return f.vertices - edges + f.faces;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Decimate, ReachesTheFaceCountAndKeepsAClosedManifold) {
  SphereParams sp;
  sp.resolution = 8;  // 768 triangles
  TorusParams tp;
  tp.major_segments = 32;
  tp.minor_segments = 16;  // 1024 triangles
  const TriangleMesh sphere = make_sphere(sp), torus = make_torus(tp);
  for (const char* policy : {"lindstrom_turk", "garland_heckbert"}) {
    for (const auto& [name, mesh, chi] :
         {std::tuple{"sphere", sphere, 2}, std::tuple{"torus", torus, 0}}) {
      SCOPED_TRACE(std::string(name) + " " + policy);
      for (int target : {200, 101, 64}) {
        const TriangleMesh d = decimate(mesh, target, 0.1, policy);
        // A collapse removes two faces of a closed mesh: target or target - 1 remain.
        EXPECT_LE(d.num_faces(), target);
        EXPECT_GE(d.num_faces(), target - 1);
        const metrics::MeshFacts f = metrics::mesh_facts(d);
        EXPECT_TRUE(f.closed);
        EXPECT_EQ(f.boundary_edges, 0);
        EXPECT_EQ(f.nonmanifold_edges, 0);
        EXPECT_EQ(f.unreferenced_vertices, 0);
        EXPECT_EQ(f.components, 1);
        EXPECT_EQ(euler(f), chi);
        // Manifold vertices and one orientation (the subdivision engine's check).
        EXPECT_NO_THROW(
            check_polygon_mesh(faces_of(d), static_cast<int>(d.num_vertices()), true, "decimated"));
      }
      // ratio: round(0.25 * faces).
      const TriangleMesh r = decimate(mesh, 0, 0.25, policy);
      const auto want = std::llround(0.25 * static_cast<double>(mesh.num_faces()));
      EXPECT_LE(r.num_faces(), want);
      EXPECT_GE(r.num_faces(), want - 1);
    }
  }
}

TEST(Decimate, VerticesStayNearTheSmoothOriginal) {
  SphereParams sp;
  sp.resolution = 16;  // 3072 triangles on the unit sphere
  // Lindstrom-Turk keeps the volume, so the coarse vertices sit slightly outside the sphere:
  // by a fraction of the sagitta of a 200-triangle tessellation (edge ~0.38: ~0.025).
  const TriangleMesh d = decimate(make_sphere(sp), 200);
  for (Eigen::Index v = 0; v < d.num_vertices(); ++v)
    EXPECT_NEAR(d.vertices.col(v).cast<double>().norm(), 1.0, 0.04) << v;
}

TEST(Decimate, AnOpenMeshKeepsItsBoundaryLoop) {
  const fixtures::Mesh open = fixtures::open_sphere(8);
  const TriangleMesh m = triangle_mesh_of(open.positions, open.faces);
  const metrics::MeshFacts before = metrics::mesh_facts(m);
  ASSERT_GT(before.boundary_edges, 0);
  const TriangleMesh d = decimate(m, 150);
  const metrics::MeshFacts after = metrics::mesh_facts(d);
  EXPECT_LE(after.faces, 150);
  EXPECT_FALSE(after.closed);
  EXPECT_GT(after.boundary_edges, 0);
  EXPECT_EQ(after.nonmanifold_edges, 0);
  EXPECT_EQ(euler(after), euler(before));  // still a disc
}

TEST(Decimate, IsDeterministicAndRegistered) {
  SphereParams sp;
  sp.resolution = 8;
  const TriangleMesh m = make_sphere(sp);
  const TriangleMesh a = decimate(m, 120), b = decimate(m, 120);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.faces, b.faces);
  const auto& entry = registry().at("mesh.decimate");
  EXPECT_TRUE(entry.fn.io.consumes.has(DataKind::Mesh));
  RunContext ctx(1);
  StageData in;
  in.mesh = m;
  const StageData out = entry.fn(in, Json{{"faces", 120}}, ctx);
  ASSERT_TRUE(out.mesh.has_value());
  EXPECT_EQ(out.mesh->faces, a.faces);
}

TEST(Decimate, BadInputIsAnErrorNamingTheFaceVertexOrParameter) {
  const fixtures::Mesh octa = fixtures::octahedron();
  // A fin: a third triangle on edge (0, 2).
  fixtures::Mesh fin = octa;
  fin.positions.conservativeResize(3, 7);
  fin.positions.col(6) << 2, 2, 2;
  fin.faces.add({0, 2, 6});
  std::string e = error_of([&] { decimate(triangle_mesh_of(fin.positions, fin.faces), 4); });
  EXPECT_NE(e.find("mesh.decimate: face 8"), std::string::npos) << e;
  EXPECT_NE(e.find("non-manifold"), std::string::npos) << e;
  // A bow tie: two triangles sharing one vertex only (CGAL's Surface_mesh would take it).
  fixtures::Mesh bow;
  bow.positions.resize(3, 5);
  bow.positions << 0, 1, 1, -1, -1, 0, 0, 1, 0, 1, 0, 1, 0, -1, 0;
  bow.faces.add({0, 1, 2});
  bow.faces.add({0, 3, 4});
  e = error_of([&] { decimate(triangle_mesh_of(bow.positions, bow.faces), 0, 0.5); });
  EXPECT_NE(e.find("non-manifold vertex"), std::string::npos) << e;
  // Inconsistent orientation.
  fixtures::Mesh flip = octa;
  std::swap(flip.faces.indices[0], flip.faces.indices[1]);
  e = error_of([&] { decimate(triangle_mesh_of(flip.positions, flip.faces), 4); });
  EXPECT_NE(e.find("inconsistent orientation"), std::string::npos) << e;
  // A non-finite vertex.
  TriangleMesh nan = triangle_mesh_of(octa.positions, octa.faces);
  nan.vertices(1, 3) = std::numeric_limits<float>::quiet_NaN();
  e = error_of([&] { decimate(nan, 4); });
  EXPECT_NE(e.find("mesh.decimate: vertex 3"), std::string::npos) << e;
  // Targets: not below the input's 8 faces, or below 4.
  const TriangleMesh o = triangle_mesh_of(octa.positions, octa.faces);
  EXPECT_THROW(decimate(o, 8), ParamError);
  e = error_of([&] { decimate(o, 8); });
  EXPECT_NE(e.find("mesh.decimate.faces"), std::string::npos) << e;
  EXPECT_THROW(decimate(o, 3), ParamError);
  EXPECT_THROW(decimate(o, 0, 0.99), ParamError);  // round(0.99 * 8) = 8
  // Points only: the step needs a mesh.
  RunContext ctx(1);
  StageData pts;
  pts.points.positions = Eigen::Matrix3Xf::Random(3, 10);
  EXPECT_THROW(decimate_mesh(pts, DecimateParams{}, ctx), InputError);
}

}  // namespace
}  // namespace scanbench::algorithms
