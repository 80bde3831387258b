// scanbench::radix_sort against std::sort: (key, index) pairs and keys packed above an index.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "scanbench/core/radix_sort.h"
#include "scanbench/core/rng.h"

namespace scanbench {
namespace {

TEST(RadixSort, PairsEndInKeyThenIndexOrder) {
  Rng rng(3);
  for (const std::uint64_t range :
       {std::uint64_t{1}, std::uint64_t{37}, std::uint64_t{1} << 20, ~std::uint64_t{0}}) {
    // Below and above the size from which the passes run in parallel blocks.
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{5000},
                                std::size_t{40000}, std::size_t{300001}}) {
      std::vector<std::pair<std::uint64_t, Eigen::Index>> v(n);
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t r = rng.next();
        v[i] = {range == ~std::uint64_t{0} ? r : r % range, static_cast<Eigen::Index>(i)};
      }
      auto want = v;
      std::sort(want.begin(), want.end());
      radix_sort(v, [](const auto& e) { return e.first; });
      EXPECT_EQ(v, want) << "range " << range << " n " << n;
    }
  }
}

TEST(RadixSort, PackedKeysSortedByTheirHighBitsStably) {
  Rng rng(5);
  const int idx_bits = 19;
  for (const std::size_t n : {std::size_t{6000}, std::size_t{300000}}) {  // < 2^19
    std::vector<std::uint64_t> v(n);
    for (std::size_t i = 0; i < n; ++i)
      v[i] = (rng.next() % 977) << idx_bits | i;  // many equal codes: stability decides
    auto want = v;
    std::sort(want.begin(), want.end());  // (code, index): what a stable sort by code gives
    radix_sort(v, [&](std::uint64_t k) { return k >> idx_bits; });
    EXPECT_EQ(v, want) << "n " << n;
  }
}

// Morton codes: compact3 inverts spread3 on every 21-bit value tried; the code of (x, y, z)
// shifted right by 3 L is the code of (x, y, z) >> L (so the runs of equal code >> 3 L are the
// cells 2^L times wider); x has the highest bit of each triple, z the lowest.
TEST(RadixSort, MortonCodesNestTheCellsOfEverySide) {
  Rng rng(11);
  const auto code = [](std::uint64_t x, std::uint64_t y, std::uint64_t z) {
    return morton_spread3(x) << 2 | morton_spread3(y) << 1 | morton_spread3(z);
  };
  for (int t = 0; t < 20000; ++t) {
    const std::uint64_t x = rng.next() & 0x1fffff, y = rng.next() & 0x1fffff,
                        z = rng.next() & 0x1fffff;
    const std::uint64_t c = code(x, y, z);
    ASSERT_EQ(morton_compact3(c >> 2), x);
    ASSERT_EQ(morton_compact3(c >> 1), y);
    ASSERT_EQ(morton_compact3(c), z);
    for (int l = 1; l < 4; ++l)
      ASSERT_EQ(c >> (3 * l), code(x >> l, y >> l, z >> l)) << "level " << l;
  }
  EXPECT_LT(code(0, 1, 1), code(1, 0, 0));
  EXPECT_LT(code(0, 0, 1), code(0, 1, 0));
  EXPECT_EQ(code(0x1fffff, 0x1fffff, 0x1fffff), (std::uint64_t{1} << 63) - 1);
}

}  // namespace
}  // namespace scanbench
