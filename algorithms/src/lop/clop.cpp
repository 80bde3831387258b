#include "scanbench/algorithms/lop/clop.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <numeric>
#include <optional>
#include <vector>

#include "input_checks.h"
#include "lop/clop_internal.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/radix_sort.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/mixture_index.h"
#include "spatial/simd_exp.h"

// Eigen's packet types (__m128, __m256, __m512) carry vector attributes that GCC reports as
// ignored when they are template arguments (the kernels are templates over the packet type of
// the active ISA, scanbench/core/simd_dispatch.h); the attributes do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace {

using Eigen::Index;

// Per component: the mean (x, y, z), then for the three fit Gaussians (k = 0..2) and the eq. 24
// kernel (k = 3) the inverse of Lambda as (xx, xy, xz, yy, yz, zz) and the log of the
// dimensionless weight prefactor: f[3 + 7 k + e]. The attraction's fields f[0..23] are a
// candidate's fields in CellScratch::soa, in order.
struct Precomputed {
  static constexpr int kernel(int k) { return 3 + 7 * k; }
  float f[32];  // 31 used; 128 bytes
};

// Bins of the candidates' order by their reach from the centre of a cell of particles.
constexpr int kReachBins = 32;
// Particles per occupied cell below which the attraction's cells widen (docs/performance.md: 16
// rather than 6 made the Camel case's attraction 1.5x faster at 70K and 1.3x at 834K points).
constexpr double kMinOccupancy = 16.0;
constexpr Precomputed kZeroRecord{};

// The packet of the candidates' transposes: the active packet, or 8 lanes for a 16-lane packet
// (the 24 fields of a record are three rows of 8).
template <class Packet>
struct FillPacket {
  using type = Packet;
};
#ifdef EIGEN_VECTORIZE_AVX512
template <>
struct FillPacket<Eigen::internal::Packet16f> {
  using type = Eigen::internal::Packet8f;
};
#endif

// Per-thread scratch of one cell of particles: the candidate components in packets of L floats
// (the packet width of the active ISA, scanbench/core/simd.h), each packet a block of fields of L
// floats (mean x, y, z, then per kernel the six entries
// of Lambda^-1 and the log prefactor): what a packet of terms needs is contiguous.
struct CellScratch {
  std::vector<detail::GridRange> ranges;
  std::vector<Index> ids, sorted;
  std::vector<float> d2;
  std::vector<int> shell;
  std::vector<float> soa;
  std::vector<float> valid;  // all-ones bit pattern for real candidates, 0 for the padding
  // Per candidate (in ids order) its bound m of gather_cell; per packet the least m of it and
  // of the packets after it.
  std::vector<float> m, m_sorted, packet_m;
};

// The components of `m` (weights, means, covariances) in the order of a grid of cubic cells of
// side `cell`, so that the components gathered for one cell of particles lie close together in
// memory (at a million points the mixture's tables no longer fit the caches).
GaussianMixture spatially_sorted(const GaussianMixture& m, double cell) {
  const Index k = m.size();
  std::vector<std::pair<std::uint64_t, Index>> keys(static_cast<std::size_t>(k));
  const Eigen::Vector3f lo =
      k > 0 ? Eigen::Vector3f(m.means.rowwise().minCoeff()) : Eigen::Vector3f::Zero();
  for (Index s = 0; s < k; ++s) {
    std::uint64_t key = 0;
    for (int d = 0; d < 3; ++d) {
      const double c = std::floor((m.means(d, s) - lo[d]) / cell);
      key = (key << 21) | static_cast<std::uint64_t>(std::clamp(c, 0.0, 2097151.0));
    }
    keys[static_cast<std::size_t>(s)] = {key, s};
  }
  tbb::parallel_sort(keys.begin(), keys.end());
  GaussianMixture out;
  out.weights.resize(k);
  out.means.resize(3, k);
  out.covariances.resize(6, k);
  for (Index t = 0; t < k; ++t) {
    const Index s = keys[static_cast<std::size_t>(t)].second;
    out.weights[t] = m.weights[s];
    out.means.col(t) = m.means.col(s);
    out.covariances.col(t) = m.covariances.col(s);
  }
  return out;
}

