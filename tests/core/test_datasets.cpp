// Procedural shapes against analytic answers (volume, area, radius, crease angles) and the
// dataset registry (every entry loads by name; parameters are validated; names and paths resolve).
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "scanbench/core/datasets.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"

namespace scanbench {
namespace {

void expect_solid(const TriangleMesh& m, const char* what) {
  SCOPED_TRACE(what);
  EXPECT_NO_THROW(m.validate(what));
  EXPECT_TRUE(m.is_closed_and_oriented());
  EXPECT_GT(m.signed_volume(), 0.0);
  EXPECT_EQ(m.count_degenerate_faces(), 0);
}

// Dihedral angle (degrees, 0 = flat) across every interior edge, keyed by the edge's vertices.
std::map<std::pair<int, int>, double> dihedral_angles(const TriangleMesh& m) {
  std::map<std::pair<int, int>, std::vector<Eigen::Index>> edge_faces;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      int a = m.faces(k, f);
      int b = m.faces((k + 1) % 3, f);
      if (a > b) std::swap(a, b);
      edge_faces[{a, b}].push_back(f);
    }
  }
  std::map<std::pair<int, int>, double> out;
  for (const auto& [e, faces] : edge_faces) {
    if (faces.size() != 2) continue;
    const double c = std::clamp(
        m.face_normal(faces[0]).cast<double>().dot(m.face_normal(faces[1]).cast<double>()), -1.0,
        1.0);
    out[e] = std::acos(c) * 180.0 / M_PI;
  }
  return out;
}

TEST(Procedural, SphereIsRoundClosedAndHasTheRightVolume) {
  SphereParams p;
  p.radius = 2.0;
  p.resolution = 24;
  const TriangleMesh m = make_sphere(p);
  expect_solid(m, "sphere");
  EXPECT_EQ(m.num_faces(), 12 * 24 * 24);
  EXPECT_EQ(m.num_vertices(), 6 * 24 * 24 + 2);  // Euler: V = F/2 + 2
  for (Eigen::Index v = 0; v < m.num_vertices(); ++v)
    EXPECT_NEAR(m.vertices.col(v).norm(), 2.0f, 2e-6f);
  const double exact = 4.0 / 3.0 * M_PI * 8.0;
  // An inscribed polyhedron: slightly smaller, converging as the grid refines.
  EXPECT_LT(m.signed_volume(), exact);
  EXPECT_NEAR(m.signed_volume() / exact, 1.0, 5e-3);
  EXPECT_NEAR(m.area() / (4.0 * M_PI * 4.0), 1.0, 5e-3);
}

TEST(Procedural, TorusMatchesPappus) {
  TorusParams p;
  const TriangleMesh m = make_torus(p);
  expect_solid(m, "torus");
  const double exact = 2.0 * M_PI * M_PI * p.major_radius * p.minor_radius * p.minor_radius;
  EXPECT_NEAR(m.signed_volume() / exact, 1.0, 5e-3);
  const double area = 4.0 * M_PI * M_PI * p.major_radius * p.minor_radius;
  EXPECT_NEAR(m.area() / area, 1.0, 5e-3);
  p.minor_radius = 1.0;  // not a ring torus
  EXPECT_THROW(make_torus(p), ParamError);
}

TEST(Procedural, CubeHasExactVolumeAndSharpEdges) {
  CubeParams p;
  p.size = 2.0;
  p.resolution = 5;
  const TriangleMesh m = make_cube(p);
  expect_solid(m, "cube");
  EXPECT_NEAR(m.signed_volume(), 8.0, 1e-5);
  EXPECT_NEAR(m.area(), 24.0, 1e-4);
  EXPECT_EQ(m.num_faces(), 12 * 25);
  // Creases are genuine: 12 edges x 5 segments carry a 90-degree dihedral, everything else is flat.
  int sharp = 0;
  for (const auto& [e, angle] : dihedral_angles(m)) {
    if (angle > 1.0) {
      EXPECT_NEAR(angle, 90.0, 1e-3);
      ++sharp;
    } else {
      EXPECT_NEAR(angle, 0.0, 1e-3);
    }
  }
  EXPECT_EQ(sharp, 12 * 5);
}

TEST(Procedural, PlateIsAThinClosedBox) {
  PlateParams p;
  p.size = 2.0;
  p.thickness = 0.1;
  p.resolution = 4;
  const TriangleMesh m = make_plate(p);
  expect_solid(m, "plate");
  EXPECT_NEAR(m.signed_volume(), 2.0 * 2.0 * 0.1, 1e-6);
  EXPECT_NEAR(m.area(), 2.0 * 4.0 + 4.0 * 2.0 * 0.1, 1e-5);
  EXPECT_EQ(m.num_faces(), 12 * 16);
  const BoundingBox b = m.bbox();
  EXPECT_FLOAT_EQ(b.extent().z(), 0.1f);
  EXPECT_FLOAT_EQ(b.extent().x(), 2.0f);
  p.thickness = 3.0;  // thicker than wide: not a plate
  EXPECT_THROW(make_plate(p), ParamError);
}

