#pragma once
// Private to scanner-sim: the photogrammetric scanner's SIFT descriptor matching (photo.cpp).
//
// Hand-written on purpose: COLMAP 3.8's own CPU matcher (exhaustive_matcher) is not repeatable.
// It searches FLANN's randomised kd-trees, whose random numbers come from the C library's shared
// rand() (reseeded by COLMAP's threads), so two runs on the same database give different matches
// for every pair, even on one thread (docs/scanner.md, Determinism). Here the nearest neighbours are
// exact (brute force), so the matches depend on the descriptors only; COLMAP then does only the
// geometric verification (`matches_importer --match_type raw`), which repeats.
//
// The definitions are COLMAP 3.8's (src/feature/sift.cc, FindBestMatchesOneWayBruteForce and
// FindBestMatchesBruteForce; defaults of SiftMatchingOptions): the similarity of two uint8
// descriptors (unit vectors scaled to length 512) is their integer dot product s; the distance is
// the angle acos(min(s / 512^2, 1)); a feature's best match is the other image's feature of largest
// s (the first one on ties), kept when its distance is at most max_distance and below max_ratio
// times the second best's (Lowe's ratio test; a tie for the best thus fails); with cross_check a
// pair is kept only when each feature is the other's kept best match.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace scanbench::scanner::detail {

/// SIFT descriptors as COLMAP stores them: one row of 128 bytes per feature.
using SiftDescriptors = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 128, Eigen::RowMajor>;

/// COLMAP 3.8's SiftMatchingOptions defaults.
struct SiftMatchOptions {
  double max_ratio = 0.8;
  double max_distance = 0.7;  ///< radians, on the unit descriptors
  bool cross_check = true;
  /// Pairs with fewer raw matches are not verified (COLMAP's min_num_inliers: its exhaustive
  /// matcher skips them too).
  int min_num_matches = 15;
};

/// One feature correspondence (feature indices in image 1 and image 2).
using FeatureMatch = std::array<std::uint32_t, 2>;

/// The matches of image 1's features in image 2, in increasing order of the first index. Exact:
/// the dot products are computed as a float matrix product, which is exact for uint8 descriptors
/// of length 128 (every partial sum is an integer below 128 * 255^2 < 2^24), in blocks of
/// `block_rows` rows of image 1; the result does not depend on the block size.
std::vector<FeatureMatch> match_sift(const SiftDescriptors& d1, const SiftDescriptors& d2,
                                     const SiftMatchOptions& o, Eigen::Index block_rows = 512);

/// One image of a COLMAP database with its SIFT descriptors.
struct DatabaseImage {
  std::uint32_t id = 0;
  std::string name;
  SiftDescriptors descriptors;
};

/// Every image of COLMAP's database.db (tables `images` and `descriptors`), by increasing id; an
/// image without a descriptors row has none. IoError("<db>: image <id> (<name>): <what>") for a
/// descriptors row that is not rows x 128 bytes; IoError naming the file when it cannot be read.
std::vector<DatabaseImage> read_database_descriptors(const std::filesystem::path& db);

/// What write_match_list matched.
struct MatchListStats {
  int pairs = 0;             ///< image pairs matched
  int pairs_listed = 0;      ///< with at least min_num_matches matches, written to the list
  std::int64_t matches = 0;  ///< matches written
};

/// Exhaustive matching of every image pair (i < j by id) in parallel over the pairs (the result
/// does not depend on the thread count), written as COLMAP's raw match list
/// (`matches_importer --match_type raw`): per listed pair a line "name1 name2", one line
/// "idx1 idx2" per match, then an empty line.
MatchListStats write_match_list(const std::vector<DatabaseImage>& images, const SiftMatchOptions& o,
                                const std::filesystem::path& list);

}  // namespace scanbench::scanner::detail
