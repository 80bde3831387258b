// Local origins (core stage_data.h, io.h): survey-scale files read with a local origin whose local
// coordinates are those of the untranslated data, written back in world coordinates, and re-read
// exactly; files near the origin unchanged bit for bit.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

// The translation of the issue: integer, and a multiple of 2^k for every 2^k up to 32, so data up
// to 64 across gets it back as its origin exactly (float_precision.h).
const Eigen::Vector3d kT(1e6, -2e6, 5e5);

class LocalOrigin : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("sb_local_origin_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

/// A cloud of float32 values on [-0.5, 0.5]^3, each a multiple of 2^-24, so that kT + x is exact
/// in double (2e6 < 2^21: double spacing 2^-32 there).
PointCloud grid_cloud(int n) {
  Rng rng(5);
  PointCloud c;
  c.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double v = rng.uniform() - 0.5;
      c.positions(k, i) = static_cast<float>(std::ldexp(std::nearbyint(std::ldexp(v, 24)), -24));
    }
  }
  return c;
}

/// An ascii PLY of `m`'s columns translated by `t`, as double (%.17g).
void write_double_ply(const fs::path& p, const Eigen::Matrix3Xf& m, const Eigen::Vector3d& t,
                      const std::string& comment = "") {
  std::ofstream out(p);
  out << "ply\nformat ascii 1.0\n" << comment;
  out << "element vertex " << m.cols()
      << "\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  char buf[128];
  for (Eigen::Index i = 0; i < m.cols(); ++i) {
    std::snprintf(buf, sizeof(buf), "%.17g %.17g %.17g\n", t.x() + m(0, i), t.y() + m(1, i),
                  t.z() + m(2, i));
    out << buf;
  }
}

TEST_F(LocalOrigin, FarDoublePlyXyzObjOffReadWithTheTranslationAsOrigin) {
  const PointCloud c = grid_cloud(500);
  write_double_ply(dir_ / "far.ply", c.positions, kT);
  {
    std::ofstream xyz(dir_ / "far.xyz");
    std::ofstream off(dir_ / "far.off");
    off << "OFF\n" << c.size() << " 0 0\n";
    char buf[128];
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      std::snprintf(buf, sizeof(buf), "%.17g %.17g %.17g\n", kT.x() + c.positions(0, i),
                    kT.y() + c.positions(1, i), kT.z() + c.positions(2, i));
      xyz << buf;
      off << buf;
    }
  }
  for (const char* f : {"far.ply", "far.xyz", "far.off"}) {
    SCOPED_TRACE(f);
    const PointCloud r = read_point_cloud(dir_ / f);
    EXPECT_EQ(r.origin, kT);
    EXPECT_EQ(r.positions, c.positions);  // exactly: the untranslated floats
  }
  // A mesh: the sphere (diagonal 3.5: origins on multiples of 2) as OBJ, OFF and PLY.
  const TriangleMesh s = make_sphere(SphereParams{});
  TriangleMesh far = s;
  far.origin = kT;
  write_mesh(far, dir_ / "sphere.obj");
  write_mesh(far, dir_ / "sphere.ply");
  for (const char* f : {"sphere.obj", "sphere.ply"}) {
    SCOPED_TRACE(f);
    const TriangleMesh r = read_mesh(dir_ / f);
    EXPECT_EQ(r.origin, kT);
    EXPECT_EQ(r.faces, s.faces);
    // Exact except for coordinates below 2^-9 in magnitude, which kT + x in double rounds: they
    // move by at most half a double spacing at 2e6 (2^-33).
    EXPECT_LE((r.vertices - s.vertices).cwiseAbs().maxCoeff(), std::ldexp(1.0, -33));
  }
}

