// Exact SIFT descriptor matching with COLMAP 3.8's definitions, and COLMAP's raw match list
// (sift_match.h).
#include "sift_match.h"

#include <fmt/format.h>
#include <sqlite3.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"

namespace scanbench::scanner::detail {

namespace {

namespace fs = std::filesystem;

/// NearestTwo and second-best similarity of one feature, scanned in increasing index order with
/// COLMAP's update rule (a later equal value becomes the second best, not the best).
struct NearestTwo {
  int index = -1;
  int best = 0;
  int second = 0;
  void add(int value, int i) {
    if (value > best) {
      index = i;
      second = best;
      best = value;
    } else if (value > second) {
      second = value;
    }
  }
};

/// COLMAP's acceptance of a best match (FindBestMatchesOneWayBruteForce), in its float arithmetic.
bool kept_by_ratio_test(const NearestTwo& b, float max_ratio, float max_distance) {
  if (b.index == -1) return false;
  // SIFT descriptor vectors are normalised to length 512.
  const float norm = 1.0f / (512.0f * 512.0f);
  const float best = std::acos(std::min(norm * static_cast<float>(b.best), 1.0f));
  if (best > max_distance) return false;
  const float second = std::acos(std::min(norm * static_cast<float>(b.second), 1.0f));
  return best < max_ratio * second;
}

}  // namespace

std::vector<FeatureMatch> match_sift(const SiftDescriptors& d1, const SiftDescriptors& d2,
                                     const SiftMatchOptions& o, Eigen::Index block_rows) {
  using RowMajorF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index n1 = d1.rows(), n2 = d2.rows();
  const RowMajorF a = d1.cast<float>();
  const Eigen::MatrixXf bt = d2.cast<float>().transpose();  // 128 x n2
  std::vector<NearestTwo> row(static_cast<std::size_t>(n1)), col(static_cast<std::size_t>(n2));
  RowMajorF s;
  block_rows = std::max<Eigen::Index>(block_rows, 1);
  for (Eigen::Index r0 = 0; r0 < n1; r0 += block_rows) {
    const Eigen::Index m = std::min(block_rows, n1 - r0);
    // Exact integers (sift_match.h), so the summation order of the product does not matter.
    s.noalias() = a.middleRows(r0, m) * bt;
    for (Eigen::Index i = 0; i < m; ++i) {
      NearestTwo& b = row[static_cast<std::size_t>(r0 + i)];
      for (Eigen::Index j = 0; j < n2; ++j) {
        const int v = static_cast<int>(s(i, j));
        b.add(v, static_cast<int>(j));
        // Rows arrive in increasing order, so each column sees image 1's features in order.
        col[static_cast<std::size_t>(j)].add(v, static_cast<int>(r0 + i));
      }
    }
  }
  const auto ratio = static_cast<float>(o.max_ratio);
  const auto dist = static_cast<float>(o.max_distance);
  std::vector<FeatureMatch> out;
  for (Eigen::Index i = 0; i < n1; ++i) {
    const NearestTwo& b = row[static_cast<std::size_t>(i)];
    if (!kept_by_ratio_test(b, ratio, dist)) continue;
    if (o.cross_check) {
      const NearestTwo& back = col[static_cast<std::size_t>(b.index)];
      if (!kept_by_ratio_test(back, ratio, dist) || back.index != i) continue;
    }
    out.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(b.index)});
  }
  return out;
}

std::vector<DatabaseImage> read_database_descriptors(const fs::path& db) {
  const std::string name = db.string();
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(name.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  const std::unique_ptr<sqlite3, int (*)(sqlite3*)> handle(raw, sqlite3_close);
  auto fail = [&](const std::string& what) {
    throw IoError(fmt::format("{}: {}: {}", name, what, sqlite3_errmsg(raw)));
  };
  if (rc != SQLITE_OK) fail("cannot open the COLMAP database");
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(raw,
                         "SELECT images.image_id, images.name, descriptors.rows, descriptors.cols, "
                         "descriptors.data FROM images LEFT JOIN descriptors ON "
                         "descriptors.image_id = images.image_id ORDER BY images.image_id",
                         -1, &st, nullptr) != SQLITE_OK)
    fail("cannot read tables images and descriptors");
  const std::unique_ptr<sqlite3_stmt, int (*)(sqlite3_stmt*)> stmt(st, sqlite3_finalize);
  std::vector<DatabaseImage> out;
  int step = 0;
  while ((step = sqlite3_step(st)) == SQLITE_ROW) {
    DatabaseImage im;
    im.id = static_cast<std::uint32_t>(sqlite3_column_int64(st, 0));
    const auto* text = sqlite3_column_text(st, 1);
    im.name = text ? reinterpret_cast<const char*>(text) : "";
    const std::int64_t rows = sqlite3_column_int64(st, 2), cols = sqlite3_column_int64(st, 3);
    const auto bytes = static_cast<std::int64_t>(sqlite3_column_bytes(st, 4));
    const std::string where = fmt::format("{}: image {} ({})", name, im.id, im.name);
    if (rows > 0 && cols != 128)
      throw IoError(fmt::format("{}: descriptors have {} columns, expected 128", where, cols));
    if (rows < 0 || bytes != rows * 128)
      throw IoError(fmt::format("{}: descriptors blob has {} bytes, expected {} rows x 128", where,
                                bytes, rows));
    im.descriptors.resize(rows, 128);
    if (rows > 0) std::memcpy(im.descriptors.data(), sqlite3_column_blob(st, 4), bytes);
    out.push_back(std::move(im));
  }
  if (step != SQLITE_DONE) fail("reading tables images and descriptors");
  return out;
}

MatchListStats write_match_list(const std::vector<DatabaseImage>& images, const SiftMatchOptions& o,
                                const fs::path& list) {
  std::vector<std::array<std::size_t, 2>> pairs;
  for (std::size_t i = 0; i < images.size(); ++i)
    for (std::size_t j = i + 1; j < images.size(); ++j)
      pairs.push_back({i, j});
  std::vector<std::vector<FeatureMatch>> matches(pairs.size());
  // One pair per task, each written to its own slot: no dependence on the thread count.
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
    matches[k] = match_sift(images[pairs[k][0]].descriptors, images[pairs[k][1]].descriptors, o);
  });
  std::ostringstream out;
  MatchListStats stats;
  stats.pairs = static_cast<int>(pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (matches[k].size() < static_cast<std::size_t>(std::max(o.min_num_matches, 1))) continue;
    ++stats.pairs_listed;
    stats.matches += static_cast<std::int64_t>(matches[k].size());
    out << images[pairs[k][0]].name << ' ' << images[pairs[k][1]].name << '\n';
    for (const FeatureMatch& m : matches[k])
      out << m[0] << ' ' << m[1] << '\n';
    out << '\n';
  }
  write_file_atomic(list, std::move(out).str());
  return stats;
}

}  // namespace scanbench::scanner::detail
