#include "scanbench/algorithms/gpf/gpf.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string_view>

#include "gpf/gpf_internal.h"
#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/grid_packets.h"
#include "spatial/simd_exp.h"

// Eigen's packet types carry vector attributes that GCC reports as ignored when they are template
// arguments (em_step is a template over the packet of the active ISA); they do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace gpf_detail {

namespace {

namespace ei = Eigen::internal;

using detail::for_each_packet;
using detail::sorted_values;

template <class Packet>
Packet load(const std::vector<float>& a, Eigen::Index t) {
  return ei::ploadu<Packet>(a.data() + t);
}

}  // namespace

Problem::Problem(Eigen::Matrix3Xf v, Eigen::Matrix3Xf b, float h)
    : v_(std::move(v)), b_(std::move(b)), h_(h), grid_(v_, 0.25f * h) {
  // Input cells as wide as the data radius (3 x 3 columns per query): the data balls hold only a
  // few tens of points, and finer cells cost more per column than they skip (kernels::query_grid
  // makes the same choice by the occupancy).
  for (int d = 0; d < 3; ++d)
    sb_[d] = sorted_values(grid_, b_.data() + d, 3);
  set_h(h);
}

void Problem::set_h(float h) {
  h_ = h;
  rho_ = kernels::density_weights(grid_, v_, h_, repulsion_radius());
  const Eigen::VectorXf inv = rho_.cwiseInverse();
  sinv_rho_ = sorted_values(grid_, inv.data(), 1);
}

