// The photogrammetric scanner's SIFT matching (scanner-sim/src/sift_match.h): equal to a plain
// transcription of COLMAP 3.8's brute-force matcher (FindBestMatchesBruteForce, src/feature/sift.cc)
// for every block size, with and without cross-checking; the ratio test, the distance bound and the
// cross-check on hand-made descriptors; the database reader on a hand-made SQLite file.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "sift_match.h"
#include "temp_dir.h"

namespace scanbench::scanner::detail {
namespace {

namespace fs = std::filesystem;

// COLMAP 3.8, FindBestMatchesOneWayBruteForce, transcribed on a row-major integer matrix.
std::vector<int> colmap_one_way(const std::vector<std::vector<int>>& dists, float max_ratio,
                                float max_distance) {
  const float kDistNorm = 1.0f / (512.0f * 512.0f);
  std::vector<int> matches(dists.size(), -1);
  for (std::size_t i1 = 0; i1 < dists.size(); ++i1) {
    int best_i2 = -1, best_dist = 0, second_best_dist = 0;
    for (std::size_t i2 = 0; i2 < dists[i1].size(); ++i2) {
      const int dist = dists[i1][i2];
      if (dist > best_dist) {
        best_i2 = static_cast<int>(i2);
        second_best_dist = best_dist;
        best_dist = dist;
      } else if (dist > second_best_dist) {
        second_best_dist = dist;
      }
    }
    if (best_i2 == -1) continue;
    const float best_dist_normed = std::acos(std::min(kDistNorm * best_dist, 1.0f));
    if (best_dist_normed > max_distance) continue;
    const float second_best_dist_normed = std::acos(std::min(kDistNorm * second_best_dist, 1.0f));
    if (best_dist_normed >= max_ratio * second_best_dist_normed) continue;
    matches[i1] = best_i2;
  }
  return matches;
}

// COLMAP 3.8, FindBestMatchesBruteForce with ComputeSiftDistanceMatrix (no guided filter).
std::vector<FeatureMatch> colmap_brute_force(const SiftDescriptors& d1, const SiftDescriptors& d2,
                                             const SiftMatchOptions& o) {
  std::vector<std::vector<int>> d12(static_cast<std::size_t>(d1.rows()),
                                    std::vector<int>(static_cast<std::size_t>(d2.rows())));
  std::vector<std::vector<int>> d21(static_cast<std::size_t>(d2.rows()),
                                    std::vector<int>(static_cast<std::size_t>(d1.rows())));
  for (Eigen::Index i = 0; i < d1.rows(); ++i)
    for (Eigen::Index j = 0; j < d2.rows(); ++j) {
      int dot = 0;
      for (int k = 0; k < 128; ++k)
        dot += int{d1(i, k)} * int{d2(j, k)};
      d12[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = dot;
      d21[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)] = dot;
    }
  const auto r = static_cast<float>(o.max_ratio), m = static_cast<float>(o.max_distance);
  const std::vector<int> m12 = colmap_one_way(d12, r, m);
  const std::vector<int> m21 = colmap_one_way(d21, r, m);
  std::vector<FeatureMatch> out;
  for (std::size_t i1 = 0; i1 < m12.size(); ++i1) {
    if (m12[i1] == -1) continue;
    if (o.cross_check && m21[static_cast<std::size_t>(m12[i1])] != static_cast<int>(i1)) continue;
    out.push_back({static_cast<std::uint32_t>(i1), static_cast<std::uint32_t>(m12[i1])});
  }
  return out;
}

// A SIFT-like descriptor as COLMAP stores one: a unit vector scaled by 512, rounded, clamped to 255.
Eigen::Matrix<std::uint8_t, 1, 128> quantise(const Eigen::Matrix<double, 1, 128>& v) {
  const Eigen::Matrix<double, 1, 128> u = v.cwiseAbs().normalized() * 512.0;
  Eigen::Matrix<std::uint8_t, 1, 128> q;
  for (int k = 0; k < 128; ++k)
    q[k] = static_cast<std::uint8_t>(std::min(255.0, std::round(u[k])));
  return q;
}

// Image 2 holds noisy copies of 150 of image 1's 300 features (reversed order) and 100 others;
// a few exact duplicates make ties.
std::pair<SiftDescriptors, SiftDescriptors> two_images(std::uint64_t seed) {
  Rng rng(seed);
  auto draw = [&] {
    Eigen::Matrix<double, 1, 128> v;
    for (int k = 0; k < 128; ++k)
      v[k] = rng.normal();
    return v;
  };
  std::vector<Eigen::Matrix<double, 1, 128>> base;
  SiftDescriptors d1(300, 128), d2(250, 128);
  for (int i = 0; i < 300; ++i) {
    base.push_back(draw());
    d1.row(i) = quantise(base.back());
  }
  for (int j = 0; j < 150; ++j)
    d2.row(j) = quantise(base[static_cast<std::size_t>(299 - 2 * j)] + 0.3 * draw());
  for (int j = 150; j < 250; ++j)
    d2.row(j) = quantise(draw());
  d2.row(200) = d2.row(10);  // a tie for image 1's feature 279
  d1.row(1) = d1.row(0);     // a tie seen from image 2
  return {d1, d2};
}

TEST(SiftMatch, EqualsColmapBruteForceForEveryBlockSize) {
  for (std::uint64_t seed : {1u, 2u}) {
    const auto [d1, d2] = two_images(seed);
    for (const bool cross : {true, false}) {
      SiftMatchOptions o;
      o.cross_check = cross;
      const std::vector<FeatureMatch> want = colmap_brute_force(d1, d2, o);
      ASSERT_GT(want.size(), 50u) << "the case should match many features";
      ASSERT_LT(want.size(), 150u) << "the ratio test should reject some";
      for (const Eigen::Index block : {1, 7, 64, 512})
        EXPECT_EQ(match_sift(d1, d2, o, block), want)
            << "seed " << seed << " cross_check " << cross << " block " << block;
    }
  }
}

SiftDescriptors rows(std::initializer_list<std::vector<std::uint8_t>> r) {
  SiftDescriptors d = SiftDescriptors::Zero(static_cast<Eigen::Index>(r.size()), 128);
  Eigen::Index i = 0;
  for (const auto& v : r) {
    for (std::size_t k = 0; k < v.size(); ++k)
      d(i, static_cast<Eigen::Index>(k)) = v[k];
    ++i;
  }
  return d;
}

TEST(SiftMatch, RatioTestDistanceBoundAndCrossCheckByHand) {
  // |a|^2 = 260100: distance acos(260100 / 512^2) = 0.125 rad to itself.
  const std::vector<std::uint8_t> a{255, 255, 255, 255};
  // a.a' = 246075: distance 0.352 rad. a.b = 195075: distance 0.732 rad.
  const std::vector<std::uint8_t> a2{255, 255, 255, 200};
  const std::vector<std::uint8_t> b{255, 255, 255, 0, 255};
  const std::vector<std::uint8_t> far{0, 0, 0, 0, 0, 255, 255, 255, 255};
  SiftMatchOptions o;
  using M = std::vector<FeatureMatch>;
  EXPECT_EQ(match_sift(rows({a}), rows({a}), o), (M{{0, 0}}));
  // A tie for the best fails the ratio test (distance >= 0.8 x an equal distance).
  EXPECT_EQ(match_sift(rows({a}), rows({far, a, a}), o), M{});
  // No similarity at all: no match.
  EXPECT_EQ(match_sift(rows({a}), rows({far}), o), M{});
  // 0.732 rad is beyond max_distance 0.7, within 0.75.
  EXPECT_EQ(match_sift(rows({a}), rows({b}), o), M{});
  o.max_distance = 0.75;
  EXPECT_EQ(match_sift(rows({a}), rows({b}), o), (M{{0, 0}}));
  o.max_distance = 0.7;
  // Both of image 1's features pick a; a picks feature 0 back (0.125 < 0.8 x 0.352), so the
  // cross-check drops (1, 0).
  EXPECT_EQ(match_sift(rows({a, a2}), rows({a}), o), (M{{0, 0}}));
  o.cross_check = false;
  EXPECT_EQ(match_sift(rows({a, a2}), rows({a}), o), (M{{0, 0}, {1, 0}}));
  // Empty images.
  EXPECT_EQ(match_sift(rows({}), rows({a}), o), M{});
  EXPECT_EQ(match_sift(rows({a}), rows({}), o), M{});
}

// A database with COLMAP's two tables (the columns scanbench reads).
fs::path make_db(const fs::path& p, const std::string& inserts) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(p.string().c_str(), &db), SQLITE_OK);
  const std::string sql =
      "CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT, camera_id INTEGER);"
      "CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY, rows INTEGER, cols INTEGER, "
      "data BLOB);" +
      inserts;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
  return p;
}

