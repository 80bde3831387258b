// Internal to the algorithms module: the Highway loop over a NeighborGrid's ranges, per target
// (spatial/grid_packets.h's for_each_packet as Highway ops, for the kernels that have moved to
// Highway). Include after hwy/highway.h in a hwy/foreach_target.h translation unit (included once
// per target, hence the toggle guard).
#if defined(SCANBENCH_SPATIAL_GRID_PACKETS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef SCANBENCH_SPATIAL_GRID_PACKETS_INL_H_
#undef SCANBENCH_SPATIAL_GRID_PACKETS_INL_H_
#else
#define SCANBENCH_SPATIAL_GRID_PACKETS_INL_H_
#endif

#include <hwy/highway.h>

#include "scanbench/core/contract.h"
#include "spatial/neighbor_grid.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::algorithms::detail::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// Calls body(t, dx, dy, dz, r2, inside) for every vector of grid points in the ranges that holds
/// at least one point within `radius` of q (d = p_t - q; `inside` masks the lanes within the
/// radius, inside the range and not at sorted position `self`, -1 for none). Fixed order: range
/// by range. The grid's arrays are padded by NeighborGrid::kPad floats, at least a vector of the
/// widest target, so the last vector of a range is read whole.
template <class D, class Body>
HWY_INLINE void ForEachVector(D d, const NeighborGrid& g, const Eigen::Vector3f& q, float radius,
                              Eigen::Index self, const GridRange* ranges, std::size_t count,
                              Body&& body) {
  using V = hn::Vec<D>;
  const auto lanes = static_cast<Eigen::Index>(hn::Lanes(d));
  SCANBENCH_EXPECTS(lanes <= NeighborGrid::kPad, "a vector fits in the grid's padding");
  const hn::RebindToSigned<D> di;
  const V qx = hn::Set(d, q.x()), qy = hn::Set(d, q.y()), qz = hn::Set(d, q.z());
  const V r2max = hn::Set(d, radius * radius);
  for (std::size_t r = 0; r < count; ++r) {
    const Eigen::Index end = ranges[r].end;
    for (Eigen::Index t = ranges[r].begin; t < end; t += lanes) {
      const V dx = hn::Sub(hn::LoadU(d, g.x() + t), qx);
      const V dy = hn::Sub(hn::LoadU(d, g.y() + t), qy);
      const V dz = hn::Sub(hn::LoadU(d, g.z() + t), qz);
      const V r2 = hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz));
      auto inside = hn::Le(r2, r2max);
      if (end - t < lanes)
        inside = hn::And(inside, hn::FirstN(d, static_cast<std::size_t>(end - t)));
      if (self >= t && self < t + lanes)
        inside = hn::AndNot(
            hn::RebindMask(d, hn::Eq(hn::Iota(di, 0), hn::Set(di, static_cast<int>(self - t)))),
            inside);
      if (hn::AllFalse(d, inside)) continue;
      body(t, dx, dy, dz, r2, inside);
    }
  }
}

}  // namespace scanbench::algorithms::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // SCANBENCH_SPATIAL_GRID_PACKETS_INL_H_ toggle
