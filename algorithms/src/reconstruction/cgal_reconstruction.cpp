// CGAL's reconstruction peers (cgal_reconstruction.h); CGAL is confined to this translation unit
// and cgal_peers.cpp (the scanbench_algorithms_cgal object library).
#include "scanbench/algorithms/reconstruction/cgal_reconstruction.h"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Scale_space_reconstruction_3/Advancing_front_mesher.h>
#include <CGAL/Scale_space_reconstruction_3/Alpha_shape_mesher.h>
#include <CGAL/Scale_space_reconstruction_3/Jet_smoother.h>
#include <CGAL/Scale_space_reconstruction_3/Weighted_PCA_smoother.h>
#include <CGAL/Scale_space_surface_reconstruction_3.h>
#include <fmt/format.h>

#include <array>
#include <vector>

#include "scanbench/core/errors.h"

namespace scanbench::algorithms {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;

std::vector<Point> input_points(const StageData& in, std::string_view stage) {
  in.points.validate(stage);
  if (in.points.size() < 4) {
    throw InputError(fmt::format("{}: needs at least 4 points, got {}", stage, in.points.size()));
  }
  const Eigen::Matrix3Xf& p = in.points.positions;
  std::vector<Point> out;
  out.reserve(static_cast<std::size_t>(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    out.emplace_back(p(0, i), p(1, i), p(2, i));
  return out;
}

// The mesh of `facets` over `points`, keeping only the referenced points (in input order).
template <class Facets>
StageData to_mesh(const std::vector<Point>& points, const Facets& facets, std::string_view stage) {
  if (facets.empty()) throw Error(fmt::format("{}: CGAL returned no facet", stage));
  std::vector<int> remap(points.size(), -1);
  for (const auto& f : facets) {
    for (int k = 0; k < 3; ++k)
      remap[static_cast<std::size_t>(f[k])] = 0;
  }
  int used = 0;
  for (int& r : remap) {
    if (r == 0) r = used++;
  }
  TriangleMesh m;
  m.vertices.resize(3, used);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (remap[i] < 0) continue;
    const Point& q = points[i];
    m.vertices.col(remap[i]) = Eigen::Vector3f(static_cast<float>(q.x()), static_cast<float>(q.y()),
                                               static_cast<float>(q.z()));
  }
  m.faces.resize(3, static_cast<Eigen::Index>(facets.size()));
  Eigen::Index c = 0;
  for (const auto& f : facets) {
    for (int k = 0; k < 3; ++k)
      m.faces(k, c) = remap[static_cast<std::size_t>(f[k])];
    ++c;
  }
  m.validate(stage);
  StageData out;
  out.mesh = std::move(m);
  return out;
}

}  // namespace

StageData cgal_advancing_front(const StageData& in, const CgalAdvancingFrontParams& p,
                               RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_advancing_front";
  const std::vector<Point> points = input_points(in, stage);
  std::vector<std::array<std::size_t, 3>> facets;
  {
    auto timer = ctx.phase("cgal");
    CGAL::advancing_front_surface_reconstruction(
        points.begin(), points.end(), std::back_inserter(facets), p.radius_ratio_bound, p.beta);
  }
  return to_mesh(points, facets, stage);
}

StageData cgal_scale_space(const StageData& in, const CgalScaleSpaceParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_scale_space";
  if (p.smoother == "jet" && p.mesher == "alpha_shape" && p.radius == 0.0) {
    throw ParamError(
        fmt::format("{}.radius: the alpha_shape mesher needs a radius with the jet "
                    "smoother (0 takes the weighted_pca smoother's estimate)",
                    stage));
  }
  const std::vector<Point> points = input_points(in, stage);
  const double diag = in.points.bbox().diagonal();
  using Reconstruction = CGAL::Scale_space_surface_reconstruction_3<Kernel>;
  // Sequential smoothers: the mesher below orders by heap address (alpha shape with
  // force_manifold, advancing front), and worker threads allocating before it change the heap,
  // so with CGAL's default (Parallel_tag) a run's bytes could depend on --threads.
  using Pca = CGAL::Scale_space_reconstruction_3::Weighted_PCA_smoother<
      Kernel, CGAL::Default_diagonalize_traits<Kernel::FT, 3>, CGAL::Sequential_tag>;
  using Jet = CGAL::Scale_space_reconstruction_3::Jet_smoother<Kernel, CGAL::Sequential_tag>;
  using Alpha = CGAL::Scale_space_reconstruction_3::Alpha_shape_mesher<Kernel>;
  using Front = CGAL::Scale_space_reconstruction_3::Advancing_front_mesher<Kernel>;
  Reconstruction r(points.begin(), points.end());
  std::vector<std::array<std::size_t, 3>> facets;
  {
    auto timer = ctx.phase("cgal");
    double squared_radius = p.radius * diag * p.radius * diag;
    if (p.smoother == "jet") {
      r.increase_scale(static_cast<std::size_t>(p.iterations),
                       Jet(static_cast<unsigned int>(p.neighbors)));
    } else {
      Pca smoother(static_cast<unsigned int>(p.neighbors), static_cast<unsigned int>(p.samples));
      r.increase_scale(static_cast<std::size_t>(p.iterations), smoother);
      if (p.radius == 0.0) squared_radius = smoother.squared_radius();
    }
    if (p.mesher == "alpha_shape") {
      r.reconstruct_surface(
          Alpha(squared_radius, p.separate_shells, p.force_manifold, p.border_angle));
    } else {
      r.reconstruct_surface(Front(p.max_facet_length * diag, p.radius_ratio_bound, p.beta));
    }
    for (auto it = r.facets_begin(); it != r.facets_end(); ++it)
      facets.push_back({(*it)[0], (*it)[1], (*it)[2]});
  }
  if (p.original_positions) return to_mesh(points, facets, stage);
  return to_mesh(std::vector<Point>(r.points_begin(), r.points_end()), facets, stage);
}

}  // namespace scanbench::algorithms
