#pragma once
// Positions are stored as float32 (PointCloud, TriangleMesh, GaussianMixture means). A file written
// in double or decimal text can hold coordinates far from the origin relative to the size of the
// data (survey and UTM coordinates near 1e6..1e7 m, a scan a few metres across): float32 keeps 24
// bits, so at 1e7 its spacing is 1 m and the shape is destroyed quietly. The readers feed every
// position through PositionPrecision and throw IoError instead when the rounding to float32 moves
// a coordinate by more than kMaxRelativeError of the data's bounding-box diagonal (the diagonal is
// the unit of every relative parameter, h and the *_rel metrics among them). Files written in
// float32 round-trip exactly and always pass.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "scanbench/core/errors.h"

namespace scanbench::io_detail {

class PositionPrecision {
 public:
  /// 1e-5 of the diagonal: a hundredth of the finest relative tolerance the metrics report.
  static constexpr double kMaxRelativeError = 1e-5;

  /// One coordinate (axis 0..2) as read in double; returns it rounded to float32.
  float add(int axis, double v, std::size_t row) {
    const auto f = static_cast<float>(v);
    const auto a = static_cast<std::size_t>(axis);
    lo_[a] = std::min(lo_[a], v);
    hi_[a] = std::max(hi_[a], v);
    const double err = std::abs(static_cast<double>(f) - v);
    if (err > err_) {
      err_ = err;
      worst_value_ = v;
      worst_row_ = row;
      worst_axis_ = axis;
    }
    return f;
  }

  /// Throws IoError("<name>: <what> <row>, <axis>: ...") when float32 loses more than allowed.
  void check(const std::string& name, const char* what) const {
    double diag2 = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      if (lo_[k] <= hi_[k]) diag2 += (hi_[k] - lo_[k]) * (hi_[k] - lo_[k]);
    }
    const double diag = std::sqrt(diag2);
    if (!(err_ > kMaxRelativeError * diag) || diag == 0.0) return;
    static constexpr std::array<const char*, 3> kAxis{"x", "y", "z"};
    throw IoError(fmt::format(
        "{}: {} {}, {}: coordinate {} is off by {:.2g} as float32, {:.1e} of the data's extent "
        "{:.6g} (more than {:g}): positions this far from the origin need a local origin; "
        "subtract one (e.g. {:.0f} {:.0f} {:.0f}) from the file",
        name, what, worst_row_, kAxis[static_cast<std::size_t>(worst_axis_)], worst_value_, err_,
        err_ / diag, diag, kMaxRelativeError, 0.5 * (lo_[0] + hi_[0]), 0.5 * (lo_[1] + hi_[1]),
        0.5 * (lo_[2] + hi_[2])));
  }

 private:
  std::array<double, 3> lo_{std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::infinity()};
  std::array<double, 3> hi_{-std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity()};
  double err_ = 0.0;
  double worst_value_ = 0.0;
  std::size_t worst_row_ = 0;
  int worst_axis_ = 0;
};

}  // namespace scanbench::io_detail
