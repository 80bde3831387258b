// Virtual scanner tests against analytic oracles: exact surface hits on a sphere (brute-force
// point-to-triangle distance), noise statistics on a plane, the recorded rigid motion, binomial
// outlier share, grazing drop-out by the analytic incidence angle, and bitwise determinism.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/procedural.h"
#include "scanbench/scanner/registry.h"
#include "scanbench/scanner/scanner.h"
#include "scanbench/scanner/throughput.h"
#include "temp_dir.h"

namespace scanbench::scanner {
namespace {

/// Icosphere of radius 1 at the origin (subdivided icosahedron, counter-clockwise from outside).
TriangleMesh icosphere(int levels) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v)
    p.normalize();
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[static_cast<std::size_t>(a)] + v[static_cast<std::size_t>(b)]).normalized());
      const int id = static_cast<int>(v.size()) - 1;
      mid[key] = id;
      return id;
    };
    std::vector<Eigen::Vector3i> g;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]),
                c = midpoint(tri[2], tri[0]);
      g.emplace_back(tri[0], a, c);
      g.emplace_back(tri[1], b, a);
      g.emplace_back(tri[2], c, b);
      g.emplace_back(a, b, c);
    }
    f = g;
  }
  TriangleMesh m;
  m.vertices.resize(3, static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    m.vertices.col(static_cast<Eigen::Index>(i)) = v[i];
  m.faces.resize(3, static_cast<Eigen::Index>(f.size()));
  for (std::size_t i = 0; i < f.size(); ++i)
    m.faces.col(static_cast<Eigen::Index>(i)) = f[i];
  return m;
}

/// Axis-aligned squares at heights z with half-sizes h (normals +z).
TriangleMesh squares(const std::vector<std::pair<float, float>>& z_half) {
  TriangleMesh m;
  m.vertices.resize(3, static_cast<Eigen::Index>(4 * z_half.size()));
  m.faces.resize(3, static_cast<Eigen::Index>(2 * z_half.size()));
  for (std::size_t k = 0; k < z_half.size(); ++k) {
    const auto [z, h] = z_half[k];
    const auto b = static_cast<int>(4 * k);
    m.vertices.col(b + 0) = Eigen::Vector3f(-h, -h, z);
    m.vertices.col(b + 1) = Eigen::Vector3f(h, -h, z);
    m.vertices.col(b + 2) = Eigen::Vector3f(h, h, z);
    m.vertices.col(b + 3) = Eigen::Vector3f(-h, h, z);
    m.faces.col(static_cast<Eigen::Index>(2 * k)) = Eigen::Vector3i(b, b + 1, b + 2);
    m.faces.col(static_cast<Eigen::Index>(2 * k + 1)) = Eigen::Vector3i(b, b + 2, b + 3);
  }
  return m;
}

/// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5), in double.
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

double mesh_distance(const TriangleMesh& m, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d q = closest_on_triangle(p, m.vertices.col(m.faces(0, f)).cast<double>(),
                                                  m.vertices.col(m.faces(1, f)).cast<double>(),
                                                  m.vertices.col(m.faces(2, f)).cast<double>());
    best = std::min(best, (q - p).norm());
  }
  return best;
}

Eigen::Vector3d clean_of(const PointCloud& c, Eigen::Index i) {
  return {c.properties.at("clean_x")[i], c.properties.at("clean_y")[i],
          c.properties.at("clean_z")[i]};
}

ScannerParams small(int views = 6, int resolution = 64) {
  ScannerParams p;
  p.views = views;
  p.resolution = resolution;
  return p;
}

std::string read_bytes(const std::filesystem::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(Scanner, SphereWithoutNoiseHitsTheSurfaceExactly) {
  const TriangleMesh m = icosphere(3);
  RunContext ctx(1);
  const Scan s = scan(m, small(6, 96), ctx);
  const PointCloud& c = s.cloud;
  ASSERT_GT(c.size(), 5000);
  c.validate("test");
  // The tessellation lies between the inradius of its faces and the radius 1.
  double inradius = 1.0;
  for (Eigen::Index f = 0; f < m.num_faces(); ++f) {
    inradius = std::min(
        inradius,
        std::abs(static_cast<double>(m.face_normal(f).dot(m.vertices.col(m.faces(0, f))))));
  }
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    const double r = c.positions.col(i).cast<double>().norm();
    ASSERT_GE(r, inradius - 1e-5) << i;
    ASSERT_LE(r, 1.0 + 1e-5) << i;
    ASSERT_EQ(c.properties.at("outlier")[i], 0.0f);
    ASSERT_EQ(clean_of(c, i), c.positions.col(i).cast<double>());
  }
  // Brute force: distance to the mesh itself, on every 5th point.
  for (Eigen::Index i = 0; i < c.size(); i += 5)
    ASSERT_LT(mesh_distance(m, c.positions.col(i).cast<double>()), 1e-5) << i;
  // Sensors at range_min + diag/2 from the bbox centre, one per scan; every scan id used.
  const double diag = m.bbox().diagonal();
  ASSERT_EQ(c.sensor_origins.cols(), 6);
  for (int v = 0; v < 6; ++v) {
    EXPECT_NEAR((c.sensor_origins.col(v) - m.bbox().center()).norm(), 1.0 * diag, 1e-5);
  }
  EXPECT_EQ(c.scan_ids.minCoeff(), 0);
  EXPECT_EQ(c.scan_ids.maxCoeff(), 5);
  for (Eigen::Index i = 1; i < c.size(); ++i)
    ASSERT_LE(c.scan_ids[i - 1], c.scan_ids[i]);  // ordered by view
  EXPECT_EQ(s.record["counts"]["points"].get<std::int64_t>(), c.size());
  EXPECT_EQ(s.record["scans"].size(), 6u);
}

