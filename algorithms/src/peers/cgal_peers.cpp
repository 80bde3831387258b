// The only translation unit that includes CGAL (its headers compile slowly and must not leak).
#include "scanbench/algorithms/peers/cgal_peers.h"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/edge_aware_upsample_point_set.h>
#include <CGAL/jet_smooth_point_set.h>
#include <CGAL/property_map.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>
#include <fmt/format.h>

#include <cmath>
#include <iterator>
#include <utility>
#include <vector>

#include "input_checks.h"
#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {

namespace {

using PeerKernel = CGAL::Simple_cartesian<double>;
using PeerPoint = PeerKernel::Point_3;
using PeerVector = PeerKernel::Vector_3;
using PointWithNormal = std::pair<PeerPoint, PeerVector>;

std::vector<PeerPoint> to_cgal(const Eigen::Matrix3Xf& p) {
  std::vector<PeerPoint> out;
  out.reserve(static_cast<std::size_t>(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    out.emplace_back(p(0, i), p(1, i), p(2, i));
  return out;
}

Eigen::Vector3f to_eigen(const PeerPoint& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

}  // namespace

PointCloud cgal_wlop(const PointCloud& input, const CgalWlopParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_wlop";
  detail::check_points(input, stage, 1);
  const double diag = input.bbox().diagonal();
  if (!(diag > 0.0))
    throw InputError(fmt::format("{}: the input's bbox has a zero diagonal", stage));
  const auto n = static_cast<std::size_t>(input.size());
  const auto kept = static_cast<std::size_t>(static_cast<double>(n) * p.particles);
  if (kept == 0) {
    throw ParamError(
        fmt::format("{}.particles: {} of {} points keeps no particle", stage, p.particles, n));
  }
  std::vector<PeerPoint> points = to_cgal(input.positions);
  // Our seeded shuffle first: CGAL's own shuffle uses a fixed-seed rand48.
  Rng rng(ctx.stream_seed("particles"));
  for (std::size_t i = n; i > 1; --i)
    std::swap(points[i - 1], points[static_cast<std::size_t>(rng.below(i))]);

  std::vector<PeerPoint> out;
  out.reserve(kept);
  {
    auto timer = ctx.phase("cgal");
    CGAL::wlop_simplify_and_regularize_point_set<CGAL::Parallel_tag>(
        points, std::back_inserter(out),
        CGAL::parameters::select_percentage(100.0 * p.particles)
            .neighbor_radius(0.5 * p.h * diag)  // exp(-4 r^2/R^2) with R = h/2 == exp(-16 r^2/h^2)
            .number_of_iterations(static_cast<unsigned int>(p.iterations))
            .require_uniform_sampling(p.uniform_sampling));
  }
  PointCloud result;
  result.positions.resize(3, static_cast<Eigen::Index>(out.size()));
  for (std::size_t i = 0; i < out.size(); ++i)
    result.positions.col(static_cast<Eigen::Index>(i)) = to_eigen(out[i]);
  result.validate(stage);  // CGAL output is checked, not trusted
  return result;
}

PointCloud cgal_bilateral(const PointCloud& input, const CgalBilateralParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_bilateral";
  detail::check_points(input, stage, 3);
  PointCloud out = input;
  if (!out.has_normals()) out = pca_normals(input, PcaNormalsParams{}, ctx);
  const auto n = static_cast<std::size_t>(out.size());
  std::vector<PointWithNormal> pwn(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    pwn[i] = {PeerPoint(out.positions(0, c), out.positions(1, c), out.positions(2, c)),
              PeerVector(out.normals(0, c), out.normals(1, c), out.normals(2, c))};
  }
  const auto k = static_cast<unsigned int>(std::min<Eigen::Index>(p.k, out.size()));
  {
    auto timer = ctx.phase("cgal");
    for (int it = 0; it < p.iterations; ++it) {
      ctx.check_cancelled(stage);
      CGAL::bilateral_smooth_point_set<CGAL::Parallel_tag>(
          pwn, k,
          CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointWithNormal>())
              .normal_map(CGAL::Second_of_pair_property_map<PointWithNormal>())
              .sharpness_angle(p.sharpness_angle));
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    out.positions.col(c) = to_eigen(pwn[i].first);
    const PeerVector& v = pwn[i].second;
    out.normals.col(c) = Eigen::Vector3f(static_cast<float>(v.x()), static_cast<float>(v.y()),
                                         static_cast<float>(v.z()))
                             .normalized();
  }
  out.validate(stage);
  return out;
}

PointCloud cgal_jet(const PointCloud& input, const CgalJetParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_jet";
  if (p.degree_monge > p.degree_fitting) {
    throw ParamError(fmt::format("{}.degree_monge: {} exceeds degree_fitting {}", stage,
                                 p.degree_monge, p.degree_fitting));
  }
  const int coefficients = (p.degree_fitting + 1) * (p.degree_fitting + 2) / 2;
  if (p.k < coefficients) {
    throw ParamError(fmt::format("{}.k: a degree-{} jet needs at least {} neighbours, got {}",
                                 stage, p.degree_fitting, coefficients, p.k));
  }
  detail::check_points(input, stage, p.k);
  std::vector<PeerPoint> points = to_cgal(input.positions);
  {
    auto timer = ctx.phase("cgal");
    CGAL::jet_smooth_point_set<CGAL::Parallel_tag>(
        points, static_cast<unsigned int>(p.k),
        CGAL::parameters::degree_fitting(static_cast<unsigned int>(p.degree_fitting))
            .degree_monge(static_cast<unsigned int>(p.degree_monge)));
  }
  PointCloud out = input;
  for (std::size_t i = 0; i < points.size(); ++i)
    out.positions.col(static_cast<Eigen::Index>(i)) = to_eigen(points[i]);
  out.validate(stage);
  return out;
}

PointCloud cgal_ear(const PointCloud& input, const CgalEarParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.cgal_ear";
  detail::check_points(input, stage, 7);  // CGAL's spacing estimate takes 6 neighbours
  detail::require_unit_normals(input, stage, "normals.pca -> normals.bilateral -> peer.cgal_ear");
  const BoundingBox box = input.bbox();
  const double diag = box.diagonal();
  if (!(diag > 0.0))
    throw InputError(fmt::format("{}: the input's bbox has a zero diagonal", stage));
  const auto n = static_cast<std::size_t>(input.size());
  const double wanted =
      p.count > 0 ? static_cast<double>(p.count) : std::floor(p.factor * static_cast<double>(n));
  if (!(wanted > static_cast<double>(n))) {
    throw InputError(fmt::format(
        "{}: asked for {} output points, but the input already has {}; EAR only adds points", stage,
        static_cast<long long>(wanted), n));
  }
  // Centred, unit diagonal (CGAL issue 4662: EAR fails on large coordinates).
  const Eigen::Vector3f centre = box.center();
  const Eigen::Matrix3Xf unit_normals = detail::unit_normals(input);
  std::vector<PointWithNormal> pwn(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    const Eigen::Vector3d q = ((input.positions.col(c) - centre).cast<double>()) / diag;
    pwn[i] = {PeerPoint(q.x(), q.y(), q.z()),
              PeerVector(unit_normals(0, c), unit_normals(1, c), unit_normals(2, c))};
  }
  std::vector<PointWithNormal> added;
  {
    auto timer = ctx.phase("cgal");
    CGAL::edge_aware_upsample_point_set<CGAL::Parallel_tag>(
        pwn, std::back_inserter(added),
        CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointWithNormal>())
            .normal_map(CGAL::Second_of_pair_property_map<PointWithNormal>())
            .sharpness_angle(p.sharpness_angle)
            .edge_sensitivity(p.edge_sensitivity)
            .neighbor_radius(0.5 * p.h)  // exp(-4 r^2/R^2), R = h/2 == exp(-16 r^2/h^2)
            .number_of_output_points(static_cast<std::size_t>(wanted)));
  }
  PointCloud out;
  const auto total = static_cast<Eigen::Index>(n + added.size());
  out.positions.resize(3, total);
  out.normals.resize(3, total);
  out.positions.leftCols(input.size()) = input.positions;
  out.normals.leftCols(input.size()) = unit_normals;
  for (std::size_t i = 0; i < added.size(); ++i) {
    const auto c = static_cast<Eigen::Index>(n + i);
    const PeerPoint& q = added[i].first;
    const PeerVector& v = added[i].second;
    out.positions.col(c) = (Eigen::Vector3d(q.x(), q.y(), q.z()) * diag).cast<float>() + centre;
    out.normals.col(c) = Eigen::Vector3d(v.x(), v.y(), v.z()).normalized().cast<float>();
  }
  out.validate(stage);  // CGAL output is checked, not trusted
  return out;
}

}  // namespace scanbench::algorithms
