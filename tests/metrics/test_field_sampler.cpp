// The field's batch sampler (leaf-sorted queries, in-leaf fast path on the value mask words,
// per-chunk leaf cache) against OpenVDB's own accessor and BoxSampler on the grid that
// write_vdb exports: the same in/out decision (all 8 stencil voxels active) and the same
// trilinear value, including stencils that straddle leaves and the edge of the band.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/simd.h"
#include "scanbench/metrics/distance_field.h"
#include "temp_dir.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

openvdb::FloatGrid::Ptr exported_grid(const DistanceField& f) {
  openvdb::initialize();
  const test::TempDir dir("sampler");
  const auto path = dir / "field.vdb";
  f.write_vdb(path, "field");
  openvdb::io::File file(path.string());
  file.open();
  auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("field"));
  file.close();
  return grid;
}

void expect_matches_openvdb(const DistanceField& f, const Eigen::Matrix3Xf& q) {
  const openvdb::FloatGrid::Ptr grid = exported_grid(f);
  ASSERT_TRUE(grid);
  const auto acc = grid->getConstAccessor();
  Eigen::VectorXf out;
  const std::vector<char> is_outside = testing::field_outside_flags(f, q, out);
  Eigen::Index partial = 0, inside = 0;
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    const openvdb::Vec3d ip =
        grid->transform().worldToIndex(openvdb::Vec3d(q(0, i), q(1, i), q(2, i)));
    const openvdb::Coord base(static_cast<int>(std::floor(ip.x())),
                              static_cast<int>(std::floor(ip.y())),
                              static_cast<int>(std::floor(ip.z())));
    int active = 0;
    for (int d = 0; d < 8; ++d)
      active += acc.isValueOn(base.offsetBy(d & 1, (d >> 1) & 1, (d >> 2) & 1)) ? 1 : 0;
    if (active > 0 && active < 8) ++partial;
    ASSERT_EQ(is_outside[static_cast<std::size_t>(i)], active < 8) << "query " << i;
    if (active < 8) continue;
    ++inside;
    const float expected = openvdb::tools::BoxSampler::sample(acc, ip);
    ASSERT_NEAR(out[i], std::abs(expected), 1e-5f * f.voxel_size()) << "query " << i;
  }
  // The queries must exercise both answers and the band's edge.
  EXPECT_GT(inside, q.cols() / 4);
  EXPECT_GT(partial, q.cols() / 50);
}

// Points at offsets up to 1.5 band widths along the normal of surface-ish directions, a share of
// them snapped onto leaf boundaries (multiples of 8 voxels) on either side.
Eigen::Matrix3Xf band_queries(Eigen::Index n, float voxel, float radius, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::Matrix3Xf q(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3f u =
        Eigen::Vector3f(rng.normal(0, 1), rng.normal(0, 1), rng.normal(0, 1)).normalized();
    q.col(i) = u * static_cast<float>(radius + rng.uniform(-6, 6) * voxel);
    if (i % 3 == 1) {
      const int k = static_cast<int>(i % 3 + i / 3) % 3;
      q(k, i) = std::round(q(k, i) / (8 * voxel)) * 8 * voxel -
                static_cast<float>(rng.uniform(0, 1)) * voxel;
    }
  }
  return q;
}

TEST(FieldSampler, SignedFieldMatchesOpenVdb) {
  const float voxel = 0.02f;
  const DistanceField f(testing::icosphere(4), voxel, 3.0f, DistanceField::Kind::Signed);
  expect_matches_openvdb(f, band_queries(20000, voxel, 1.0f, 21));
}

TEST(FieldSampler, UnsignedFieldMatchesOpenVdb) {
  const float voxel = 0.02f;
  const DistanceField f(testing::icosphere(3, 0.7f), voxel, 4.0f, DistanceField::Kind::Unsigned);
  expect_matches_openvdb(f, band_queries(20000, voxel, 0.7f, 22));
}

// The batch sampler runs in double packets as wide as the active ISA (2, 4 or 8 doubles): every
// ISA this machine has matches OpenVDB as above, is bit-identical at 1 and 2 threads, and gives
// the sse2 path's in/out decisions and values within 1e-6 voxel (the same IEEE operations per
// lane; the scalar tail of a chunk, n mod the lanes, may contract to fused multiply-adds).
TEST(FieldSampler, EveryIsaMatchesOpenVdbAndSse2) {
  const float voxel = 0.02f;
  const DistanceField f(testing::icosphere(4), voxel, 3.0f, DistanceField::Kind::Signed);
  const Eigen::Matrix3Xf q = band_queries(20003, voxel, 1.0f, 23);
  auto run = [&](simd::Isa isa, int threads, std::vector<Eigen::Index>& outside) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(1, threads);
    Eigen::VectorXf out;
    f.distances(q, out, outside);
    for (const Eigen::Index i : outside)
      out[i] = -1.0f;
    return out;
  };
  std::vector<Eigen::Index> ref_outside;
  const Eigen::VectorXf ref = run(simd::Isa::sse2, 1, ref_outside);
  for (const simd::Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    {
      simd::ScopedIsa scoped(isa);
      expect_matches_openvdb(f, q);
    }
    std::vector<Eigen::Index> o1, o2;
    const Eigen::VectorXf a = run(isa, 1, o1), b = run(isa, 2, o2);
    EXPECT_EQ(0,
              std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size())));
    EXPECT_EQ(o1, o2);
    EXPECT_EQ(o1, ref_outside);
    EXPECT_LE((a - ref).cwiseAbs().maxCoeff(), 1e-6f * voxel);
  }
}

// The batch sampler is a Highway kernel (metrics/src/field_sampler.cpp): on every target this CPU
// runs, the one-lane SCALAR reference among them, it matches OpenVDB's BoxSampler, makes the
// SCALAR target's in/out decisions and is bit-identical at 1 and 2 threads.
TEST(FieldSampler, EveryHighwayTargetMatchesOpenVdbAndTheScalarReference) {
  const float voxel = 0.02f;
  const DistanceField f(testing::icosphere(4), voxel, 3.0f, DistanceField::Kind::Signed);
  const Eigen::Matrix3Xf q = band_queries(20003, voxel, 1.0f, 29);
  auto run = [&](int threads, std::vector<Eigen::Index>& outside) {
    RunContext ctx(1, threads);
    Eigen::VectorXf out;
    f.distances(q, out, outside);
    for (const Eigen::Index i : outside)
      out[i] = -1.0f;
    return out;
  };
  std::vector<Eigen::Index> ref_outside;
  Eigen::VectorXf ref;
  {
    simd::ScopedTarget scalar(simd::scalar_target());
    ref = run(1, ref_outside);
  }
  for (const std::string& t : simd::runnable_targets()) {
    SCOPED_TRACE(t);
    simd::ScopedTarget scoped(t);
    expect_matches_openvdb(f, q);
    std::vector<Eigen::Index> o1, o2;
    const Eigen::VectorXf a = run(1, o1), b = run(2, o2);
    EXPECT_EQ(0,
              std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size())));
    EXPECT_EQ(o1, o2);
    EXPECT_EQ(o1, ref_outside);
    EXPECT_LE((a - ref).cwiseAbs().maxCoeff(), 1e-6f * voxel);
  }
}

}  // namespace
}  // namespace scanbench::metrics
