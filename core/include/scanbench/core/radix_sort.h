#pragma once
// One stable least-significant-digit radix sort for the spatial orders of the project: the cell
// keys of the algorithms' neighbour grids and the Morton orders of the metrics' queries.
//
// Hand-written on purpose: the standard library and TBB sort by comparison; at a million 64-bit
// keys of which only a few low bytes vary, a radix sort that skips the constant digits is
// several times faster than std::sort or tbb::parallel_sort, and being stable it gives a total
// order that depends on the keys alone (never on the thread count).
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace scanbench {

/// Sorts v stably by key(element) (a std::uint64_t), 8-bit digits from the lowest; digits in
/// which no two keys differ are skipped (no pass, no histogram). Elements with equal keys keep
/// their input order, so elements entered in index order end sorted by (key, index).
template <class T, class Key>
void radix_sort(std::vector<T>& v, Key key) {
  const std::size_t n = v.size();
  if (n < 2) return;
  // The bits that differ between keys: only their digits need a pass (and a histogram).
  std::uint64_t any = 0, all = ~std::uint64_t{0};
  for (const T& e : v) {
    const std::uint64_t k = key(e);
    any |= k;
    all &= k;
  }
  const std::uint64_t varying = any ^ all;
  std::array<std::size_t, 8> digits{};
  std::size_t nd = 0;
  for (std::size_t d = 0; d < 8; ++d)
    if ((varying >> (8 * d)) & 0xffu) digits[nd++] = d;
  if (nd == 0) return;
  std::vector<std::array<std::size_t, 256>> count(nd);
  for (auto& c : count)
    c.fill(0);
  for (const T& e : v) {
    const std::uint64_t k = key(e);
    for (std::size_t i = 0; i < nd; ++i)
      ++count[i][(k >> (8 * digits[i])) & 0xffu];
  }
  std::vector<T> tmp(n);
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
}

}  // namespace scanbench
