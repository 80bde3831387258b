// PU-GAN's uniformity as PD-Flow's eval/uniformity computes it (conventions.h). CGAL stays in
// this file: it compiles in its own object library (metrics/CMakeLists.txt).
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_shortest_path.h>
#include <CGAL/boost/graph/Euler_operations.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "scanbench/metrics/conventions.h"

namespace scanbench::metrics {

namespace {

// uniformity.cpp's types.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Traits = CGAL::Surface_mesh_shortest_path_traits<Kernel, Mesh>;
using ShortestPath = CGAL::Surface_mesh_shortest_path<Traits>;
using FaceLocation = ShortestPath::Face_location;
using AabbTraits = CGAL::AABB_traits<Kernel, CGAL::AABB_face_graph_triangle_primitive<Mesh>>;
using AabbTree = CGAL::AABB_tree<AabbTraits>;
using Point = Kernel::Point_3;

constexpr std::size_t kShares = kUniformityShares.size();

/// The mesh as CGAL's OFF reader builds it (Generic_facegraph_builder: the vertices in order, then
/// Euler::add_face per face), so face i is faces.col(i). Empty when a face cannot be added.
std::optional<Mesh> cgal_mesh(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces) {
  Mesh m;
  std::vector<Mesh::Vertex_index> v;
  v.reserve(static_cast<std::size_t>(vertices.cols()));
  for (Eigen::Index i = 0; i < vertices.cols(); ++i)
    v.push_back(m.add_vertex(Point(vertices(0, i), vertices(1, i), vertices(2, i))));
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    std::array<Mesh::Vertex_index, 3> corner{};
    for (int c = 0; c < 3; ++c) {
      const int i = faces(c, f);
      if (i < 0 || i >= vertices.cols())
        throw InputError("convention.pdflow: a face index out of range");
      corner[static_cast<std::size_t>(c)] = v[static_cast<std::size_t>(i)];
    }
    if (CGAL::Euler::add_face(corner, m) == Mesh::null_face()) return std::nullopt;
  }
  return m;
}

Mesh::Face_index face_of(Eigen::Index f) {
  return Mesh::Face_index(static_cast<Mesh::size_type>(f));
}

FaceLocation location_of(const UniformityCentre& c) {
  return {face_of(c.face), {{c.barycentric(0), c.barycentric(1), c.barycentric(2)}}};
}

Eigen::Vector3d to_eigen(const Point& p) {
  return {p.x(), p.y(), p.z()};
}

}  // namespace

std::vector<UniformityCentre> pdflow_uniformity_centres(const Eigen::Matrix3Xd& vertices,
                                                        const Eigen::Matrix3Xi& faces,
                                                        Eigen::Index count, Rng& rng) {
  const std::optional<Mesh> m = cgal_mesh(vertices, faces);
  if (!m) throw NotApplicable("convention.pdflow: CGAL cannot build the ground-truth mesh");
  // uniformity.cpp: the cumulative shares of CGAL's face areas in the total.
  const double total = CGAL::Polygon_mesh_processing::area(*m);
  if (!(total > 0.0)) throw InputError("convention.pdflow: the ground-truth mesh has no area");
  std::vector<double> cumulative(static_cast<std::size_t>(faces.cols()));
  double sum = 0.0;
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    sum += CGAL::Polygon_mesh_processing::face_area(face_of(f), *m) / total;
    cumulative[static_cast<std::size_t>(f)] = sum;
  }
  std::vector<UniformityCentre> centres(static_cast<std::size_t>(count));
  for (UniformityCentre& c : centres) {
    // find_surface: the face whose share interval holds u (the last one for u past the sum).
    const double u = rng.uniform();
    const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), u);
    c.face = std::min<Eigen::Index>(it - cumulative.begin(), faces.cols() - 1);
    for (int k = 0; k < 3; ++k)
      c.barycentric(k) = rng.uniform(0.01, 1.0);
    c.barycentric /= c.barycentric.sum();
  }
  return centres;
}

