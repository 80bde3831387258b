// The Highway vocabulary of the kernels (algorithms/src/spatial/simd_math-inl.h) against the
// Eigen-packet functions it replaces (spatial/simd_exp.h, Eigen's predux): on every target this
// CPU runs, the one-lane SCALAR reference among them, FastExp and FastRsqrt give each lane the bits
// of fast_pexp and fast_prsqrt, and SumOfLanesInEigenOrder the bits of Eigen's predux at the same
// width. (The sanitizer tree compiles without contracting a * b + c, so there a target without
// fused multiply-add instructions rounds MulAdd twice where Eigen's packets fuse: within 8 ulp,
// measured at most 4.)
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "algorithms/test_simd_math.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "spatial/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::algorithms::detail::HWY_NAMESPACE {

void ExpLanes(const float* in, float* out, std::size_t n) {
  const hn::ScalableTag<float> d;
  for (std::size_t i = 0; i < n; i += hn::Lanes(d))
    hn::Store(FastExp(d, hn::Load(d, in + i)), d, out + i);
}

void RsqrtLanes(const float* in, float* out, std::size_t n) {
  const hn::ScalableTag<float> d;
  for (std::size_t i = 0; i < n; i += hn::Lanes(d))
    hn::Store(FastRsqrt(d, hn::Load(d, in + i)), d, out + i);
}

// One sum per vector of the target's width; returns that width.
std::size_t SumLanes(const float* in, float* sums, std::size_t n) {
  const hn::ScalableTag<float> d;
  for (std::size_t i = 0; i < n; i += hn::Lanes(d))
    sums[i / hn::Lanes(d)] = SumOfLanesInEigenOrder(d, hn::Load(d, in + i));
  return hn::Lanes(d);
}

}  // namespace scanbench::algorithms::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "scanbench/core/rng.h"
#include "scanbench/core/simd.h"
#include "spatial/simd_exp.h"

#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms::detail {

HWY_EXPORT(ExpLanes);
HWY_EXPORT(RsqrtLanes);
HWY_EXPORT(SumLanes);

namespace {

namespace ei = Eigen::internal;
constexpr std::size_t kN = 4096;  // a multiple of every width

struct Floats {
  alignas(64) float v[kN];
};

std::int64_t ulps(float a, float b) {
  std::int32_t ia = 0, ib = 0;
  std::memcpy(&ia, &a, 4);
  std::memcpy(&ib, &b, 4);
  if (ia < 0) ia = std::numeric_limits<std::int32_t>::min() - ia;
  if (ib < 0) ib = std::numeric_limits<std::int32_t>::min() - ib;
  return std::abs(static_cast<std::int64_t>(ia) - ib);
}

#if defined(SCANBENCH_SANITIZE)
constexpr std::int64_t kUlps = 8;
#else
constexpr std::int64_t kUlps = 0;
#endif

void expect_lanes_equal(const Floats& got, const Floats& want, const std::string& what) {
  int bad = 0;
  for (std::size_t i = 0; i < kN && bad < 5; ++i)
    if (ulps(got.v[i], want.v[i]) > kUlps) {
      ADD_FAILURE() << what << " lane " << i << ": " << got.v[i] << " vs " << want.v[i];
      ++bad;
    }
}

TEST(SimdMath, FastExpGivesFastPexpsBitsOnEveryTarget) {
  Floats in{}, want{};
  Rng rng(5);
  for (std::size_t i = 0; i < kN; ++i)
    in.v[i] = static_cast<float>(rng.uniform(-120.0, 100.0));
  const float special[] = {0.0f,
                           -0.0f,
                           1.0f,
                           -1.0f,
                           88.723f,
                           -88.723f,
                           88.0f,
                           -87.0f,
                           89.0f,
                           -90.0f,
                           1e-30f,
                           -1e-30f,
                           std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity(),
                           0.5f,
                           -0.5f};
  std::memcpy(in.v, special, sizeof special);
  for (std::size_t i = 0; i < kN; i += 4)
    ei::pstore(want.v + i, fast_pexp(ei::pload<ei::Packet4f>(in.v + i)));
  for (const std::string& t : simd::runnable_targets()) {
    simd::ScopedTarget scoped(t);
    Floats got{};
    HWY_DYNAMIC_DISPATCH(ExpLanes)(in.v, got.v, kN);
    expect_lanes_equal(got, want, "FastExp on " + t);
  }
}

TEST(SimdMath, FastRsqrtGivesFastPrsqrtsBitsOnEveryTarget) {
  Floats in{}, want{};
  Rng rng(6);
  for (std::size_t i = 0; i < kN; ++i)
    in.v[i] = static_cast<float>(std::exp2(rng.uniform(-120.0, 120.0)) * rng.uniform(1.0, 2.0));
  for (std::size_t i = 0; i < kN; i += 4)
    ei::pstore(want.v + i, fast_prsqrt(ei::pload<ei::Packet4f>(in.v + i)));
  for (const std::string& t : simd::runnable_targets()) {
    simd::ScopedTarget scoped(t);
    Floats got{};
    HWY_DYNAMIC_DISPATCH(RsqrtLanes)(in.v, got.v, kN);
    expect_lanes_equal(got, want, "FastRsqrt on " + t);
  }
}

// Eigen's predux of the packet `lanes` wide, for each such vector of `in`.
bool eigen_sums(const Floats& in, std::size_t lanes, Floats& out) {
  for (std::size_t i = 0; i < kN; i += lanes) {
    float s = 0.0f;
    if (lanes == 1) {
      s = in.v[i];
    } else if (lanes == 4) {
      s = ei::predux(ei::pload<ei::Packet4f>(in.v + i));
#ifdef EIGEN_VECTORIZE_AVX
    } else if (lanes == 8) {
      s = ei::predux(ei::pload<ei::Packet8f>(in.v + i));
#endif
#ifdef EIGEN_VECTORIZE_AVX512
    } else if (lanes == 16) {
      s = ei::predux(ei::pload<ei::Packet16f>(in.v + i));
#endif
    } else {
      return false;
    }
    out.v[i / lanes] = s;
  }
  return true;
}

TEST(SimdMath, SumOfLanesGivesEigensPreduxBitsAtEachWidth) {
  Floats in{};
  Rng rng(8);
  for (std::size_t i = 0; i < kN; ++i)
    in.v[i] = static_cast<float>(rng.uniform(-1.0, 1.0) * std::exp2(rng.uniform(-20.0, 20.0)));
  int compared = 0;
  for (const std::string& t : simd::runnable_targets()) {
    SCOPED_TRACE(t);
    simd::ScopedTarget scoped(t);
    Floats got{}, want{};
    const std::size_t lanes = HWY_DYNAMIC_DISPATCH(SumLanes)(in.v, got.v, kN);
    // A width this build's Eigen does not compile (AVX3 in an avx2 build) has no predux to match.
    if (!eigen_sums(in, lanes, want)) continue;
    ++compared;
    EXPECT_EQ(0, std::memcmp(got.v, want.v, sizeof(float) * (kN / lanes))) << lanes << " lanes";
  }
  EXPECT_GE(compared, 2);  // SCALAR and SSE4 at least
}

}  // namespace
}  // namespace scanbench::algorithms::detail
#endif  // HWY_ONCE
