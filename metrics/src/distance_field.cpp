#include "scanbench/metrics/distance_field.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <sstream>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial_order.h"

// Eigen's packet types carry vector attributes that GCC reports as ignored when they are
// template arguments (scanbench/core/simd_dispatch.h); they do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::metrics {

namespace {

/// A .vdb file's bytes in memory. io::File::write streams straight into an std::ofstream whose
/// state it never checks (a full disk left a field truncated at 3 of 11 MB, and no error); the
/// archive is encoded here exactly as io::File encodes it (Archive::write, seekable, so the
/// grid offsets are in and io::File reads it back with delayed loading), and the bytes go to
/// write_file_atomic, which checks every write and reports the reason.
class VdbEncoder : public openvdb::io::Archive {
 public:
  std::string encode(const openvdb::GridCPtrVec& grids) const {
    std::ostringstream out(std::ios::binary);
    Archive::write(out, grids, /*seekable=*/true);
    if (!out) throw IoError("vdb: encoding failed");
    return std::move(out).str();
  }
};

void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

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

// |value| of the n queries (x, y, z world coordinates as doubles, exact from the floats) with the
// double packet of the active ISA's width (scanbench/core/simd.h: 2, 4 or 8 doubles for sse2,
// avx2, avx512): index coordinates, floors and the trilinear blend in packets, the 8 voxel values
// per lane from the sampler's leaf cache; -1 where a stencil voxel is inactive (outside the band).
// The same IEEE operations as Sampler::sample in the same order, per lane.
template <class PacketD>
void sample_batch(Sampler& sampler, const double* x, const double* y, const double* z,
                  std::size_t n, float* value) {
  namespace ei = Eigen::internal;
  constexpr int kLanes = ei::unpacket_traits<PacketD>::size;
  const PacketD inv = ei::pset1<PacketD>(sampler.inv_voxel()), one = ei::pset1<PacketD>(1.0);
  const PacketD limit = ei::pset1<PacketD>(kMaxIndex);
  alignas(64) double v[8 * kLanes], bx[kLanes], by[kLanes], bz[kLanes], ok[kLanes], res[kLanes];
  std::size_t k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    const PacketD px = ei::pmul(ei::ploadu<PacketD>(x + k), inv),
                  py = ei::pmul(ei::ploadu<PacketD>(y + k), inv),
                  pz = ei::pmul(ei::ploadu<PacketD>(z + k), inv);
    const PacketD in =
        ei::pand(ei::pand(ei::pcmp_lt(ei::pabs(px), limit), ei::pcmp_lt(ei::pabs(py), limit)),
                 ei::pcmp_lt(ei::pabs(pz), limit));
    const PacketD x0 = ei::pfloor(px), y0 = ei::pfloor(py), z0 = ei::pfloor(pz);
    ei::pstore(bx, x0);
    ei::pstore(by, y0);
    ei::pstore(bz, z0);
    ei::pstore(ok, in);
    bool any = false;
    for (int l = 0; l < kLanes; ++l) {
      bool good = false;
      std::uint64_t bits = 0;
      std::memcpy(&bits, &ok[l], sizeof bits);
      if (bits != 0)
        good = sampler.corners(openvdb::Coord(static_cast<int>(bx[l]), static_cast<int>(by[l]),
                                              static_cast<int>(bz[l])),
                               v + l, kLanes);
      if (!good)
        for (int c = 0; c < 8; ++c)
          v[c * kLanes + l] = 0.0;
      ok[l] = good ? 1.0 : 0.0;
      any = any || good;
    }
    if (!any) {
      std::fill_n(value + k, kLanes, -1.0f);
      continue;
    }
    const PacketD fx = ei::psub(px, x0), fy = ei::psub(py, y0), fz = ei::psub(pz, z0);
    const PacketD gx = ei::psub(one, fx), gy = ei::psub(one, fy), gz = ei::psub(one, fz);
    auto corner = [&](int c) { return ei::pload<PacketD>(v + c * kLanes); };
    const PacketD c00 = ei::padd(ei::pmul(corner(0), gx), ei::pmul(corner(4), fx));
    const PacketD c01 = ei::padd(ei::pmul(corner(1), gx), ei::pmul(corner(5), fx));
    const PacketD c10 = ei::padd(ei::pmul(corner(2), gx), ei::pmul(corner(6), fx));
    const PacketD c11 = ei::padd(ei::pmul(corner(3), gx), ei::pmul(corner(7), fx));
    const PacketD c0 = ei::padd(ei::pmul(c00, gy), ei::pmul(c10, fy));
    const PacketD c1 = ei::padd(ei::pmul(c01, gy), ei::pmul(c11, fy));
    ei::pstore(res, ei::padd(ei::pmul(c0, gz), ei::pmul(c1, fz)));
    for (int l = 0; l < kLanes; ++l)
      value[k + static_cast<std::size_t>(l)] =
          ok[l] != 0.0 ? std::abs(static_cast<float>(res[l])) : -1.0f;
  }
  for (; k < n; ++k) {
    float s = 0.0f;
    value[k] = sampler.sample(static_cast<float>(x[k]), static_cast<float>(y[k]),
                              static_cast<float>(z[k]), s)
                   ? std::abs(s)
                   : -1.0f;
  }
}

}  // namespace

