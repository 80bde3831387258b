// File IO: round trips in every format (bit-exact), hand-written files as oracles for the
// readers (every PLY type, big endian, polygons, OFF variants, STL welding, OBJ), and malformed
// files, which must throw IoError naming the file and the place, never crash.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

class IoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           (std::string("scanbench_test_io_") + info->name() + "_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path file(const std::string& name, const std::string& content) const {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }
  static std::string bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir_;
};

template <class T>
void put_be(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

template <class T>
void put_le(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

void expect_same(const TriangleMesh& a, const TriangleMesh& b) {
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.faces, b.faces);
}

PointCloud random_cloud(Eigen::Index n, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  c.resize(n);
  c.normals.resize(3, n);
  c.weights.resize(n);
  c.scan_ids.resize(n);
  c.properties["outlier"].resize(n);
  c.properties["clean_x"].resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      c.positions(k, i) = static_cast<float>(rng.normal(0.0, 10.0));
      c.normals(k, i) = static_cast<float>(rng.normal());
    }
    c.normals.col(i).normalize();
    c.weights[i] = static_cast<float>(rng.uniform());
    c.scan_ids[i] = static_cast<int>(rng.below(3));
    c.properties["outlier"][i] = rng.uniform() < 0.1 ? 1.0f : 0.0f;
    c.properties["clean_x"][i] = static_cast<float>(rng.uniform(-1e-3, 1e6));
  }
  c.sensor_origins = Eigen::Matrix3Xf::Random(3, 3) * 100.0f;
  return c;
}

void expect_same(const PointCloud& a, const PointCloud& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.scan_ids, b.scan_ids);
  EXPECT_EQ(a.sensor_origins, b.sensor_origins);
  ASSERT_EQ(a.properties.size(), b.properties.size());
  for (const auto& [name, values] : a.properties) {
    ASSERT_TRUE(b.has_property(name)) << name;
    EXPECT_EQ(values, b.properties.at(name)) << name;
  }
}

// A square pyramid: base quad (0, 3, 2, 1) facing down plus four sides; volume 1/3.
constexpr const char* kPyramidOff =
    "OFF\n5 5 8\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 3 2 1\n3 0 1 4\n3 1 2 4\n3 2 3 4\n"
    "3 3 0 4\n";

// A tetrahedron (o, x, y, z) with outward faces; volume 1/6.
constexpr float kTet[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
constexpr int kTetFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

TEST_F(IoTest, MeshRoundTripsBitExactlyThroughPlyAndObj) {
  SphereParams sp;
  sp.radius = 0.7;
  sp.resolution = 7;
  const TriangleMesh m = make_sphere(sp);
  for (const char* name : {"m.ply", "m.obj", "M.PLY"}) {
    SCOPED_TRACE(name);
    write_mesh(m, dir_ / name);
    expect_same(read_mesh(dir_ / name), m);
  }
  EXPECT_THROW(write_mesh(m, dir_ / "m.off"), IoError);
  EXPECT_THROW(write_mesh(m, dir_ / "no_dir" / "m.ply"), IoError);
}

TEST_F(IoTest, PointCloudRoundTripsBitExactlyAndDeterministically) {
  const PointCloud c = random_cloud(257, 7);
  for (PlyFormat f : {PlyFormat::BinaryLittleEndian, PlyFormat::Ascii}) {
    const fs::path a = dir_ / "a.ply";
    const fs::path b = dir_ / "b.ply";
    write_point_cloud(c, a, f);
    write_point_cloud(c, b, f);
    EXPECT_EQ(bytes(a), bytes(b));
    expect_same(read_point_cloud(a), c);
  }
  // Only positions.
  PointCloud p;
  p.positions = c.positions;
  write_point_cloud(p, dir_ / "p.ply");
  const PointCloud q = read_point_cloud(dir_ / "p.ply");
  expect_same(q, p);
  EXPECT_FALSE(q.has_normals() || q.has_weights() || q.has_scan_ids());
  // Reserved property names and unsupported extensions are refused.
  PointCloud bad = p;
  bad.properties["x"] = Eigen::VectorXf::Zero(p.size());
  EXPECT_THROW(write_point_cloud(bad, dir_ / "bad.ply"), IoError);
  EXPECT_THROW(write_point_cloud(p, dir_ / "p.xyz"), IoError);
}

TEST_F(IoTest, MixtureRoundTripsWithAndWithoutNormalAxes) {
  Rng rng(3);
  GaussianMixture m;
  m.resize(33);
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    const Eigen::Matrix3f a = Eigen::Matrix3f::Random();
    m.set_covariance(i, a * a.transpose() + 0.01f * Eigen::Matrix3f::Identity());
    m.means.col(i) = Eigen::Vector3f::Random();
    m.weights[i] = static_cast<float>(rng.uniform());
  }
  for (PlyFormat f : {PlyFormat::BinaryLittleEndian, PlyFormat::Ascii}) {
    write_mixture(m, dir_ / "m.ply", f);
    const GaussianMixture r = read_mixture(dir_ / "m.ply");
    EXPECT_EQ(r.means, m.means);
    EXPECT_EQ(r.covariances, m.covariances);
    EXPECT_EQ(r.weights, m.weights);
    EXPECT_FALSE(r.has_normal_axes());
  }
  m.normal_axes = Eigen::Matrix3Xf::Random(3, m.size()).colwise().normalized();
  m.normal_spreads = Eigen::VectorXf::Random(m.size()).cwiseAbs();
  write_mixture(m, dir_ / "n.ply", PlyFormat::Ascii);
  const std::string text = bytes(dir_ / "n.ply");
  EXPECT_NE(text.find("element component 33\n"), std::string::npos);
  EXPECT_NE(text.find("property float covxy\n"), std::string::npos);
  const GaussianMixture r = read_mixture(dir_ / "n.ply");
  EXPECT_EQ(r.normal_axes, m.normal_axes);
  EXPECT_EQ(r.normal_spreads, m.normal_spreads);
}

