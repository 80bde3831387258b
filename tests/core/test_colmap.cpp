// COLMAP model IO (core/colmap.h): text round trip, the binary reader against COLMAP's own writer
// (colmap model_converter), the mapping to a scan against hand-computed centres and ids, the dense
// fused.ply + .vis reader, and malformed files naming file and record.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "scanbench/core/colmap.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() /
                     ("scanbench_colmap_" + name + "_" +
                      std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Two cameras, three images (the third without observations), three points.
colmap::Model small_model() {
  colmap::Model m;
  m.cameras.push_back({1, "PINHOLE", 640, 480, {500, 510, 320, 240}});
  m.cameras.push_back({7, "SIMPLE_RADIAL", 320, 200, {300, 160, 100, 0.01}});
  colmap::Image a;
  a.id = 3;
  a.camera_id = 1;
  a.name = "a.png";
  a.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  a.translation = Eigen::Vector3d(0.5, -1, 4);
  a.xy = {{10.5, 20.25}, {30, 40}};
  a.point3d_ids = {11, -1};
  colmap::Image b = a;
  b.id = 1;
  b.camera_id = 7;
  b.name = "b.png";
  b.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitZ()));
  b.translation = Eigen::Vector3d(2, 0, 3);
  b.point3d_ids = {11, 12};
  colmap::Image c = a;
  c.id = 9;
  c.name = "c.png";
  c.xy.clear();
  c.point3d_ids.clear();
  m.images = {a, b, c};
  m.points.push_back({11, {0.1, 0.2, 0.3}, {1, 2, 3}, 0.75, {{3, 0}, {1, 0}}});
  m.points.push_back({12, {-1, 0.5, 2}, {9, 8, 7}, 1.5, {{1, 1}}});
  m.points.push_back({13, {0, 0, 1}, {0, 0, 0}, 0.25, {{3, 1}, {1, 1}}});
  return m;
}

void expect_same(const colmap::Model& x, const colmap::Model& y) {
  ASSERT_EQ(x.cameras.size(), y.cameras.size());
  for (std::size_t i = 0; i < x.cameras.size(); ++i) {
    EXPECT_EQ(x.cameras[i].id, y.cameras[i].id);
    EXPECT_EQ(x.cameras[i].model, y.cameras[i].model);
    EXPECT_EQ(x.cameras[i].params, y.cameras[i].params);
  }
  ASSERT_EQ(x.images.size(), y.images.size());
  for (std::size_t i = 0; i < x.images.size(); ++i) {
    EXPECT_EQ(x.images[i].id, y.images[i].id);
    EXPECT_EQ(x.images[i].name, y.images[i].name);
    // Both readers normalise qvec (COLMAP too): equal to rounding.
    EXPECT_TRUE(x.images[i].rotation.coeffs().isApprox(y.images[i].rotation.coeffs(), 1e-14));
    EXPECT_EQ(x.images[i].translation, y.images[i].translation);
    EXPECT_EQ(x.images[i].point3d_ids, y.images[i].point3d_ids);
  }
  ASSERT_EQ(x.points.size(), y.points.size());
  for (std::size_t i = 0; i < x.points.size(); ++i) {
    EXPECT_EQ(x.points[i].id, y.points[i].id);
    EXPECT_EQ(x.points[i].xyz, y.points[i].xyz);
    EXPECT_EQ(x.points[i].error, y.points[i].error);
    EXPECT_EQ(x.points[i].track, y.points[i].track);
  }
}

TEST(Colmap, TextModelRoundTripsExactly) {
  const fs::path d = fresh_dir("txt");
  const colmap::Model m = small_model();
  colmap::write_model_text(m, d);
  expect_same(m, colmap::read_model(d));
  fs::remove_all(d);
}