UniformityDisks pdflow_uniformity_disks(const Eigen::Matrix3Xd& points,
                                        const Eigen::Matrix3Xd& vertices,
                                        const Eigen::Matrix3Xi& faces,
                                        const std::vector<UniformityCentre>& centres) {
  if (points.cols() == 0) throw InputError("convention.pdflow: no output points");
  const std::optional<Mesh> built = cgal_mesh(vertices, faces);
  if (!built) throw NotApplicable("convention.pdflow: CGAL cannot build the ground-truth mesh");
  const Mesh& mesh = *built;
  for (const UniformityCentre& c : centres)
    if (c.face < 0 || c.face >= faces.cols())
      throw InputError("convention.pdflow: a disk centre's face is out of range");

  UniformityDisks out;
  const double area = CGAL::Polygon_mesh_processing::area(mesh);
  for (std::size_t k = 0; k < kShares; ++k)  // float, as uniformity.cpp's `radius`
    out.radius[k] = static_cast<float>(std::sqrt(area * kUniformityShares[k] / M_PI));
  const double reach = out.radius.back();

  // Each output point's closest location on the mesh (ShortestPath::locate through an AABB tree).
  const ShortestPath locator(mesh);
  AabbTree tree;
  locator.build_aabb_tree(tree);
  const auto n = static_cast<std::size_t>(points.cols());
  std::vector<FaceLocation> located(n);
  out.mapped.resize(3, points.cols());
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          const auto c = points.col(static_cast<Eigen::Index>(i));
          located[i] = locator.locate<AabbTraits>(Point(c(0), c(1), c(2)), tree);
          out.mapped.col(static_cast<Eigen::Index>(i)) =
              to_eigen(ShortestPath::point(located[i].first, located[i].second, mesh));
        }
      });

  // The disks: the Euclidean pre-cut at the largest radius through a kd-tree (candidates with a
  // slack, then the original's test in double), an exact geodesic for the rest. One shortest-path
  // object per thread; its answers depend only on its source, so the slots are thread-free.
  const Eigen::Matrix3Xf mapped_f = out.mapped.cast<float>();  // the tree views it
  const KdTree mapped_tree(mapped_f);
  // The float copy's rounding grows with the coordinates, and so does the slack (no point is cut
  // by rounding; the exact double test below decides).
  const double slack = 1e-7 + 1e-6 * out.mapped.cwiseAbs().maxCoeff();
  out.members.assign(centres.size() * kShares, {});
  tbb::enumerable_thread_specific<ShortestPath> paths([&mesh] { return ShortestPath(mesh); });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, centres.size(), 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        ShortestPath& path = paths.local();
        std::vector<std::pair<Eigen::Index, float>> near;
        std::vector<Eigen::Index> candidates;
        for (std::size_t d = r.begin(); d < r.end(); ++d) {
          const FaceLocation source = location_of(centres[d]);
          const Eigen::Vector3d centre =
              to_eigen(ShortestPath::point(source.first, source.second, mesh));
          mapped_tree.radius(centre.cast<float>(), static_cast<float>(reach * (1.0 + 1e-5) + slack),
                             near);
          candidates.clear();
          for (const auto& [i, unused] : near) {
            // CGAL::squared_distance's sum, term by term, as the original's test.
            const Eigen::Vector3d e = centre - out.mapped.col(i);
            if (!(std::sqrt(e(0) * e(0) + e(1) * e(1) + e(2) * e(2)) > reach))
              candidates.push_back(i);
          }
          std::sort(candidates.begin(), candidates.end());  // the original's loop order
          if (candidates.empty()) continue;
          path.remove_all_source_points();
          path.add_source_point(source);
          for (const Eigen::Index i : candidates) {
            const FaceLocation& at = located[static_cast<std::size_t>(i)];
            const double g = path.shortest_distance_to_source_points(at.first, at.second).first;
            for (std::size_t k = 0; k < kShares; ++k)
              if (g <= out.radius[k]) out.members[d * kShares + k].push_back(i);
          }
        }
      });
  return out;
}

}  // namespace scanbench::metrics
