#pragma once
// One stable least-significant-digit radix sort for the spatial orders of the project: the cell
// keys of the algorithms' neighbour grids and the Morton orders of CLOP's cells of particles and
// of the metrics' queries (morton_spread3).
//
// Hand-written on purpose: the standard library and TBB sort by comparison; at a million 64-bit
// keys of which only a few low bytes vary, a radix sort that skips the constant digits is
// several times faster than std::sort or tbb::parallel_sort, and being stable it gives a total
// order that depends on the keys alone (never on the thread count). TBB has no radix sort and
// its parallel_sort is not stable.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace scanbench {

namespace radix_detail {

/// Elements per block of the parallel passes: at least 4096, at most about 256 blocks; a function
/// of n alone, so the blocks (and the result, which a stable sort fixes anyway) never depend on
/// the thread count.
inline std::size_t block_size(std::size_t n) {
  return std::max<std::size_t>(4096, n / 256 + 1);
}

/// Below this many elements one thread sorts (the tasks would cost more than they save).
inline constexpr std::size_t kParallelFrom = std::size_t{1} << 18;

}  // namespace radix_detail

/// Spreads the low 21 bits of v to every third bit: x, y, z spread and shifted by 2, 1, 0 and
/// or-ed give the Morton code of a cell (radix-sorted, the cells of side 2^L are the runs of
/// equal code >> 3L).
inline std::uint64_t morton_spread3(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

/// The inverse of morton_spread3: every third bit of v from bit 0, gathered into 21 bits.
inline std::uint64_t morton_compact3(std::uint64_t v) {
  v &= 0x1249249249249249ULL;
  v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
  v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
  v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
  v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
  v = (v ^ (v >> 32)) & 0x1fffffULL;
  return v;
}

/// Sorts v stably by key(element) (a std::uint64_t), 8-bit digits from the lowest; digits in
/// which no two keys differ are skipped (no pass, no histogram). Elements with equal keys keep
/// their input order, so elements entered in index order end sorted by (key, index).
/// From kParallelFrom elements the passes run TBB-parallel over fixed blocks: each block counts
/// its digits, the blocks' offsets follow in (digit, block) order, and each block scatters its
/// elements in order, which keeps the sort stable (the result is that of one thread).
template <class T, class Key>
void radix_sort(std::vector<T>& v, Key key) {
  const std::size_t n = v.size();
  if (n < 2) return;
  const std::size_t block = radix_detail::block_size(n);
  const std::size_t blocks = (n + block - 1) / block;
  const bool parallel = n >= radix_detail::kParallelFrom;
  const auto over_blocks = [&](auto&& f) {
    if (parallel)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const auto& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b)
          f(b, b * block, std::min(n, (b + 1) * block));
      });
    else
      f(std::size_t{0}, std::size_t{0}, n);
  };
  // The bits that differ between keys: only their digits need a pass (and a histogram).
  std::vector<std::uint64_t> any(parallel ? blocks : 1, 0), all(parallel ? blocks : 1, ~0ull);
  over_blocks([&](std::size_t b, std::size_t from, std::size_t to) {
    std::uint64_t a = 0, l = ~std::uint64_t{0};
    for (std::size_t i = from; i < to; ++i) {
      const std::uint64_t k = key(v[i]);
      a |= k;
      l &= k;
    }
    any[b] = a;
    all[b] = l;
  });
  std::uint64_t any_bits = 0, all_bits = ~std::uint64_t{0};
  for (std::size_t b = 0; b < any.size(); ++b) {
    any_bits |= any[b];
    all_bits &= all[b];
  }
  const std::uint64_t varying = any_bits ^ all_bits;
  std::array<std::size_t, 8> digits{};
  std::size_t nd = 0;
  for (std::size_t d = 0; d < 8; ++d)
    if ((varying >> (8 * d)) & 0xffu) digits[nd++] = d;
  if (nd == 0) return;
  std::vector<T> tmp(n);
  if (!parallel) {  // one histogram pass for every digit, then one scatter pass per digit
    std::vector<std::array<std::size_t, 256>> count(nd);
    for (auto& c : count)
      c.fill(0);
    for (const T& e : v) {
      const std::uint64_t k = key(e);
      for (std::size_t i = 0; i < nd; ++i)
        ++count[i][(k >> (8 * digits[i])) & 0xffu];
    }
    for (std::size_t i = 0; i < nd; ++i) {
      const std::size_t shift = 8 * digits[i];
      auto& c = count[i];
      std::size_t sum = 0;
      for (std::size_t& x : c) {
        const std::size_t k = x;
        x = sum;
        sum += k;
      }
      for (const T& e : v)
        tmp[c[(key(e) >> shift) & 0xffu]++] = e;
      v.swap(tmp);
    }
    return;
  }
  std::vector<std::array<std::size_t, 256>> count(blocks);
  for (std::size_t i = 0; i < nd; ++i) {
    const std::size_t shift = 8 * digits[i];
    over_blocks([&](std::size_t b, std::size_t from, std::size_t to) {
      auto& c = count[b];
      c.fill(0);
      for (std::size_t k = from; k < to; ++k)
        ++c[(key(v[k]) >> shift) & 0xffu];
    });
    std::size_t sum = 0;
    for (std::size_t d = 0; d < 256; ++d)
      for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t k = count[b][d];
        count[b][d] = sum;
        sum += k;
      }
    over_blocks([&](std::size_t b, std::size_t from, std::size_t to) {
      auto& c = count[b];
      for (std::size_t k = from; k < to; ++k)
        tmp[c[(key(v[k]) >> shift) & 0xffu]++] = v[k];
    });
    v.swap(tmp);
  }
}

}  // namespace scanbench
