// Internal to the algorithms module: the kernels' exp(), 1 / sqrt() and lane sum as Highway ops,
// the per-target vocabulary that replaces spatial/simd_exp.h's Eigen-packet versions as the
// kernels move to Highway (docs/performance.md, "SIMD width"). Include after hwy/highway.h in a
// hwy/foreach_target.h translation unit (this header is included once per target, hence the
// toggle guard instead of #pragma once).
//
// Each function performs the IEEE operations of its simd_exp.h counterpart in the same order,
// with Eigen's operand order of min and max (Eigen's pmin(a, b) is minps(b, a), for std::min's
// NaN behaviour), so a lane gets the same bits on every target and as the Eigen version at the
// same width: test_simd_isa's SimdMath.* check this on every target this CPU runs.
#if defined(SCANBENCH_SPATIAL_SIMD_MATH_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef SCANBENCH_SPATIAL_SIMD_MATH_INL_H_
#undef SCANBENCH_SPATIAL_SIMD_MATH_INL_H_
#else
#define SCANBENCH_SPATIAL_SIMD_MATH_INL_H_
#endif

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace scanbench::algorithms::detail::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// exp(x) per lane for the kernel sums (simd_exp.h fast_pexp: Eigen 3.4's pexp_float polynomial
/// with its fast ldexp; bit-identical to Eigen's pexp on [-87, 88], 0 below where Eigen gives a
/// denormal).
template <class D, class V = hn::Vec<D>>
HWY_INLINE V FastExp(D d, V x_in) {
  const hn::RebindToSigned<D> di;
  const V one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  const V x = hn::Max(hn::Set(d, -88.723f), hn::Min(hn::Set(d, 88.723f), x_in));
  const V v = hn::MulAdd(x, hn::Set(d, 1.44269504088896341f), half);
  // floor(v): truncation to int32, one less where that rounded up (v < 0).
  V m = hn::ConvertTo(d, hn::ConvertTo(di, v));
  m = hn::Sub(m, hn::And(hn::VecFromMask(d, hn::Lt(v, m)), one));
  V r = hn::MulAdd(m, hn::Set(d, -0.693359375f), x);
  r = hn::MulAdd(m, hn::Set(d, 2.12194440e-4f), r);
  const V r2 = hn::Mul(r, r);
  const V r3 = hn::Mul(r2, r);
  V y = hn::MulAdd(hn::Set(d, 1.9875691500E-4f), r, hn::Set(d, 1.3981999507E-3f));
  V y1 = hn::MulAdd(hn::Set(d, 4.1665795894E-2f), r, hn::Set(d, 1.6666665459E-1f));
  const V y2 = hn::Add(r, one);
  y = hn::MulAdd(y, r, hn::Set(d, 8.3334519073E-3f));
  y1 = hn::MulAdd(y1, r, hn::Set(d, 5.0000001201E-1f));
  y = hn::MulAdd(y, r3, y1);
  y = hn::MulAdd(y, r2, y2);
  // Eigen's pldexp_fast_impl: y * 2^m with the biased exponent m + 127 clamped to [0, 255].
  const V biased =
      hn::Min(hn::Set(d, 255.0f), hn::Max(hn::Zero(d), hn::Add(m, hn::Set(d, 127.0f))));
  const V scale = hn::BitCast(d, hn::ShiftLeft<23>(hn::ConvertTo(di, biased)));
  return hn::Max(x_in, hn::Mul(y, scale));
}

/// 1 / sqrt(x) per lane of positive normal floats from IEEE operations only (simd_exp.h
/// fast_prsqrt: the bit-level first guess and three Newton steps).
template <class D, class V = hn::Vec<D>>
HWY_INLINE V FastRsqrt(D d, V x) {
  const hn::RebindToSigned<D> di;
  const hn::RebindToUnsigned<D> du;
  const auto guess =
      hn::Sub(hn::Set(di, 0x5f375a86), hn::BitCast(di, hn::ShiftRight<1>(hn::BitCast(du, x))));
  V y = hn::BitCast(d, guess);
  const V minus_half_x = hn::Mul(x, hn::Set(d, -0.5f));
  const V three_halves = hn::Set(d, 1.5f);
  for (int step = 0; step < 3; ++step)
    y = hn::Mul(y, hn::MulAdd(hn::Mul(minus_half_x, y), y, three_halves));
  return y;
}

/// The sum of the lanes in Eigen's predux order: the upper half added to the lower half until
/// four lanes are left, then (l0 + l2) + (l1 + l3); one lane is itself.
template <class D, class V = hn::Vec<D>>
HWY_INLINE float SumOfLanesInEigenOrder(D d, V v) {
  constexpr std::size_t kMax = 64 / sizeof(float);
  HWY_ALIGN float lanes[kMax];
  std::size_t n = hn::Lanes(d);
  hn::Store(v, d, lanes);
  while (n > 4) {
    n /= 2;
    for (std::size_t i = 0; i < n; ++i)
      lanes[i] = lanes[i] + lanes[i + n];
  }
  if (n == 1) return lanes[0];
  if (n == 2) return lanes[0] + lanes[1];
  return (lanes[0] + lanes[2]) + (lanes[1] + lanes[3]);
}

}  // namespace scanbench::algorithms::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // SCANBENCH_SPATIAL_SIMD_MATH_INL_H_ toggle