TEST(Scanner, RangeNoiseAlongTheRayHasTheSetSigma) {
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(1, 128);
  p.poses = "0 0 0.6";
  p.fov_deg = 50;
  p.noise_sigma = 0.004;
  RunContext ctx(7);
  const PointCloud c = scan(m, p, ctx).cloud;
  ASSERT_GT(c.size(), 10000);
  const Eigen::Vector3d o = c.sensor_origins.col(0).cast<double>();
  double sum = 0, sum2 = 0;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d q = clean_of(c, i);
    EXPECT_NEAR(q.z(), 0.0, 1e-6);
    const Eigen::Vector3d d = (q - o).normalized();
    const Eigen::Vector3d e = c.positions.col(i).cast<double>() - q;
    EXPECT_LT((e - e.dot(d) * d).norm(), 1e-5 * diag);  // displacement along the ray only
    sum += e.dot(d);
    sum2 += e.dot(d) * e.dot(d);
  }
  const double n = static_cast<double>(c.size());
  const double mean = sum / n;
  const double sd = std::sqrt((sum2 - n * mean * mean) / (n - 1));
  const double sigma = p.noise_sigma * diag;
  EXPECT_NEAR(sd, sigma, 0.05 * sigma);
  EXPECT_NEAR(mean, 0.0, 4 * sigma / std::sqrt(n));
}

// The other two noise definitions on the same plane (z = 0, face normal +-z): normal_gauss moves
// each point along the face normal by N(0, sigma) (nothing along the plane); ray_uniform moves it
// along its ray by U[-sigma, sigma]: |e| never exceeds sigma, std sigma / sqrt 3.
TEST(Scanner, NoiseModelsAlongTheNormalAndUniformAlongTheRay) {
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(1, 128);
  p.poses = "0 0 0.6";
  p.fov_deg = 50;
  p.noise_sigma = 0.004;
  const double sigma = p.noise_sigma * diag;
  for (const char* model : {"normal_gauss", "ray_uniform"}) {
    SCOPED_TRACE(model);
    p.noise_model = model;
    RunContext ctx(7);
    const PointCloud c = scan(m, p, ctx).cloud;
    ASSERT_GT(c.size(), 10000);
    const Eigen::Vector3d o = c.sensor_origins.col(0).cast<double>();
    double sum = 0, sum2 = 0, max_abs = 0;
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      const Eigen::Vector3d q = clean_of(c, i);
      const Eigen::Vector3d e = c.positions.col(i).cast<double>() - q;
      double x = 0;
      if (std::string(model) == "normal_gauss") {
        ASSERT_LT(e.head<2>().norm(), 1e-5 * diag);  // along the normal only
        x = e.z();
      } else {
        const Eigen::Vector3d d = (q - o).normalized();
        ASSERT_LT((e - e.dot(d) * d).norm(), 1e-5 * diag);  // along the ray only
        x = e.dot(d);
      }
      sum += x;
      sum2 += x * x;
      max_abs = std::max(max_abs, std::abs(x));
    }
    const double n = static_cast<double>(c.size());
    const double mean = sum / n;
    const double sd = std::sqrt((sum2 - n * mean * mean) / (n - 1));
    const double expected_sd =
        std::string(model) == "normal_gauss" ? sigma : sigma / std::sqrt(3.0);
    EXPECT_NEAR(sd, expected_sd, 0.05 * expected_sd);
    EXPECT_NEAR(mean, 0.0, 4 * expected_sd / std::sqrt(n));
    if (std::string(model) == "ray_uniform") {
      EXPECT_LE(max_abs, sigma * (1 + 1e-5));
      EXPECT_GT(max_abs, 0.99 * sigma);
    } else {
      EXPECT_GT(max_abs, 3 * sigma);  // Gaussian tails
    }
  }
}

TEST(Scanner, NoiseGrowsWithRangeAndIncidenceAsDeclared) {
  // Standardised residuals z = e / sigma(r, incidence) have unit variance on an oblique plane.
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(1, 128);
  p.poses = "0.35 0 0.3";
  p.fov_deg = 60;
  p.range_min = 0.05;
  p.noise_sigma = 0.001;
  p.noise_range_slope = 0.004;
  p.noise_incidence_slope = 0.002;
  RunContext ctx(8);
  const PointCloud c = scan(m, p, ctx).cloud;
  ASSERT_GT(c.size(), 5000);
  const Eigen::Vector3d o = c.sensor_origins.col(0).cast<double>();
  double sum2 = 0;
  double min_cos = 1;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d q = clean_of(c, i);
    const double r = (q - o).norm();
    const Eigen::Vector3d d = (q - o) / r;
    const double cosi = std::abs(d.z());
    min_cos = std::min(min_cos, cosi);
    const double sigma = diag * (p.noise_sigma + p.noise_range_slope * r / diag +
                                 p.noise_incidence_slope * (1.0 / cosi - 1.0));
    const double z = (c.positions.col(i).cast<double>() - q).dot(d) / sigma;
    sum2 += z * z;
  }
  EXPECT_LT(min_cos, 0.6);  // the incidence really varies
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(c.size())), 1.0, 0.05);
}