struct DistanceField::Impl {
  openvdb::FloatGrid::Ptr grid;
  double inv_voxel = 0.0;           // world -> index scale of the grid's uniform-scale map
  bool empty = true;                // no active voxel
  openvdb::Coord leaf_lo, leaf_hi;  // leaf coordinates (voxel >> 3) spanned by the active voxels
};

DistanceField::DistanceField(const TriangleMesh& mesh, float voxel, float band_voxels, Kind kind)
    : impl_(std::make_unique<Impl>()), kind_(kind), voxel_(voxel), band_voxels_(band_voxels) {
  if (!(voxel > 0.0f) || !std::isfinite(voxel))
    throw ParamError("distance field: voxel size must be positive, got " + std::to_string(voxel));
  if (!(band_voxels >= 2.0f) || !std::isfinite(band_voxels))
    throw ParamError("distance field: band must be at least 2 voxels, got " +
                     std::to_string(band_voxels));
  mesh.validate("distance field");
  init_openvdb();
  std::vector<openvdb::Vec3s> points(static_cast<std::size_t>(mesh.num_vertices()));
  for (Eigen::Index i = 0; i < mesh.num_vertices(); ++i)
    points[static_cast<std::size_t>(i)] =
        openvdb::Vec3s(mesh.vertices(0, i), mesh.vertices(1, i), mesh.vertices(2, i));
  std::vector<openvdb::Vec3I> tris(static_cast<std::size_t>(mesh.num_faces()));
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
    tris[static_cast<std::size_t>(f)] = openvdb::Vec3I(static_cast<unsigned>(mesh.faces(0, f)),
                                                       static_cast<unsigned>(mesh.faces(1, f)),
                                                       static_cast<unsigned>(mesh.faces(2, f)));
  const auto xf = openvdb::math::Transform::createLinearTransform(voxel);
  if (kind == Kind::Signed) {
    impl_->grid =
        openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xf, points, tris, band_voxels);
  } else {
    impl_->grid = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(
        *xf, points, tris, std::vector<openvdb::Vec4I>(), band_voxels);
  }
  const auto& map = *impl_->grid->transform().baseMap();
  if (map.type() != openvdb::math::UniformScaleMap::mapType())
    throw Error("distance field: unexpected grid transform " + map.type());
  impl_->inv_voxel = 1.0 / impl_->grid->transform().voxelSize()[0];
  openvdb::CoordBBox box;
  impl_->empty = !impl_->grid->tree().evalActiveVoxelBoundingBox(box);
  if (!impl_->empty) {
    impl_->leaf_lo = openvdb::Coord(box.min().x() >> 3, box.min().y() >> 3, box.min().z() >> 3);
    impl_->leaf_hi = openvdb::Coord(box.max().x() >> 3, box.max().y() >> 3, box.max().z() >> 3);
  }
}