namespace {

// E-step (eq. 3): the denominators D_n into s.denominator (p_mn = exp(-|v_n - x_m|^2 / 2 s2) /
// D_n, `c` the outlier term); returns 1 / D_n in the input grid's order (an underflowed
// denominator contributes nothing).
template <class Packet>
std::vector<float> e_step(const Problem& problem, const detail::NeighborGrid& pgrid,
                          const Packet& k_gauss, float c, Step& s) {
  const Eigen::Matrix3Xf& v = problem.v();
  const Eigen::Index n = v.cols();
  const float r_data = problem.data_radius();
  s.denominator.resize(n);
  pgrid.for_each_query(
      v, r_data, false,
      [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
        Packet acc = ei::pset1<Packet>(0.0f);
        for_each_packet<Packet>(
            pgrid, v.col(i), r_data, -1, r, count,
            [&](Eigen::Index, Packet, Packet, Packet, Packet r2, Packet inside) {
              acc = ei::padd(acc, ei::pand(detail::fast_pexp(ei::pmul(k_gauss, r2)), inside));
            });
        s.denominator[i] = ei::predux(acc) + c;
      });
  const detail::NeighborGrid& vgrid = problem.grid();
  std::vector<float> inv_d(static_cast<std::size_t>(n + detail::NeighborGrid::kPad), 0.0f);
  for (Eigen::Index k = 0; k < n; ++k) {
    const float d = s.denominator[vgrid.index(k)];
    inv_d[static_cast<std::size_t>(k)] = d > 1e-30f ? 1.0f / d : 0.0f;
  }
  return inv_d;
}

// M-step data term (eq. 10) into s.data, and per particle for eq. 11: np_m = sum_n p_mn,
// res_m = S1 and the moments g and A (see em_step_impl).
template <class Packet, bool kPointToPoint>
void data_term(const Problem& problem, const Eigen::Matrix3Xf& x, const std::vector<float>& inv_d,
               const Packet& k_gauss, Step& s, std::vector<double>& np_m,
               std::vector<double>& res_m, Eigen::Matrix<double, 9, Eigen::Dynamic>& moments) {
  const detail::NeighborGrid& vgrid = problem.grid();
  const float r_data = problem.data_radius();
  const std::vector<float>* vb = &problem.sorted_b(0);
  const std::vector<float>& inv_rho = problem.sorted_inv_rho();
  vgrid.for_each_query(
      x, r_data, false,
      [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
        const Packet zero = ei::pset1<Packet>(0.0f);
        // q = p / rho weighted: Q, G (eq. 10); p weighted: P, S1, g, A (eq. 11).
        Packet Q = zero, Gx = zero, Gy = zero, Gz = zero;
        Packet P = zero, S1 = zero, gx = zero, gy = zero, gz = zero;
        Packet Axx = zero, Axy = zero, Axz = zero, Ayy = zero, Ayz = zero, Azz = zero;
        for_each_packet<Packet>(
            vgrid, x.col(i), r_data, -1, r, count,
            [&](Eigen::Index t, Packet dx, Packet dy, Packet dz, Packet r2, Packet inside) {
              const Packet p = ei::pand(
                  ei::pmul(detail::fast_pexp(ei::pmul(k_gauss, r2)), load<Packet>(inv_d, t)),
                  inside);
              const Packet q = ei::pmul(p, load<Packet>(inv_rho, t));
              const Packet bx = load<Packet>(vb[0], t), by = load<Packet>(vb[1], t),
                           bz = load<Packet>(vb[2], t);
              const Packet tt = ei::padd(ei::padd(ei::pmul(bx, dx), ei::pmul(by, dy)),
                                         ei::pmul(bz, dz));  // (v_n - x_m) . b_n
              const Packet qt = ei::pmul(q, tt), pt = ei::pmul(p, tt);
              Q = ei::padd(Q, q);
              Gx = ei::padd(Gx, ei::pmul(qt, bx));
              Gy = ei::padd(Gy, ei::pmul(qt, by));
              Gz = ei::padd(Gz, ei::pmul(qt, bz));
              P = ei::padd(P, p);
              if constexpr (kPointToPoint) {
                // The padding's r2 is not finite: masked, not multiplied by p = 0.
                S1 = ei::padd(S1, ei::pand(ei::pmul(p, r2), inside));
                gx = ei::padd(gx, ei::pmul(p, dx));
                gy = ei::padd(gy, ei::pmul(p, dy));
                gz = ei::padd(gz, ei::pmul(p, dz));
                return;
              }
              S1 = ei::padd(S1, ei::pmul(pt, tt));
              gx = ei::padd(gx, ei::pmul(pt, bx));
              gy = ei::padd(gy, ei::pmul(pt, by));
              gz = ei::padd(gz, ei::pmul(pt, bz));
              const Packet pbx = ei::pmul(p, bx), pby = ei::pmul(p, by);
              Axx = ei::padd(Axx, ei::pmul(pbx, bx));
              Axy = ei::padd(Axy, ei::pmul(pbx, by));
              Axz = ei::padd(Axz, ei::pmul(pbx, bz));
              Ayy = ei::padd(Ayy, ei::pmul(pby, by));
              Ayz = ei::padd(Ayz, ei::pmul(pby, bz));
              Azz = ei::padd(Azz, ei::pmul(ei::pmul(p, bz), bz));
            });
        const float q_sum = ei::predux(Q);
        s.data.col(i) =
            q_sum > 0.0f
                ? Eigen::Vector3f(Eigen::Vector3f(ei::predux(Gx), ei::predux(Gy), ei::predux(Gz)) /
                                  q_sum)
                : Eigen::Vector3f::Zero();
        // Kept for eq. 11 once the repulsion (so x_m') is known:
        // sum_n p (t - b.D)^2 = S1 - 2 D.g + D^T A D, D = x_m' - x_m (point to point:
        // sum_n p |d_n - D|^2 = S1 - 2 D.g + P |D|^2 with A = P I, d_n = v_n - x_m).
        np_m[static_cast<std::size_t>(i)] = ei::predux(P);
        res_m[static_cast<std::size_t>(i)] = ei::predux(S1);
        moments.col(i) << ei::predux(gx), ei::predux(gy), ei::predux(gz), ei::predux(Axx),
            ei::predux(Axy), ei::predux(Axz), ei::predux(Ayy), ei::predux(Ayz), ei::predux(Azz);
      });
}

// Repulsion (eq. 10) into s.repulsion: sum_m' w_m' beta_mm' C_mm' (x_m - x_m') / sum_m' w_m'
// beta_mm', projected onto the tangent plane of x_m', beta = theta(r)/r at the tangential
// distance r (clamped 0.01 h). `pb`: the particle normals in pgrid's order; pgrid holds the
// particle weights w_m.
template <class Packet>
void repulsion_term(const detail::NeighborGrid& pgrid, const Eigen::Matrix3Xf& x,
                    const std::vector<float> (&pb)[3], float h, float r_rep, Step& s) {
  const Packet theta_k = ei::pset1<Packet>(-kernels::kThetaFactor / (h * h));
  const Packet floor2 = ei::pset1<Packet>(kernels::kClampRatio * kernels::kClampRatio * h * h);
  pgrid.for_each_query(
      x, r_rep, true,
      [&](Eigen::Index i, Eigen::Index self, const detail::GridRange* r, std::size_t count) {
        const Packet zero = ei::pset1<Packet>(0.0f);
        Packet W = zero, Rx = zero, Ry = zero, Rz = zero;
        for_each_packet<Packet>(
            pgrid, x.col(i), r_rep, self, r, count,
            [&](Eigen::Index t, Packet dx, Packet dy, Packet dz, Packet, Packet inside) {
              // d = x_m' - x_m; C d = d - (b_m' . d) b_m'.
              const Packet bx = load<Packet>(pb[0], t), by = load<Packet>(pb[1], t),
                           bz = load<Packet>(pb[2], t);
              const Packet tt =
                  ei::padd(ei::padd(ei::pmul(bx, dx), ei::pmul(by, dy)), ei::pmul(bz, dz));
              const Packet cx = ei::psub(dx, ei::pmul(tt, bx));
              const Packet cy = ei::psub(dy, ei::pmul(tt, by));
              const Packet cz = ei::psub(dz, ei::pmul(tt, bz));
              const Packet rt2 = ei::pmax(
                  ei::padd(ei::padd(ei::pmul(cx, cx), ei::pmul(cy, cy)), ei::pmul(cz, cz)), floor2);
              Packet wb =
                  ei::pmul(detail::fast_pexp(ei::pmul(theta_k, rt2)), detail::fast_prsqrt(rt2));
              wb = ei::pand(ei::pmul(wb, ei::ploadu<Packet>(pgrid.weight() + t)), inside);
              W = ei::padd(W, wb);
              Rx = ei::padd(Rx, ei::pmul(wb, cx));
              Ry = ei::padd(Ry, ei::pmul(wb, cy));
              Rz = ei::padd(Rz, ei::pmul(wb, cz));
            });
        const float w_sum = ei::predux(W);
        // Offsets were x_m' - x_m; eq. 10 sums C (x_m - x_m').
        s.repulsion.col(i) =
            w_sum > 0.0f
                ? Eigen::Vector3f(-Eigen::Vector3f(ei::predux(Rx), ei::predux(Ry), ei::predux(Rz)) /
                                  w_sum)
                : Eigen::Vector3f::Zero();
      });
}

template <class Packet, bool kPointToPoint>
Step em_step_impl(const Problem& problem, const Eigen::Matrix3Xf& x, const Eigen::Matrix3Xf& xb,
                  double s2, double omega, double mu, RunContext* ctx) {
  const Eigen::Matrix3Xf& v = problem.v();
  const Eigen::Index n = v.cols();
  const Eigen::Index m = x.cols();
  const float h = problem.h();
  const float r_rep = problem.repulsion_radius();
  Step s;
  s.outlier_term = std::pow(2.0 * M_PI * s2, 1.5) * omega * static_cast<double>(m) /
                   ((1.0 - omega) * static_cast<double>(n));
  const Packet k_gauss = ei::pset1<Packet>(static_cast<float>(-0.5 / s2));
  std::optional<RunContext::PhaseTimer> timer;

  // E-step (eq. 3).
  if (ctx) timer.emplace(*ctx, "e_step");
  // Where the particles are dense, cells of r_rep / 2 = r_data: the E-step (radius r_data) reads
  // 3 x 3 columns, the repulsion (radius r_rep) 5 x 5; where they are sparse, cells of r_rep
  // (kernels::query_grid).
  detail::NeighborGrid pgrid = kernels::query_grid(x, r_rep);
  const std::vector<float> inv_d =
      e_step<Packet>(problem, pgrid, k_gauss, static_cast<float>(s.outlier_term), s);

  // M-step (eq. 10, 11).
  if (ctx) timer.emplace(*ctx, "m_step");
  // Particle densities w_m (WLOP) and the particle normals in the particle grid's order.
  s.particle_weights = kernels::density_weights(pgrid, x, h, r_rep);
  pgrid.set_weights(s.particle_weights);
  std::vector<float> pb[3];
  for (int d = 0; d < 3; ++d)
    pb[d] = sorted_values(pgrid, xb.data() + d, 3);

  s.data.resize(3, m);
  s.repulsion.resize(3, m);
  // Per particle for eq. 11: sum_n p_mn, and sum_n p_mn (b_n . (v_n - x_m'))^2 with the new x_m'.
  std::vector<double> np_m(static_cast<std::size_t>(m)), res_m(static_cast<std::size_t>(m));
  // Per particle: g = sum_n p b_n (b_n . (v_n - x_m)) and the upper triangle of sum_n p b_n b_n^T;
  // point to point (kPointToPoint): sum_n p |v_n - x_m|^2 and sum_n p (v_n - x_m) instead.
  Eigen::Matrix<double, 9, Eigen::Dynamic> moments(9, m);
  data_term<Packet, kPointToPoint>(problem, x, inv_d, k_gauss, s, np_m, res_m, moments);
  repulsion_term<Packet>(pgrid, x, pb, h, r_rep, s);

  s.x = x + s.data + static_cast<float>(mu) * s.repulsion;
  double np_sum = 0.0, res_sum = 0.0, max_move2 = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::Vector3d dm = (s.x.col(i) - x.col(i)).cast<double>();
    const auto& mo = moments.col(i);
    const Eigen::Vector3d g(mo[0], mo[1], mo[2]);
    Eigen::Matrix3d a;
    a << mo[3], mo[4], mo[5], mo[4], mo[6], mo[7], mo[5], mo[7], mo[8];
    if constexpr (kPointToPoint)
      a = np_m[static_cast<std::size_t>(i)] * Eigen::Matrix3d::Identity();
    const double res = res_m[static_cast<std::size_t>(i)] - 2.0 * dm.dot(g) + dm.dot(a * dm);
    res_sum += std::max(res, 0.0);
    np_sum += np_m[static_cast<std::size_t>(i)];
    max_move2 = std::max(max_move2, dm.squaredNorm());
  }
  s.np = np_sum;
  s.s2 = np_sum > 0.0 ? std::max(res_sum / (3.0 * np_sum), kMinS2) : s2;
  s.max_move = std::sqrt(max_move2);
  return s;
}

}  // namespace