TEST(Scanner, MisalignmentIsExactlyTheRecordedRigidMotion) {
  const TriangleMesh m = icosphere(3);
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(6, 64);
  p.misalign_fraction = 0.5;
  p.misalign_deg = 3.0;
  p.misalign_shift = 0.01;
  RunContext ctx(3);
  const Scan s = scan(m, p, ctx);
  const PointCloud& c = s.cloud;
  int misaligned = 0;
  for (const Json& sc : s.record["scans"]) {
    const int id = sc["id"].get<int>();
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    Eigen::Vector3d t = Eigen::Vector3d::Zero();
    if (sc["misaligned"].get<bool>()) {
      ++misaligned;
      const Json& mis = sc["misalignment"];
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b)
          R(a, b) = mis["rotation"][a][b].get<double>();
        t[a] = mis["translation"][a].get<double>();
      }
      EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
      EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
      EXPECT_NEAR(std::acos((R.trace() - 1.0) / 2.0) * 180.0 / M_PI, 3.0, 1e-6);
      // The rotation axis goes through the centre of mass of the scan; the rest is the shift.
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      int n = 0;
      for (Eigen::Index i = 0; i < c.size(); ++i) {
        if (c.scan_ids[i] != id) continue;
        centre += clean_of(c, i);
        ++n;
      }
      centre /= n;
      const Eigen::Vector3d rec_c(mis["center"][0].get<double>(), mis["center"][1].get<double>(),
                                  mis["center"][2].get<double>());
      EXPECT_LT((rec_c - centre).norm(), 1e-5);
      EXPECT_NEAR((R * centre + t - centre).norm(), 0.01 * diag, 1e-5);
    } else {
      EXPECT_TRUE(sc["misalignment"].is_null());
    }
    // Every point of the scan is the rigid motion of its noise-free hit; so is the sensor.
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      if (c.scan_ids[i] != id) continue;
      const Eigen::Vector3d expect = R * clean_of(c, i) + t;
      ASSERT_LT((expect - c.positions.col(i).cast<double>()).norm(), 2e-6 * diag) << i;
    }
    const Eigen::Vector3d o(sc["sensor_origin"][0].get<double>(),
                            sc["sensor_origin"][1].get<double>(),
                            sc["sensor_origin"][2].get<double>());
    EXPECT_LT(((R * o + t) - c.sensor_origins.col(id).cast<double>()).norm(), 1e-5);
  }
  EXPECT_EQ(misaligned, 3);  // round(0.5 * 6)
}

TEST(Scanner, UniformOutlierShareIsBinomial) {
  const TriangleMesh m = icosphere(2);
  ScannerParams p = small(4, 64);
  p.outlier_fraction = 0.25;
  RunContext ctx(11);
  const Scan s = scan(m, p, ctx);
  const PointCloud& c = s.cloud;
  const double n = static_cast<double>(c.size());
  const BoundingBox box = m.bbox().scaled(1.1f);
  double outliers = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    if (c.properties.at("outlier")[i] == 0.0f) {
      ASSERT_NEAR(c.positions.col(i).norm(), 1.0, 0.03);  // coarse tessellation
      continue;
    }
    outliers += 1;
    const Eigen::Vector3f q = c.positions.col(i);
    ASSERT_TRUE((q.array() >= box.min.array()).all() && (q.array() <= box.max.array()).all());
    mean += q.cast<double>();
  }
  const double f = p.outlier_fraction;
  EXPECT_NEAR(outliers / n, f, 4.0 * std::sqrt(f * (1 - f) / n));
  // Uniform in the box: the mean of the outliers is near the centre (sd of a uniform coordinate
  // is extent / sqrt(12)).
  mean /= outliers;
  const Eigen::Vector3f ext = box.extent();
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(mean[k], box.center()[k], 4.0 * ext[k] / std::sqrt(12.0 * outliers));
  EXPECT_EQ(s.record["counts"]["uniform_outliers"].get<double>(), outliers);
}

// outlier_box_min widens only the sides of the scaled box that are shorter than it, about the
// centre: on a thin plate the outliers fill a slab of that height, and a minimum below every side
// changes no bit of the scan.
TEST(Scanner, OutlierBoxMinWidensOnlyTheNarrowSides) {
  PlateParams pp;
  pp.resolution = 4;
  const TriangleMesh m = make_plate(pp);
  const float diag = m.bbox().diagonal();
  ScannerParams p = small(4, 48);
  p.outlier_fraction = 0.3;
  RunContext ctx(12);
  const Scan flat = scan(m, p, ctx);
  p.outlier_box_min = 0.001;  // below every side of the scaled box (its z side is 0.011)
  const Scan same = scan(m, p, ctx);
  ASSERT_EQ(flat.cloud.positions, same.cloud.positions);
  p.outlier_box_min = 0.5;
  const Scan tall = scan(m, p, ctx);
  const BoundingBox scaled = m.bbox().scaled(1.1f);
  const float half_z = 0.25f * diag;
  double outliers = 0, mean_z = 0, max_z = 0;
  for (Eigen::Index i = 0; i < tall.cloud.size(); ++i) {
    if (tall.cloud.properties.at("outlier")[i] == 0.0f) continue;
    const Eigen::Vector3f q = tall.cloud.positions.col(i);
    for (int k = 0; k < 2; ++k) {  // x and y keep the scaled box (1.1 > 0.5 diag)
      ASSERT_GE(q[k], scaled.min[k]);
      ASSERT_LE(q[k], scaled.max[k]);
    }
    ASSERT_LE(std::abs(q.z()), half_z * (1.0f + 1e-6f));
    outliers += 1;
    mean_z += q.z();
    max_z = std::max(max_z, static_cast<double>(std::abs(q.z())));
  }
  ASSERT_GT(outliers, 100);
  // Uniform over the slab's height: the largest |z| is near its half height and the mean near 0
  // (sd of a uniform coordinate is height / sqrt(12)).
  EXPECT_GT(max_z, 0.9 * half_z);
  EXPECT_NEAR(mean_z / outliers, 0.0, 4.0 * 2.0 * half_z / std::sqrt(12.0 * outliers));
}