DistanceField::~DistanceField() = default;
DistanceField::DistanceField(DistanceField&&) noexcept = default;
DistanceField& DistanceField::operator=(DistanceField&&) noexcept = default;

std::uint64_t DistanceField::active_voxels() const {
  return impl_->grid->activeVoxelCount();
}

std::optional<float> DistanceField::value(const Eigen::Vector3f& q) const {
  Sampler sampler(*impl_->grid, impl_->inv_voxel);
  float v = 0.0f;
  if (!sampler.sample(q.x(), q.y(), q.z(), v)) return std::nullopt;
  return v;
}

std::optional<float> DistanceField::distance(const Eigen::Vector3f& q) const {
  const auto v = value(q);
  if (!v) return std::nullopt;
  return std::abs(*v);
}

void DistanceField::distances(const Eigen::Matrix3Xf& q, Eigen::VectorXf& out,
                              std::vector<Eigen::Index>& outside) const {
  const Eigen::Index n = q.cols();
  out.resize(n);
  outside.clear();
  const Impl& m = *impl_;
  if (m.empty) {
    for (Eigen::Index i = 0; i < n; ++i)
      outside.push_back(i);
    return;
  }
  // Visit the queries leaf by leaf for cache locality: key = Morton code of the 8^3 leaf
  // (clamped to the grid's leaf bounds, coarsened only if it would not fit) above the query
  // index, so the order is total and depends on q alone. Every value is written to its own
  // index: the order never changes a result.
  const auto bits = [](std::uint64_t v) { return static_cast<int>(std::bit_width(v)); };
  const int idx_bits = detail::index_bits(n);
  int axis_bits = 0;
  for (int k = 0; k < 3; ++k)
    axis_bits = std::max(axis_bits, bits(static_cast<std::uint64_t>(m.leaf_hi[k] - m.leaf_lo[k])));
  int coarsen = 0;
  while (axis_bits - coarsen > 21 || 3 * (axis_bits - coarsen) + idx_bits > 64)
    ++coarsen;
  const std::vector<Eigen::Index> order =
      detail::order_by_key(n, 3 * (axis_bits - coarsen), [&](Eigen::Index i) {
        std::uint64_t key = 0;
        for (int k = 0; k < 3; ++k) {
          const double c = std::floor(static_cast<double>(q(k, i)) * m.inv_voxel / 8.0);
          const int lo = m.leaf_lo[k], hi = m.leaf_hi[k];
          // NaN fails both comparisons and lands on lo.
          const int l = c > hi ? hi : (c >= lo ? static_cast<int>(c) : lo);
          key |= morton_spread3(static_cast<std::uint64_t>(l - lo) >> coarsen) << k;
        }
        return key;
      });

  // Fixed chunks of the sorted order, each with its own sampler; the outside lists are joined
  // in chunk order, so they do not depend on the thread count either.
  constexpr std::size_t kChunk = 4096;
  const simd::Isa isa = simd::active();
  const std::size_t chunks = (order.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<Eigen::Index>> chunk_outside(chunks);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
        // The chunk's queries are gathered first (independent loads, many in flight),
        // sampled from the contiguous copy, and the values scattered after: about 15%
        // faster than sampling in place with prefetches.
        std::vector<double> lx(kChunk), ly(kChunk), lz(kChunk);
        std::vector<float> value(kChunk);
        for (std::size_t c = r.begin(); c < r.end(); ++c) {
          Sampler sampler(*m.grid, m.inv_voxel);
          const std::size_t begin = c * kChunk;
          const std::size_t end = std::min(order.size(), (c + 1) * kChunk);
          for (std::size_t k = begin; k < end; ++k) {
            const Eigen::Index i = order[k];
            lx[k - begin] = q(0, i);
            ly[k - begin] = q(1, i);
            lz[k - begin] = q(2, i);
          }
          simd::with_packet(isa, [&](auto tag) {
            sample_batch<typename simd::DoublePacket<typename decltype(tag)::type>::type>(
                sampler, lx.data(), ly.data(), lz.data(), end - begin, value.data());
          });
          for (std::size_t k = begin; k < end; ++k) {
            const Eigen::Index i = order[k];
            if (value[k - begin] >= 0.0f)
              out[i] = value[k - begin];
            else
              chunk_outside[c].push_back(i);  // -1: outside the band
          }
        }
      });
  for (const auto& co : chunk_outside)
    outside.insert(outside.end(), co.begin(), co.end());
}

