#pragma once
// Internal to the algorithms module: the positions of a range of sorted grid points that lie
// within a distance of a query, for the searches whose candidates an exact test decides after
// (HEM's eq. 12 neighbours, its density pairs and its merge children).
#include <Eigen/Core>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace scanbench::algorithms::detail {

/// Room that compact_within needs past the last position it may write.
inline constexpr std::size_t kCompactSlack = 16;

/// Writes to out[m], out[m + 1], ... the positions t in [b, e) whose point (x[t], y[t], z[t])
/// lies within squared float distance r2 of q, in increasing order; returns m plus their number.
/// A filter: the squared distance rounds as the build fuses it (-ffp-contract), so a point within
/// an ulp of the bound may fall either side; give r2 slack and let an exact test decide.
/// x, y, z must be readable 16 floats past e (NeighborGrid's arrays are padded); out must have
/// room for m + (e - b) + kCompactSlack entries.
///
/// With AVX-512 (an x86-64-v4 build) 16 points at a time, compressed in registers (stores of
/// compressed registers straight to memory are slow on AMD Zen 4). Otherwise the scalar loop,
/// without a branch on the unpredictable test. The two agree but for points within an ulp of the
/// bound (above).
template <class Pos>
std::size_t compact_within(const float* x, const float* y, const float* z, std::size_t b,
                           std::size_t e, const Eigen::Vector3f& q, float r2, Pos* out,
                           std::size_t m) {
  static_assert(sizeof(Pos) == 8 && std::is_integral_v<Pos>);
#if defined(__AVX512F__)
  const __m512 qx = _mm512_set1_ps(q.x()), qy = _mm512_set1_ps(q.y()), qz = _mm512_set1_ps(q.z());
  const __m512 bound = _mm512_set1_ps(r2);
  const __m512i lanes_lo = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
  const __m512i lanes_hi = _mm512_set_epi64(15, 14, 13, 12, 11, 10, 9, 8);
  for (std::size_t t = b; t < e; t += 16) {
    const __m512 dx = _mm512_sub_ps(_mm512_loadu_ps(x + t), qx);
    const __m512 dy = _mm512_sub_ps(_mm512_loadu_ps(y + t), qy);
    const __m512 dz = _mm512_sub_ps(_mm512_loadu_ps(z + t), qz);
    const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                                    _mm512_mul_ps(dz, dz));
    auto k = static_cast<std::uint32_t>(_mm512_cmp_ps_mask(d2, bound, _CMP_LE_OQ));
    if (e - t < 16) k &= (std::uint32_t{1} << (e - t)) - 1u;
    const __m512i base = _mm512_set1_epi64(static_cast<long long>(t));
    const auto k_lo = static_cast<__mmask8>(k & 0xffu), k_hi = static_cast<__mmask8>(k >> 8);
    _mm512_storeu_si512(out + m,
                        _mm512_maskz_compress_epi64(k_lo, _mm512_add_epi64(base, lanes_lo)));
    m += static_cast<std::size_t>(std::popcount(k & 0xffu));
    _mm512_storeu_si512(out + m,
                        _mm512_maskz_compress_epi64(k_hi, _mm512_add_epi64(base, lanes_hi)));
    m += static_cast<std::size_t>(std::popcount(k >> 8));
  }
#else
  for (std::size_t t = b; t < e; ++t) {
    const float dx = x[t] - q.x(), dy = y[t] - q.y(), dz = z[t] - q.z();
    out[m] = static_cast<Pos>(t);
    m += dx * dx + dy * dy + dz * dz <= r2 ? 1 : 0;
  }
#endif
  return m;
}

}  // namespace scanbench::algorithms::detail
