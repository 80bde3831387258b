// The ray-direction kernels (scanner-sim/src/ray_directions.cpp), a Highway kernel compiled for
// every target of cmake/Simd.cmake: each target this CPU runs gives the same bits as the reference
// target without SIMD instructions (SCALAR, or EMU128 in clang builds), which is always among
// them and gives the direction a double-precision oracle computes, to float rounding. The active
// ISA chooses the target.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "ray_directions.h"
#include "scanbench/core/contract.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd.h"

namespace scanbench::scanner {
namespace {

constexpr std::size_t kN = 3 * kRayLanePad;

struct Rays {
  alignas(64) float xs[kN], oy[kN], ax[kN], ay[kN], az[kN], dt[4 * kN];
};

// A camera basis (forward, right, up) from random angles, and image-plane offsets within a wide
// field of view.
CameraBasis random_basis(Rng& rng) {
  const double yaw = rng.uniform() * 6.283, pitch = (rng.uniform() - 0.5) * 3.0;
  const double f[3] = {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                       std::sin(pitch)};
  const double r[3] = {-std::sin(yaw), std::cos(yaw), 0.0};
  const double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2],
                       r[0] * f[1] - r[1] * f[0]};
  CameraBasis c{};
  for (int i = 0; i < 3; ++i) {
    c.forward[i] = static_cast<float>(f[i]);
    c.right[i] = static_cast<float>(r[i]);
    c.up[i] = static_cast<float>(u[i]);
  }
  return c;
}

void run(const CameraBasis& c, float y, Rays& r) {
  ray_dirs_x(c, r.xs, kN, r.ax, r.ay, r.az);
  ray_dirs_y(c, r.ax, r.ay, r.az, r.oy, y, kN, r.dt);
}

TEST(RayDirections, EveryTargetGivesTheScalarReferencesBitsAndTheOraclesDirection) {
  const std::vector<std::string> targets = simd::runnable_targets();
  const std::string scalar = simd::scalar_target();
  ASSERT_NE(std::find(targets.begin(), targets.end(), scalar), targets.end());
  Rng rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const CameraBasis c = random_basis(rng);
    const float y = static_cast<float>(rng.uniform() * 2.0 - 1.0);
    Rays ref{};
    for (std::size_t j = 0; j < kN; ++j) {
      ref.xs[j] = static_cast<float>(rng.uniform() * 2.0 - 1.0);
      ref.oy[j] = static_cast<float>((rng.uniform() - 0.5) * 0.01);
    }
    {
      simd::ScopedTarget scoped(scalar);
      ASSERT_EQ(simd::chosen_target(), scalar);
      run(c, y, ref);
    }
    // The oracle: normalise(forward + x right + (y + oy) up) in double.
    for (std::size_t j = 0; j < kN; ++j) {
      const double x = ref.xs[j], yk = static_cast<double>(y) + ref.oy[j];
      double d[3];
      for (int i = 0; i < 3; ++i)
        d[i] = c.forward[i] + x * c.right[i] + yk * c.up[i];
      const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      EXPECT_NEAR(ref.dt[4 * j], d[0] / len, 1e-6);
      EXPECT_NEAR(ref.dt[4 * j + 1], d[1] / len, 1e-6);
      EXPECT_NEAR(ref.dt[4 * j + 2], d[2] / len, 1e-6);
      EXPECT_EQ(ref.dt[4 * j + 3], 0.0f);  // the ray's time
    }
    for (const std::string& t : targets) {
      SCOPED_TRACE(t);
      simd::ScopedTarget scoped(t);
      ASSERT_EQ(simd::chosen_target(), t);
      Rays r = ref;
      for (float* a : {r.ax, r.ay, r.az})
        std::fill(a, a + kN, -2.0f);
      std::fill(std::begin(r.dt), std::end(r.dt), -2.0f);
      run(c, y, r);
      EXPECT_EQ(0, std::memcmp(r.ax, ref.ax, sizeof r.ax));
      EXPECT_EQ(0, std::memcmp(r.ay, ref.ay, sizeof r.ay));
      EXPECT_EQ(0, std::memcmp(r.az, ref.az, sizeof r.az));
      EXPECT_EQ(0, std::memcmp(r.dt, ref.dt, sizeof r.dt));
    }
  }
}

TEST(RayDirections, TheActiveIsaChoosesTheTarget) {
  const std::vector<std::string> compiled = simd::compiled_targets();
  const std::string scalar = simd::scalar_target();
  ASSERT_TRUE(scalar == "SCALAR" || scalar == "EMU128") << scalar;
  for (const std::string& t :
       {std::string("AVX3"), std::string("AVX2"), std::string("SSE4"), scalar})
    EXPECT_NE(std::find(compiled.begin(), compiled.end(), t), compiled.end()) << t;
  const std::vector<std::string> runnable = simd::runnable_targets();
  auto runs = [&](const char* t) {
    return std::find(runnable.begin(), runnable.end(), t) != runnable.end();
  };
  for (simd::Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    simd::ScopedIsa scoped(isa);
    std::string want = scalar;
    if (runs("SSE4")) want = "SSE4";
    if (isa != simd::Isa::sse2 && runs("AVX2")) want = "AVX2";
    if (isa == simd::Isa::avx512 && runs("AVX3")) want = "AVX3";
    EXPECT_EQ(simd::chosen_target(), want);
    {
      simd::ScopedTarget scoped_scalar(scalar);
      EXPECT_EQ(simd::chosen_target(), scalar);
    }
    EXPECT_EQ(simd::chosen_target(), want);
  }
  EXPECT_THROW(simd::ScopedTarget("AVX9"), ParamError);
  EXPECT_NE(simd::describe().find("Highway target " + simd::chosen_target()), std::string::npos);
}

#if SCANBENCH_CHECK_CONTRACTS
// Where checks are on (the sanitizer tree, builds without NDEBUG): an unpadded array dies with the
// contract's one line.
TEST(RayDirections, AnUnpaddedArrayBreaksTheContractWhereChecksAreOn) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Rays r{};
  const CameraBasis c{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_DEATH(ray_dirs_x(c, r.xs, kRayLanePad + 1, r.ax, r.ay, r.az),
               "contract broken: .*kRayLanePad");
  EXPECT_DEATH(ray_dirs_y(c, r.ax, r.ay, r.az, r.oy + 1, 0.0f, kRayLanePad, r.dt),
               "contract broken: .*kRayLanePad");
}
#else
// Release: the contract is compiled out, its condition never evaluated (it costs nothing).
TEST(RayDirections, TheContractCostsNothingInRelease) {
  int evaluated = 0;
  SCANBENCH_EXPECTS(++evaluated > 0, "never evaluated here");
  EXPECT_EQ(evaluated, 0);
}
#endif

}  // namespace
}  // namespace scanbench::scanner