class PreparedMixture {
 public:
  // h: the attraction's kernel width; h_initial: the first iteration's (eq. 24).
  PreparedMixture(const GaussianMixture& mixture, double h, double h_initial,
                  bool skip_out_of_reach)
      : sorted_(spatially_sorted(mixture, h)),
        cell_(static_cast<float>(h / 4.0)),
        index_(sorted_, kClopFitSigmas[0] * kClopFitSigmas[0] * h * h,
               kClopFitSigmas[0] * kClopFitSigmas[0] * h * h),
        skip_out_of_reach_(skip_out_of_reach) {
    const GaussianMixture& m = sorted_;
    const Index k = m.size();
    for (int j = 0; j < 3; ++j)
      s2_[j] = static_cast<float>(kClopFitSigmas[j] * kClopFitSigmas[j] * h * h);
    s2_[3] = static_cast<float>(h_initial * h_initial / 32.0);
    pre_.resize(static_cast<std::size_t>(k));
    // Per component, for the widest kernels (j = 0, 3): 1 / lambda_min and lambda_max / lambda_min
    // of Lambda (the largest eigenvalue of Lambda^-1 and its condition number).
    std::vector<std::array<double, 4>> spectra(static_cast<std::size_t>(k));
    tbb::parallel_for(tbb::blocked_range<Index>(0, k, 256), [&](const auto& r) {
      for (Index s = r.begin(); s != r.end(); ++s) {
        const Eigen::Matrix3d cov = m.covariance(s).cast<double>();
        Precomputed& p = pre_[static_cast<std::size_t>(s)];
        for (int d = 0; d < 3; ++d)
          p.f[d] = m.means(d, s);
        for (int j = 0; j < 4; ++j) {
          const double var =
              j < 3 ? kClopFitSigmas[j] * kClopFitSigmas[j] * h * h : h_initial * h_initial / 32.0;
          const Eigen::Matrix3d lambda = cov + var * Eigen::Matrix3d::Identity();
          if (j == 0 || j == 3) {
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
            es.computeDirect(lambda, Eigen::EigenvaluesOnly);
            const double lo = es.eigenvalues()(0), hi = es.eigenvalues()(2);
            auto& sp = spectra[static_cast<std::size_t>(s)];
            sp[j == 0 ? 0 : 2] = lo > 0.0 ? 1.0 / lo : std::numeric_limits<double>::infinity();
            sp[j == 0 ? 1 : 3] = lo > 0.0 ? hi / lo : std::numeric_limits<double>::infinity();
          }
          const Eigen::Matrix3d inv = lambda.inverse();
          const double det = lambda.determinant();
          float* kj = p.f + Precomputed::kernel(j);
          kj[0] = static_cast<float>(inv(0, 0));
          kj[1] = static_cast<float>(inv(0, 1));
          kj[2] = static_cast<float>(inv(0, 2));
          kj[3] = static_cast<float>(inv(1, 1));
          kj[4] = static_cast<float>(inv(1, 2));
          kj[5] = static_cast<float>(inv(2, 2));
          // eq. 19 times h^3 (dimensionless; the common h^3 cancels in eq. 22) and eq. 24 times
          // the constant (h^2/32)^(3/2) (2 pi)^(3/2) / c_theta that cancels in eq. 23.
          const double scale = j < 3 ? kClopFitWeights[j] * std::pow(var, 1.5) : std::pow(var, 1.5);
          kj[6] = static_cast<float>(std::log(m.weights(s) * scale / std::sqrt(det)));
        }
      }
    });
    r_attraction_ = index_.radii(s2_[0]);
    r_initial_ = index_.radii(s2_[3]);
    for (int w = 0; w < 2; ++w) {
      double inv_min = 0.0, cond = 1.0;
      for (const auto& sp : spectra) {
        inv_min = std::max(inv_min, sp[2 * w]);
        cond = std::max(cond, sp[2 * w + 1]);
      }
      // A term is kept when its float exponent is >= -16: the float quadratic form of a
      // particle (six products, relative error < 1e-6 of |d|^T |A| |d| <= 3 cond d^T A d) is at
      // least (1 - 3e-6 cond) times the exact one. Past cond 1e5 no bound is used.
      const double slack = 1.0 - 3e-6 * cond;
      reach_base_[w] = slack > 0.5 ? static_cast<float>(std::sqrt(32.0 / slack) * (1.0 + 1e-5))
                                   : std::numeric_limits<float>::infinity();
      reach_scale_[w] = static_cast<float>(std::sqrt(inv_min) * (1.0 + 1e-5) * (1.0 + 1e-5));
    }
  }