Step em_step(const Problem& problem, const Eigen::Matrix3Xf& x, const Eigen::Matrix3Xf& xb,
             double s2, double omega, double mu, RunContext* ctx, S2Residual residual) {
  return simd::with_packet([&](auto tag) {
    using Packet = typename decltype(tag)::type;
    return residual == S2Residual::Point
               ? em_step_impl<Packet, true>(problem, x, xb, s2, omega, mu, ctx)
               : em_step_impl<Packet, false>(problem, x, xb, s2, omega, mu, ctx);
  });
}

}  // namespace gpf_detail

namespace {
constexpr std::string_view kGpfStage = "filter.gpf";
constexpr std::string_view kChain = "normals.pca -> normals.bilateral -> filter.gpf";
}  // namespace

PointCloud gpf(const PointCloud& input, const GpfParams& p, RunContext& ctx) {
  const float diag = detail::checked_diagonal(input, kGpfStage);
  Eigen::Matrix3Xf normals;
  {
    auto timer = ctx.phase("normals");
    detail::require_unit_normals(input, kGpfStage, kChain);
    normals = detail::unit_normals(input);
  }
  const BoundingBox box = input.bbox();
  const Eigen::Index n = input.size();
  const Eigen::Index m = kernels::particle_count(p.particles, n, kGpfStage);
  if (m > n) {
    throw ParamError(
        fmt::format("{}.particles: {} particles exceed the {} input points (GPF projects a subset)",
                    kGpfStage, m, n));
  }
  // Working units (see gpf.h, "Units"): centred on the bbox, unit diagonal; or CPD's
  // normalisation, centred on the mean, unit root-mean-square distance to it.
  const bool cpd = p.units == "cpd";
  const Eigen::Vector3f centre =
      cpd ? Eigen::Vector3f(input.positions.cast<double>().rowwise().mean().cast<float>())
          : box.center();
  const float scale = cpd ? static_cast<float>(std::sqrt(
                                (input.positions.cast<double>().colwise() - centre.cast<double>())
                                    .colwise()
                                    .squaredNorm()
                                    .mean()))
                          : diag;
  // h and the tolerance are fractions of the diagonal in every unit system.
  const double to_work = static_cast<double>(diag) / static_cast<double>(scale);
  Eigen::Matrix3Xf v = (input.positions.colwise() - centre) / scale;

  std::optional<gpf_detail::Problem> problem;
  Eigen::Matrix3Xf x(3, m), xb(3, m);
  {
    auto timer = ctx.phase("init");
    Rng rng(ctx.stream_seed("particles"));
    const std::vector<char> chosen = kernels::seeded_subset(n, m, rng);
    Eigen::Index k = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!chosen[static_cast<std::size_t>(j)]) continue;
      x.col(k) = v.col(j);
      xb.col(k) = normals.col(j);
      ++k;
    }
    problem.emplace(std::move(v), std::move(normals), static_cast<float>(p.h * to_work));
  }
  double s2 = p.s2_init;
  const bool fixed_s2 = p.s2_update == "fixed";
  const auto residual =
      p.s2_update == "point" ? gpf_detail::S2Residual::Point : gpf_detail::S2Residual::Plane;
  for (int it = 0; it < p.iterations; ++it) {
    ctx.check_cancelled(kGpfStage);
    gpf_detail::Step step = gpf_detail::em_step(*problem, x, xb, s2, p.omega, p.mu, &ctx, residual);
    x = std::move(step.x);
    if (!fixed_s2) s2 = step.s2;
    if (step.max_move <= p.tolerance * to_work) break;
  }
  if (p.gap_iterations > 0) {
    {
      auto timer = ctx.phase("init");
      problem->set_h(static_cast<float>(p.h * p.gap_scale * to_work));
    }
    for (int it = 0; it < p.gap_iterations; ++it) {
      ctx.check_cancelled(kGpfStage);
      gpf_detail::Step step =
          gpf_detail::em_step(*problem, x, xb, s2, p.omega, p.mu, &ctx, residual);
      x = std::move(step.x);
      if (!fixed_s2) s2 = step.s2;
    }
  }
  PointCloud out;
  out.positions = (x * scale).colwise() + centre;
  out.normals = std::move(xb);
  out.validate(kGpfStage);  // never NaN: checked, not assumed
  return out;
}

}  // namespace scanbench::algorithms
