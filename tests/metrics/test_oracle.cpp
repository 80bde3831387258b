// Exact oracle vs brute force, field path vs exact path, and the .vdb writer.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <filesystem>

#include <tbb/task_arena.h>

#include "scanbench/core/errors.h"
#include "scanbench/metrics/closest_point.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/surface_sampling.h"
#include "temp_dir.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

using testing::grid;
using testing::icosphere;
using testing::random_soup;

// Independent oracle: projection onto the plane when inside (barycentric), else the best of the
// three segment projections.
Eigen::Vector3d brute_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  auto seg = [&](const Eigen::Vector3d& s, const Eigen::Vector3d& e) {
    const Eigen::Vector3d d = e - s;
    const double l2 = d.squaredNorm();
    const double t = l2 > 0 ? std::clamp((p - s).dot(d) / l2, 0.0, 1.0) : 0.0;
    return Eigen::Vector3d(s + t * d);
  };
  Eigen::Vector3d best = seg(a, b);
  for (const Eigen::Vector3d& q : {seg(b, c), seg(c, a)})
    if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  const Eigen::Vector3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 1e-24) {
    const Eigen::Vector3d q = p - n * (p - a).dot(n) / n.squaredNorm();
    const double u = (b - q).cross(c - q).dot(n), v = (c - q).cross(a - q).dot(n),
                 w = (a - q).cross(b - q).dot(n);
    if (u >= 0 && v >= 0 && w >= 0 && (q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  }
  return best;
}

TEST(ClosestPointOnTriangle, MatchesBruteForceIncludingDegenerate) {
  Rng rng(7);
  for (int it = 0; it < 20000; ++it) {
    Eigen::Vector3d a(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    Eigen::Vector3d b(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    Eigen::Vector3d c(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    if (it % 10 == 1) c = a + 0.3 * (b - a);  // collinear
    if (it % 10 == 2) b = a;                  // repeated vertex
    if (it % 10 == 3) b = c = a;              // a point
    const Eigen::Vector3d p(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    const double d = (closest_point_on_triangle(p, a, b, c) - p).norm();
    const double e = (brute_triangle(p, a, b, c) - p).norm();
    ASSERT_NEAR(d, e, 1e-9) << "iteration " << it;
  }
}

struct Brute {
  double d2 = std::numeric_limits<double>::infinity();
  Eigen::Index face = -1;
};
Brute brute_mesh(const TriangleMesh& m, const Eigen::Vector3f& qf) {
  const Eigen::Vector3d q = qf.cast<double>();
  Brute b;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d p = closest_point_on_triangle(
        q, m.vertices.col(m.faces(0, f)).cast<double>(),
        m.vertices.col(m.faces(1, f)).cast<double>(), m.vertices.col(m.faces(2, f)).cast<double>());
    const double d2 = (p - q).squaredNorm();
    if (d2 < b.d2) b = {d2, f};
  }
  return b;
}

TEST(GroundTruth, ExactOracleMatchesBruteForceOnRandomMeshes) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const TriangleMesh m = random_soup(300, seed);
    GroundTruth gt(m, 0);
    Rng rng(seed + 100);
    Eigen::Matrix3Xf q(3, 600);
    for (int i = 0; i < 600; ++i) {
      const double s = i < 400 ? 1.5 : 50.0;  // near the mesh and far outliers
      q.col(i) = Eigen::Vector3f(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s));
    }
    const auto cps = gt.closest_points(q);
    for (int i = 0; i < q.cols(); ++i) {
      const Brute b = brute_mesh(m, q.col(i));
      ASSERT_NEAR(cps[i].distance, std::sqrt(b.d2), 1e-6 * (1 + std::sqrt(b.d2))) << i;
      ASSERT_EQ(cps[i].face, b.face) << i;
      ASSERT_NEAR((cps[i].point - q.col(i)).norm(), cps[i].distance, 1e-5);
      ASSERT_NEAR(cps[i].normal.dot(m.face_normal(b.face)), 1.0f, 1e-6);
    }
  }
}

TEST(ClosestPointOnTriangle, PreparedTriangleGivesTheSameBits) {
  Rng rng(11);
  for (int it = 0; it < 5000; ++it) {
    const Eigen::Vector3d a(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const Eigen::Vector3d b(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const Eigen::Vector3d c =
        it % 7 == 0 ? Eigen::Vector3d(a + 0.5 * (b - a))
                    : Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const PreparedTriangle t(a, b, c);
    EXPECT_EQ(t.degenerate, it % 7 == 0);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
      ASSERT_EQ(t.closest_point(p), closest_point_on_triangle(p, a, b, c)) << it;
    }
  }
}

// The exact path visits queries in Morton order: the answers must not depend on the order in
// which the queries are given, nor on the thread count.
TEST(GroundTruth, ExactPathIgnoresQueryOrderAndThreadCount) {
  const TriangleMesh m = random_soup(400, 5);
  GroundTruth gt(m, 0);
  Rng rng(9);
  const Eigen::Index n = 3000;
  Eigen::Matrix3Xf q(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double s = i % 10 == 0 ? 20.0 : 1.5;
    q.col(i) = Eigen::Vector3f(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s));
  }
  std::vector<Eigen::Index> perm(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    perm[static_cast<std::size_t>(i)] = (i * 7919) % n;  // 7919 is prime, n = 3000: a bijection
  Eigen::Matrix3Xf shuffled(3, n);
  for (Eigen::Index i = 0; i < n; ++i)
    shuffled.col(i) = q.col(perm[static_cast<std::size_t>(i)]);
  Eigen::VectorXf a, b;
  std::vector<ClosestPoint> ca, cb;
  tbb::task_arena(1).execute([&] {
    a = gt.distances(q, DistancePath::Exact);
    ca = gt.closest_points(q);
  });
  tbb::task_arena(2).execute([&] {
    b = gt.distances(shuffled, DistancePath::Exact);
    cb = gt.closest_points(shuffled);
  });
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto j = static_cast<std::size_t>(i);
    const Eigen::Index src = perm[j];
    ASSERT_EQ(b[i], a[src]) << i;
    ASSERT_EQ(cb[j].face, ca[static_cast<std::size_t>(src)].face) << i;
    ASSERT_EQ(cb[j].point, ca[static_cast<std::size_t>(src)].point) << i;
    const ClosestPoint one = gt.closest_point(shuffled.col(i));
    ASSERT_EQ(one.distance, b[i]) << i;
    ASSERT_EQ(one.face, cb[j].face) << i;
  }
}

// The per-face lower bounds (plane patch, sphere for slivers) may only reject faces that cannot
// win: slivers, needles, nearly parallel faces and queries from very near to very far must give
// exactly the brute-force answer (same routine, so the same bits and the same face).
TEST(GroundTruth, FaceRejectionKeepsTheExactAnswerOnSliversAndFarQueries) {
  Rng rng(21);
  TriangleMesh m = random_soup(500, 21);
  for (Eigen::Index f = 0; f < m.num_faces(); f += 3) {
    // Every third face becomes a sliver or a needle: c almost on the line ab.
    const Eigen::Vector3f a = m.vertices.col(m.faces(0, f)), b = m.vertices.col(m.faces(1, f));
    const float t = static_cast<float>(rng.uniform(-0.5, 1.5));
    const float off = static_cast<float>(std::pow(10.0, rng.uniform(-9, -3)));
    m.vertices.col(m.faces(2, f)) = a + t * (b - a) + off * Eigen::Vector3f(0.3f, -0.7f, 0.2f);
  }
  GroundTruth gt(m, 0);
  const Eigen::Index n = 1500;
  Eigen::Matrix3Xf q(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double s = std::pow(10.0, rng.uniform(-1, 2.5));  // from inside the soup to far away
    q.col(i) = Eigen::Vector3f(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s));
  }
  const auto cps = gt.closest_points(q);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Brute b = brute_mesh(m, q.col(i));
    ASSERT_EQ(cps[static_cast<std::size_t>(i)].distance, static_cast<float>(std::sqrt(b.d2))) << i;
    ASSERT_EQ(cps[static_cast<std::size_t>(i)].face, b.face) << i;
  }
}

