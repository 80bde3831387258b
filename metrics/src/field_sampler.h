#pragma once
// Internal to the metrics module: trilinear sampling of an OpenVDB distance field
// (distance_field.cpp) and the batch kernel over sorted queries (field_sampler.cpp, a Highway
// kernel dispatched to the active ISA's target, scanbench/core/simd.h).
#include <openvdb/openvdb.h>

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace scanbench::metrics::detail {

using Accessor = openvdb::FloatGrid::ConstAccessor;
using Leaf = openvdb::FloatTree::LeafNodeType;
static_assert(Leaf::LOG2DIM == 3, "the stencil and mask arithmetic assume 8^3 leaves");

// Index coordinates beyond this are never inside a grid (OpenVDB coordinates are int32).
constexpr double kMaxIndex = 1 << 30;

// Trilinear sampling over the 8 voxels around a query (index space), false when any of them is
// inactive. One sampler per thread or chunk: it holds an unregistered accessor (the tree is
// read-only while queries run) and the leaves of the last 2x2x2 block of leaves, so sorted
// queries rarely walk the tree.
class Sampler {
 public:
  Sampler(const openvdb::FloatGrid& grid, double inv_voxel)
      : acc_(grid.tree()), inv_voxel_(inv_voxel) {}

  bool sample(float qx, float qy, float qz, float& value) {
    // The grid map is a uniform scale with the lattice at the origin: index = world / voxel,
    // computed exactly as openvdb::math::UniformScaleMap::applyInverseMap does.
    const double x = static_cast<double>(qx) * inv_voxel_;
    const double y = static_cast<double>(qy) * inv_voxel_;
    const double z = static_cast<double>(qz) * inv_voxel_;
    if (!(std::abs(x) < kMaxIndex && std::abs(y) < kMaxIndex && std::abs(z) < kMaxIndex))
      return false;
    const double x0 = std::floor(x), y0 = std::floor(y), z0 = std::floor(z);
    double v[8];
    if (!corners(openvdb::Coord(static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(z0)),
                 v, 1))
      return false;
    const double fx = x - x0, fy = y - y0, fz = z - z0;
    const double c00 = v[0] * (1 - fx) + v[4] * fx;
    const double c01 = v[1] * (1 - fx) + v[5] * fx;
    const double c10 = v[2] * (1 - fx) + v[6] * fx;
    const double c11 = v[3] * (1 - fx) + v[7] * fx;
    const double c0 = c00 * (1 - fy) + c10 * fy;
    const double c1 = c01 * (1 - fy) + c11 * fy;
    value = static_cast<float>(c0 * (1 - fz) + c1 * fz);
    return true;
  }

  // The 8 voxel values around `base` (index space), corner (dx, dy, dz) at v[(dx * 4 + dy * 2 +
  // dz) * stride]; false when any of them is inactive.
  bool corners(const openvdb::Coord& base, double* v, int stride) {
    const int lx = base.x() & 7, ly = base.y() & 7, lz = base.z() & 7;
    const Leaf* leaf = nullptr;
    if (lx < 7 && ly < 7 && lz < 7) leaf = leaf_at(base);
    if (leaf) {
      // Stencil inside one leaf: offsets x*64 + y*8 + z; the value mask is 8 words, one per x,
      // bit y*8 + z, so the 4 (y, z) corners of an x slice are bits b, b+1, b+8, b+9.
      const unsigned bit = static_cast<unsigned>((ly << 3) | lz);
      const auto& mask = leaf->getValueMask();
      constexpr std::uint64_t kCorners = 0x303;
      if (((mask.getWord<std::uint64_t>(static_cast<openvdb::Index>(lx)) >> bit) & kCorners) !=
              kCorners ||
          ((mask.getWord<std::uint64_t>(static_cast<openvdb::Index>(lx + 1)) >> bit) & kCorners) !=
              kCorners)
        return false;
      const float* d = leaf->buffer().data() + ((lx << 6) | static_cast<int>(bit));
      v[0 * stride] = d[0];
      v[1 * stride] = d[1];
      v[2 * stride] = d[8];
      v[3 * stride] = d[9];
      v[4 * stride] = d[64];
      v[5 * stride] = d[65];
      v[6 * stride] = d[72];
      v[7 * stride] = d[73];
      return true;
    }
    for (int dx = 0; dx < 2; ++dx)
      for (int dy = 0; dy < 2; ++dy)
        for (int dz = 0; dz < 2; ++dz) {
          const openvdb::Coord c = base.offsetBy(dx, dy, dz);
          float s = 0.0f;
          if (const Leaf* l = leaf_at(c)) {
            const openvdb::Index off = Leaf::coordToOffset(c);
            if (!l->isValueOn(off)) return false;
            s = l->getValue(off);
          } else if (!acc_.probeValue(c, s)) {  // a tile or the background
            return false;
          }
          v[(dx * 4 + dy * 2 + dz) * stride] = s;
        }
    return true;
  }

  double inv_voxel() const { return inv_voxel_; }

 private:
  // The leaf holding voxel c (nullptr if none). The 8 leaves a stencil can touch form a 2x2x2
  // block, so the parity of the leaf coordinates gives each a cache slot of its own.
  const Leaf* leaf_at(const openvdb::Coord& c) {
    const int slot = ((c.x() >> 3) & 1) | (((c.y() >> 3) & 1) << 1) | (((c.z() >> 3) & 1) << 2);
    const openvdb::Coord origin(c.x() & ~7, c.y() & ~7, c.z() & ~7);
    if (!filled_[slot] || origin_[slot] != origin) {
      leaf_[slot] = acc_.probeConstLeaf(c);
      origin_[slot] = origin;
      filled_[slot] = true;
    }
    return leaf_[slot];
  }

  openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> acc_;
  double inv_voxel_;
  openvdb::Coord origin_[8];
  const Leaf* leaf_[8] = {};
  bool filled_[8] = {};
};

/// |value| of the n queries (x, y, z world coordinates as doubles, exact from the floats), -1
/// where a stencil voxel is inactive (outside the band): index coordinates, floors and the
/// trilinear blend in double vectors of the active target (1, 2, 4 or 8 lanes for SCALAR, SSE4,
/// AVX2, AVX3), the 8 voxel values per lane from the sampler's leaf cache, the n mod lanes last
/// queries with Sampler::sample. The same IEEE operations as Sampler::sample in the same order,
/// per lane.
void sample_batch(Sampler& sampler, const double* x, const double* y, const double* z,
                  std::size_t n, float* value);

}  // namespace scanbench::metrics::detail
