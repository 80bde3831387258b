// The distance field's batch sampler (field_sampler.h), compiled for every Highway target
// (cmake/Simd.cmake) and dispatched to the active ISA's.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "field_sampler.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "field_sampler.h"
#include "scanbench/core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::metrics::detail::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void SampleBatch(Sampler& sampler, const double* HWY_RESTRICT x, const double* HWY_RESTRICT y,
                 const double* HWY_RESTRICT z, std::size_t n, float* HWY_RESTRICT value) {
  const hn::ScalableTag<double> d;
  const std::size_t lanes = hn::Lanes(d);
  constexpr std::size_t kMaxLanes = 64 / sizeof(double);  // the widest target's
  const auto inv = hn::Set(d, sampler.inv_voxel()), one = hn::Set(d, 1.0);
  const auto limit = hn::Set(d, kMaxIndex);
  // v: the 8 corners, corner c of lane l at v[c * lanes + l].
  HWY_ALIGN double v[8 * kMaxLanes], bx[kMaxLanes], by[kMaxLanes], bz[kMaxLanes], ok[kMaxLanes],
      res[kMaxLanes];
  std::size_t k = 0;
  for (; k + lanes <= n; k += lanes) {
    const auto px = hn::Mul(hn::LoadU(d, x + k), inv), py = hn::Mul(hn::LoadU(d, y + k), inv),
               pz = hn::Mul(hn::LoadU(d, z + k), inv);
    const auto in = hn::And(hn::And(hn::Lt(hn::Abs(px), limit), hn::Lt(hn::Abs(py), limit)),
                            hn::Lt(hn::Abs(pz), limit));
    const auto x0 = hn::Floor(px), y0 = hn::Floor(py), z0 = hn::Floor(pz);
    hn::Store(x0, d, bx);
    hn::Store(y0, d, by);
    hn::Store(z0, d, bz);
    hn::Store(hn::VecFromMask(d, in), d, ok);
    bool any = false;
    for (std::size_t l = 0; l < lanes; ++l) {
      bool good = false;
      std::uint64_t bits = 0;
      std::memcpy(&bits, &ok[l], sizeof bits);
      if (bits != 0)
        good = sampler.corners(openvdb::Coord(static_cast<int>(bx[l]), static_cast<int>(by[l]),
                                              static_cast<int>(bz[l])),
                               v + l, static_cast<int>(lanes));
      if (!good)
        for (std::size_t c = 0; c < 8; ++c)
          v[c * lanes + l] = 0.0;
      ok[l] = good ? 1.0 : 0.0;
      any = any || good;
    }
    if (!any) {
      std::fill_n(value + k, lanes, -1.0f);
      continue;
    }
    const auto fx = hn::Sub(px, x0), fy = hn::Sub(py, y0), fz = hn::Sub(pz, z0);
    const auto gx = hn::Sub(one, fx), gy = hn::Sub(one, fy), gz = hn::Sub(one, fz);
    auto corner = [&](std::size_t c) { return hn::Load(d, v + c * lanes); };
    const auto c00 = hn::Add(hn::Mul(corner(0), gx), hn::Mul(corner(4), fx));
    const auto c01 = hn::Add(hn::Mul(corner(1), gx), hn::Mul(corner(5), fx));
    const auto c10 = hn::Add(hn::Mul(corner(2), gx), hn::Mul(corner(6), fx));
    const auto c11 = hn::Add(hn::Mul(corner(3), gx), hn::Mul(corner(7), fx));
    const auto c0 = hn::Add(hn::Mul(c00, gy), hn::Mul(c10, fy));
    const auto c1 = hn::Add(hn::Mul(c01, gy), hn::Mul(c11, fy));
    hn::Store(hn::Add(hn::Mul(c0, gz), hn::Mul(c1, fz)), d, res);
    for (std::size_t l = 0; l < lanes; ++l)
      value[k + l] = ok[l] != 0.0 ? std::abs(static_cast<float>(res[l])) : -1.0f;
  }
  for (; k < n; ++k) {
    float s = 0.0f;
    value[k] = sampler.sample(static_cast<float>(x[k]), static_cast<float>(y[k]),
                              static_cast<float>(z[k]), s)
                   ? std::abs(s)
                   : -1.0f;
  }
}

}  // namespace scanbench::metrics::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace scanbench::metrics::detail {

HWY_EXPORT(SampleBatch);

void sample_batch(Sampler& sampler, const double* x, const double* y, const double* z,
                  std::size_t n, float* value) {
  SCANBENCH_DISPATCH(SampleBatch)(sampler, x, y, z, n, value);
}

}  // namespace scanbench::metrics::detail
#endif  // HWY_ONCE