TEST(GroundTruth, PointsOnVerticesAndEdgesHaveZeroDistanceAndLowestFace) {
  const TriangleMesh m = icosphere(2);
  GroundTruth gt(m, 0);
  // Vertices: distance 0 and, of all faces touching the vertex, the lowest index.
  for (Eigen::Index v = 0; v < m.num_vertices(); ++v) {
    const ClosestPoint c = gt.closest_point(m.vertices.col(v));
    EXPECT_FLOAT_EQ(c.distance, 0.0f);
    Eigen::Index lowest = m.num_faces();
    for (Eigen::Index f = 0; f < m.num_faces(); ++f)
      if ((m.faces.col(f).array() == v).any()) lowest = std::min(lowest, f);
    const Brute b = brute_mesh(m, m.vertices.col(v));
    EXPECT_EQ(b.d2, 0.0);
    EXPECT_EQ(c.face, lowest) << "vertex " << v;
  }
  // Edge midpoints: distance matches brute force (about 0) and the face matches brute force.
  for (Eigen::Index f = 0; f < m.num_faces(); f += 7) {
    const Eigen::Vector3f q =
        0.5f * (m.vertices.col(m.faces(0, f)) + m.vertices.col(m.faces(1, f)));
    const ClosestPoint c = gt.closest_point(q);
    const Brute b = brute_mesh(m, q);
    EXPECT_NEAR(c.distance, std::sqrt(b.d2), 1e-7);
    EXPECT_EQ(c.face, b.face);
  }
}

