// The non-config files of the bad-input corpus (tests/data/bad_input) through read_stage_file, the
// reader the CLI uses: each either throws IoError naming the file, or reads as data that the
// corpus expects to be valid input (EXPECTED.tsv: the error is then the algorithm's, or the result
// is documented). In the sanitizer tree (cmake/Sanitizers.cmake) this runs under ASan + UBSan.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "temp_dir.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

// Files whose bytes are valid for the reader; what goes wrong with them is for the algorithm
// (degenerate or non-manifold meshes, too few points, non-SPD mixture covariances) or nothing.
const std::set<std::string> kReadable{"cloud_empty.ply",
                                      "cloud_identical_points.xyz",
                                      "cloud_one_point.xyz",
                                      "cloud_two_points.xyz",
                                      "cloud_utm_1e7.xyz",  // read with a local origin
                                      "mesh_duplicate_faces.off",
                                      "mesh_inconsistent_orientation.off",
                                      "mesh_isolated_vertex.off",
                                      "mesh_nonmanifold_edge.off",
                                      "mesh_nonmanifold_vertex.off",
                                      "mesh_repeated_vertex_face.off",
                                      "mesh_utm_1e7.off",  // read with a local origin
                                      "mesh_zero_area_face.off",
                                      "mixture_empty.ply",
                                      "mixture_non_spd.ply",
                                      "mixture_zero_weights.ply"};

TEST(BadInputReaders, EveryFileReadsOrThrowsIoErrorNamingIt) {
  const fs::path dir = fs::path(SCANBENCH_TEST_DATA) / "bad_input";
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("config_", 0) == 0 || name == "EXPECTED.tsv") continue;
    SCOPED_TRACE(name);
    ++n;
    if (kReadable.count(name) != 0) {
      EXPECT_NO_THROW((void)read_stage_file(entry.path()));
      continue;
    }
    try {
      (void)read_stage_file(entry.path());
      ADD_FAILURE() << "read without an error";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  EXPECT_GE(n, 30);
}

// Coordinates near 1e7 read from text lose their shape in float32 (spacing 1 there): they are read
// with a local origin (core stage_data.h), not quantised quietly. The same shape near the origin
// reads with origin zero and the same local coordinates to float32 rounding.
TEST(BadInputReaders, FarCoordinatesInTextGetALocalOriginNotAQuietQuantisation) {
  const test::TempDir tmp("far-coordinates");
  const fs::path dir = tmp.path;
  std::ostringstream far, near;
  far << std::fixed << std::setprecision(3);
  near << std::fixed << std::setprecision(3);
  for (int i = 0; i < 10; ++i) {
    far << 691234.5 + 0.01 * i << " " << 9876543.25 + 0.013 * (i % 7) << " " << 120.5 << "\n";
    near << 0.01 * i << " " << 0.013 * (i % 7) << " " << 0.0 << "\n";
  }
  for (const auto& [file, text] : {std::pair{"far.xyz", far.str()}, {"near.xyz", near.str()}}) {
    std::ofstream(dir / file) << text;
  }
  const PointCloud f = read_point_cloud(dir / "far.xyz");
  EXPECT_FALSE(f.origin.isZero(0.0));
  const PointCloud n = read_point_cloud(dir / "near.xyz");
  EXPECT_TRUE(n.origin.isZero(0.0));
  for (Eigen::Index i = 0; i < 10; ++i) {
    const Eigen::Vector3d w = f.origin + f.positions.col(i).cast<double>();
    EXPECT_NEAR(w.x(), 691234.5 + 0.01 * static_cast<double>(i), 1e-7);
    EXPECT_NEAR(w.y(), 9876543.25 + 0.013 * static_cast<double>(i % 7), 1e-7);
    EXPECT_NEAR(w.z(), 120.5, 1e-7);
  }
  EXPECT_EQ(read_point_cloud(dir / "near.xyz").size(), 10);
  // The same points as float32 binary PLY (what scanbench writes) read back exactly: no error.
  PointCloud c;
  c.positions.resize(3, 2);
  c.positions << 691234.5f, 691234.5f, 9876543.0f, 9876544.0f, 120.5f, 121.5f;
  write_point_cloud(c, dir / "far.ply");
  EXPECT_EQ(read_point_cloud(dir / "far.ply").positions, c.positions);
}

}  // namespace
}  // namespace scanbench
