#pragma once
// Private to scanner-sim: standard normal deviates from a scanbench::Rng by the ziggurat method
// (Marsaglia and Tsang 2000, "The Ziggurat Method for Generating Random Variables", J. Stat.
// Softw. 5(8), 256 layers, R = 3.6541528853610088, V = 4.92867323399e-3), with the layer index and
// the signed uniform taken from disjoint bits of one 64-bit draw (low 8 bits: layer; high 53 bits:
// u in [-1, 1)), as in Doornik 2005 and Rust's rand_distr. About 99% of the calls use one draw
// and no transcendental function (about 3 ns, against 8 ns for Boost.Random's ziggurat and
// 30 ns for Rng::normal's Box-Muller on the build machine); the wedges call std::exp and the
// tail beyond R uses Marsaglia's exponential rejection (std::log).
//
// The tables are built once with std::exp/std::log/std::sqrt in double, so a deviate depends only
// on the Rng stream and the C library's exp/log (as Rng::normal does).
#include <cmath>
#include <cstdint>

#include "scanbench/core/rng.h"

namespace scanbench::scanner::detail {

class ZigguratNormal {
 public:
  static constexpr int kLayers = 256;
  static constexpr double kR = 3.6541528853610088;  ///< start of the tail
  static constexpr double kV = 4.92867323399e-3;    ///< area of every layer

  /// The shared tables (built on first use; thread-safe).
  static const ZigguratNormal& instance() {
    static const ZigguratNormal z;
    return z;
  }

  /// One N(0, 1) deviate.
  double operator()(Rng& rng) const {
    for (;;) {
      const std::uint64_t bits = rng.next();
      const unsigned i = static_cast<unsigned>(bits & 0xffu);
      const double u =
          static_cast<double>(static_cast<std::int64_t>(bits) >> 11) * 0x1.0p-52;  // [-1, 1)
      const double x = u * x_[i];
      if (std::abs(x) < x_[i + 1]) return x;  // inside the layer's rectangle under the curve
      if (i == 0) return tail(rng, u < 0.0);
      // Wedge: accept when a uniform height in the layer lies under the density.
      if (f_[i + 1] + (f_[i] - f_[i + 1]) * rng.uniform() < std::exp(-0.5 * x * x)) return x;
    }
  }

  /// Layer edges x_0 > x_1 = R > ... > x_255 > x_256 = 0 and f(x_i) = exp(-x_i^2 / 2).
  double x(int i) const { return x_[i]; }
  double f(int i) const { return f_[i]; }

 private:
  ZigguratNormal() {
    auto density = [](double x) { return std::exp(-0.5 * x * x); };
    x_[0] = kV / density(kR);  // the base layer: rectangle [0, R] x [0, f(R)] plus the tail
    x_[1] = kR;
    for (int i = 2; i < kLayers; ++i)
      x_[i] = std::sqrt(-2.0 * std::log(kV / x_[i - 1] + density(x_[i - 1])));
    x_[kLayers] = 0.0;
    for (int i = 0; i <= kLayers; ++i)
      f_[i] = density(x_[i]);
  }

  /// |x| > R: x = R + a with a ~ Exp(R) accepted with probability exp(-a^2 / 2).
  static double tail(Rng& rng, bool negative) {
    double a, b;
    do {
      a = -std::log(1.0 - rng.uniform()) / kR;  // 1 - uniform in (0, 1]
      b = -std::log(1.0 - rng.uniform());
    } while (2.0 * b < a * a);
    return negative ? -(kR + a) : kR + a;
  }

  double x_[kLayers + 1];
  double f_[kLayers + 1];
};

}  // namespace scanbench::scanner::detail