TEST(GroundTruth, RejectsBadInput) {
  TriangleMesh empty;
  EXPECT_THROW(GroundTruth(empty, 0), InputError);
  TriangleMesh m = icosphere(1);
  m.vertices(0, 3) = std::nanf("");
  EXPECT_THROW(GroundTruth(m, 0), InputError);
  GroundTruth gt(icosphere(1), 0);
  EXPECT_THROW(gt.closest_point(Eigen::Vector3f(std::nanf(""), 0, 0)), InputError);
}

TEST(DistanceField, FieldPathMatchesExactNearTheSurface) {
  const TriangleMesh m = icosphere(4);
  GroundTruth gt(m, 3, GroundTruthOptions{1.0 / 200.0, 3.0f});
  const float voxel = gt.field().voxel_size();
  EXPECT_EQ(gt.field().kind(), DistanceField::Kind::Signed);
  const PointCloud& s = gt.surface_samples(20000);
  Rng rng(5);
  Eigen::Matrix3Xf q(3, s.size() + 200);
  for (Eigen::Index i = 0; i < s.size(); ++i)
    q.col(i) =
        s.positions.col(i) + static_cast<float>(rng.uniform(-1.5, 1.5) * voxel) * s.normals.col(i);
  for (Eigen::Index i = s.size(); i < q.cols(); ++i)  // far: must fall back
    q.col(i) = Eigen::Vector3f(rng.uniform(2, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
  Eigen::Index fallbacks = -1;
  const Eigen::VectorXf field = gt.distances(q, DistancePath::Field, &fallbacks);
  const Eigen::VectorXf exact = gt.distances(q, DistancePath::Exact);
  EXPECT_GE(fallbacks, 200);
  EXPECT_LT(fallbacks, 200 + s.size() / 100);
  const double mean_dev = (field - exact).cwiseAbs().mean() / voxel;
  EXPECT_LT(mean_dev, 0.05);
  EXPECT_LT((field - exact).cwiseAbs().maxCoeff() / voxel, 0.5);
  for (Eigen::Index i = s.size(); i < q.cols(); ++i)
    EXPECT_EQ(field[i], exact[i]);
}

TEST(DistanceField, UnsignedForOpenMeshes) {
  const TriangleMesh m = grid(20);
  GroundTruth gt(m, 0, GroundTruthOptions{1.0 / 100.0, 3.0f});
  EXPECT_FALSE(gt.closed());
  EXPECT_EQ(gt.field().kind(), DistanceField::Kind::Unsigned);
  const float voxel = gt.field().voxel_size();
  // Away from the kink (|z| > 1 voxel) the unsigned field is linear in z: exact to rounding.
  for (float z : {1.2f, -1.7f}) {
    const auto d = gt.field().distance(Eigen::Vector3f(0.43f, 0.51f, z * voxel));
    ASSERT_TRUE(d.has_value());
    EXPECT_NEAR(*d, std::abs(z) * voxel, 0.02 * voxel);
  }
  EXPECT_FALSE(gt.field().distance(Eigen::Vector3f(0.5f, 0.5f, 0.5f)).has_value());
}

// The batch path (sorted by leaf, per-chunk samplers, in-leaf fast path) against single queries,
// on points that straddle leaf boundaries (multiples of 8 voxels, on both signs of every axis),
// lie on lattice points, far away, or beyond the grid's coordinate range; and the same results
// and outside order with 1 and 2 threads.
TEST(DistanceField, BatchMatchesSingleQueriesAndIgnoresThreadCount) {
  const float voxel = 0.02f;
  const DistanceField f(icosphere(4), voxel, 3.0f, DistanceField::Kind::Signed);
  Rng rng(11);
  const Eigen::Index n = 30000;
  Eigen::Matrix3Xf q(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::Vector3f u(rng.normal(0, 1), rng.normal(0, 1), rng.normal(0, 1));
    q.col(i) = u.normalized() * static_cast<float>(1.0 + rng.uniform(-4, 4) * voxel);
    if (i % 5 == 1)  // snap one axis to a leaf boundary (8 voxels), just below or on it
      q(i % 3, i) = std::round(q(i % 3, i) / (8 * voxel)) * 8 * voxel - (i % 2 ? 0.5f * voxel : 0);
    if (i % 7 == 2) q.col(i) = (q.col(i) / voxel).array().round().matrix() * voxel;  // lattice
    if (i % 97 == 3) q.col(i) *= 3.0f;                                               // far
    if (i % 997 == 4) q(0, i) = (i % 2 ? 1e30f : -1e30f);  // beyond int32 index coordinates
  }
  auto batch = [&](int threads, Eigen::VectorXf& out, std::vector<Eigen::Index>& outside) {
    tbb::task_arena arena(threads);
    arena.execute([&] { f.distances(q, out, outside); });
  };
  Eigen::VectorXf out1, out2;
  std::vector<Eigen::Index> outside1, outside2;
  batch(1, out1, outside1);
  batch(2, out2, outside2);
  EXPECT_EQ(outside1, outside2);
  std::vector<char> is_outside(static_cast<std::size_t>(n), 0);
  for (const Eigen::Index i : outside1) {
    ASSERT_EQ(is_outside[static_cast<std::size_t>(i)], 0) << "index listed twice: " << i;
    is_outside[static_cast<std::size_t>(i)] = 1;
  }
  Eigen::Index inside = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto d = f.distance(q.col(i));
    ASSERT_EQ(d.has_value(), !is_outside[static_cast<std::size_t>(i)]) << i;
    if (!d) continue;
    ++inside;
    ASSERT_EQ(out1[i], *d) << i;
    ASSERT_EQ(out2[i], *d) << i;
  }
  EXPECT_GT(inside, n / 2);
  EXPECT_GT(static_cast<Eigen::Index>(outside1.size()), n / 100);
}

// A flat open mesh, with its normal along each axis in turn: away from the kink the unsigned
// distance is linear along the normal, and trilinear interpolation of a linear function is
// exact, also for stencils across leaf boundaries. A stencil reaching the band's last layer
// (4 voxels: inactive) must report "outside".
TEST(DistanceField, BatchIsExactOnALinearFieldAcrossLeaves) {
  const float voxel = 0.01f;
  for (int axis = 0; axis < 3; ++axis) {
    TriangleMesh m = grid(20);
    for (Eigen::Index v = 0; v < m.num_vertices(); ++v) {
      const Eigen::Vector3f p = m.vertices.col(v);
      m.vertices.col(v) = Eigen::Vector3f(p[(2 - axis) % 3], p[(3 - axis) % 3], p[(4 - axis) % 3]);
    }
    const DistanceField f(m, voxel, 4.0f, DistanceField::Kind::Unsigned);
    Rng rng(12);
    Eigen::Matrix3Xf q(3, 6000);
    Eigen::VectorXf t(q.cols());  // offset along the normal, in voxels
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      t[i] = static_cast<float>(i % 3 == 0 ? rng.uniform(3.05, 3.95) : rng.uniform(1.1, 2.9));
      Eigen::Vector3f p(rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.9));
      p[axis] = (i % 2 ? 1.0f : -1.0f) * t[i] * voxel;
      q.col(i) = p;
    }
    Eigen::VectorXf out;
    const std::vector<char> is_outside = testing::field_outside_flags(f, q, out);
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      ASSERT_EQ(is_outside[static_cast<std::size_t>(i)], i % 3 == 0) << axis << " " << t[i];
      if (i % 3) {
        ASSERT_NEAR(out[i], t[i] * voxel, 0.02 * voxel) << axis << " " << i;
      }
    }
  }
}

