// mesh.decimate (decimate.h): CGAL 5.5 Surface_mesh_simplification edge collapse. CGAL is
// confined to this translation unit (the scanbench_algorithms_cgal object library).
//
// GCC 12 reports -Wmaybe-uninitialized inside Eigen's fixed 4x4 matrices that CGAL's
// Garland-Heckbert quadrics instantiate (a false positive: CGAL assigns them before use); it is
// silenced for this file only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <vector>

#include "scanbench/algorithms/gps/decimate.h"
#include "scanbench/algorithms/gps/gps.h"
#include "scanbench/core/errors.h"

namespace scanbench::algorithms {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMS = CGAL::Surface_mesh_simplification;

// Stops once the mesh has at most `target` faces (CGAL 5.5 ships only edge-count predicates;
// the face count of a mesh with boundary is not a fixed function of its edge count).
struct FaceCountStop {
  std::size_t target;
  template <class F, class Profile>
  bool operator()(const F& /*cost*/, const Profile& profile, std::size_t /*initial_edges*/,
                  std::size_t /*current_edges*/) const {
    // Surface_mesh::number_of_faces() excludes the removed faces (the BGL num_faces() does not).
    return profile.surface_mesh().number_of_faces() <= target;
  }
};

}  // namespace

StageData decimate_mesh(const StageData& in, const DecimateParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "mesh.decimate";
  const TriangleMesh& m = in.require_mesh(stage);
  m.validate(stage);
  // The subdivision engine's connectivity check: manifold, consistently oriented, no repeated
  // vertex in a face (errors name the face).
  check_polygon_mesh(faces_of(m), static_cast<int>(m.vertices.cols()), true, stage);

  const auto input_faces = static_cast<std::size_t>(m.faces.cols());
  std::size_t target = 0;
  if (p.faces > 0) {
    if (p.faces < 4) {
      throw ParamError(
          fmt::format("{}.faces: expected 0 (use ratio) or at least 4, got {}", stage, p.faces));
    }
    target = static_cast<std::size_t>(p.faces);
  } else {
    target = std::max<std::size_t>(
        4, static_cast<std::size_t>(std::llround(p.ratio * static_cast<double>(input_faces))));
  }
  if (target >= input_faces) {
    throw ParamError(fmt::format(
        "{}.{}: the target of {} faces is not below the input's {} faces (nothing to collapse)",
        stage, p.faces > 0 ? "faces" : "ratio", target, input_faces));
  }

  Mesh sm;
  sm.reserve(static_cast<Mesh::size_type>(m.vertices.cols()),
             static_cast<Mesh::size_type>(3 * input_faces / 2 + 3),
             static_cast<Mesh::size_type>(input_faces));
  std::vector<Mesh::Vertex_index> vid;
  vid.reserve(static_cast<std::size_t>(m.vertices.cols()));
  for (Eigen::Index v = 0; v < m.vertices.cols(); ++v)
    vid.push_back(
        sm.add_vertex(Kernel::Point_3(m.vertices(0, v), m.vertices(1, v), m.vertices(2, v))));
  for (Eigen::Index f = 0; f < m.faces.cols(); ++f) {
    const auto fi = sm.add_face(vid[static_cast<std::size_t>(m.faces(0, f))],
                                vid[static_cast<std::size_t>(m.faces(1, f))],
                                vid[static_cast<std::size_t>(m.faces(2, f))]);
    if (fi == Mesh::null_face()) {
      throw InputError(
          fmt::format("{}: face {}: CGAL's Surface_mesh rejects it (non-manifold)", stage, f));
    }
  }

  {
    auto timer = ctx.phase("cgal");
    const FaceCountStop stop{target};
    if (p.policy == "garland_heckbert") {
      SMS::GarlandHeckbert_plane_policies<Mesh, Kernel> gh(sm);
      SMS::edge_collapse(
          sm, stop, CGAL::parameters::get_cost(gh.get_cost()).get_placement(gh.get_placement()));
    } else {
      SMS::edge_collapse(sm, stop,
                         CGAL::parameters::get_cost(SMS::LindstromTurk_cost<Mesh>())
                             .get_placement(SMS::LindstromTurk_placement<Mesh>()));
    }
  }

  // Remaining faces over the remaining vertices, in the order of their input indices (the
  // vertex indices of sm are the input's; collapsed vertices are marked removed, not renumbered).
  std::vector<int> remap(vid.size(), -1);
  std::vector<std::array<int, 3>> tris;
  tris.reserve(sm.number_of_faces());
  for (const auto f : sm.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (k == 3) throw Error(fmt::format("{}: CGAL returned a non-triangle face", stage));
      t[static_cast<std::size_t>(k++)] = static_cast<int>(v.idx());
    }
    for (int i : t)
      remap[static_cast<std::size_t>(i)] = 0;
    tris.push_back(t);
  }
  if (tris.empty()) throw Error(fmt::format("{}: CGAL returned no face", stage));
  int used = 0;
  for (int& r : remap) {
    if (r == 0) r = used++;
  }
  TriangleMesh out;
  out.vertices.resize(3, used);
  for (std::size_t i = 0; i < vid.size(); ++i) {
    if (remap[i] < 0) continue;
    const auto& q = sm.point(vid[i]);
    out.vertices.col(remap[i]) = Eigen::Vector3f(
        static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
  }
  out.faces.resize(3, static_cast<Eigen::Index>(tris.size()));
  for (std::size_t f = 0; f < tris.size(); ++f) {
    for (int k = 0; k < 3; ++k)
      out.faces(k, static_cast<Eigen::Index>(f)) = remap[static_cast<std::size_t>(tris[f][k])];
  }
  out.validate(stage);
  StageData result;
  result.mesh = std::move(out);
  return result;
}

}  // namespace scanbench::algorithms
