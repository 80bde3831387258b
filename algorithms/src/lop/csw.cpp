#include "scanbench/algorithms/lop/csw.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/mixture_index.h"
#include "spatial/simd_exp.h"

// Eigen's packet types carry vector attributes that GCC reports as ignored when they are
// template arguments (scanbench/core/simd_dispatch.h); they do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace {

using Eigen::Index;

// Per component, the fields of both passes: mean, Lambda^-1 (xx, xy, xz, yy, yz, zz), the eq. 24
// prefactor, the normal axis and its spread; 16 floats, transposed kLanes at a time into packets.
constexpr int kMean = 0, kInv = 3, kCoef = 9, kAxis = 10, kSpread = 13, kFields = 16;
struct Record {
  float f[kFields] = {};
};
const Record kZeroCswRecord{};

// arccos of a packet of cosines c in [0, 1] (the axes are flipped into the particle's
// hemisphere): Cephes' acosf, acos(c) = 2 asin(sqrt((1 - c) / 2)) above 1/2, pi/2 - asin(c)
// below, asin(x) = x + x^3 P(x^2) for |x| <= 1/2 (relative error about 1e-7). Eigen 3.4 has no
// packet arccos.
template <class Packet>
Packet pacos_unit(const Packet& c) {
  namespace ei = Eigen::internal;
  const Packet half = ei::pset1<Packet>(0.5f);
  const Packet big = ei::pcmp_lt(half, c);
  const Packet z_big = ei::pmul(half, ei::psub(ei::pset1<Packet>(1.0f), c));
  const Packet x = ei::pselect(big, ei::psqrt(z_big), c);
  const Packet z = ei::pselect(big, z_big, ei::pmul(c, c));
  Packet p = ei::pmadd(ei::pset1<Packet>(4.2163199048E-2f), z, ei::pset1<Packet>(2.4181311049E-2f));
  p = ei::pmadd(p, z, ei::pset1<Packet>(4.5470025998E-2f));
  p = ei::pmadd(p, z, ei::pset1<Packet>(7.4953002686E-2f));
  p = ei::pmadd(p, z, ei::pset1<Packet>(1.6666752422E-1f));
  const Packet asin_x = ei::pmadd(ei::pmul(x, z), p, x);
  return ei::pselect(big, ei::padd(asin_x, asin_x),
                     ei::psub(ei::pset1<Packet>(1.57079632679489661923f), asin_x));
}

// Per-thread scratch of one particle: the candidate components and their records (packets of
// transposed records), their spatial weights, and the near components padded to whole packets.
struct CswScratch {
  std::vector<detail::GridRange> ranges;
  std::vector<Index> ids, near_ids;
  std::vector<float> d2, soa, w;
  std::vector<float> ax, ay, az, sp, wn;
};

