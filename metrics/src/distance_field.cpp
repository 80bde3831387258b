#include "scanbench/metrics/distance_field.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <cmath>
#include <mutex>

#include "scanbench/core/errors.h"

namespace scanbench::metrics {

namespace {

void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

using Accessor = openvdb::FloatGrid::ConstAccessor;

// Trilinear interpolation over the 8 voxels around q (index space); false when any is inactive.
bool sample(const Accessor& acc, const openvdb::math::Transform& xf, const Eigen::Vector3f& q,
            float& value) {
  const openvdb::Vec3d ip = xf.worldToIndex(openvdb::Vec3d(q.x(), q.y(), q.z()));
  const openvdb::Coord base(static_cast<int>(std::floor(ip.x())),
                            static_cast<int>(std::floor(ip.y())),
                            static_cast<int>(std::floor(ip.z())));
  const double fx = ip.x() - base.x();
  const double fy = ip.y() - base.y();
  const double fz = ip.z() - base.z();
  double v[2][2][2];
  // Fast path: the whole stencil inside one leaf node (8^3 voxels), read without 8 tree walks.
  using Leaf = openvdb::FloatGrid::TreeType::LeafNodeType;
  const openvdb::Coord local = base - (base & ~(Leaf::DIM - 1));
  const Leaf* leaf = nullptr;
  if (local.x() < static_cast<int>(Leaf::DIM) - 1 && local.y() < static_cast<int>(Leaf::DIM) - 1 &&
      local.z() < static_cast<int>(Leaf::DIM) - 1)
    leaf = acc.probeConstLeaf(base);
  if (leaf) {
    for (int dx = 0; dx < 2; ++dx)
      for (int dy = 0; dy < 2; ++dy)
        for (int dz = 0; dz < 2; ++dz) {
          const openvdb::Index off = Leaf::coordToOffset(base.offsetBy(dx, dy, dz));
          if (!leaf->isValueOn(off)) return false;
          v[dx][dy][dz] = leaf->getValue(off);
        }
  } else {
    for (int dx = 0; dx < 2; ++dx)
      for (int dy = 0; dy < 2; ++dy)
        for (int dz = 0; dz < 2; ++dz) {
          float s = 0.0f;
          if (!acc.probeValue(base.offsetBy(dx, dy, dz), s)) return false;
          v[dx][dy][dz] = s;
        }
  }
  const double c00 = v[0][0][0] * (1 - fx) + v[1][0][0] * fx;
  const double c01 = v[0][0][1] * (1 - fx) + v[1][0][1] * fx;
  const double c10 = v[0][1][0] * (1 - fx) + v[1][1][0] * fx;
  const double c11 = v[0][1][1] * (1 - fx) + v[1][1][1] * fx;
  const double c0 = c00 * (1 - fy) + c10 * fy;
  const double c1 = c01 * (1 - fy) + c11 * fy;
  value = static_cast<float>(c0 * (1 - fz) + c1 * fz);
  return true;
}

}  // namespace

struct DistanceField::Impl {
  openvdb::FloatGrid::Ptr grid;
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
}

DistanceField::~DistanceField() = default;
DistanceField::DistanceField(DistanceField&&) noexcept = default;
DistanceField& DistanceField::operator=(DistanceField&&) noexcept = default;

std::uint64_t DistanceField::active_voxels() const {
  return impl_->grid->activeVoxelCount();
}

std::optional<float> DistanceField::value(const Eigen::Vector3f& q) const {
  const Accessor acc = impl_->grid->getConstAccessor();
  float v = 0.0f;
  if (!sample(acc, impl_->grid->transform(), q, v)) return std::nullopt;
  return v;
}

std::optional<float> DistanceField::distance(const Eigen::Vector3f& q) const {
  const auto v = value(q);
  if (!v) return std::nullopt;
  return std::abs(*v);
}

void DistanceField::distances(const Eigen::Matrix3Xf& q, Eigen::VectorXf& out,
                              std::vector<std::uint8_t>& inside) const {
  const Eigen::Index n = q.cols();
  out.resize(n);
  inside.assign(static_cast<std::size_t>(n), 0);
  const auto& xf = impl_->grid->transform();
  // Visit the queries leaf by leaf (sorted by the Morton code of their 8^3 leaf, then by index:
  // a total order, so the visiting order is deterministic) for cache locality; every result is
  // written to its own index, so the order never changes a value.
  std::vector<std::pair<std::uint64_t, Eigen::Index>> order(static_cast<std::size_t>(n));
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, n, 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
        for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
          const openvdb::Vec3d ip = xf.worldToIndex(openvdb::Vec3d(q(0, i), q(1, i), q(2, i)));
          std::uint64_t key = 0;
          for (int k = 0; k < 3; ++k) {
            // 21 bits per axis of the leaf coordinate (offset to stay positive).
            const auto c = static_cast<std::uint64_t>(
                (static_cast<std::int64_t>(std::floor(ip[k])) >> 3) + (1 << 20));
            for (int b = 0; b < 21; ++b)
              key |= ((c >> b) & 1u) << (3 * b + k);
          }
          order[static_cast<std::size_t>(i)] = {key, i};
        }
      });
  tbb::parallel_sort(order.begin(), order.end());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      const Accessor acc = impl_->grid->getConstAccessor();
                      for (std::size_t k = r.begin(); k < r.end(); ++k) {
                        const Eigen::Index i = order[k].second;
                        float v = 0.0f;
                        if (sample(acc, xf, q.col(i), v)) {
                          out[i] = std::abs(v);
                          inside[static_cast<std::size_t>(i)] = 1;
                        }
                      }
                    });
}

void DistanceField::write_vdb(const std::filesystem::path& path,
                              const std::string& grid_name) const {
  openvdb::FloatGrid::Ptr g = impl_->grid->deepCopy();
  g->setName(grid_name);
  g->setGridClass(kind_ == Kind::Signed ? openvdb::GRID_LEVEL_SET : openvdb::GRID_UNKNOWN);
  g->insertMeta("scanbench_kind",
                openvdb::StringMetadata(kind_ == Kind::Signed ? "signed" : "unsigned"));
  g->insertMeta("scanbench_band_voxels", openvdb::FloatMetadata(band_voxels_));
  try {
    openvdb::io::File file(path.string());
    file.write({g});
    file.close();
  } catch (const openvdb::Exception& e) {
    throw IoError(path.string() + ": cannot write vdb: " + e.what());
  }
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