TEST(Scanner, GrazingDropoutRemovesExactlyTheSteepHits) {
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  ScannerParams p = small(1, 128);
  p.poses = "0.4 0 0.25";
  p.fov_deg = 70;
  p.range_min = 0.05;  // the sensor is nearer than the default minimum range
  RunContext ctx(5);
  const Scan all = scan(m, p, ctx);
  const double limit = 60.0;
  p.max_incidence_deg = limit;
  const Scan kept = scan(m, p, ctx);
  const Eigen::Vector3d o = all.cloud.sensor_origins.col(0).cast<double>();
  auto incidence = [&](const PointCloud& c, Eigen::Index i) {
    const Eigen::Vector3d d = (clean_of(c, i) - o).normalized();
    return std::acos(std::abs(d.z())) * 180.0 / M_PI;
  };
  std::int64_t expect = 0, ambiguous = 0, above = 0;
  for (Eigen::Index i = 0; i < all.cloud.size(); ++i) {
    const double a = incidence(all.cloud, i);
    if (std::abs(a - limit) < 1e-3) {
      ++ambiguous;
    } else if (a < limit) {
      ++expect;
    } else {
      ++above;
    }
  }
  ASSERT_GT(
      above,
      1000);  // the test really drops something << " " << ambiguous << " " << all.cloud.size();
  ASSERT_GT(expect, 1000);
  EXPECT_GE(kept.cloud.size(), expect);
  EXPECT_LE(kept.cloud.size(), expect + ambiguous);
  for (Eigen::Index i = 0; i < kept.cloud.size(); ++i)
    ASSERT_LE(incidence(kept.cloud, i), limit + 1e-3);
  EXPECT_EQ(kept.record["counts"]["dropped_grazing"].get<std::int64_t>(),
            all.cloud.size() - kept.cloud.size());
}

TEST(Scanner, MixedPixelsLieBetweenSurfacesOnlyWithSubRays) {
  // A small square in front of a large one: beams straddling its edge mix both ranges.
  const TriangleMesh m = squares({{0.5f, 0.4f}, {0.0f, 1.0f}});
  ScannerParams p = small(1, 96);
  p.poses = "0 0 0.5";
  p.fov_deg = 50;
  auto between = [](const PointCloud& c) {
    int n = 0;
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      const float z = c.positions(2, i);
      n += z > 0.01f && z < 0.49f;
    }
    return n;
  };
  RunContext ctx(2);
  EXPECT_EQ(between(scan(m, p, ctx).cloud), 0);
  p.sub_rays = 8;
  p.beam_divergence_deg = 3.0;
  const Scan s = scan(m, p, ctx);
  EXPECT_GT(between(s.cloud), 10);
  EXPECT_GT(s.record["counts"]["mixed_pixels"].get<int>(), 10);
  for (Eigen::Index i = 0; i < s.cloud.size(); ++i)
    ASSERT_EQ(s.cloud.properties.at("outlier")[i], 0.0f);
}

TEST(Scanner, FlyingPixelsStayOnTheirRayBehindTheSurface) {
  const TriangleMesh m = icosphere(3);
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(2, 64);
  p.flying_pixel_prob = 1.0;
  p.flying_spread = 0.1;
  RunContext ctx(4);
  const Scan s = scan(m, p, ctx);
  const PointCloud& c = s.cloud;
  int flying = 0;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d q = clean_of(c, i);
    const Eigen::Vector3d o = c.sensor_origins.col(c.scan_ids[i]).cast<double>();
    const Eigen::Vector3d pp = c.positions.col(i).cast<double>();
    if (c.properties.at("outlier")[i] == 0.0f) {
      ASSERT_EQ(pp, q);
      continue;
    }
    ++flying;
    const double rq = (q - o).norm(), rp = (pp - o).norm();
    ASSERT_GE(rp, rq - 1e-5);
    ASSERT_LE(rp, rq + 0.1 * diag + 1e-5);
    ASSERT_LT(((pp - o) / rp - (q - o) / rq).norm(), 1e-5);  // on the same ray
  }
  EXPECT_GT(flying, 50);  // the silhouette ring of two 64 x 64 views
  EXPECT_EQ(s.record["counts"]["flying_pixels"].get<int>(), flying);
}

TEST(Scanner, RangeLimitsDropFarHits) {
  const TriangleMesh m = icosphere(3);
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(3, 64);
  p.range_max = 0.6;  // sensors at 1.0 diag; the sphere's front is at about 0.71 diag
  RunContext ctx(1);
  EXPECT_EQ(scan(m, p, ctx).cloud.size(), 0);
  p.range_max = 0.8;
  const Scan s = scan(m, p, ctx);
  ASSERT_GT(s.cloud.size(), 100);
  for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
    const Eigen::Vector3f o = s.cloud.sensor_origins.col(s.cloud.scan_ids[i]);
    ASSERT_LE((s.cloud.positions.col(i) - o).norm(), 0.8 * diag + 1e-5);
  }
}

TEST(Scanner, BitIdenticalFilesForOneAndTwoThreads) {
  const TriangleMesh m = icosphere(3);
  ScannerParams p = all_artifacts_params();
  p.resolution = 64;
  const test::TempDir tmp("scanner");
  const auto dir = tmp.path;
  std::string ply[2], json[2];
  for (int threads = 1; threads <= 2; ++threads) {
    RunContext ctx(42, threads);
    const auto f = dir / ("t" + std::to_string(threads) + ".ply");
    write_scan(scan(m, p, ctx), f);
    ply[threads - 1] = read_bytes(f);
    json[threads - 1] = read_bytes(sidecar_path(f));
  }
  ASSERT_GT(ply[0].size(), 10000u);
  EXPECT_TRUE(ply[0] == ply[1]);
  EXPECT_TRUE(json[0] == json[1]);
  RunContext other(43, 2);
  const auto f = dir / "seed43.ply";
  write_scan(scan(m, p, other), f);
  EXPECT_FALSE(read_bytes(f) == ply[0]);
  // The PLY holds every promised property.
  const PointCloud back = read_point_cloud(dir / "t1.ply");
  EXPECT_TRUE(back.has_scan_ids());
  EXPECT_EQ(back.sensor_origins.cols(), p.views);
  for (const char* prop : {"outlier", "clean_x", "clean_y", "clean_z"})
    EXPECT_TRUE(back.has_property(prop)) << prop;
  // The sidecar holds parameters, seed and per-scan poses and misalignments.
  const Json rec = Json::parse(json[0]);
  EXPECT_EQ(rec["seed"].get<int>(), 42);
  EXPECT_EQ(rec["params"], params_to_json(p));
  ASSERT_EQ(rec["scans"].size(), static_cast<std::size_t>(p.views));
  for (const Json& sc : rec["scans"]) {
    for (const char* key : {"sensor_origin", "registered_origin", "forward", "up", "misaligned"})
      EXPECT_TRUE(sc.contains(key)) << key;
    EXPECT_EQ(sc["misaligned"].get<bool>(), !sc["misalignment"].is_null());
  }
}