// The components near particle q (sc.near_ids, their axes, spreads and spatial weights
// omega_s = w_s g(mu_s | q, Sigma_s + normal_h^2/32 I) up to a constant, padded to whole
// packets). Components whose spatial weight is below 1e-6 of the largest one are negligible for
// the weighted median and would only cost time (large flat Gaussians reach far).
template <class Packet>
void near_components(const Eigen::Vector3f& q, const detail::MixtureGrid& index,
                     const std::vector<float>& radii, const std::vector<Record>& records,
                     CswScratch& sc) {
  namespace ei = Eigen::internal;
  constexpr int kLanes = ei::unpacket_traits<Packet>::size;
  sc.ids.clear();
  sc.d2.clear();
  index.gather(q, radii, sc.ranges, sc.ids, sc.d2);
  const auto nc = static_cast<Index>(sc.ids.size());
  const Index padded = (nc + kLanes - 1) / kLanes * kLanes;
  const auto np = static_cast<std::size_t>(padded);
  // The candidates' records, transposed in kLanes x kLanes blocks (zero records pad the
  // last packet: weight 0).
  sc.soa.resize(kFields * np);
  sc.w.resize(np);
  for (Index t = 0; t < padded; t += kLanes) {
    const float* rec[kLanes];
    for (int l = 0; l < kLanes; ++l)
      rec[l] = t + l < nc
                   ? records[static_cast<std::size_t>(sc.ids[static_cast<std::size_t>(t + l)])].f
                   : kZeroCswRecord.f;
    float* block = sc.soa.data() + static_cast<std::size_t>(t) * kFields;
    for (int b = 0; b < kFields; b += kLanes) {
      ei::PacketBlock<Packet, kLanes> pb;
      for (int l = 0; l < kLanes; ++l)
        pb.packet[l] = ei::ploadu<Packet>(rec[l] + b);
      ei::ptranspose(pb);
      for (int l = 0; l < kLanes; ++l)
        ei::pstoreu(block + (b + l) * kLanes, pb.packet[l]);
    }
  }
  const Packet qx = ei::pset1<Packet>(q.x()), qy = ei::pset1<Packet>(q.y()),
               qz = ei::pset1<Packet>(q.z()), minus_half = ei::pset1<Packet>(-0.5f);
  Packet pmax = ei::pset1<Packet>(0.0f);
  for (Index t = 0; t < padded; t += kLanes) {
    const float* block = sc.soa.data() + static_cast<std::size_t>(t) * kFields;
    auto field = [&](int f) { return ei::ploadu<Packet>(block + f * kLanes); };
    const Packet dx = ei::psub(field(kMean), qx), dy = ei::psub(field(kMean + 1), qy),
                 dz = ei::psub(field(kMean + 2), qz);
    const Packet a0 = field(kInv), a1 = field(kInv + 1), a2 = field(kInv + 2), a3 = field(kInv + 3),
                 a4 = field(kInv + 4), a5 = field(kInv + 5);
    const Packet tx = ei::padd(ei::padd(ei::pmul(a0, dx), ei::pmul(a1, dy)), ei::pmul(a2, dz));
    const Packet ty = ei::padd(ei::padd(ei::pmul(a1, dx), ei::pmul(a3, dy)), ei::pmul(a4, dz));
    const Packet tz = ei::padd(ei::padd(ei::pmul(a2, dx), ei::pmul(a4, dy)), ei::pmul(a5, dz));
    const Packet quad = ei::padd(ei::padd(ei::pmul(dx, tx), ei::pmul(dy, ty)), ei::pmul(dz, tz));
    const Packet wt = ei::pmul(field(kCoef), detail::fast_pexp(ei::pmul(minus_half, quad)));
    pmax = ei::pmax(pmax, wt);
    ei::pstoreu(sc.w.data() + t, wt);
  }
  const float floor = 1e-6f * ei::predux_max(pmax);
  sc.near_ids.clear();
  sc.ax.clear();
  sc.ay.clear();
  sc.az.clear();
  sc.sp.clear();
  sc.wn.clear();
  for (Index k = 0; k < nc; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    if (!(sc.w[uk] > 0.0f) || sc.w[uk] < floor) continue;
    const float* rec = sc.soa.data() + (uk - uk % kLanes) * kFields + uk % kLanes;
    sc.near_ids.push_back(sc.ids[uk]);
    sc.ax.push_back(rec[kAxis * kLanes]);
    sc.ay.push_back(rec[(kAxis + 1) * kLanes]);
    sc.az.push_back(rec[(kAxis + 2) * kLanes]);
    sc.sp.push_back(rec[kSpread * kLanes]);
    sc.wn.push_back(sc.w[uk]);
  }
  if (sc.near_ids.empty()) return;
  while (sc.wn.size() % kLanes != 0) {  // padding: weight 0, a finite axis
    sc.ax.push_back(0.0f);
    sc.ay.push_back(0.0f);
    sc.az.push_back(1.0f);
    sc.sp.push_back(0.0f);
    sc.wn.push_back(0.0f);
  }
}