  // One projection of every particle: eq. 24 (kInitial, j = 3) or eq. 22 (j = 0..2),
  // q' = q + sum_j s2_j w_j Lambda_j^-1 (mu - q) / sum_j w_j. Particles are batched by cells of
  // width h/4: the components near a cell are gathered once (radius + the cell's half diagonal,
  // from per-size-class grids of the means, which never move) into structure-of-arrays form, then
  // each particle of the cell evaluates them in SIMD packets.
  // A term (component s, kernel k) is dropped when its exponent is below -16: exactly the
  // truncation of the gather radius, applied per term (when the widest kernel is out of reach,
  // the narrower ones are too: Lambda_j^-1 >= Lambda_0^-1). Each particle's result depends only
  // on its cell's candidate list, never on the thread count.
  // Packet is the float packet of the active ISA: the terms of a particle are summed lane-wise
  // in a fixed order, so each width gives the same result at any thread count (widths differ
  // from each other only in float summation order).
  template <bool kInitial>
  void project_all(const Eigen::Matrix3Xf& q, Eigen::Matrix3Xf& out) const {
    simd::with_packet(
        [&](auto tag) { project_all_impl<kInitial, typename decltype(tag)::type>(q, out); });
  }

 private:
  // The particles in cells of side `cell` (returned): keys (Morton code of the particle's cell of
  // side h/4, particle) in code order, starts[c] .. starts[c + 1] the particles of cell c. Cells
  // of side h/4; where the particles are spread thinly (noise thicker than the cell, fewer than
  // kMinOccupancy per occupied cell on average) the side doubles, up to h, so that one gather
  // serves several particles. The terms kept do not depend on the cell (every term within reach
  // is gathered, the rest is masked out), only their summation order does.
  // One sort serves every side: the cells of side 2^level h/4 (`level`) are the runs of equal
  // code >> 3 level, the same cells as floor((p - lo) / side) (the side's reciprocal is a
  // power-of-two multiple of h/4's, so the quotient is halved exactly) while the box spans fewer
  // than 2^21 cells of h/4 per axis (beyond, the coordinates clamp). A cell's particles are
  // in (cell of side h/4, index) order, which changes no result: each is projected on its own.
  float sort_into_cells(const Eigen::Matrix3Xf& q, const Eigen::Vector3f& lo,
                        std::vector<std::pair<std::uint64_t, Index>>& keys,
                        std::vector<std::size_t>& starts, int& level) const {
    const Index n = q.cols();
    constexpr int kLevels = 3;  // sides h/4, h/2, h
    const float inv_cell = 1.0f / cell_;
    auto coord = [&](float v, float l) {
      return static_cast<std::uint64_t>(
          std::clamp(std::floor((v - l) * inv_cell), 0.0f, static_cast<float>((1 << 21) - 1)));
    };
    keys.resize(static_cast<std::size_t>(n));
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096), [&](const auto& r) {
      for (Index i = r.begin(); i != r.end(); ++i) {
        const std::uint64_t key = morton_spread3(coord(q(0, i), lo.x())) << 2 |
                                  morton_spread3(coord(q(1, i), lo.y())) << 1 |
                                  morton_spread3(coord(q(2, i), lo.z()));
        keys[static_cast<std::size_t>(i)] = {key, i};
      }
    });
    radix_sort(keys, [](const auto& e) { return e.first; });  // (code, index) order
    std::array<std::size_t, kLevels> cells{};
    for (std::size_t i = 0; i < keys.size(); ++i)
      for (int l = 0; l < kLevels; ++l)
        cells[static_cast<std::size_t>(l)] +=
            i == 0 || keys[i].first >> (3 * l) != keys[i - 1].first >> (3 * l) ? 1 : 0;
    level = 0;
    while (level + 1 < kLevels &&
           static_cast<double>(n) / static_cast<double>(std::max<std::size_t>(
                                        cells[static_cast<std::size_t>(level)], 1)) <
               kMinOccupancy)
      ++level;
    starts.clear();
    for (std::size_t i = 0; i < keys.size(); ++i)
      if (i == 0 || keys[i].first >> (3 * level) != keys[i - 1].first >> (3 * level))
        starts.push_back(i);
    starts.push_back(keys.size());
    return cell_ * static_cast<float>(1 << level);
  }

  // The candidate components of a cell of particles (centre `center`, its particles within
  // delta_max of it) into sc.ids, in the order of their reach m = |mu - center|_A, with A the
  // Lambda^-1 of the widest kernel (the first in the candidates' fields), in bins of m (a stable
  // counting sort). A particle at delta from the centre has |mu - q|_A >= |mu - center|_A -
  // delta sqrt(lambda_max(A)) (the triangle inequality of the A norm): every candidate with
  // m > reach_limit(delta) is out of its reach (float exponent below -16, which drops the term
  // and, the widest kernel first, the narrower ones), and the candidates beyond
  // reach_limit(delta_max) are out of reach of all the cell's particles and are dropped. The
  // out-of-reach terms of a particle thus fill whole packets at the end, which project_particle
  // does not visit: the kept terms are those of a full scan.
  template <bool kInitial>
  void gather_cell(const Eigen::Vector3f& center, const std::vector<float>& radii, float delta_max,
                   CellScratch& sc) const {
    constexpr int j0 = kInitial ? 3 : 0;
    sc.ids.clear();
    sc.d2.clear();
    index_.gather(center, radii, sc.ranges, sc.ids, sc.d2);
    const float limit = reach_limit<kInitial>(delta_max);
    const float to_bin = kReachBins / limit;
    std::array<std::size_t, kReachBins + 2> next{};
    sc.m.resize(sc.ids.size());
    sc.shell.resize(sc.ids.size());
    std::size_t kept = 0;
    for (std::size_t k = 0; k < sc.ids.size(); ++k) {
      const float* rec = pre_[static_cast<std::size_t>(sc.ids[k])].f;
      const float* a = rec + Precomputed::kernel(j0);
      // In double: the bound is the exact form of the float entries (less a hair for the cast).
      const double dx = static_cast<double>(rec[0]) - center.x(),
                   dy = static_cast<double>(rec[1]) - center.y(),
                   dz = static_cast<double>(rec[2]) - center.z();
      const double quad = dx * (a[0] * dx + a[1] * dy + a[2] * dz) +
                          dy * (a[1] * dx + a[3] * dy + a[4] * dz) +
                          dz * (a[2] * dx + a[4] * dy + a[5] * dz);
      const auto m = static_cast<float>(std::sqrt(std::max(quad, 0.0)) * (1.0 - 1e-6));
      sc.ids[kept] = sc.ids[k];  // branch-free compaction
      sc.m[kept] = m;
      kept += m <= limit || !skip_out_of_reach_ ? 1 : 0;
    }
    sc.ids.resize(kept);
    sc.m.resize(kept);
    // Without the skipping (the test that it changes nothing), the dropped candidates follow
    // all the others, in a bin of their own.
    for (std::size_t k = 0; k < kept; ++k)
      sc.shell[k] = sc.m[k] <= limit ? std::min(kReachBins - 1, static_cast<int>(sc.m[k] * to_bin))
                                     : kReachBins;
    for (std::size_t k = 0; k < kept; ++k)
      ++next[static_cast<std::size_t>(sc.shell[k]) + 1];
    for (int b = 0; b < kReachBins + 1; ++b)
      next[static_cast<std::size_t>(b) + 1] += next[static_cast<std::size_t>(b)];
    sc.sorted.resize(kept);
    sc.m_sorted.resize(kept);
    for (std::size_t k = 0; k < kept; ++k) {
      const std::size_t at = next[static_cast<std::size_t>(sc.shell[k])]++;
      sc.sorted[at] = sc.ids[k];
      sc.m_sorted[at] = sc.m[k];
    }
    sc.ids.swap(sc.sorted);
    sc.m.swap(sc.m_sorted);
  }

  // The largest bound m (gather_cell) of a candidate within reach of a particle at distance
  // delta from its cell's centre: sqrt(32) (the exponent -16, widened for the rounding of the
  // particle's float form) plus delta sqrt(lambda_max(A)), the largest over the components.
  template <bool kInitial>
  float reach_limit(float delta) const {
    constexpr int w = kInitial ? 1 : 0;
    return reach_base_[w] + reach_scale_[w] * delta;
  }

  // The least m of the candidates from each packet of `lanes` on (padding lanes excluded).
  static void packet_bounds(CellScratch& sc, Index padded, int lanes) {
    const auto np = static_cast<std::size_t>(padded / lanes);
    sc.packet_m.assign(np, std::numeric_limits<float>::infinity());
    for (std::size_t k = 0; k < sc.m.size(); ++k) {
      float& e = sc.packet_m[k / static_cast<std::size_t>(lanes)];
      e = std::min(e, sc.m[k]);
    }
    for (std::size_t p = np; p-- > 1;)
      sc.packet_m[p - 1] = std::min(sc.packet_m[p - 1], sc.packet_m[p]);
  }

  // The fields of the cell's m candidates into sc.soa (packets of kLanes candidates, padded with
  // zero records) and their lane mask into sc.valid. Returns m rounded up to whole packets.
  template <bool kInitial, class Packet>
  Index fill_candidates(CellScratch& sc) const {
    namespace ei = Eigen::internal;
    constexpr int kLanes = ei::unpacket_traits<Packet>::size;
    constexpr int j0 = kInitial ? 3 : 0;
    constexpr int nk = kInitial ? 1 : 3;
    constexpr int nf = 3 + 7 * nk;
    float ones;
    const std::uint32_t bits = 0xffffffffu;
    std::memcpy(&ones, &bits, sizeof ones);
    const auto m = static_cast<Index>(sc.ids.size());
    const Index padded = (m + kLanes - 1) / kLanes * kLanes;
    const auto np = static_cast<std::size_t>(padded);
    sc.soa.resize(nf * np);
    sc.valid.assign(np, 0.0f);
    std::fill_n(sc.valid.begin(), m, ones);
    // Transposed in blocks of S x S floats (S = 4 or 8; a 16-lane packet is filled as two halves
    // of 8 lanes), so the 16-lane path moves whole rows too.
    using Sub = typename FillPacket<Packet>::type;
    constexpr int kSub = ei::unpacket_traits<Sub>::size;
    if constexpr (!kInitial && nf % kSub == 0) {
      // The 24 fields of S candidates: their records' first 24 floats, transposed in S x S
      // blocks (a zero record pads the last packet).
      static_assert(nf == 24);
      using Block = Eigen::internal::PacketBlock<Sub, kSub>;
      for (Index t = 0; t < padded; t += kSub) {
        const float* rec[kSub];
        for (int l = 0; l < kSub; ++l)
          rec[l] = t + l < m
                       ? pre_[static_cast<std::size_t>(sc.ids[static_cast<std::size_t>(t + l)])].f
                       : kZeroRecord.f;
        // Lanes t % L .. t % L + S - 1 of the packet starting at t - t % L.
        float* block = sc.soa.data() + static_cast<std::size_t>(t - t % kLanes) * nf + t % kLanes;
        for (int b = 0; b < nf; b += kSub) {
          Block pb;
          for (int l = 0; l < kSub; ++l)
            pb.packet[l] = ei::ploadu<Sub>(rec[l] + b);
          ei::ptranspose(pb);
          for (int l = 0; l < kSub; ++l)
            ei::pstoreu(block + (b + l) * kLanes, pb.packet[l]);
        }
      }
    } else {
      for (Index k = m; k < padded; ++k)  // the padding lanes of the last packet
        for (int f = 0; f < nf; ++f)
          sc.soa[static_cast<std::size_t>((padded - kLanes) * nf + f * kLanes + k % kLanes)] = 0.0f;
      for (Index k = 0; k < m; ++k) {
        const float* src = pre_[static_cast<std::size_t>(sc.ids[static_cast<std::size_t>(k)])].f;
        const auto kk = static_cast<std::size_t>(k);
        float* dst = sc.soa.data() + (kk - kk % kLanes) * nf + kk % kLanes;
        for (int d = 0; d < 3; ++d)
          dst[d * kLanes] = src[d];
        for (int e = 0; e < 7 * nk; ++e)
          dst[(3 + e) * kLanes] = src[Precomputed::kernel(j0) + e];
      }
    }
    return padded;
  }

  // Particle qi projected on the cell's candidates (sc.soa, `padded` lanes): eq. 24 or eq. 22.
  template <bool kInitial, class Packet>
  Eigen::Vector3f project_particle(const Eigen::Vector3f& qi, const CellScratch& sc,
                                   Index padded) const {
    namespace ei = Eigen::internal;
    constexpr int kLanes = ei::unpacket_traits<Packet>::size;
    constexpr int j0 = kInitial ? 3 : 0;
    constexpr int nk = kInitial ? 1 : 3;
    constexpr int nf = 3 + 7 * nk;
    const Packet limit = ei::pset1<Packet>(32.0f);
    const Packet minus_half = ei::pset1<Packet>(-0.5f);
    const Packet qx = ei::pset1<Packet>(qi.x()), qy = ei::pset1<Packet>(qi.y()),
                 qz = ei::pset1<Packet>(qi.z());
    Packet sw = ei::pset1<Packet>(0.0f), sx = sw, sy = sw, sz = sw;
    for (Index t = 0; t < padded; t += kLanes) {
      const float* block = sc.soa.data() + static_cast<std::size_t>(t) * nf;
      const Packet dx = ei::psub(ei::ploadu<Packet>(block), qx);
      const Packet dy = ei::psub(ei::ploadu<Packet>(block + kLanes), qy);
      const Packet dz = ei::psub(ei::ploadu<Packet>(block + 2 * kLanes), qz);
      const Packet keep = ei::ploadu<Packet>(sc.valid.data() + t);
      for (int jj = 0; jj < nk; ++jj) {
        const float* a = block + (3 + 7 * jj) * kLanes;
        const Packet a0 = ei::ploadu<Packet>(a);
        const Packet a1 = ei::ploadu<Packet>(a + kLanes);
        const Packet a2 = ei::ploadu<Packet>(a + 2 * kLanes);
        const Packet a3 = ei::ploadu<Packet>(a + 3 * kLanes);
        const Packet a4 = ei::ploadu<Packet>(a + 4 * kLanes);
        const Packet a5 = ei::ploadu<Packet>(a + 5 * kLanes);
        const Packet tx = ei::padd(ei::padd(ei::pmul(a0, dx), ei::pmul(a1, dy)), ei::pmul(a2, dz));
        const Packet ty = ei::padd(ei::padd(ei::pmul(a1, dx), ei::pmul(a3, dy)), ei::pmul(a4, dz));
        const Packet tz = ei::padd(ei::padd(ei::pmul(a2, dx), ei::pmul(a4, dy)), ei::pmul(a5, dz));
        const Packet quad =
            ei::padd(ei::padd(ei::pmul(dx, tx), ei::pmul(dy, ty)), ei::pmul(dz, tz));
        // A term whose exponent is below -16 is dropped (the e^-16 truncation of
        // LOP's support radius, per component and kernel). The widest kernel comes
        // first: when it is out of reach, so are the narrower ones.
        const Packet in = ei::pand(keep, ei::pcmp_le(quad, limit));
        if (!ei::predux_any(in)) {
          if (jj == 0) break;
          continue;
        }
        const Packet w = ei::pand(detail::fast_pexp(ei::padd(ei::ploadu<Packet>(a + 6 * kLanes),
                                                             ei::pmul(minus_half, quad))),
                                  in);
        const Packet ws = ei::pmul(w, ei::pset1<Packet>(s2_[j0 + jj]));
        sw = ei::padd(sw, w);
        sx = ei::padd(sx, ei::pmul(ws, tx));
        sy = ei::padd(sy, ei::pmul(ws, ty));
        sz = ei::padd(sz, ei::pmul(ws, tz));
      }
    }
    const float den = ei::predux(sw);
    return den > 0.0f ? Eigen::Vector3f(qi + Eigen::Vector3f(ei::predux(sx), ei::predux(sy),
                                                             ei::predux(sz)) /
                                                 den)
                      : qi;  // no component within reach: the particle stays
  }

  template <bool kInitial, class Packet>
  void project_all_impl(const Eigen::Matrix3Xf& q, Eigen::Matrix3Xf& out) const {
    const Index n = q.cols();
    if (n == 0) return;
    const Eigen::Vector3f lo = q.rowwise().minCoeff();
    std::vector<std::pair<std::uint64_t, Index>> keys;
    std::vector<std::size_t> starts;
    int level = 0;
    const float cell = sort_into_cells(q, lo, keys, starts, level);
    std::vector<float> radii = kInitial ? r_initial_ : r_attraction_;
    const float half_diag = 0.5f * std::sqrt(3.0f) * cell;
    for (float& r : radii)
      r += half_diag;
    constexpr int kLanes = Eigen::internal::unpacket_traits<Packet>::size;

    const auto project_cells = [&](const tbb::blocked_range<std::size_t>& rr) {
      CellScratch sc;
      for (std::size_t c = rr.begin(); c != rr.end(); ++c) {
        const std::uint64_t key = keys[starts[c]].first >> (3 * level);
        const Eigen::Vector3f center =
            lo + cell * (Eigen::Vector3f(static_cast<float>(morton_compact3(key >> 2)),
                                         static_cast<float>(morton_compact3(key >> 1)),
                                         static_cast<float>(morton_compact3(key))) +
                         Eigen::Vector3f::Constant(0.5f));
        float delta_max = 0.0f;
        for (std::size_t pi = starts[c]; pi < starts[c + 1]; ++pi)
          delta_max = std::max(delta_max, (q.col(keys[pi].second) - center).norm());
        gather_cell<kInitial>(center, radii, delta_max, sc);
        const Index padded = fill_candidates<kInitial, Packet>(sc);
        packet_bounds(sc, padded, kLanes);
        for (std::size_t pi = starts[c]; pi < starts[c + 1]; ++pi) {
          const Index i = keys[pi].second;
          // The packets within this particle's reach: a prefix (their bound grows).
          const float limit = reach_limit<kInitial>((q.col(i) - center).norm());
          const auto reached = skip_out_of_reach_
                                   ? static_cast<Index>(std::upper_bound(sc.packet_m.begin(),
                                                                         sc.packet_m.end(), limit) -
                                                        sc.packet_m.begin())
                                   : padded / kLanes;
          out.col(i) = project_particle<kInitial, Packet>(q.col(i), sc, reached * kLanes);
        }
      }
    };
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, starts.size() - 1, 1), project_cells);
  }

  GaussianMixture sorted_;
  float cell_;
  float s2_[4];
  std::vector<Precomputed> pre_;
  detail::MixtureGrid index_;
  std::vector<float> r_attraction_, r_initial_;
  // reach_limit's terms for the attraction [0] and the first iteration [1].
  float reach_base_[2], reach_scale_[2];
  bool skip_out_of_reach_;  // skip the packets out of reach of a particle (gather_cell)
};

}  // namespace