TEST_F(IoTest, ReadsEveryPlyTypeInBigEndian) {
  std::string s =
      "ply\nformat binary_big_endian 1.0\ncomment by hand\nobj_info none\nelement vertex 2\n"
      "property float32 x\nproperty double y\nproperty int16 z\nproperty char c\n"
      "property uchar uc\nproperty ushort us\nproperty int i\nproperty uint ui\n"
      "element extra 1\nproperty list uint8 int32 idx\nend_header\n";
  for (int row = 0; row < 2; ++row) {
    put_be<float>(s, 1.5f + row);
    put_be<double>(s, -2.25);
    put_be<std::int16_t>(s, -300);
    put_be<std::int8_t>(s, -5);
    put_be<std::uint8_t>(s, 200);
    put_be<std::uint16_t>(s, 60000);
    put_be<std::int32_t>(s, -100000);
    put_be<std::uint32_t>(s, 4000000000u);
  }
  put_be<std::uint8_t>(s, 2);
  put_be<std::int32_t>(s, 7);
  put_be<std::int32_t>(s, -7);
  const PointCloud c = read_point_cloud(file("be.ply", s));
  ASSERT_EQ(c.size(), 2);
  EXPECT_EQ(c.positions.col(1), Eigen::Vector3f(2.5f, -2.25f, -300.0f));
  EXPECT_EQ(c.properties.at("c")[0], -5.0f);
  EXPECT_EQ(c.properties.at("uc")[0], 200.0f);
  EXPECT_EQ(c.properties.at("us")[1], 60000.0f);
  EXPECT_EQ(c.properties.at("i")[1], -100000.0f);
  EXPECT_EQ(c.properties.at("ui")[0], 4000000000.0f);
  // The same body one byte short: the error names the file, element, row and property.
  try {
    read_point_cloud(file("short.ply", s.substr(0, s.size() - 9)));
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("short.ply: element extra, row 0, property idx: "
                                         "unexpected end of file"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(IoTest, ReadsAsciiPlyPolygonsAndSensors) {
  const fs::path p = file("poly.ply",
                          "ply\r\nformat ascii 1.0\r\ncomment quad + triangle\r\n"
                          "element vertex 5\r\nproperty float x\r\nproperty float y\r\n"
                          "property float z\r\nproperty int scan_id\r\nelement face 2\r\n"
                          "property list uchar int vertex_index\r\nelement sensor 2\r\n"
                          "property float x\r\nproperty float y\r\nproperty float z\r\n"
                          "end_header\r\n0 0 0 0\r\n1 0 0 1\r\n1 1 0 0\r\n0 1 0 1\r\n"
                          "0.5 0.5 1 1\r\n4 0 1 2 3\r\n3 0 1 4\r\n5 5 5\r\n-1 -1 +2e1\r\n");
  const TriangleMesh m = read_mesh(p);
  ASSERT_EQ(m.num_faces(), 3);
  EXPECT_EQ(m.faces.col(0), Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces.col(1), Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(m.faces.col(2), Eigen::Vector3i(0, 1, 4));
  const PointCloud c = read_point_cloud(p);
  EXPECT_EQ(c.scan_ids, (Eigen::VectorXi(5) << 0, 1, 0, 1, 1).finished());
  EXPECT_EQ(c.sensor_origins.col(1), Eigen::Vector3f(-1, -1, 20));
}

TEST_F(IoTest, OffVariantsAndFanTriangulation) {
  const TriangleMesh pyramid = read_mesh(file("p.off", kPyramidOff));
  EXPECT_EQ(pyramid.num_faces(), 6);
  EXPECT_TRUE(pyramid.is_closed_and_oriented());
  EXPECT_NEAR(pyramid.signed_volume(), 1.0 / 3.0, 1e-6);
  // Comments, counts on the header line, colours and normals to skip, homogeneous coordinates.
  const std::string variants[] = {
      "# made by hand\nOFF 5 5 0 # counts here\n\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n"
      "4 0 3 2 1\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4 # last\n",
      "COFF\n5 5 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n0 1 0 1 1 1 1\n"
      "0.5 0.5 1 9 9 9 9\n4 0 3 2 1 1 0 0\n3 0 1 4 0.5 0.5 0.5\n3 1 2 4\n3 2 3 4\n3 3 0 4\n",
      "NOFF\n5 5 0\n0 0 0 0 0 -1\n1 0 0 0 0 -1\n1 1 0 0 0 -1\n0 1 0 0 0 -1\n0.5 0.5 1 0 0 1\n"
      "4 0 3 2 1\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4\n",
      "4OFF\n5 5 0\n0 0 0 2\n2 0 0 2\n2 2 0 2\n0 2 0 2\n1 1 2 2\n4 0 3 2 1\n3 0 1 4\n3 1 2 4\n"
      "3 2 3 4\n3 3 0 4\n",
  };
  int i = 0;
  for (const auto& text : variants) {
    SCOPED_TRACE(i);
    expect_same(read_mesh(file("v" + std::to_string(i++) + ".off", text)), pyramid);
  }
}

TEST_F(IoTest, StlAsciiAndBinaryAreWelded) {
  std::string ascii = "solid tet\n";
  std::string binary(80, ' ');
  put_le<std::uint32_t>(binary, 4);
  for (const auto& f : kTetFaces) {
    ascii += "  facet normal 0 0 0\n    outer loop\n";
    for (int k = 0; k < 12; ++k)
      put_le<float>(binary, k < 3 ? 0.0f : kTet[f[(k - 3) / 3]][(k - 3) % 3]);
    put_le<std::uint16_t>(binary, 0);
    for (int k = 0; k < 3; ++k) {
      ascii += fmt::format("      vertex {} {} {}\n", kTet[f[k]][0], kTet[f[k]][1], kTet[f[k]][2]);
    }
    ascii += "    endloop\n  endfacet\n";
  }
  ascii += "endsolid tet\n";
  for (const auto& [name, data] : {std::pair{"a.stl", ascii}, std::pair{"b.STL", binary}}) {
    SCOPED_TRACE(name);
    const TriangleMesh m = read_mesh(file(name, data));
    EXPECT_EQ(m.num_vertices(), 4);
    EXPECT_EQ(m.num_faces(), 4);
    EXPECT_TRUE(m.is_closed_and_oriented());
    EXPECT_NEAR(m.signed_volume(), 1.0 / 6.0, 1e-7);
  }
  EXPECT_THROW(read_mesh(file("c.stl", binary.substr(0, binary.size() - 1))), IoError);
  EXPECT_THROW(read_mesh(file("d.stl", ascii.substr(0, ascii.size() - 13))), IoError);
}

TEST_F(IoTest, ObjPolygonsAndIndexForms) {
  const TriangleMesh pyramid = read_mesh(file("p.off", kPyramidOff));
  const std::string obj =
      "# pyramid\nmtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
      "vt 0 0\nvn 0 0 1\no pyramid\nf 1/1/1 4/1/1 3/1/1 2/1/1\nf 1//1 2//1 5//1\nf -4 -3 -1\n"
      "f 3 4 5\nf 4 1 5\n";
  expect_same(read_mesh(file("p.obj", obj)), pyramid);
  EXPECT_THROW(read_mesh(file("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")), IoError);
  EXPECT_THROW(read_mesh(file("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")), IoError);
  EXPECT_THROW(read_mesh(file("empty.obj", "# nothing\n")), IoError);
  EXPECT_THROW(read_mesh(file("frac.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2.5 3\n")), IoError);
  EXPECT_THROW(read_mesh(file("short.obj", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n")), IoError);
}

TEST_F(IoTest, TruncatedPlyGivesAClearError) {
  const TriangleMesh cube = make_cube(CubeParams{});
  write_mesh(cube, dir_ / "cube.ply");
  const std::string full = bytes(dir_ / "cube.ply");
  const std::size_t header = full.find("end_header\n") + 11;
  const auto cut = [&](std::size_t n, const char* expect) {
    SCOPED_TRACE(n);
    try {
      read_mesh(file("cut.ply", full.substr(0, n)));
      FAIL() << "expected IoError";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("cut.ply"), std::string::npos) << e.what();
    }
  };
  cut(header + 12 * 5 + 6, "element vertex, row 5, property y: unexpected end of file");
  cut(full.size() - 1, "element face, row");
  cut(header - 5, "unexpected end of file in the header");
  cut(0, "not a PLY file");
}

TEST_F(IoTest, BadValuesAreRejectedWithTheirPlace) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const auto expect_error = [&](const std::string& body, const char* expect) {
    SCOPED_TRACE(body);
    try {
      read_mesh(file("bad.ply", head + body));
      FAIL() << "expected IoError";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  expect_error("0 0 0\n1 0 0\nnan 1 0\n3 0 1 2\n", "row 2, property x: non-finite");
  expect_error("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "vertex index 3 out of range");
  expect_error("0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "polygon with 2 vertices");
  expect_error("0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", "out of range of its type");
  expect_error("0 0 0\n1 0 0\n0 1 x\n3 0 1 2\n", "row 2, property z: not a number");
  expect_error("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n7\n", "unexpected data after the last element");
  expect_error("0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n", "not an integer");
  expect_error("0 0 0\n1 0 0\n0 1 1e39\n3 0 1 2\n", "out of range of its type");
  // Normals must come as a full group.
  const std::string cloud =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nend_header\n0 0 0 1\n";
  EXPECT_THROW(read_point_cloud(file("n.ply", cloud)), IoError);
  EXPECT_THROW(read_point_cloud(dir_ / "missing.ply"), IoError);
  EXPECT_THROW(read_mesh(file("x.xyz", "0 0 0\n")), IoError);
}

// Every file of the committed malformed corpus throws IoError from every reader that accepts its
// extension (the fuzz target's crashes and slow inputs end up here too).
TEST(MalformedCorpus, EveryFileThrowsIoError) {
  const fs::path dir = fs::path(SCANBENCH_TEST_DATA) / "malformed";
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const fs::path p = entry.path();
    SCOPED_TRACE(p.filename().string());
    ++n;
    EXPECT_THROW(read_mesh(p), IoError);
    if (p.extension() == ".ply") {
      // A cloud or mixture reader may legitimately ignore a broken face element, so it must
      // either succeed or throw IoError; any other exception is a bug.
      for (auto* reader : {+[](const fs::path& q) { (void)read_point_cloud(q); },
                           +[](const fs::path& q) { (void)read_mixture(q); }}) {
        try {
          reader(p);
        } catch (const IoError&) {
        } catch (const std::exception& e) {
          ADD_FAILURE() << "unexpected exception: " << e.what();
        }
      }
    }
  }
  EXPECT_GE(n, 20);
}

}  // namespace
}  // namespace scanbench
