// Batched symmetric 3x3 eigen decompositions by cyclic Jacobi (sym_eigen3.h).
#include "mixtures/sym_eigen3.h"

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>

#include "scanbench/core/simd_dispatch.h"

// Eigen's packet types carry vector attributes that GCC reports as ignored when they are template
// arguments; the attributes do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms::detail {

namespace {

namespace ei = Eigen::internal;

// ei::psqrt is the correctly rounded square root on every width: scanbench_core defines
// EIGEN_FAST_MATH=0 for every target (Eigen's fast psqrt<Packet8d> is an rsqrt approximation).
constexpr int kMaxSweeps = 50;

// Entries of the upper triangle: a[0] xx, a[1] xy, a[2] xz, a[3] yy, a[4] yz, a[5] zz.
constexpr int kDiag[3] = {0, 3, 5};
constexpr int kEntry[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};
constexpr int off_index(int p, int q) {
  return kEntry[p][q];
}

// One Jacobi rotation in the (p, q) plane (r: the third index) annihilating a_pq, and its
// accumulation into the eigenvector columns v[3 p ..], v[3 q ..] (when kVectors).
template <bool kVectors, class P>
[[gnu::always_inline]] inline void rotate(int p, int q, int r, std::array<P, 6>& a,
                                          std::array<P, 9>& v) {
  const P zero = ei::pzero(P()), one = ei::pset1<P>(1.0), hundred = ei::pset1<P>(100.0);
  P& app = a[kDiag[p]];
  P& aqq = a[kDiag[q]];
  P& apq = a[off_index(p, q)];
  P& arp = a[off_index(r, p)];
  P& arq = a[off_index(r, q)];
  const P g = ei::pmul(hundred, ei::pabs(apq));
  const P abs_p = ei::pabs(app), abs_q = ei::pabs(aqq);
  const P negligible =
      ei::pand(ei::pcmp_eq(ei::padd(abs_p, g), abs_p), ei::pcmp_eq(ei::padd(abs_q, g), abs_q));
  // t = sgn(theta) / (|theta| + sqrt(theta^2 + 1)), theta = (a_qq - a_pp) / (2 a_pq): the
  // tangent of the smaller rotation angle (0 where a_pq is negligible).
  const P theta = ei::pdiv(ei::psub(aqq, app), ei::padd(apq, apq));
  P t = ei::pdiv(one, ei::padd(ei::pabs(theta), ei::psqrt(ei::padd(ei::pmul(theta, theta), one))));
  t = ei::pselect(ei::pcmp_lt(theta, zero), ei::pnegate(t), t);
  t = ei::pselect(negligible, zero, t);
  const P c = ei::pdiv(one, ei::psqrt(ei::padd(ei::pmul(t, t), one)));
  const P s = ei::pmul(t, c);
  const P h = ei::pmul(t, apq);
  app = ei::psub(app, h);
  aqq = ei::padd(aqq, h);
  apq = zero;
  // (x_p, x_q) <- (c x_p - s x_q, s x_p + c x_q): where t = 0, c = 1 and s = 0 exactly.
  auto turn = [&](P& xp, P& xq) {
    const P yp = xp, yq = xq;
    xp = ei::psub(ei::pmul(c, yp), ei::pmul(s, yq));
    xq = ei::padd(ei::pmul(s, yp), ei::pmul(c, yq));
  };
  turn(arp, arq);
  if constexpr (kVectors)
    for (int k = 0; k < 3; ++k)
      turn(v[3 * p + k], v[3 * q + k]);
}

// Swaps eigenpairs i < j in the lanes where value j is strictly below value i.
template <bool kVectors, class P>
[[gnu::always_inline]] inline void order(int i, int j, std::array<P, 3>& d, std::array<P, 9>& v) {
  const P swap = ei::pcmp_lt(d[j], d[i]);
  const P di = d[i];
  d[i] = ei::pselect(swap, d[j], di);
  d[j] = ei::pselect(swap, di, d[j]);
  if constexpr (kVectors)
    for (int k = 0; k < 3; ++k) {
      const P vi = v[3 * i + k];
      v[3 * i + k] = ei::pselect(swap, v[3 * j + k], vi);
      v[3 * j + k] = ei::pselect(swap, vi, v[3 * j + k]);
    }
}

// kGroup packets at a time: their rotations are independent chains of divisions and square
// roots, which the processor overlaps.
constexpr int kGroup = 2;

template <bool kVectors, class P>
void decompose(const Eigen::Matrix3d* in, std::size_t n, Eigen::Vector3d* values,
               Eigen::Matrix3d* vectors) {
  constexpr int kLanes = ei::unpacket_traits<P>::size;
  constexpr int kWidth = kGroup * kLanes;
  // Per matrix of the group: 6 entries in; 3 values and 9 vector components out; off-diagonal.
  alignas(64) double lanes[13][kWidth];
  static const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  for (std::size_t b = 0; b < n; b += kWidth) {
    for (int l = 0; l < kWidth; ++l) {  // padding lanes: the identity, diagonal from the start
      const auto at = b + static_cast<std::size_t>(l);
      const Eigen::Matrix3d& m = at < n ? in[at] : identity;
      lanes[0][l] = m(0, 0);
      lanes[1][l] = m(0, 1);
      lanes[2][l] = m(0, 2);
      lanes[3][l] = m(1, 1);
      lanes[4][l] = m(1, 2);
      lanes[5][l] = m(2, 2);
    }
    const P zero = ei::pzero(P()), one = ei::pset1<P>(1.0);
    std::array<P, 6> a[kGroup];
    std::array<P, 9> v[kGroup];
    for (int g = 0; g < kGroup; ++g) {
      for (int e = 0; e < 6; ++e)
        a[g][static_cast<std::size_t>(e)] = ei::pload<P>(lanes[e] + g * kLanes);
      v[g] = {one, zero, zero, zero, one, zero, zero, zero, one};
    }
    bool done = false;
    for (int sweep = 0; sweep < kMaxSweeps && !done; ++sweep) {
      for (int g = 0; g < kGroup; ++g)
        rotate<kVectors>(0, 1, 2, a[g], v[g]);
      for (int g = 0; g < kGroup; ++g)
        rotate<kVectors>(0, 2, 1, a[g], v[g]);
      for (int g = 0; g < kGroup; ++g)
        rotate<kVectors>(1, 2, 0, a[g], v[g]);
      // Done when every lane's off-diagonal is exactly 0 (a NaN lane never is).
      for (int g = 0; g < kGroup; ++g)
        ei::pstore(lanes[12] + g * kLanes,
                   ei::padd(ei::padd(ei::pabs(a[g][1]), ei::pabs(a[g][2])), ei::pabs(a[g][4])));
      done = true;
      for (int l = 0; l < kWidth; ++l)
        done = done && lanes[12][l] == 0.0;
    }
    for (int g = 0; g < kGroup; ++g) {
      std::array<P, 3> d{a[g][0], a[g][3], a[g][5]};
      order<kVectors>(0, 1, d, v[g]);
      order<kVectors>(1, 2, d, v[g]);
      order<kVectors>(0, 1, d, v[g]);
      for (int e = 0; e < 3; ++e)
        ei::pstore(lanes[e] + g * kLanes, d[static_cast<std::size_t>(e)]);
      if constexpr (kVectors)
        for (int e = 0; e < 9; ++e)
          ei::pstore(lanes[3 + e] + g * kLanes, v[g][static_cast<std::size_t>(e)]);
    }
    for (int l = 0; l < kWidth && b + static_cast<std::size_t>(l) < n; ++l) {
      const auto at = b + static_cast<std::size_t>(l);
      if (!(lanes[12][l] == 0.0)) {  // not diagonal after 50 sweeps (a NaN entry)
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(
            in[at], kVectors ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly);
        values[at] = es.eigenvalues();
        if constexpr (kVectors) vectors[at] = es.eigenvectors();
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        values[at](c) = lanes[c][l];
        if constexpr (kVectors)
          for (int k = 0; k < 3; ++k)
            vectors[at](k, c) = lanes[3 + 3 * c + k][l];
      }
    }
  }
}

}  // namespace

void sym_eigen3(const Eigen::Matrix3d* in, std::size_t n, Eigen::Vector3d* values,
                Eigen::Matrix3d* vectors) {
  simd::with_packet([&](auto tag) {
    using PacketD = typename simd::DoublePacket<typename decltype(tag)::type>::type;
    if (vectors)
      decompose<true, PacketD>(in, n, values, vectors);
    else
      decompose<false, PacketD>(in, n, values, nullptr);
  });
}

}  // namespace scanbench::algorithms::detail