double clop_alpha_hat(double r, double h) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double sh = kClopFitSigmas[k] * h;
    sum += kClopFitWeights[k] * std::exp(-0.5 * r * r / (sh * sh));
  }
  return sum;
}

Eigen::Vector3f clop_attraction_reference(const Eigen::Vector3f& q, const GaussianMixture& m,
                                          double h) {
  Eigen::Vector3d num = Eigen::Vector3d::Zero();
  double den = 0.0;
  const Eigen::Vector3d qd = q.cast<double>();
  for (Index s = 0; s < m.size(); ++s) {
    const Eigen::Matrix3d cov = m.covariance(s).cast<double>();
    const Eigen::Vector3d d = m.means.col(s).cast<double>() - qd;
    for (int k = 0; k < 3; ++k) {
      const double var = kClopFitSigmas[k] * kClopFitSigmas[k] * h * h;
      const Eigen::Matrix3d lambda = cov + var * Eigen::Matrix3d::Identity();
      const Eigen::Matrix3d inv = lambda.inverse();
      const double w = m.weights(s) * kClopFitWeights[k] * std::pow(var, 1.5) /
                       std::sqrt(lambda.determinant()) * std::exp(-0.5 * d.dot(inv * d));
      num += w * var * (inv * d);
      den += w;
    }
  }
  if (!(den > 0.0)) return q;
  return (qd + num / den).cast<float>();
}