// Continuous PCA: the smallest eigenvector of the second moment of the kernel-weighted near
// components about their weighted mean.
Eigen::Vector3f continuous_pca_normal(const GaussianMixture& m, const CswScratch& sc) {
  float wsum = 0.0f;
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (std::size_t e = 0; e < sc.near_ids.size(); ++e) {
    c += sc.wn[e] * m.means.col(sc.near_ids[e]);
    wsum += sc.wn[e];
  }
  c /= wsum;
  Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
  for (std::size_t e = 0; e < sc.near_ids.size(); ++e) {
    const Eigen::Vector3f d = m.means.col(sc.near_ids[e]) - c;
    cov += sc.wn[e] * (m.covariance(sc.near_ids[e]) + d * d.transpose());
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> es(cov / wsum);
  return es.eigenvectors().col(0).normalized();
}

// The Weiszfeld steps (eq. 31-34) from `nrm` over the near components of sc.
template <class Packet>
Eigen::Vector3f weiszfeld(Eigen::Vector3f nrm, const CswScratch& sc, const std::array<float, 3>& wk,
                          const std::array<float, 3>& s2k, int iterations) {
  namespace ei = Eigen::internal;
  constexpr int kLanes = ei::unpacket_traits<Packet>::size;
  const std::vector<float>&ax = sc.ax, &ay = sc.ay, &az = sc.az, &sp = sc.sp, &wn = sc.wn;
  const Packet one = ei::pset1<Packet>(1.0f), zero = ei::pset1<Packet>(0.0f),
               tiny = ei::pset1<Packet>(1e-4f), minus_half_p = ei::pset1<Packet>(-0.5f);
  for (int it = 0; it < iterations; ++it) {
    const Packet nx = ei::pset1<Packet>(nrm.x()), ny = ei::pset1<Packet>(nrm.y()),
                 nz = ei::pset1<Packet>(nrm.z());
    Packet sx = zero, sy = zero, sz = zero;
    for (std::size_t t = 0; t < wn.size(); t += kLanes) {
      Packet mx = ei::ploadu<Packet>(ax.data() + t), my = ei::ploadu<Packet>(ay.data() + t),
             mz = ei::ploadu<Packet>(az.data() + t);
      const Packet c0 = ei::padd(ei::padd(ei::pmul(mx, nx), ei::pmul(my, ny)), ei::pmul(mz, nz));
      // Unoriented axes: the closer pole.
      const Packet flip = ei::pcmp_lt(c0, zero);
      mx = ei::pselect(flip, ei::pnegate(mx), mx);
      my = ei::pselect(flip, ei::pnegate(my), my);
      mz = ei::pselect(flip, ei::pnegate(mz), mz);
      const Packet dg = pacos_unit(ei::pmin(ei::pabs(c0), one));  // d_g, the arc n -> axis
      const Packet ew = ei::ploadu<Packet>(wn.data() + t);
      const Packet spread = ei::ploadu<Packet>(sp.data() + t);
      const Packet half_dg2 = ei::pmul(ei::pmul(minus_half_p, dg), dg);
      const Packet linear = ei::pcmp_lt(dg, tiny);
      const Packet inv_sin = ei::pdiv(one, ei::psin(ei::pselect(linear, one, dg)));
      for (std::size_t j = 0; j < 3; ++j) {
        const Packet s2 = ei::pset1<Packet>(s2k[j]);
        const Packet lambda = ei::padd(spread, s2);
        const Packet tt = ei::pdiv(s2, lambda);  // eq. 34
        const Packet wt = ei::pmul(ei::pmul(ei::pmul(ew, ei::pset1<Packet>(wk[j])), tt),
                                   detail::fast_pexp(ei::pdiv(half_dg2, lambda)));  // eq. 32
        // eq. 33: the point at angle t d_g from n towards the axis on their great circle
        // (slerp; linear below 1e-4 rad), normalised.
        const Packet cn = ei::pselect(linear, ei::psub(one, tt),
                                      ei::pmul(ei::psin(ei::pmul(ei::psub(one, tt), dg)), inv_sin));
        const Packet cm = ei::pselect(linear, tt, ei::pmul(ei::psin(ei::pmul(tt, dg)), inv_sin));
        const Packet vx = ei::padd(ei::pmul(cn, nx), ei::pmul(cm, mx));
        const Packet vy = ei::padd(ei::pmul(cn, ny), ei::pmul(cm, my));
        const Packet vz = ei::padd(ei::pmul(cn, nz), ei::pmul(cm, mz));
        const Packet len =
            ei::psqrt(ei::padd(ei::padd(ei::pmul(vx, vx), ei::pmul(vy, vy)), ei::pmul(vz, vz)));
        const Packet scale = ei::pdiv(wt, len);
        sx = ei::padd(sx, ei::pmul(scale, vx));
        sy = ei::padd(sy, ei::pmul(scale, vy));
        sz = ei::padd(sz, ei::pmul(scale, vz));
      }
    }
    const Eigen::Vector3f sum(ei::predux(sx), ei::predux(sy), ei::predux(sz));
    const float len = sum.norm();
    if (!(len > 0.0f)) break;
    nrm = sum / len;
  }
  return nrm;
}

// The particles with the packet of the active ISA (scanbench/core/simd.h): per particle the
// spatial weights of its candidate components (eq. 24 kernel), then the Weiszfeld steps (eq.
// 31-34), each summed lane-wise over the near components in a fixed order (the result depends
// only on the particle and the mixture, never on the thread count).
template <class Packet>
void csw_particles(const GaussianMixture& m, const Eigen::Matrix3Xf& particles,
                   const Eigen::Matrix3Xf& initial, const detail::MixtureGrid& index,
                   const std::vector<float>& radii, const std::vector<Record>& records,
                   const std::array<float, 3>& wk, const std::array<float, 3>& s2k, int iterations,
                   Eigen::Matrix3Xf& out) {
  static_assert(kFields % Eigen::internal::unpacket_traits<Packet>::size == 0);
  const Index n = particles.cols();
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 64), [&](const tbb::blocked_range<Index>& r) {
    CswScratch sc;
    for (Index i = r.begin(); i != r.end(); ++i) {
      const Eigen::Vector3f q = particles.col(i);
      near_components<Packet>(q, index, radii, records, sc);
      if (sc.near_ids.empty()) {
        out.col(i) = initial.cols() ? Eigen::Vector3f(initial.col(i)) : Eigen::Vector3f::UnitZ();
        continue;
      }
      const Eigen::Vector3f start = initial.cols() ? Eigen::Vector3f(initial.col(i).normalized())
                                                   : continuous_pca_normal(m, sc);
      const Eigen::Vector3f nrm = weiszfeld<Packet>(start, sc, wk, s2k, iterations);
      out.col(i) = nrm.dot(start) < 0.0f ? Eigen::Vector3f(-nrm) : nrm;
    }
  });
}

}  // namespace