// COLMAP's own binary writer (model_converter), read back by ours: the same model.
TEST(Colmap, BinaryModelOfColmapReadsAsItsText) {
  ASSERT_EQ(std::system("colmap help >/dev/null 2>&1"), 0)
      << "colmap not installed (scripts/setup.sh installs it)";
  const fs::path d = fresh_dir("bin");
  colmap::write_model_text(small_model(), d / "txt");
  fs::create_directories(d / "bin");
  const std::string cmd = "colmap model_converter --input_path '" + (d / "txt").string() +
                          "' --output_path '" + (d / "bin").string() +
                          "' --output_type BIN >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  ASSERT_TRUE(fs::exists(d / "bin" / "points3D.bin"));
  colmap::Model txt = colmap::read_model(d / "txt");
  colmap::Model bin = colmap::read_model(d / "bin");
  // COLMAP writes its hash maps in its own order: compare by id.
  auto by_id = [](auto& v) {
    std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  };
  for (colmap::Model* m : {&txt, &bin}) {
    by_id(m->cameras);
    by_id(m->images);
    by_id(m->points);
  }
  expect_same(txt, bin);
  fs::remove_all(d);
}

TEST(Colmap, ScanHasCameraCentresFirstImageTrackAndError) {
  const colmap::Model m = small_model();
  const PointCloud c = colmap::model_to_cloud(m, "model");
  ASSERT_EQ(c.size(), 3);
  ASSERT_EQ(c.sensor_origins.cols(), 3);
  for (int i = 0; i < 3; ++i) {
    const colmap::Image& im = m.images[static_cast<std::size_t>(i)];
    // C = -R^T t: the camera centre maps to the camera's origin.
    const Eigen::Vector3d centre = c.sensor_origins.col(i).cast<double>();
    EXPECT_LT((im.rotation * centre + im.translation).norm(), 1e-6);
  }
  // Point 11 is seen by images 3 and 1: the first is id 1 = sensor 1 (file order a, b, c).
  EXPECT_EQ(c.scan_ids[0], 1);
  EXPECT_EQ(c.scan_ids[1], 1);
  EXPECT_EQ(c.properties.at("track_length")[0], 2.0f);
  EXPECT_EQ(c.properties.at("track_length")[1], 1.0f);
  EXPECT_EQ(c.properties.at("reprojection_error")[1], 1.5f);
  EXPECT_EQ(c.positions.col(1), Eigen::Vector3f(-1, 0.5f, 2));
}

TEST(Colmap, DenseFusedWithVisibility) {
  const fs::path d = fresh_dir("dense");
  colmap::write_model_text(small_model(), d / "sparse");
  PointCloud fused;
  fused.positions = Eigen::Matrix3Xf::Random(3, 4);
  write_point_cloud(fused, d / "fused.ply");
  {
    std::ofstream vis(d / "fused.ply.vis", std::ios::binary);
    const std::uint64_t n = 4;
    vis.write(reinterpret_cast<const char*>(&n), 8);
    const std::vector<std::vector<std::uint32_t>> lists{{2, 1}, {0}, {1, 0, 2}, {2}};
    for (const auto& l : lists) {
      const auto k = static_cast<std::uint32_t>(l.size());
      vis.write(reinterpret_cast<const char*>(&k), 4);
      vis.write(reinterpret_cast<const char*>(l.data()), static_cast<std::streamsize>(4 * k));
    }
  }
  const PointCloud c = colmap::import_dir(d);
  ASSERT_EQ(c.size(), 4);
  EXPECT_EQ(c.positions, fused.positions);
  EXPECT_EQ(c.scan_ids, Eigen::Vector4i(1, 0, 0, 2));
  EXPECT_EQ(c.properties.at("track_length"), Eigen::Vector4f(2, 1, 3, 1));
  EXPECT_EQ(c.sensor_origins.cols(), 3);
  fs::remove_all(d);
}

TEST(Colmap, MalformedFilesNameFileAndRecord) {
  const fs::path d = fresh_dir("bad");
  colmap::Model m = small_model();
  m.points[1].track = {{5, 0}};
  colmap::write_model_text(m, d);
  try {
    (void)colmap::read_model(d);
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("points3D.txt: point 1 (id 12): track image 5 is not in"),
              std::string::npos)
        << e.what();
  }
  m = small_model();
  m.points[0].track = {{1, 7}};  // image 1 has 2 observations
  colmap::write_model_text(m, d);
  EXPECT_THROW((void)colmap::read_model(d), IoError);
  fs::remove_all(d);
}

}  // namespace
}  // namespace scanbench