namespace {

// The particles' places in a spatial order: ids[k] is the particle stored at place k (cells of
// side `cell` in key order, the particles of a cell in index order). Every pass visits the
// particles cell by cell; stored in that order, their reads and writes stream through memory
// instead of missing the caches once a pass no longer fits them (from about a million particles).
std::vector<Index> spatial_order(const Eigen::Matrix3Xf& q, float cell) {
  const Index n = q.cols();
  std::vector<std::pair<std::uint64_t, Index>> keys(static_cast<std::size_t>(n));
  const Eigen::Vector3f lo =
      n > 0 ? Eigen::Vector3f(q.rowwise().minCoeff()) : Eigen::Vector3f::Zero();
  const float inv_cell = 1.0f / cell;
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096), [&](const auto& r) {
    for (Index i = r.begin(); i != r.end(); ++i) {
      std::uint64_t key = 0;
      for (int d = 0; d < 3; ++d)
        key = (key << 21) | static_cast<std::uint64_t>(std::clamp(
                                std::floor((q(d, i) - lo[d]) * inv_cell), 0.0f, 2097151.0f));
      keys[static_cast<std::size_t>(i)] = {key, i};
    }
  });
  radix_sort(keys, [](const auto& e) { return e.first; });
  std::vector<Index> ids(keys.size());
  for (std::size_t k = 0; k < keys.size(); ++k)
    ids[k] = keys[k].second;
  return ids;
}

}  // namespace

