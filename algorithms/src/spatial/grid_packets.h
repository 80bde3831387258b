#pragma once
// Internal to the algorithms module: packet loops over a NeighborGrid's ranges for the kernels
// that take the packet of the active ISA (filter.gpf's E- and M-step sums, normals.bilateral).
#include <Eigen/Core>
#include <vector>

#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms::detail {

// Calls body(t, dx, dy, dz, r2, inside) for every packet of grid points in the ranges that holds
// at least one point within `radius` of q (d = p_t - q; `inside` masks the lanes within the
// radius, inside the range and not at sorted position `self`, -1 for none). Fixed order: range by
// range. Packet is the float packet of the active ISA (scanbench/core/simd.h).
template <class Packet, class Body>
void for_each_packet(const NeighborGrid& g, const Eigen::Vector3f& q, float radius,
                     Eigen::Index self, const GridRange* ranges, std::size_t count, Body&& body) {
  namespace ei = Eigen::internal;
  constexpr int kLanes = ei::unpacket_traits<Packet>::size;
  static_assert(kLanes <= kPacketLanes && kLanes <= NeighborGrid::kPad);
  const Packet qx = ei::pset1<Packet>(q.x()), qy = ei::pset1<Packet>(q.y()),
               qz = ei::pset1<Packet>(q.z());
  const Packet r2max = ei::pset1<Packet>(radius * radius);
  for (std::size_t r = 0; r < count; ++r) {
    const Eigen::Index end = ranges[r].end;
    for (Eigen::Index t = ranges[r].begin; t < end; t += kLanes) {
      const Packet dx = ei::psub(ei::ploadu<Packet>(g.x() + t), qx);
      const Packet dy = ei::psub(ei::ploadu<Packet>(g.y() + t), qy);
      const Packet dz = ei::psub(ei::ploadu<Packet>(g.z() + t), qz);
      const Packet r2 = ei::padd(ei::padd(ei::pmul(dx, dx), ei::pmul(dy, dy)), ei::pmul(dz, dz));
      Packet inside = ei::pcmp_le(r2, r2max);
      if (end - t < kLanes)
        inside = ei::pand(inside, ei::ploadu<Packet>(kLaneMasks.first + kPacketLanes - (end - t)));
      if (self >= t && self < t + kLanes)
        inside = ei::pand(inside, ei::ploadu<Packet>(kLaneMasks.hole + kPacketLanes - (self - t)));
      if (!ei::predux_any(inside)) continue;
      body(t, dx, dy, dz, r2, inside);
    }
  }
}

// Per-point values (values[i * stride] for point i) in the grid's sorted order, padded with
// zeros like the grid's arrays.
inline std::vector<float> sorted_values(const NeighborGrid& g, const float* values,
                                        Eigen::Index stride) {
  std::vector<float> out(static_cast<std::size_t>(g.size() + NeighborGrid::kPad), 0.0f);
  for (Eigen::Index k = 0; k < g.size(); ++k)
    out[static_cast<std::size_t>(k)] = values[g.index(k) * stride];
  return out;
}

}  // namespace scanbench::algorithms::detail