// The field path is deterministic: the same distances with 1 and 2 threads, and the fallback
// answers equal the exact path bit for bit.
TEST(DistanceField, FieldPathIgnoresThreadCount) {
  GroundTruth gt(icosphere(3), 3, GroundTruthOptions{1.0 / 150.0, 3.0f});
  Rng rng(13);
  Eigen::Matrix3Xf q(3, 8000);
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    Eigen::Vector3f u(rng.normal(0, 1), rng.normal(0, 1), rng.normal(0, 1));
    q.col(i) = u.normalized() *
               static_cast<float>(i % 10 ? rng.uniform(0.98, 1.02) : rng.uniform(0.0, 2.0));
  }
  Eigen::VectorXf a, b;
  Eigen::Index fa = 0, fb = 0;
  tbb::task_arena(1).execute([&] { a = gt.distances(q, DistancePath::Field, &fa); });
  tbb::task_arena(2).execute([&] { b = gt.distances(q, DistancePath::Field, &fb); });
  EXPECT_EQ(fa, fb);
  EXPECT_GT(fa, 0);
  EXPECT_TRUE(a == b);
  const Eigen::VectorXf exact = gt.distances(q, DistancePath::Exact);
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    if (!gt.field().distance(q.col(i))) {
      ASSERT_EQ(a[i], exact[i]) << i;
    }
  }
}

