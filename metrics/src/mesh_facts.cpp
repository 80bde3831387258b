#include "scanbench/metrics/mesh_facts.h"

#include <algorithm>
#include <numeric>
#include <vector>

namespace scanbench::metrics {

namespace {

// Facts of `faces` polygons in CSR form (offsets has faces + 1 entries) over `nv` vertices.
MeshFacts polygon_facts(Eigen::Index nv, const std::vector<int>& offsets,
                        const std::vector<int>& corners) {
  MeshFacts f;
  f.vertices = nv;
  f.faces = static_cast<std::int64_t>(offsets.size()) - 1;
  // Undirected edges as (min, max) packed into 64 bits, sorted: runs are the faces per edge.
  std::vector<std::uint64_t> edges;
  edges.reserve(corners.size());
  std::vector<int> parent(static_cast<std::size_t>(nv));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int v) {
    while (parent[static_cast<std::size_t>(v)] != v) {
      int& p = parent[static_cast<std::size_t>(v)];
      p = parent[static_cast<std::size_t>(p)];  // path halving
      v = p;
    }
    return v;
  };
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (std::int64_t k = 0; k < f.faces; ++k) {
    const int b = offsets[static_cast<std::size_t>(k)],
              e = offsets[static_cast<std::size_t>(k) + 1];
    for (int c = b; c < e; ++c) {
      const int u = corners[static_cast<std::size_t>(c)];
      const int v = corners[static_cast<std::size_t>(c + 1 < e ? c + 1 : b)];
      used[static_cast<std::size_t>(u)] = 1;
      edges.push_back((static_cast<std::uint64_t>(std::min(u, v)) << 32) |
                      static_cast<std::uint32_t>(std::max(u, v)));
      const int ru = find(u), rv = find(v);
      if (ru != rv) parent[static_cast<std::size_t>(std::max(ru, rv))] = std::min(ru, rv);
    }
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i])
      ++j;
    if (j - i == 1) ++f.boundary_edges;
    if (j - i > 2) ++f.nonmanifold_edges;
    ++f.edges;
    i = j;
  }
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!used[static_cast<std::size_t>(v)]) {
      ++f.unreferenced_vertices;
    } else if (find(static_cast<int>(v)) == v) {
      ++f.components;
    }
  }
  f.closed = f.faces > 0 && f.boundary_edges == 0 && f.nonmanifold_edges == 0;
  f.euler = (f.vertices - f.unreferenced_vertices) - f.edges + f.faces;
  f.bytes = 12 * f.vertices + 4 * static_cast<std::int64_t>(corners.size());
  return f;
}

}  // namespace

MeshFacts mesh_facts(const TriangleMesh& mesh) {
  std::vector<int> offsets(static_cast<std::size_t>(mesh.num_faces()) + 1);
  for (std::size_t k = 0; k < offsets.size(); ++k)
    offsets[k] = static_cast<int>(3 * k);
  const std::vector<int> corners(mesh.faces.data(), mesh.faces.data() + mesh.faces.size());
  MeshFacts f = polygon_facts(mesh.num_vertices(), offsets, corners);
  f.degenerate_faces = mesh.count_degenerate_faces();
  return f;
}

MeshFacts mesh_facts(const CovarianceMesh& mesh) {
  MeshFacts f = polygon_facts(mesh.num_vertices(), mesh.faces.offsets, mesh.faces.indices);
  for (Eigen::Index k = 0; k < mesh.num_faces(); ++k) {
    auto c = mesh.faces.face(k);
    std::vector<int> s(c.begin(), c.end());
    std::sort(s.begin(), s.end());
    f.degenerate_faces += std::adjacent_find(s.begin(), s.end()) != s.end();
  }
  f.bytes += 24 * f.vertices;  // 6 float32 covariance entries per vertex (GPS sec. 7.2)
  return f;
}

Json mesh_facts_metric(const MetricInput& in, const MeshFactsParams&) {
  if (!in.output_mesh) throw NotApplicable("mesh.facts: the output is not a mesh");
  const MeshFacts f = in.output_covariance_mesh ? mesh_facts(*in.output_covariance_mesh)
                                                : mesh_facts(*in.output_mesh);
  Json j = Json::object();
  j["mesh_vertices"] = f.vertices;
  j["mesh_faces"] = f.faces;
  j["mesh_unreferenced_vertices"] = f.unreferenced_vertices;
  j["mesh_degenerate_faces"] = f.degenerate_faces;
  j["mesh_boundary_edges"] = f.boundary_edges;
  j["mesh_nonmanifold_edges"] = f.nonmanifold_edges;
  j["mesh_components"] = f.components;
  j["mesh_closed"] = f.closed;
  j["mesh_edges"] = f.edges;
  j["mesh_euler"] = f.euler;
  // Closed components (orientable: every closed surface embedded in 3-space is) have
  // chi = sum (2 - 2 g_i), so the total genus is (2 C - chi) / 2; null for an open mesh, and
  // when 2 C - chi is odd or negative (vertices where sheets touch).
  const std::int64_t twice_genus = 2 * f.components - f.euler;
  j["mesh_genus"] =
      f.closed && twice_genus >= 0 && twice_genus % 2 == 0 ? Json(twice_genus / 2) : Json(nullptr);
  j["mesh_bytes"] = f.bytes;
  return j;
}

}  // namespace scanbench::metrics