Eigen::Matrix3Xf csw_normals(const GaussianMixture& m, const Eigen::Matrix3Xf& particles,
                             const Eigen::Matrix3Xf& initial, double normal_h, int iterations,
                             RunContext& ctx) {
  constexpr const char* stage = "normals.csw";
  if (m.size() == 0) throw InputError(fmt::format("{}: empty mixture", stage));
  if (!m.has_normal_axes())
    throw InputError(fmt::format("{}: the mixture carries no normal axes", stage));
  const Index n = particles.cols();
  if (initial.cols() != 0 && initial.cols() != n) {
    throw InputError(
        fmt::format("{}: {} initial normals for {} particles", stage, initial.cols(), n));
  }
  // Per component: Lambda^-1 and the eq. 24 prefactor for the spatial kernel of width normal_h.
  const Index k = m.size();
  const double var = normal_h * normal_h / 32.0;
  std::vector<Eigen::Matrix3f> inv(static_cast<std::size_t>(k));
  std::vector<float> coef(static_cast<std::size_t>(k));
  for (Index s = 0; s < k; ++s) {
    const Eigen::Matrix3d cov = m.covariance(s).cast<double>();
    const Eigen::Matrix3d lambda = cov + var * Eigen::Matrix3d::Identity();
    inv[static_cast<std::size_t>(s)] = lambda.inverse().cast<float>();
    coef[static_cast<std::size_t>(s)] =
        static_cast<float>(m.weights(s) * std::pow(var, 1.5) / std::sqrt(lambda.determinant()));
  }
  const detail::MixtureGrid index(m, var, var);
  const std::vector<float> radii = index.radii(var);
  std::array<float, 3> wk, s2k;
  for (int j = 0; j < 3; ++j) {
    wk[j] = static_cast<float>(kClopFitWeights[j]);
    s2k[j] = static_cast<float>(kClopFitSigmas[j] * kClopFitSigmas[j] * M_PI * M_PI);  // H = pi
  }
  // One record of 16 floats per component (the fields of both passes), transposed per packet.
  std::vector<Record> records(static_cast<std::size_t>(k));
  for (Index s = 0; s < k; ++s) {
    const auto us = static_cast<std::size_t>(s);
    float* f = records[us].f;
    for (int d = 0; d < 3; ++d) {
      f[kMean + d] = m.means(d, s);
      f[kAxis + d] = m.normal_axes(d, s);
    }
    const Eigen::Matrix3f& a = inv[us];
    f[kInv + 0] = a(0, 0);
    f[kInv + 1] = a(0, 1);
    f[kInv + 2] = a(0, 2);
    f[kInv + 3] = a(1, 1);
    f[kInv + 4] = a(1, 2);
    f[kInv + 5] = a(2, 2);
    f[kCoef] = coef[us];
    f[kSpread] = std::max(m.normal_spreads(s), 0.0f);
  }

  Eigen::Matrix3Xf out(3, n);
  auto timer = ctx.phase("csw");
  simd::with_packet([&](auto tag) {
    csw_particles<typename decltype(tag)::type>(m, particles, initial, index, radii, records, wk,
                                                s2k, iterations, out);
  });
  return out;
}

