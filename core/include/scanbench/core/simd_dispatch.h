#pragma once
// Runs a kernel templated on an Eigen float packet with the packet of the active ISA
// (scanbench/core/simd.h). Usage:
//   simd::with_packet([&](auto tag) { using Packet = typename decltype(tag)::type; ... });
// Every width up to the compiled one is instantiated in the same translation unit with the same
// compiler flags, so no inline function exists in copies compiled for different instruction sets.
#include <Eigen/Core>

#include "scanbench/core/simd.h"

namespace scanbench::simd {

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"
/// The double packet of the same width in bytes as a float packet (half its lanes): Packet2d for
/// Packet4f, Packet4d for Packet8f, Packet8d for Packet16f. Kernels that need double precision
/// (HEM's eq. 9-12, the distance field's index coordinates) run it on the active ISA.
template <class PacketF>
struct DoublePacket;
template <>
struct DoublePacket<Eigen::internal::Packet4f> {
  using type = Eigen::internal::Packet2d;
};
#ifdef EIGEN_VECTORIZE_AVX
template <>
struct DoublePacket<Eigen::internal::Packet8f> {
  using type = Eigen::internal::Packet4d;
};
#endif
#ifdef EIGEN_VECTORIZE_AVX512
template <>
struct DoublePacket<Eigen::internal::Packet16f> {
  using type = Eigen::internal::Packet8d;
};
#endif

template <class P>
struct PacketTag {
  using type = P;
  static constexpr int lanes = Eigen::internal::unpacket_traits<P>::size;
};

template <class F>
decltype(auto) with_packet(Isa isa, F&& f) {
  namespace ei = Eigen::internal;
  switch (isa) {
#ifdef EIGEN_VECTORIZE_AVX512
    case Isa::avx512:
      return f(PacketTag<ei::Packet16f>{});
#endif
#ifdef EIGEN_VECTORIZE_AVX
    case Isa::avx2:
      return f(PacketTag<ei::Packet8f>{});
#endif
    default:
      return f(PacketTag<ei::Packet4f>{});
  }
}
#pragma GCC diagnostic pop

template <class F>
decltype(auto) with_packet(F&& f) {
  return with_packet(active(), static_cast<F&&>(f));
}

}  // namespace scanbench::simd