TEST_F(LocalOrigin, WriteReadRoundTripsExactlyWithTheOriginComment) {
  PointCloud c = grid_cloud(300);
  c.origin = kT + Eigen::Vector3d(0.25, 0.5, -0.75);  // any origin: the comment states it
  c.normals = Eigen::Matrix3Xf::Zero(3, c.size());
  c.normals.row(2).setOnes();
  c.sensor_origins = Eigen::Matrix3Xf::Constant(3, 1, 2.5f);
  c.scan_ids = Eigen::VectorXi::Zero(c.size());
  for (const PlyFormat fmt : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
    write_point_cloud(c, dir_ / "c.ply", fmt);
    const PointCloud r = read_point_cloud(dir_ / "c.ply");
    EXPECT_EQ(r.origin, c.origin);
    EXPECT_EQ(r.positions, c.positions);
    EXPECT_EQ(r.normals, c.normals);
    EXPECT_EQ(r.sensor_origins, c.sensor_origins);
  }
  // The file holds world coordinates as double and the comment.
  write_point_cloud(c, dir_ / "c.ply", PlyFormat::Ascii);
  std::ifstream in(dir_ / "c.ply");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("comment scanbench_origin 1000000.25 -1999999.5 499999.25"),
            std::string::npos)
      << text.substr(0, 400);
  EXPECT_NE(text.find("property double x"), std::string::npos);
  // Mixture and covariance mesh keep the origin too.
  GaussianMixture m;
  m.resize(2);
  m.means = c.positions.leftCols(2);
  m.weights.setConstant(0.5f);
  for (Eigen::Index i = 0; i < 2; ++i)
    m.set_covariance(i, 0.01f * Eigen::Matrix3f::Identity());
  m.origin = kT;
  write_mixture(m, dir_ / "m.ply");
  const GaussianMixture rm = read_mixture(dir_ / "m.ply");
  EXPECT_EQ(rm.origin, kT);
  EXPECT_EQ(rm.means, m.means);
  CovarianceMesh cm;
  cm.resize(3);
  cm.means = c.positions.leftCols(3).cast<double>();
  for (Eigen::Index i = 0; i < 3; ++i)
    cm.set_covariance(i, 0.01 * Eigen::Matrix3d::Identity());
  const int tri[3] = {0, 1, 2};
  cm.faces.add(tri);
  cm.origin = kT;
  write_covariance_mesh(cm, dir_ / "cm.ply");
  const CovarianceMesh rcm = read_covariance_mesh(dir_ / "cm.ply");
  EXPECT_EQ(rcm.origin, kT);
  EXPECT_EQ(rcm.means, cm.means);
}

TEST_F(LocalOrigin, FilesNearTheOriginAreUnchangedBitForBit) {
  const TriangleMesh s = make_sphere(SphereParams{});
  write_mesh(s, dir_ / "s.ply");
  const TriangleMesh r = read_mesh(dir_ / "s.ply");
  EXPECT_TRUE(r.origin.isZero(0.0));
  EXPECT_EQ(r.vertices, s.vertices);
  std::ifstream in(dir_ / "s.ply", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find("scanbench_origin"), std::string::npos);
  EXPECT_NE(text.find("property float x"), std::string::npos);
  // Double coordinates that float32 holds within the tolerance keep origin zero (float of each).
  PointCloud c = grid_cloud(50);
  c.positions.array() += 10.0f;  // 10 + x: float32 error << 1e-5 of the diagonal
  write_double_ply(dir_ / "near.ply", c.positions, Eigen::Vector3d::Zero());
  const PointCloud rc = read_point_cloud(dir_ / "near.ply");
  EXPECT_TRUE(rc.origin.isZero(0.0));
  EXPECT_EQ(rc.positions, c.positions);
}

TEST_F(LocalOrigin, TheOriginCommentIsHonouredAndChecked) {
  const PointCloud c = grid_cloud(100);
  const Eigen::Vector3d stated(1000003.0, -1999998.0, 500001.0);  // not the reader's own choice
  write_double_ply(dir_ / "stated.ply", c.positions, kT,
                   "comment scanbench_origin 1000003 -1999998 500001\n");
  const PointCloud r = read_point_cloud(dir_ / "stated.ply");
  EXPECT_EQ(r.origin, stated);
  const Eigen::Matrix3Xf expect =
      (c.positions.cast<double>().colwise() + (kT - stated)).cast<float>();
  EXPECT_EQ(r.positions, expect);
  // An origin from which float32 cannot hold the data: the refusal that remains.
  write_double_ply(dir_ / "zero.ply", c.positions, kT, "comment scanbench_origin 0 0 0\n");
  try {
    (void)read_point_cloud(dir_ / "zero.ply");
    ADD_FAILURE() << "read without an error";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("as float32"), std::string::npos) << e.what();
  }
  write_double_ply(dir_ / "bad.ply", c.positions, kT, "comment scanbench_origin 1 2\n");
  EXPECT_THROW((void)read_point_cloud(dir_ / "bad.ply"), IoError);
}

TEST_F(LocalOrigin, RebaseReexpressesInAnotherFrame) {
  PointCloud c = grid_cloud(20);
  c.origin = kT;
  PointCloud d = c;
  rebase(d, kT + Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(d.origin, kT + Eigen::Vector3d(1, 2, 3));
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    EXPECT_EQ(d.positions(0, i), static_cast<float>(c.positions(0, i) - 1.0));
    EXPECT_EQ(d.positions(2, i), static_cast<float>(c.positions(2, i) - 3.0));
  }
  StageData s{c};
  s.mesh = make_sphere(SphereParams{});
  EXPECT_THROW((void)s.origin("x"), InputError);  // points at kT, mesh at zero
  s.set_origin(kT);
  EXPECT_EQ(s.origin("x"), kT);
}

}  // namespace
}  // namespace scanbench