// The fallback starts its exact search from a coarse lattice's vertex (far from the mesh), the
// kd-tree (near it) or outside the lattice: every start must give the exact path's answer bit
// for bit, and that answer must match brute force.
TEST(DistanceField, FallbackEqualsExactAndBruteForce) {
  for (const bool closed : {true, false}) {
    const TriangleMesh m = closed ? icosphere(3) : random_soup(300, 4);
    GroundTruth gt(m, 0, GroundTruthOptions{1.0 / 100.0, 3.0f});
    Rng rng(14);
    Eigen::Matrix3Xf q(3, 3000);
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      const double s = i % 3 == 0 ? 3.0 : 1.3;  // a third beyond 1.5 x the bounding box
      q.col(i) = Eigen::Vector3f(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s));
    }
    Eigen::Index fallbacks = 0;
    const Eigen::VectorXf field = gt.distances(q, DistancePath::Field, &fallbacks);
    const Eigen::VectorXf exact = gt.distances(q, DistancePath::Exact);
    EXPECT_GT(fallbacks, q.cols() / 2);
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      if (gt.field().distance(q.col(i))) continue;
      ASSERT_EQ(field[i], exact[i]) << closed << " " << i;
      if (i % 10 == 0) {
        const Brute b = brute_mesh(m, q.col(i));
        ASSERT_NEAR(field[i], std::sqrt(b.d2), 1e-6 * (1 + std::sqrt(b.d2))) << i;
      }
    }
  }
}