TEST(Scanner, BadInputGivesClearErrors) {
  RunContext ctx(1);
  const ScannerParams p = small(2, 16);
  EXPECT_THROW(scan(TriangleMesh{}, p, ctx), InputError);
  TriangleMesh nan = icosphere(0);
  nan.vertices(1, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(scan(nan, p, ctx), InputError);
  TriangleMesh flat = icosphere(0);
  for (Eigen::Index f = 0; f < flat.num_faces(); ++f)
    flat.faces.col(f) = Eigen::Vector3i(flat.faces(0, f), flat.faces(0, f), flat.faces(1, f));
  try {
    scan(flat, p, ctx);
    FAIL() << "all-degenerate mesh accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("degenerate"), std::string::npos);
  }
  // Single degenerate triangles are legal: counted in the record.
  TriangleMesh some = icosphere(1);
  some.faces.conservativeResize(3, some.num_faces() + 1);
  some.faces.col(some.num_faces() - 1) = Eigen::Vector3i(0, 0, 1);
  EXPECT_EQ(scan(some, p, ctx).record["mesh"]["degenerate_faces"].get<int>(), 1);

  ScannerParams zero = p;
  zero.views = 0;
  EXPECT_THROW(scan(icosphere(1), zero, ctx), ParamError);
  try {
    params_from_json<ScannerParams>(Json{{"views", 0}}, "cfg");
    FAIL();
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("cfg.views"), std::string::npos);
  }
  ScannerParams range = p;
  range.range_max = 0.2;
  EXPECT_THROW(scan(icosphere(1), range, ctx), ParamError);
  ScannerParams poses = p;
  poses.poses = "0 0 1";  // one pose for two views
  EXPECT_THROW(scan(icosphere(1), poses, ctx), ParamError);
  poses.poses = "0 0 1; 1 0 x";
  EXPECT_THROW(scan(icosphere(1), poses, ctx), ParamError);
  poses.poses = "0 0 1; 0 0 0";  // at the centre
  EXPECT_THROW(scan(icosphere(1), poses, ctx), ParamError);
  ScannerParams nanp = p;
  nanp.noise_sigma = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(scan(icosphere(1), nanp, ctx), ParamError);
}

TEST(ScannerPresets, EveryPresetCreatesByName) {
  const auto& reg = presets();
  std::vector<std::string> names;
  for (const auto& e : reg.entries())
    names.push_back(e.name);
  EXPECT_EQ(names, (std::vector<std::string>{"clean", "moderate", "scut_low", "scut_medium",
                                             "scut_high", "outliers_heavy", "photo_default",
                                             "photo_noisy", "photo_dense"}));
  const TriangleMesh m = icosphere(2);
  for (const auto& e : reg.entries()) {
    SCOPED_TRACE(e.name);
    EXPECT_FALSE(e.doc.empty());
    // The schema's defaults are the preset's values, and they validate.
    EXPECT_EQ(e.params.defaults(), e.fn.values);
    EXPECT_EQ(preset_values(e.name), e.fn.values);
    // The photogrammetric presets run COLMAP (PhotoScanner.* test them; photo_dense needs CUDA).
    if (e.fn.values.value("kind", std::string("range")) != "range") continue;
    ScannerParams p = params_from_json<ScannerParams>(e.fn.values, e.name);
    p.resolution = 32;  // keep the test fast
    RunContext ctx(9);
    const Scan s = scan(m, p, ctx);
    EXPECT_GT(s.cloud.size(), 100);
    EXPECT_EQ(s.record["params"]["views"].get<int>(), p.views);
  }
  EXPECT_EQ(reg.at("scut_medium").fn.values["noise_sigma"].get<double>(), 0.003);
  EXPECT_EQ(reg.at("scut_high").fn.values["misalign_fraction"].get<double>(), 0.5);
  EXPECT_THROW(preset_values("no_such_preset"), UnknownNameError);
}

TEST(ScannerPresets, PresetFilesAreValidatedWithFileAndKey) {
  const test::TempDir tmp("presets");
  const auto dir = tmp.path;
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  const auto good = write("good.json", R"({"doc": "x", "params": {"views": 3}})");
  EXPECT_EQ(preset_values(good.string())["views"].get<int>(), 3);
  const auto bare = write("bare.json", R"({"noise_sigma": 0.01})");
  EXPECT_EQ(load_preset_file(bare)["noise_sigma"].get<double>(), 0.01);
  const auto unknown = write("unknown.json", R"({"params": {"nosie_sigma": 0.01}})");
  try {
    load_preset_file(unknown);
    FAIL();
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("nosie_sigma"), std::string::npos);
  }
  const auto type = write("type.json", R"({"params": {"views": "many"}})");
  EXPECT_THROW(load_preset_file(type), ParamError);
  const auto broken = write("broken.json", R"({"params": )");
  EXPECT_THROW(load_preset_file(broken), IoError);
  EXPECT_THROW(load_preset_file(dir / "missing.json"), IoError);
}

TEST(ScannerThroughput, BareAndScannerCastTheSameRays) {
  ScannerParams p = all_artifacts_params();
  p.resolution = 32;
  p.views = 2;
  RunContext ctx(1);
  const ThroughputResult r = measure_throughput(uv_sphere(1000), p, 1, ctx);
  EXPECT_EQ(r.rays_per_run, 2 * 32 * 32 * 4);
  EXPECT_GT(r.points, 100);
  // The bare loop's hits give the scanner's returned beams pixel for pixel.
  EXPECT_GT(r.bare_beams_returned, 100);
  EXPECT_EQ(r.bare_beams_returned, r.scanner_beams_returned);
  EXPECT_EQ(r.scanner_seconds.size(), 1u);
  EXPECT_GT(r.ratio, 0.0);
  const TriangleMesh s = uv_sphere(1000);
  EXPECT_TRUE(s.is_closed_and_oriented());
  EXPECT_GT(s.signed_volume(), 0.0);
  EXPECT_NEAR(s.num_faces(), 1000, 100);
}

