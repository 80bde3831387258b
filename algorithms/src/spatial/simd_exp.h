#pragma once
// Internal to the algorithms module: exp() and 1 / sqrt() of a SIMD packet of floats for the
// kernel sums.
//
// Why not Eigen's pexp directly: Eigen 3.4's pexp_float ends with the generic pldexp, which
// splits 2^m into four factors so that it never overflows for any exponent (profiled: the four
// dependent multiplications are the hottest instructions of CLOP's attraction). The kernel
// arguments here are exponents of normalised Gaussians, far inside the normal float range, so
// this is Eigen's own polynomial (the Cephes coefficients, the same operations in the same
// order) with Eigen's pldexp_fast_impl. For arguments in [-87, 88] the result is bit-identical
// to Eigen's pexp (a multiplication by an exact power of two is exact); below, it flushes to 0
// where Eigen returns a denormal. The floor of x log2(e) + 1/2 (in [-127.5, 128.5] after the
// clamp) is the truncation to int32 corrected by one below zero: the same value as pfloor, whose
// SSE2 emulation (no roundps before SSE4.1) was a third of this function's instructions.
// Eigen 3.4's pexp for AVX-512 floats is not pexp_float but an older Cephes variant (one-step
// ln 2 reduction, other clamp); this function stays pexp_float's arithmetic on every packet
// width, so the avx512 path computes the same exp per lane as the sse2 and avx2 paths.
#include <Eigen/Core>

namespace scanbench::algorithms::detail {

template <class Packet>
Packet fast_pexp(const Packet& x_in) {
  namespace ei = Eigen::internal;
  const Packet one = ei::pset1<Packet>(1.0f);
  const Packet half = ei::pset1<Packet>(0.5f);
  const Packet x =
      ei::pmax(ei::pmin(x_in, ei::pset1<Packet>(88.723f)), ei::pset1<Packet>(-88.723f));
  const Packet v = ei::pmadd(x, ei::pset1<Packet>(1.44269504088896341f), half);
  using PacketI = typename ei::unpacket_traits<Packet>::integer_packet;
  Packet m = ei::pcast<PacketI, Packet>(ei::pcast<Packet, PacketI>(v));
  m = ei::psub(m, ei::pand(ei::pcmp_lt(v, m), one));
  Packet r = ei::pmadd(m, ei::pset1<Packet>(-0.693359375f), x);
  r = ei::pmadd(m, ei::pset1<Packet>(2.12194440e-4f), r);
  const Packet r2 = ei::pmul(r, r);
  const Packet r3 = ei::pmul(r2, r);
  Packet y = ei::pmadd(ei::pset1<Packet>(1.9875691500E-4f), r, ei::pset1<Packet>(1.3981999507E-3f));
  Packet y1 =
      ei::pmadd(ei::pset1<Packet>(4.1665795894E-2f), r, ei::pset1<Packet>(1.6666665459E-1f));
  const Packet y2 = ei::padd(r, one);
  y = ei::pmadd(y, r, ei::pset1<Packet>(8.3334519073E-3f));
  y1 = ei::pmadd(y1, r, ei::pset1<Packet>(5.0000001201E-1f));
  y = ei::pmadd(y, r3, y1);
  y = ei::pmadd(y, r2, y2);
  return ei::pmax(ei::pldexp_fast_impl<Packet>::run(y, m), x_in);
}

// 1 / sqrt(x) of a packet of positive normal floats, from IEEE operations only: the classic
// bit-level first guess (relative error < 3.5e-2) and three Newton steps y (1.5 - x y^2 / 2)
// (< 1.8e-3, < 5e-6, then a few float ulps). Lanes holding +inf give NaN (callers mask them
// out). Why not rsqrtps: its approximation is implementation-specific
// (Intel and AMD return other bits), and Eigen's prsqrt starts from it; why not 1 / psqrt: the
// division and the square root are the slowest instructions of the repulsion kernels.
template <class Packet>
Packet fast_prsqrt(const Packet& x) {
  namespace ei = Eigen::internal;
  using PacketI = typename ei::unpacket_traits<Packet>::integer_packet;
  const PacketI guess = ei::psub(ei::pset1<PacketI>(0x5f375a86),
                                 ei::plogical_shift_right<1>(ei::preinterpret<PacketI>(x)));
  Packet y = ei::preinterpret<Packet>(guess);
  const Packet minus_half_x = ei::pmul(x, ei::pset1<Packet>(-0.5f));
  const Packet three_halves = ei::pset1<Packet>(1.5f);
  for (int step = 0; step < 3; ++step)
    y = ei::pmul(y, ei::pmadd(ei::pmul(minus_half_x, y), y, three_halves));
  return y;
}

}  // namespace scanbench::algorithms::detail