TEST(DistanceField, CompareAndVdbRoundTrip) {
  const TriangleMesh a = icosphere(4, 1.0f);
  const TriangleMesh b = icosphere(4, 1.05f);
  const float voxel = 0.03f;
  const DistanceField fa(a, voxel, 3.0f, DistanceField::Kind::Signed);
  const DistanceField fa2(a, voxel, 3.0f, DistanceField::Kind::Signed);
  const DistanceField fb(b, voxel, 3.0f, DistanceField::Kind::Signed);
  const auto same = DistanceField::compare(fa, fa2);
  EXPECT_EQ(same.mean_abs_diff, 0.0);
  ASSERT_TRUE(same.iou.has_value());
  EXPECT_DOUBLE_EQ(*same.iou, 1.0);
  const auto diff = DistanceField::compare(fa, fb);
  ASSERT_TRUE(diff.iou.has_value());
  // Polyhedral volumes scale by 1.05^3 exactly; voxelisation costs about a voxel layer.
  EXPECT_NEAR(*diff.iou, 1.0 / (1.05 * 1.05 * 1.05), 0.02);
  // Bands of 3 voxels = 0.09: | |d_a| - |d_b| | is 0.05 outside both spheres, |2r - 2.05| between
  // them and at most the band width where clamped.
  EXPECT_GT(diff.mean_abs_diff, 0.02);
  EXPECT_LE(diff.mean_abs_diff, 0.09 + 1e-6);
  EXPECT_THROW(
      DistanceField::compare(fa, DistanceField(a, 0.05f, 3.0f, DistanceField::Kind::Signed)),
      InputError);
  EXPECT_THROW(DistanceField(a, 0.0f, 3.0f, DistanceField::Kind::Signed), ParamError);

  const test::TempDir dir("field");
  const auto path = dir / "field.vdb";
  fa.write_vdb(path, "ground_truth");
  const VdbInfo info = read_vdb_info(path);
  EXPECT_EQ(info.name, "ground_truth");
  EXPECT_EQ(info.active_voxels, fa.active_voxels());
  EXPECT_NEAR(info.voxel_size, voxel, 1e-7);
  std::filesystem::remove(path);
  EXPECT_THROW(read_vdb_info(path), IoError);
}

TEST(SurfaceSampling, SeededPrefixStableAndOnTheSurface) {
  const TriangleMesh m = icosphere(3, 2.0f);
  const PointCloud a = sample_surface(m, 1000, 42);
  const PointCloud b = sample_surface(m, 2000, 42);
  EXPECT_TRUE(a.positions == b.positions.leftCols(1000));
  const PointCloud c = sample_surface(m, 1000, 43);
  EXPECT_FALSE(a.positions == c.positions);
  GroundTruth gt(m, 0);
  for (const auto& cp : gt.closest_points(a.positions))
    EXPECT_LT(cp.distance, 1e-5f);
  // Area weighting: the mean of the samples of a centred sphere is near 0.
  EXPECT_LT(b.positions.rowwise().mean().norm(), 0.1);
}

}  // namespace
}  // namespace scanbench::metrics