/// Sample moments of one displacement component, with the standard errors of the mean of x^2 and
/// x^4 estimated from the sample itself (the tolerances below are 5 of them).
struct Moments {
  double n = 0, s1 = 0, s2 = 0, s4 = 0, s8 = 0;
  void add(double x) {
    const double x2 = x * x, x4 = x2 * x2;
    n += 1;
    s1 += x;
    s2 += x2;
    s4 += x4;
    s8 += x4 * x4;
  }
  double mean() const { return s1 / n; }
  double m2() const { return s2 / n; }
  double m4() const { return s4 / n; }
  double se_mean() const { return std::sqrt(m2() / n); }
  double se_m2() const { return std::sqrt((m4() - m2() * m2()) / n); }
  double se_m4() const { return std::sqrt((s8 / n - m4() * m4()) / n); }
};

/// Checks mean 0, variance sigma^2 and kurtosis k (E x^4 / sigma^4) to 5 standard errors.
void expect_law(const Moments& m, double sigma, double k) {
  EXPECT_NEAR(m.mean(), 0.0, 5 * m.se_mean());
  EXPECT_NEAR(m.m2(), sigma * sigma, 5 * m.se_m2());
  EXPECT_NEAR(m.m4() / std::pow(sigma, 4), k, 5 * m.se_m4() / std::pow(sigma, 4) + 0.02 * k);
}

// Every family along the ray, along the normal and isotropic on the plane z = 0 seen from
// above: the displacement has the family's mean (0), std (sigma per displaced axis), kurtosis
// (gaussian 3, laplace 6, uniform 1.8, discrete 1/0.6 along a direction and 5 per axis
// isotropic) and support, and moves the point only where the direction says.
TEST(Scanner, NoiseFamiliesHaveTheStatedLawInEveryDirection) {
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(1, 256);
  p.poses = "0 0 0.6";
  p.fov_deg = 50;
  p.noise_sigma = 0.004;
  const double sigma = p.noise_sigma * diag;
  const std::map<std::string, double> kurtosis_1d = {
      {"gaussian", 3.0}, {"laplace", 6.0}, {"uniform", 1.8}, {"discrete", 1.0 / 0.6}};
  const std::map<std::string, double> kurtosis_3d = {
      {"gaussian", 3.0}, {"laplace", 6.0}, {"uniform", 1.8}, {"discrete", 5.0}};
  for (const char* family : {"gaussian", "laplace", "uniform", "discrete"}) {
    for (const char* direction : {"ray", "normal", "isotropic"}) {
      SCOPED_TRACE(std::string(family) + " " + direction);
      p.noise_family = family;
      p.noise_direction = direction;
      RunContext ctx(11);
      const Scan sc = scan(m, p, ctx);
      const PointCloud& c = sc.cloud;
      ASSERT_GT(c.size(), 40000);
      EXPECT_EQ(sc.record["noise"]["family"], family);
      EXPECT_EQ(sc.record["noise"]["direction"], direction);
      const Eigen::Vector3d o = c.sensor_origins.col(0).cast<double>();
      const std::string dir = direction;
      Moments along, axis[3];
      std::int64_t moved = 0, off_support = 0, two_axes = 0;
      const double tol = 1e-5 * diag;
      const double step = dir == "isotropic" ? std::sqrt(5.0) * sigma : sigma / std::sqrt(0.6);
      for (Eigen::Index i = 0; i < c.size(); ++i) {
        const Eigen::Vector3d q = clean_of(c, i);
        const Eigen::Vector3d e = c.positions.col(i).cast<double>() - q;
        if (dir == "ray") {
          const Eigen::Vector3d d = (q - o).normalized();
          ASSERT_LT((e - e.dot(d) * d).norm(), tol);  // along the ray only
          along.add(e.dot(d));
        } else if (dir == "normal") {
          ASSERT_LT(e.head<2>().norm(), tol);  // along the face normal (z) only
          along.add(e.z());
        } else {
          for (int k = 0; k < 3; ++k)
            axis[k].add(e[k]);
        }
        if (std::string(family) == "discrete") {
          const double len = e.norm();
          moved += len > tol;
          off_support += len > tol && std::abs(len - step) > 1e-4 * step + tol;
          two_axes += (e.cwiseAbs().array() > tol).count() > 1 && dir == "isotropic";
        }
      }
      if (dir == "isotropic") {
        for (int k = 0; k < 3; ++k) {
          SCOPED_TRACE(k);
          expect_law(axis[k], sigma, kurtosis_3d.at(family));
        }
      } else {
        expect_law(along, sigma, kurtosis_1d.at(family));
      }
      if (std::string(family) == "discrete") {
        // 60% move (PD-Flow's six slots of ten), by exactly one step, along one axis at most.
        const double n = static_cast<double>(c.size());
        EXPECT_NEAR(static_cast<double>(moved) / n, 0.6, 5 * std::sqrt(0.24 / n));
        EXPECT_EQ(off_support, 0);
        EXPECT_EQ(two_axes, 0);
      }
    }
  }
}