TEST(Procedural, FandiskBlockHasCreasesAndASmoothFillet) {
  FandiskBlockParams p;
  const TriangleMesh m = make_fandisk_block(p);
  expect_solid(m, "fandisk_block");
  // Profile area: wall-and-fillet part, flat top, ramp, left flat; the fillet polygon is inscribed.
  const double rho = p.fillet_radius;
  const double area = (0.9 - rho) * rho + M_PI * rho * rho / 4.0 + 0.9 * (0.9 - rho) +
                      0.5 * (0.9 + 1.2) * 0.4 + 1.2 * 0.7;
  EXPECT_LT(m.signed_volume(), area * p.depth);
  EXPECT_NEAR(m.signed_volume() / (area * p.depth), 1.0, 1e-3);
  double max_fillet = 0.0;
  bool ramp_concave = false;
  bool ramp_convex = false;
  for (const auto& [e, angle] : dihedral_angles(m)) {
    const Eigen::Vector3f a = m.vertices.col(e.first);
    const Eigen::Vector3f b = m.vertices.col(e.second);
    const bool interior_y = std::abs(a.y()) < 0.49f && std::abs(b.y()) < 0.49f;
    if (!interior_y) continue;
    // Edges along y inside the fillet: only the polygonal facet angle (G1 blend, no crease).
    if (a.x() > 1.0f - rho + 1e-4f && b.x() > 1.0f - rho + 1e-4f && a.z() > 0.9f - rho + 1e-4f &&
        b.z() > 0.9f - rho + 1e-4f && a.x() < 1.0f - 1e-4f)
      max_fillet = std::max(max_fillet, angle);
    const double ramp = std::atan2(0.3, 0.4) * 180.0 / M_PI;
    if (std::abs(a.x() - 0.1f) < 1e-6f && std::abs(b.x() - 0.1f) < 1e-6f && a.z() > 0.89f &&
        b.z() > 0.89f)
      ramp_concave = std::abs(angle - ramp) < 1e-3;
    if (std::abs(a.x() + 0.3f) < 1e-6f && std::abs(b.x() + 0.3f) < 1e-6f && a.z() > 1.19f &&
        b.z() > 1.19f)
      ramp_convex = std::abs(angle - ramp) < 1e-3;
  }
  EXPECT_GT(max_fillet, 0.0);
  EXPECT_LT(max_fillet, 90.0 / 8.0 + 1e-3);  // at least 8 segments on the quarter circle
  EXPECT_TRUE(ramp_concave);
  EXPECT_TRUE(ramp_convex);
}

TEST(Procedural, RippleHeightFollowsItsDefinition) {
  RippleParams p;
  const double lambda = p.radius / p.ripples;
  EXPECT_NEAR(ripple_height(p, 0.0), p.amplitude, 1e-12);  // conic apex
  for (int k = 0; k < p.ripples; ++k) {
    const double r = (k + 0.5) * lambda;
    EXPECT_NEAR(ripple_height(p, r), 0.0, 1e-12);  // trench bottom
    // Smooth trench: symmetric second difference, zero first difference.
    const double d = 1e-4;
    EXPECT_NEAR(ripple_height(p, r + d) - ripple_height(p, r - d), 0.0, 1e-9);
    // Sharp ridge at (k + 1) lambda: slopes +4A/lambda and -4A/lambda (plus the taper term).
    const double rr = (k + 1) * lambda;
    const double a = p.amplitude * (1.0 - p.taper * rr / p.radius);
    const double left = (ripple_height(p, rr - 1e-7) - ripple_height(p, rr - 2e-7)) / 1e-7;
    EXPECT_NEAR(left, 4.0 * a / lambda - p.amplitude * p.taper / p.radius, 1e-3);
    if (k + 1 < p.ripples) {
      const double right = (ripple_height(p, rr + 2e-7) - ripple_height(p, rr + 1e-7)) / 1e-7;
      EXPECT_NEAR(right, -4.0 * a / lambda - p.amplitude * p.taper / p.radius, 1e-3);
    }
  }
}

TEST(Procedural, RippleIsAClosedSolidWithTheIntegratedVolume) {
  RippleParams p;
  p.sectors = 128;
  const TriangleMesh m = make_ripple(p);
  expect_solid(m, "ripple");
  // Volume of revolution: integral of 2 pi r (f(r) + base) dr (midpoint rule, fine steps).
  const int n = 200000;
  double v = 0.0;
  for (int i = 0; i < n; ++i) {
    const double r = (i + 0.5) * p.radius / n;
    v += 2.0 * M_PI * r * (ripple_height(p, r) + p.base) * p.radius / n;
  }
  EXPECT_NEAR(m.signed_volume() / v, 1.0, 2e-3);
  // Top vertices lie on the height field.
  for (Eigen::Index i = 0; i < m.num_vertices(); ++i) {
    const Eigen::Vector3f q = m.vertices.col(i);
    const double r = std::hypot(q.x(), q.y());
    if (q.z() > -p.base + 1e-6 && r < p.radius * (1.0 - 1e-6)) {
      EXPECT_NEAR(q.z(), ripple_height(p, r), 1e-5);
    }
  }
}