void clop_project(const GaussianMixture& m, Eigen::Matrix3Xf& q, const ClopParams& p, double h_abs,
                  RunContext& ctx) {
  detail::clop_project_stored(m, q, p, h_abs, ctx, {});
}

namespace detail {

void clop_project_stored(const GaussianMixture& m, Eigen::Matrix3Xf& q_in, const ClopParams& p,
                         double h_abs, RunContext& ctx, const ClopInternals& how) {
  if (m.size() == 0) throw InputError("resample.clop: empty mixture");
  const Index n = q_in.cols();
  std::optional<PreparedMixture> pm;
  // The particles in a spatial order (ids[k]: the particle at place k). The projections do not
  // depend on the storage order (the attraction of a particle depends on its cell only; the
  // repulsion's grid orders the particles of a cell by ids, i.e. by index), so the result equals
  // that of the particles in index order, bit for bit.
  std::vector<Index> ids;
  Eigen::Matrix3Xf q(3, n);
  {
    auto timer = ctx.phase("init");
    // The authors' demo runs its first iteration at 2 h (see clop.h).
    pm.emplace(m, h_abs, p.first_iteration == "authors" ? 2.0 * h_abs : h_abs,
               how.skip_out_of_reach);
    if (how.spatial_order) {
      ids = spatial_order(q_in, static_cast<float>(h_abs / 4.0));
    } else {
      ids.resize(static_cast<std::size_t>(n));
      std::iota(ids.begin(), ids.end(), Index{0});
    }
    for (Index k = 0; k < n; ++k)
      q.col(k) = q_in.col(ids[static_cast<std::size_t>(k)]);
  }
  Eigen::Matrix3Xf next(3, n);
  {
    auto timer = ctx.phase("attraction");
    pm->project_all<true>(q, next);
    q.swap(next);
  }
  const float h = static_cast<float>(h_abs);
  const float cutoff = static_cast<float>(p.repulsion_cutoff * h_abs);
  const float mu = static_cast<float>(p.mu);
  Eigen::Matrix3Xf rep = Eigen::Matrix3Xf::Zero(3, n);
  const int steps = p.iterations - 1;
  for (int t = 0; t < steps; ++t) {
    ctx.check_cancelled("resample.clop");
    {
      auto timer = ctx.phase("attraction");
      pm->project_all<false>(q, next);
    }
    if (mu > 0.0f) {
      const bool recompute = !p.interleave || t % 2 == 0 || t == steps - 1;
      if (recompute) {
        auto timer = ctx.phase("repulsion");
        detail::NeighborGrid grid = kernels::query_grid(q, cutoff, &ids);
        // w_i' within the cutoff: the whole repulsion kernel is cut (section 8).
        if (p.repulsion_weights == "wlop")
          grid.set_weights(kernels::density_weights(grid, q, h, cutoff));
        rep = kernels::repulsions(q, grid, h, cutoff);
      }
      next += mu * rep;
    }
    q.swap(next);
  }
  for (Index k = 0; k < n; ++k)
    q_in.col(ids[static_cast<std::size_t>(k)]) = q.col(k);
}

}  // namespace detail

AlgorithmOutput clop(const PointCloud& in, const ClopParams& p, RunContext& ctx) {
  constexpr const char* stage = "resample.clop";
  const double diag = detail::checked_diagonal(in, stage);
  const double h = p.h * diag;
  const Index m = kernels::particle_count(p.particles, in.size(), stage);
  AlgorithmOutput out;
  Eigen::Matrix3Xf q;
  {
    auto timer = ctx.phase("init");
    q = kernels::initial_particles(in.positions, m, ctx.stream_seed("particles"),
                                   static_cast<float>(0.01 * h));
  }
  {
    auto timer = ctx.phase("hem");
    out.mixture = hem_mixture(in.positions, hem_params_of(p), h, diag, ctx);
  }
  clop_project(*out.mixture, q, p, h, ctx);
  out.points.positions = std::move(q);
  return out;
}

}  // namespace scanbench::algorithms