TEST(SiftMatch, DatabaseReaderReadsRowsAndNamesTheBadImage) {
  // Image 2's two rows are bytes 0..255 (row-major); image 1 has no descriptors row.
  std::string hex;
  for (int i = 0; i < 256; ++i)
    hex += fmt::format("{:02X}", i);
  const test::TempDir tmp("sift");
  const fs::path good = make_db(tmp / "good.db",
                                "INSERT INTO images VALUES (2, 'b.png', 1), (1, 'a.png', 1);"
                                "INSERT INTO descriptors VALUES (2, 2, 128, X'" +
                                    hex + "');");
  const std::vector<DatabaseImage> im = read_database_descriptors(good);
  ASSERT_EQ(im.size(), 2u);
  EXPECT_EQ(im[0].id, 1u);
  EXPECT_EQ(im[0].name, "a.png");
  EXPECT_EQ(im[0].descriptors.rows(), 0);
  EXPECT_EQ(im[1].name, "b.png");
  ASSERT_EQ(im[1].descriptors.rows(), 2);
  EXPECT_EQ(im[1].descriptors(0, 5), 5);
  EXPECT_EQ(im[1].descriptors(1, 0), 128);
  EXPECT_EQ(im[1].descriptors(1, 127), 255);
  fs::remove(good);

  const fs::path bad = make_db(tmp / "bad.db",
                               "INSERT INTO images VALUES (1, 'a.png', 1), (2, 'b.png', 1);"
                               "INSERT INTO descriptors VALUES (2, 3, 128, zeroblob(100));");
  try {
    (void)read_database_descriptors(bad);
    FAIL() << "expected an IoError";
  } catch (const IoError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(bad.string() + ": image 2 (b.png): descriptors blob has 100 bytes"),
              std::string::npos)
        << m;
  }
  fs::remove(bad);
  EXPECT_THROW((void)read_database_descriptors(bad), IoError);  // missing file
}

}  // namespace
}  // namespace scanbench::scanner::detail