void DistanceField::write_vdb(const std::filesystem::path& path,
                              const std::string& grid_name) const {
  openvdb::FloatGrid::Ptr g = impl_->grid->deepCopy();
  g->setName(grid_name);
  g->setGridClass(kind_ == Kind::Signed ? openvdb::GRID_LEVEL_SET : openvdb::GRID_UNKNOWN);
  g->insertMeta("scanbench_kind",
                openvdb::StringMetadata(kind_ == Kind::Signed ? "signed" : "unsigned"));
  g->insertMeta("scanbench_band_voxels", openvdb::FloatMetadata(band_voxels_));
  std::string bytes;
  try {
    bytes = VdbEncoder().encode({g});
  } catch (const openvdb::Exception& e) {
    throw IoError(path.string() + ": cannot write vdb: " + e.what());
  }
  write_file_atomic(path, bytes);
}

DistanceField::Comparison DistanceField::compare(const DistanceField& a, const DistanceField& b) {
  if (a.voxel_ != b.voxel_)
    throw InputError("distance field comparison: voxel sizes differ (" + std::to_string(a.voxel_) +
                     " vs " + std::to_string(b.voxel_) + ")");
  Comparison c;
  const Accessor acc_a = a.impl_->grid->getConstAccessor();
  const Accessor acc_b = b.impl_->grid->getConstAccessor();
  const float wa = a.band_width();
  const float wb = b.band_width();
  double sum = 0.0;
  // Sequential iteration: a fixed voxel order, so the sum does not depend on threads.
  for (auto it = a.impl_->grid->cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue()) continue;
    float vb = 0.0f;
    const bool on_b = acc_b.probeValue(it.getCoord(), vb);
    const double da = std::min(std::abs(*it), wa);
    const double db = on_b ? std::min(std::abs(vb), wb) : wb;
    sum += std::abs(da - db);
    ++c.voxels;
  }
  for (auto it = b.impl_->grid->cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue()) continue;
    if (acc_a.isValueOn(it.getCoord())) continue;
    const double db = std::min(std::abs(*it), wb);
    sum += std::abs(wa - db);
    ++c.voxels;
  }
  c.mean_abs_diff = c.voxels > 0 ? sum / static_cast<double>(c.voxels) : 0.0;
  if (a.kind_ == Kind::Signed && b.kind_ == Kind::Signed) {
    auto ma = openvdb::tools::sdfInteriorMask(*a.impl_->grid);
    auto mb = openvdb::tools::sdfInteriorMask(*b.impl_->grid);
    const double na = static_cast<double>(ma->activeVoxelCount());
    const double nb = static_cast<double>(mb->activeVoxelCount());
    ma->topologyIntersection(*mb);
    const double ni = static_cast<double>(ma->activeVoxelCount());
    const double nu = na + nb - ni;
    c.iou = nu > 0.0 ? ni / nu : 1.0;
  }
  return c;
}

VdbInfo read_vdb_info(const std::filesystem::path& path) {
  init_openvdb();
  try {
    openvdb::io::File file(path.string());
    file.open();
    for (auto it = file.beginName(); it != file.endName(); ++it) {
      openvdb::GridBase::Ptr base = file.readGrid(it.gridName());
      if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) {
        VdbInfo info{g->getName(), g->activeVoxelCount(), g->voxelSize()[0]};
        file.close();
        return info;
      }
    }
    file.close();
  } catch (const openvdb::Exception& e) {
    throw IoError(path.string() + ": cannot read vdb: " + e.what());
  }
  throw IoError(path.string() + ": no float grid");
}

}  // namespace scanbench::metrics