TEST(Procedural, CoarsestAndOddParametersStayClosedAndOriented) {
  SphereParams sp;
  sp.resolution = 1;
  expect_solid(make_sphere(sp), "sphere 1");
  sp.resolution = 7;
  sp.radius = 1e-3;
  expect_solid(make_sphere(sp), "sphere tiny");
  TorusParams tp;
  tp.major_segments = 3;
  tp.minor_segments = 3;
  expect_solid(make_torus(tp), "torus 3x3");
  CubeParams cp;
  cp.resolution = 1;
  expect_solid(make_cube(cp), "cube 1");
  FandiskBlockParams fp;
  fp.resolution = 2;
  fp.fillet_radius = 0.05;
  expect_solid(make_fandisk_block(fp), "fandisk coarse");
  fp.resolution = 97;
  fp.fillet_radius = 0.6;
  fp.depth = 3.3;
  expect_solid(make_fandisk_block(fp), "fandisk fine");
  RippleParams rp;
  rp.ripples = 1;
  rp.rings_per_ripple = 2;
  rp.sectors = 3;
  expect_solid(make_ripple(rp), "ripple coarse");
  rp.ripples = 7;
  rp.rings_per_ripple = 5;
  rp.sectors = 101;
  rp.taper = 0.0;
  rp.radius = 3.7;
  expect_solid(make_ripple(rp), "ripple odd");
}

TEST(Procedural, WeldMergesExactDuplicatesOnly) {
  TriangleMesh m;
  m.vertices.resize(3, 4);
  m.vertices << 0, 1, 0, 1, 0, 0, 1, 0, -0.0f, 0, 0, 0;
  m.faces.resize(3, 2);
  m.faces << 0, 3, 1, 2, 2, 0;
  const TriangleMesh w = weld_coincident_vertices(m);
  EXPECT_EQ(w.num_vertices(), 3);  // vertex 3 = (1, 0, 0): an exact duplicate of vertex 1
  EXPECT_EQ(w.faces(0, 1), 1);
  m.vertices(2, 3) = 1e-7f;  // no longer exact
  EXPECT_EQ(weld_coincident_vertices(m).num_vertices(), 4);
}

TEST(Datasets, EveryEntryLoadsByNameOrSkipsWhenItsFileIsAbsent) {
  std::set<std::string> names;
  int missing = 0;
  for (const auto& e : datasets().entries()) {
    SCOPED_TRACE(e.name);
    EXPECT_TRUE(names.insert(e.name).second);
    EXPECT_FALSE(e.doc.empty());
    if (!e.fn.available()) {
      ++missing;
      EXPECT_THROW(load_dataset(e.name), IoError);
      continue;
    }
    const TriangleMesh m = load_dataset(e.name);
    EXPECT_GT(m.num_faces(), 0);
    EXPECT_GT(m.bbox().diagonal(), 0.0f);
    if (e.fn.file.empty()) expect_solid(m, e.name.c_str());
  }
  for (const char* n :
       {"sphere", "torus", "cube", "plate", "fandisk_block", "ripple", "bunny", "fandisk",
        "armadillo", "camel", "elephant", "man", "eight", "cow", "knot", "hand", "femur"})
    EXPECT_TRUE(names.count(n)) << n;
  if (missing > 0) GTEST_SKIP() << missing << " file datasets absent (run scripts/setup.sh)";
}

TEST(Datasets, ParametersAreValidated) {
  EXPECT_EQ(load_dataset("cube", Json{{"resolution", 2}}).num_faces(), 12 * 4);
  EXPECT_THROW(load_dataset("cube", Json{{"resolutoin", 2}}), ParamError);
  EXPECT_THROW(load_dataset("cube", Json{{"resolution", 2.5}}), ParamError);
  EXPECT_THROW(load_dataset("cube", Json{{"resolution", 0}}), ParamError);
  EXPECT_THROW(load_dataset("sphere", Json{{"radius", "1"}}), ParamError);
  EXPECT_THROW(load_dataset("torus", Json{{"minor_radius", 2.0}}), ParamError);
  EXPECT_THROW(load_dataset("ripple", Json::array()), ParamError);
  const Json schema = datasets().at("ripple").to_json();
  EXPECT_EQ(schema["params"].size(), 7u);
}

TEST(Datasets, NamesFallBackToPathsAndUnknownNamesListTheKnownOnes) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("scanbench_test_datasets_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const TriangleMesh cube = make_cube(CubeParams{});
  write_mesh(cube, dir / "cube.ply");
  const TriangleMesh back = load_dataset((dir / "cube.ply").string());
  EXPECT_EQ(back.vertices, cube.vertices);
  EXPECT_EQ(back.faces, cube.faces);
  EXPECT_THROW(load_dataset((dir / "cube.ply").string(), Json{{"normalize", true}}), ParamError);
  try {
    load_dataset("no_such_dataset");
    FAIL() << "expected UnknownNameError";
  } catch (const UnknownNameError& e) {
    EXPECT_NE(std::string(e.what()).find("sphere"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("no_such_dataset"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace scanbench
