// The ray-direction kernels of ray_directions.h, compiled for every Highway target
// (cmake/Simd.cmake) and dispatched to the active ISA's.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "ray_directions.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstdint>

#include "ray_directions.h"
#include "scanbench/core/contract.h"
#include "scanbench/core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::scanner::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void RayDirsX(const CameraBasis& c, const float* HWY_RESTRICT xs, std::size_t n,
              float* HWY_RESTRICT ax, float* HWY_RESTRICT ay, float* HWY_RESTRICT az) {
  const hn::ScalableTag<float> d;
  const auto fx = hn::Set(d, c.forward[0]), fy = hn::Set(d, c.forward[1]),
             fz = hn::Set(d, c.forward[2]);
  const auto rx = hn::Set(d, c.right[0]), ry = hn::Set(d, c.right[1]), rz = hn::Set(d, c.right[2]);
  for (std::size_t j = 0; j < n; j += hn::Lanes(d)) {
    const auto x = hn::Load(d, xs + j);
    hn::Store(hn::Add(fx, hn::Mul(x, rx)), d, ax + j);
    hn::Store(hn::Add(fy, hn::Mul(x, ry)), d, ay + j);
    hn::Store(hn::Add(fz, hn::Mul(x, rz)), d, az + j);
  }
}

void RayDirsY(const CameraBasis& c, const float* HWY_RESTRICT ax, const float* HWY_RESTRICT ay,
              const float* HWY_RESTRICT az, const float* HWY_RESTRICT oy, float y, std::size_t n,
              float* HWY_RESTRICT dir_time) {
  const hn::ScalableTag<float> d;
  const auto ux = hn::Set(d, c.up[0]), uy = hn::Set(d, c.up[1]), uz = hn::Set(d, c.up[2]);
  const auto yv = hn::Set(d, y), one = hn::Set(d, 1.0f), time = hn::Zero(d);
  for (std::size_t j = 0; j < n; j += hn::Lanes(d)) {
    const auto yk = hn::Add(yv, hn::Load(d, oy + j));
    auto x = hn::Add(hn::Load(d, ax + j), hn::Mul(yk, ux));
    auto yy = hn::Add(hn::Load(d, ay + j), hn::Mul(yk, uy));
    auto z = hn::Add(hn::Load(d, az + j), hn::Mul(yk, uz));
    const auto len2 = hn::Add(hn::Add(hn::Mul(x, x), hn::Mul(yy, yy)), hn::Mul(z, z));
    const auto inv = hn::Div(one, hn::Sqrt(len2));
    hn::StoreInterleaved4(hn::Mul(x, inv), hn::Mul(yy, inv), hn::Mul(z, inv), time, d,
                          dir_time + 4 * j);
  }
}

}  // namespace scanbench::scanner::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace scanbench::scanner {

HWY_EXPORT(RayDirsX);
HWY_EXPORT(RayDirsY);

namespace {
[[maybe_unused]] bool padded(std::size_t n, const void* p) {
  return n % kRayLanePad == 0 &&
         reinterpret_cast<std::uintptr_t>(p) % (kRayLanePad * sizeof(float)) == 0;
}
}  // namespace

void ray_dirs_x(const CameraBasis& c, const float* xs, std::size_t n, float* ax, float* ay,
                float* az) {
  SCANBENCH_EXPECTS(padded(n, xs) && padded(n, ax) && padded(n, ay) && padded(n, az),
                    "ray arrays padded to kRayLanePad floats and aligned to as many");
  SCANBENCH_DISPATCH(RayDirsX)(c, xs, n, ax, ay, az);
}

void ray_dirs_y(const CameraBasis& c, const float* ax, const float* ay, const float* az,
                const float* oy, float y, std::size_t n, float* dir_time) {
  SCANBENCH_EXPECTS(
      padded(n, ax) && padded(n, ay) && padded(n, az) && padded(n, oy) && padded(n, dir_time),
      "ray arrays padded to kRayLanePad floats and aligned to as many");
  SCANBENCH_DISPATCH(RayDirsY)(c, ax, ay, az, oy, y, n, dir_time);
}

}  // namespace scanbench::scanner
#endif  // HWY_ONCE