PointCloud csw(const StageData& data, const CswParams& p, RunContext& ctx) {
  constexpr const char* stage = "normals.csw";
  const PointCloud& in = data.points;
  const double diag = detail::checked_diagonal(in, stage);
  const GaussianMixture& mixture =
      data.require_mixture(fmt::format("{} (chain mixture.hem -> normals.csw)", stage));
  const double h = p.h * diag;
  Eigen::Matrix3Xf q;
  Eigen::Matrix3Xf initial;
  if (p.resample) {
    ClopParams cp;
    static_cast<ClopProjectionSettings&>(cp) = p;
    cp.repulsion_weights = p.weighted ? "wlop" : "none";
    const Index m = kernels::particle_count(p.particles, in.size(), stage);
    {
      auto timer = ctx.phase("init");
      q = kernels::initial_particles(in.positions, m, ctx.stream_seed("particles"),
                                     static_cast<float>(0.01 * h));
    }
    clop_project(mixture, q, cp, h, ctx);
  } else {
    q = in.positions;
    if (in.has_normals()) initial = in.normals;
  }
  Eigen::Matrix3Xf normals =
      csw_normals(mixture, q, initial, p.normal_h * diag, p.csw_iterations, ctx);

  // Orientation from the nearest input point's sensor or normal (see csw.h).
  const bool sensors = in.has_scan_ids() && in.sensor_origins.cols() > 0;
  if (sensors || in.has_normals()) {
    const KdTree tree(in.positions);
    tbb::parallel_for(tbb::blocked_range<Index>(0, q.cols(), 256), [&](const auto& r) {
      for (Index i = r.begin(); i != r.end(); ++i) {
        const Index j = p.resample ? tree.nearest(q.col(i)) : i;
        const Eigen::Vector3f ref =
            sensors ? Eigen::Vector3f(in.sensor_origins.col(in.scan_ids(j)) - q.col(i))
                    : Eigen::Vector3f(in.normals.col(j));
        if (normals.col(i).dot(ref) < 0.0f) normals.col(i) *= -1.0f;
      }
    });
  }
  PointCloud out;
  out.positions = std::move(q);
  out.normals = std::move(normals);
  return out;
}

}  // namespace scanbench::algorithms
