// Stage data: the covariance mesh type and its PLY codec (bit-exact round trip, polygons kept,
// SPD and index errors naming the vertex or face), reading files by content, and the carrying of
// kinds a step does not produce.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/stage_data.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

fs::path temp_file(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("scanbench_stage_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

// A quad and a triangle sharing an edge, with anisotropic covariances that need every bit of a
// double.
CovarianceMesh small_mesh() {
  CovarianceMesh m;
  m.resize(5);
  m.means << 0, 1, 1, 0, 2,  //
      0, 0, 1, 1, 0.5,       //
      0, 0, 0, 0.1, 1.0 / 3.0;
  for (Eigen::Index i = 0; i < 5; ++i) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Identity() * (0.01 + 0.001 * static_cast<double>(i));
    a(0, 1) = a(1, 0) = 0.002 / 3.0;
    m.set_covariance(i, a);
  }
  const int quad[4] = {0, 1, 2, 3};
  const int tri[3] = {1, 4, 2};
  m.faces.add(quad);
  m.faces.add(tri);
  return m;
}

TEST(CovarianceMesh, PlyRoundTripIsBitExactAndKeepsPolygons) {
  const CovarianceMesh m = small_mesh();
  ASSERT_NO_THROW(m.validate("test"));
  const fs::path p = temp_file("cm.ply");
  write_covariance_mesh(m, p);
  const CovarianceMesh r = read_covariance_mesh(p);
  EXPECT_EQ(r.means, m.means);
  EXPECT_EQ(r.covariances, m.covariances);
  EXPECT_EQ(r.faces.offsets, m.faces.offsets);
  EXPECT_EQ(r.faces.indices, m.faces.indices);
  EXPECT_EQ(r.faces.size(0), 4);
  EXPECT_FALSE(r.faces.all_of_size(3));
  // read_stage_file tells it apart from a mesh and a cloud by its covxx property.
  const StageData d = read_stage_file(p);
  EXPECT_EQ(d.kinds(), DataKinds(DataKind::CovarianceMesh));
  // Its mean mesh is the fan triangulation: 2 + 1 triangles.
  EXPECT_EQ(m.mean_mesh().num_faces(), 3);
}

TEST(CovarianceMesh, ValidateNamesTheVertexOrFace) {
  CovarianceMesh m = small_mesh();
  m.set_covariance(3, Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal());  // singular
  try {
    m.validate("cm.ply");
    FAIL() << "singular covariance accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cm.ply: vertex 3: covariance is not symmetric positive"),
              std::string::npos)
        << e.what();
  }
  m = small_mesh();
  m.set_covariance(1, Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal());  // indefinite
  EXPECT_THROW(m.validate("x"), InputError);
  m = small_mesh();
  m.covariances(0, 2) = std::nan("");
  EXPECT_THROW(m.validate("x"), InputError);
  m = small_mesh();
  m.faces.indices[5] = 9;  // out of range in face 1
  try {
    m.validate("x");
    FAIL() << "bad index accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("face 1"), std::string::npos) << e.what();
  }
  m = small_mesh();
  m.faces.indices[1] = 0;  // repeated in face 0
  EXPECT_THROW(m.validate("x"), InputError);
}

TEST(CovarianceMesh, MalformedPlyIsAnIoErrorNamingTheFile) {
  const fs::path p = temp_file("bad.ply");
  std::ofstream(p) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float "
                      "y\nproperty float z\nproperty float covxx\nend_header\n0 0 0 1\n";
  try {
    (void)read_covariance_mesh(p);
    FAIL() << "missing covariance properties accepted";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("covxy"), std::string::npos) << e.what();
  }
}

TEST(StageData, KindsReadByContentAndCarried) {
  SphereParams sp;
  sp.resolution = 2;
  const TriangleMesh mesh = make_sphere(sp);
  const fs::path mp = temp_file("m.ply");
  write_mesh(mesh, mp);
  EXPECT_EQ(read_stage_file(mp).kinds(), DataKinds(DataKind::Mesh));
  PointCloud c;
  c.positions = mesh.vertices;
  const fs::path cp = temp_file("c.ply");
  write_point_cloud(c, cp);
  EXPECT_EQ(read_stage_file(cp).kinds(), DataKinds(DataKind::Points));

  StageData in = c;
  in.mesh = mesh;
  StageData produced;
  produced.covariance_mesh = small_mesh();
  const StageData out = StageData::carry(produced, in, DataKind::CovarianceMesh);
  EXPECT_EQ(out.kinds(), DataKind::Points | DataKind::Mesh | DataKind::CovarianceMesh);
  // A step that produces points replaces them even when it returns none.
  const StageData cleared = StageData::carry(StageData{}, in, DataKind::Points);
  EXPECT_FALSE(cleared.kinds().has(DataKind::Points));
  try {
    (void)in.require_mixture("normals.csw");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "normals.csw: needs mixture, but its input holds only points and mesh");
  }
  EXPECT_EQ(kind_from_name("covariance_mesh", "w"), DataKind::CovarianceMesh);
  EXPECT_THROW(kind_from_name("cloud", "w"), ParamError);
}

}  // namespace
}  // namespace scanbench