// The world-frame laws: anisotropic has covariance sigma^2 3C / trace C; unidirectional moves
// along world x only, with std sigma.
TEST(Scanner, AnisotropicAndUnidirectionalNoiseInTheWorldFrame) {
  const TriangleMesh m = squares({{0.0f, 1.0f}});
  const double diag = m.bbox().diagonal();
  ScannerParams p = small(1, 256);
  p.poses = "0 0 0.6";
  p.fov_deg = 50;
  p.noise_sigma = 0.004;
  p.noise_direction = "isotropic";
  const double sigma = p.noise_sigma * diag;
  {
    p.noise_family = "anisotropic";
    p.noise_covariance = "4 1 0; 1 2 -0.5; 0 -0.5 1";
    Eigen::Matrix3d cov;
    cov << 4, 1, 0, 1, 2, -0.5, 0, -0.5, 1;
    const Eigen::Matrix3d want = sigma * sigma * 3.0 / cov.trace() * cov;
    RunContext ctx(12);
    const Scan sc = scan(m, p, ctx);
    const PointCloud& c = sc.cloud;
    ASSERT_GT(c.size(), 40000);
    const double n = static_cast<double>(c.size());
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero(), sum2 = Eigen::Matrix3d::Zero();
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      const Eigen::Vector3d e = c.positions.col(i).cast<double>() - clean_of(c, i);
      const Eigen::Matrix3d outer = e * e.transpose();
      sum += outer;
      sum2 += outer.cwiseProduct(outer);
      mean += e;
    }
    const Eigen::Matrix3d got = sum / n;
    const Eigen::Matrix3d se = ((sum2 / n - got.cwiseProduct(got)) / n).cwiseSqrt();
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(mean[a] / n, 0.0, 5 * std::sqrt(got(a, a) / n));
      for (int b = 0; b < 3; ++b)
        EXPECT_NEAR(got(a, b), want(a, b), 5 * se(a, b)) << a << " " << b;
    }
    EXPECT_NEAR(got.trace() / 3.0, sigma * sigma, 0.03 * sigma * sigma);  // mean per-axis var
    const Json& unit = sc.record["noise"]["unit_covariance"];
    ASSERT_EQ(unit.size(), 9u);
    EXPECT_NEAR(unit[0].get<double>(), 12.0 / 7.0, 1e-12);
  }
  {
    p.noise_family = "unidirectional";
    p.noise_covariance.clear();
    RunContext ctx(13);
    const PointCloud c = scan(m, p, ctx).cloud;
    Moments x;
    for (Eigen::Index i = 0; i < c.size(); ++i) {
      const Eigen::Vector3d e = c.positions.col(i).cast<double>() - clean_of(c, i);
      ASSERT_LT(e.tail<2>().norm(), 1e-5 * diag);  // world x only
      x.add(e.x());
    }
    expect_law(x, sigma, 3.0);
  }
}

// The shorthands are the same law as their (family, direction): identical scans.
TEST(Scanner, NoiseModelShorthandsEqualTheirFamilyAndDirection) {
  const TriangleMesh m = icosphere(2);
  ScannerParams a = small(3, 48);
  a.noise_sigma = 0.01;
  ScannerParams b = a;
  a.noise_model = "normal_gauss";
  b.noise_direction = "normal";
  RunContext ca(5), cb(5);
  const Scan sa = scan(m, a, ca), sb = scan(m, b, cb);
  EXPECT_EQ(sa.cloud.positions, sb.cloud.positions);
  EXPECT_EQ(sa.record["noise"], sb.record["noise"]);
  a.noise_model = "ray_gauss";
  b.noise_direction = "ray";
  RunContext cc(5), cd(5);
  EXPECT_EQ(scan(m, a, cc).cloud.positions, scan(m, b, cd).cloud.positions);
  // ray_uniform's sigma is the amplitude: the uniform family at sigma / sqrt 3 has its std.
  a.noise_model = "ray_uniform";
  RunContext ce(5);
  const Scan su = scan(m, a, ce);
  EXPECT_EQ(su.record["noise"]["sigma_is"], "half_width");
  EXPECT_NEAR(su.record["noise"]["std_over_sigma"].get<double>(), 1.0 / std::sqrt(3.0), 1e-15);
}

