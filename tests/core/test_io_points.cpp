// Point clouds from plain text: .xyz / .pwn and point-only .off, on hand-written files, on the
// malformed corpus, and on CGAL's own data/points_3 (extracted at test time from the
// libcgal-dev / libcgal-demo documentation tarball, not committed).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

class IoPoints : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("sb_io_points_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path file(const std::string& name, const std::string& content) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << content;
    return p;
  }
  fs::path dir_;
};

std::string message_of(const fs::path& p) {
  try {
    (void)read_point_cloud(p);
  } catch (const IoError& e) {
    return e.what();
  }
  return "(no IoError)";
}

TEST_F(IoPoints, XyzColumns) {
  const PointCloud a = read_point_cloud(file("a.xyz", "# header\n1 2 3\n\n4 5 6  \n"));
  ASSERT_EQ(a.size(), 2);
  EXPECT_FALSE(a.has_normals());
  EXPECT_EQ(a.positions(2, 1), 6.0f);

  const PointCloud b = read_point_cloud(file("b.pwn", "2\n0 0 1 0 0 1\n0 1 0 0 -1 0\n"));
  ASSERT_EQ(b.size(), 2);
  ASSERT_TRUE(b.has_normals());
  EXPECT_EQ(b.normals(1, 1), -1.0f);

  // All-zero normals are "no normals" (CGAL's writer without normals).
  EXPECT_FALSE(read_point_cloud(file("z.xyz", "1 2 3 0 0 0\n4 5 6 0 0 0\n")).has_normals());

  // Other column counts keep the extra values by name.
  const PointCloud c = read_point_cloud(file("c.xyz", "1 2 3 7 8\n4 5 6 9 10\n"));
  EXPECT_FALSE(c.has_normals());
  ASSERT_TRUE(c.has_property("column4"));
  ASSERT_TRUE(c.has_property("column5"));
  EXPECT_EQ(c.properties.at("column5")[1], 10.0f);
}

TEST_F(IoPoints, MalformedNameFileAndLine) {
  EXPECT_NE(message_of(file("n.xyz", "0 0 0\n1 nan 0\n")).find("n.xyz: line 2: non-finite"),
            std::string::npos);
  EXPECT_NE(message_of(file("m.xyz", "0 0 0\n\n1 0\n")).find("m.xyz: line 3: expected x y z"),
            std::string::npos);
  EXPECT_NE(message_of(file("i.pwn", "0 0 0 0 0 1\n0 0 0\n")).find("i.pwn: line 2: 3 values"),
            std::string::npos);
  EXPECT_NE(message_of(file("c.xyz", "5\n0 0 0\n")).find("declares 5 points"), std::string::npos);
  EXPECT_NE(message_of(file("e.xyz", "")).find("e.xyz: no points"), std::string::npos);
}

TEST_F(IoPoints, PointOnlyOff) {
  const fs::path p = file("p.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
  const PointCloud c = read_point_cloud(p);
  EXPECT_EQ(c.size(), 3);
  EXPECT_EQ(c.positions(0, 1), 1.0f);
  const StageData d = read_stage_file(p);
  EXPECT_EQ(d.kinds(), DataKinds(DataKind::Points));
  EXPECT_THROW(read_mesh(p), IoError);

  const PointCloud n = read_point_cloud(file("n.off", "NOFF\n1 0 0\n1 2 3 0 0 1\n"));
  ASSERT_TRUE(n.has_normals());
  EXPECT_EQ(n.normals(2, 0), 1.0f);

  // An OFF with faces is a mesh: read_stage_file gives the mesh, read_point_cloud refuses it.
  const fs::path m = file("m.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(read_stage_file(m).kinds(), DataKinds(DataKind::Mesh));
  EXPECT_NE(message_of(m).find("1 faces is a mesh"), std::string::npos);
  EXPECT_EQ(read_stage_file(file("s.xyz", "0 0 0\n")).kinds(), DataKinds(DataKind::Points));
}

// Every plain point file of the malformed corpus (and every malformed OFF) throws IoError naming
// the file.
TEST(IoPointsCorpus, MalformedPointFilesThrow) {
  const fs::path dir = fs::path(SCANBENCH_TEST_DATA) / "malformed";
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const fs::path p = entry.path();
    const std::string ext = p.extension().string();
    if (ext != ".xyz" && ext != ".pwn" && ext != ".off") continue;
    SCOPED_TRACE(p.filename().string());
    ++n;
    if (p.filename() == "no_faces.off") {
      EXPECT_EQ(read_point_cloud(p).size(), 3);  // a mesh without faces is a valid point set
      continue;
    }
    EXPECT_NE(message_of(p).find(p.filename().string()), std::string::npos) << message_of(p);
  }
  EXPECT_GE(n, 25);
}

// Counts the points of a plain text file independently: non-empty lines not starting with '#',
// minus a first line holding a single value (the point count).
Eigen::Index count_points(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  Eigen::Index n = 0;
  bool first = true;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tok;
    int tokens = 0;
    while (s >> tok && tok[0] != '#')
      ++tokens;
    if (tokens == 0) continue;
    if (!(first && tokens == 1)) ++n;
    first = false;
  }
  return n;
}

// The plain point files of CGAL's data/points_3 (17 .xyz, 3 .pwn, the point-only kitten.off)
// all read, with as many points as the file has point lines.
TEST_F(IoPoints, CgalDataPoints3) {
  fs::path tarball;
  for (const char* t :
       {"/usr/share/doc/libcgal-dev/data.tar.gz", "/usr/share/doc/libcgal-demo/data.tar.gz"}) {
    if (fs::exists(t)) tarball = t;
  }
  ASSERT_FALSE(tarball.empty()) << "CGAL's data.tar.gz (libcgal-dev documentation) is missing";
  const std::string cmd = "tar -xzf " + tarball.string() + " -C " + dir_.string() +
                          " --wildcards 'data/points_3/*.xyz' 'data/points_3/*.pwn' "
                          "'data/points_3/*.off'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::set<std::string> seen;
  int xyz = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "data" / "points_3")) {
    const fs::path p = entry.path();
    SCOPED_TRACE(p.filename().string());
    const PointCloud c = read_point_cloud(p);
    EXPECT_GT(c.size(), 0);
    if (p.extension() == ".off") {
      EXPECT_EQ(c.size(), count_points(p) - 1);  // the OFF header's counts line
    } else {
      EXPECT_EQ(c.size(), count_points(p));
      xyz += p.extension() == ".xyz";
    }
    seen.insert(p.filename().string());
  }
  EXPECT_EQ(xyz, 17);
  EXPECT_TRUE(seen.count("kitten.off"));
  const PointCloud k = read_point_cloud(dir_ / "data" / "points_3" / "kitten.xyz");
  ASSERT_TRUE(k.has_normals());
  EXPECT_FLOAT_EQ(k.positions(0, 0), -0.0721898f);
  EXPECT_FLOAT_EQ(k.normals(2, 0), -0.0690972f);
  const PointCloud s = read_point_cloud(dir_ / "data" / "points_3" / "sphere_20k_normal.xyz");
  EXPECT_EQ(s.size(), 21000);
  EXPECT_NEAR(s.normals.colwise().norm().mean(), 1.0f, 1e-3f);
}

}  // namespace
}  // namespace scanbench