// Bad noise parameters: one line naming the field.
TEST(Scanner, BadNoiseParametersNameTheField) {
  const TriangleMesh m = icosphere(1);
  auto message = [&](const Json& j) -> std::string {
    try {
      const ScannerParams p = params_from_json<ScannerParams>(j, "scanner");
      RunContext ctx(1);
      scan(m, p, ctx);
    } catch (const ParamError& e) {
      return e.what();
    }
    return "";
  };
  auto expect_names = [&](const Json& j, const std::string& field) {
    SCOPED_TRACE(j.dump());
    const std::string what = message(j);
    EXPECT_NE(what.find("scanner." + field), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  };
  const Json base = {{"views", 2}, {"resolution", 16}, {"noise_sigma", 0.01}};
  auto with = [&](Json extra) {
    Json j = base;
    j.update(extra);
    return j;
  };
  expect_names(with({{"noise_family", "cauchy"}}), "noise_family");
  expect_names(with({{"noise_direction", "sideways"}}), "noise_direction");
  expect_names(with({{"noise_family", "anisotropic"}, {"noise_direction", "isotropic"}}),
               "noise_covariance");  // missing
  expect_names(with({{"noise_family", "anisotropic"},
                     {"noise_direction", "isotropic"},
                     {"noise_covariance", "1 0.5 0 0 1 0 0 0 1"}}),
               "noise_covariance");  // not symmetric
  expect_names(with({{"noise_family", "anisotropic"},
                     {"noise_direction", "isotropic"},
                     {"noise_covariance", "1 2 0 2 1 0 0 0 1"}}),
               "noise_covariance");  // indefinite
  expect_names(with({{"noise_family", "anisotropic"},
                     {"noise_direction", "isotropic"},
                     {"noise_covariance", "1 0 0 0 1 0 0 0"}}),
               "noise_covariance");  // 8 numbers
  expect_names(with({{"noise_family", "anisotropic"}, {"noise_covariance", "1 0 0 0 1 0 0 0 1"}}),
               "noise_direction");  // a world-frame law along the ray
  expect_names(with({{"noise_family", "unidirectional"}, {"noise_direction", "normal"}}),
               "noise_direction");
  expect_names(with({{"noise_covariance", "1 0 0 0 1 0 0 0 1"}}), "noise_covariance");
  expect_names(with({{"noise_model", "ray_uniform"}, {"noise_family", "laplace"}}), "noise_model");
  expect_names(with({{"noise_model", "ray_laplace"}}), "noise_model");
}

/// A closed cube of edge 1 at the origin, 2 x 2 cells per face.
TriangleMesh unit_cube() {
  CubeParams c;
  c.size = 1.0;
  c.resolution = 2;
  return make_cube(c);
}

// Surface samples: the exact count, on the mesh without noise, the noise std the stated share
// of the bounding sphere's radius, along the face normal when asked, repeatable bit for bit at
// any thread count, and another sample set for another seed.
TEST(ScannerSurfaceSamples, CountOnTheMeshNoiseShareAndDeterminism) {
  const TriangleMesh m = unit_cube();
  const double radius = std::sqrt(3.0) / 2.0;  // ScoreDenoise's unit-sphere scale of the cube
  ScannerParams p;
  p.kind = "surface_samples";
  p.points = 3000;
  p.noise_direction = "isotropic";
  {
    RunContext ctx(3);
    const Scan s = scan(m, p, ctx);
    ASSERT_EQ(s.cloud.size(), 3000);
    EXPECT_EQ(s.cloud.sensor_origins.cols(), 0);
    EXPECT_FALSE(s.cloud.has_scan_ids());
    EXPECT_NEAR(s.record["mesh"]["sphere_radius"].get<double>(), radius, 1e-6);
    for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
      ASSERT_LT(mesh_distance(m, s.cloud.positions.col(i).cast<double>()), 1e-6) << i;
      ASSERT_EQ(clean_of(s.cloud, i), s.cloud.positions.col(i).cast<double>());
    }
    // Poisson-disk: no two samples much closer than the mean spacing (uniform sampling of 3000
    // points on area 6 would give pairs about 100 times closer).
    double nearest = std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
      for (Eigen::Index j = i + 1; j < s.cloud.size(); ++j)
        nearest = std::min(
            nearest,
            static_cast<double>((s.cloud.positions.col(i) - s.cloud.positions.col(j)).norm()));
    }
    EXPECT_GT(nearest, 0.2 * std::sqrt(6.0 / 3000.0));
  }
  p.points = 10000;
  p.noise_sigma = 0.02;
  p.noise_scale = "sphere_radius";
  for (const char* family : {"gaussian", "laplace"}) {
    SCOPED_TRACE(family);
    p.noise_family = family;
    RunContext ctx(4);
    const Scan s = scan(m, p, ctx);
    EXPECT_NEAR(s.record["noise"]["sigma"].get<double>(), 0.02 * radius, 1e-8);
    Moments axis[3];
    for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
      const Eigen::Vector3d e = (s.cloud.positions.col(i).cast<double>() - clean_of(s.cloud, i));
      for (int k = 0; k < 3; ++k)
        axis[k].add(e[k] / radius);  // in the unit-sphere frame
    }
    for (int k = 0; k < 3; ++k)
      expect_law(axis[k], 0.02, std::string(family) == "gaussian" ? 3.0 : 6.0);
  }
  // Along the face normal: the cube's normals are axes, so one component moves.
  p.noise_family = "gaussian";
  p.noise_direction = "normal";
  p.points = 5000;
  {
    RunContext ctx(5);
    const Scan s = scan(m, p, ctx);
    Moments along;
    for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
      const Eigen::Vector3d e = s.cloud.positions.col(i).cast<double>() - clean_of(s.cloud, i);
      ASSERT_LE((e.cwiseAbs().array() > 1e-6).count(), 1) << e.transpose();
      along.add(e.cwiseAbs().maxCoeff() * (e.sum() < 0 ? -1.0 : 1.0) / radius);
    }
    EXPECT_NEAR(std::sqrt(along.m2()), 0.02, 5 * along.se_m2() / (2 * 0.02));
  }
  // Bit for bit at 1 and 2 threads; another seed, other samples.
  p.noise_direction = "isotropic";
  const test::TempDir tmp("surface_samples");
  auto write = [&](std::uint64_t seed, int threads, const std::string& name) {
    RunContext ctx(seed, threads);
    write_scan(scan(m, p, ctx), tmp.path / name);
    return read_bytes(tmp.path / name);
  };
  const std::string one = write(7, 1, "a.ply");
  EXPECT_EQ(one, write(7, 2, "b.ply"));
  EXPECT_EQ(one, write(7, 1, "c.ply"));
  EXPECT_NE(one, write(8, 1, "d.ply"));
  p.noise_sigma = 0;
  RunContext c7(7), c8(8);
  EXPECT_NE(scan(m, p, c7).cloud.positions, scan(m, p, c8).cloud.positions);
}

TEST(ScannerSurfaceSamples, BadParametersNameTheField) {
  const TriangleMesh m = unit_cube();
  auto expect_names = [&](Json j, const std::string& field) {
    j["kind"] = "surface_samples";
    SCOPED_TRACE(j.dump());
    try {
      const ScannerParams p = params_from_json<ScannerParams>(j, "scanner");
      RunContext ctx(1);
      scan(m, p, ctx);
      FAIL() << "accepted";
    } catch (const ParamError& e) {
      EXPECT_NE(std::string(e.what()).find("scanner." + field), std::string::npos) << e.what();
    }
  };
  expect_names({{"noise_direction", "ray"}}, "noise_direction");  // no rays
  expect_names({{"noise_direction", "isotropic"}, {"points", 0}}, "points");
  expect_names({{"noise_direction", "isotropic"}, {"noise_scale", "bbox"}}, "noise_scale");
  expect_names({{"noise_direction", "isotropic"}, {"noise_range_slope", 0.1}}, "noise_range_slope");
  expect_names({{"noise_model", "ray_gauss"}}, "noise_model");
}

}  // namespace
}  // namespace scanbench::scanner
