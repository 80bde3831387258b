#pragma once
// Positions are stored as float32 (PointCloud, TriangleMesh, GaussianMixture means). A file written
// in double or decimal text can hold coordinates far from the origin relative to the size of the
// data (survey and UTM coordinates near 1e6..1e7 m, a scan a few metres across): float32 keeps 24
// bits, so at 1e7 its spacing is 1 m and the shape is destroyed quietly. The readers feed every
// position through PositionPrecision. When the rounding to float32 moves a coordinate by more than
// kMaxRelativeError of the data's bounding-box diagonal (the diagonal is the unit of every relative
// parameter, h and the *_rel metrics among them), the data gets a local origin (local_origin()):
// the reader stores float(x - origin) and records the origin on what it returns (stage_data.h).
// Otherwise the origin stays zero and the floats are those of the file, bit for bit. Files written
// in float32 round-trip exactly and never get an origin. A file may state its origin (our writers
// put `comment scanbench_origin X Y Z` in a PLY); the reader then uses it, and refuses the file
// only when even that origin leaves more than the allowed error (an origin far from the data).
#include <fmt/format.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

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

  /// Bounding-box diagonal of the values added (0 for none).
  double diagonal() const {
    double diag2 = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      if (lo_[k] <= hi_[k]) diag2 += (hi_[k] - lo_[k]) * (hi_[k] - lo_[k]);
    }
    return std::sqrt(diag2);
  }

  /// True when the values added fit float32 within the allowed error (see above).
  bool fits() const {
    const double diag = diagonal();
    return !(err_ > kMaxRelativeError * diag) || diag == 0.0;
  }

  /// The local origin for the values added: the bounding-box centre rounded to a multiple of 2^k,
  /// 2^k the largest power of two not above the diagonal. Local coordinates then lie within about
  /// one diagonal of zero (float32 error below 1e-7 of the diagonal), and data translated by a
  /// multiple of 2^k (e.g. an integer vector for data up to ~1 across, any multiple of 64 for
  /// data up to 64 across) gets the translation back as its origin, so its local floats are the
  /// untranslated ones bit for bit.
  Eigen::Vector3d local_origin() const {
    const double diag = diagonal();
    if (!(diag > 0.0) || !std::isfinite(diag)) return Eigen::Vector3d::Zero();
    int e = 0;
    (void)std::frexp(diag, &e);  // diag = m 2^e, m in [0.5, 1)
    const double step = std::ldexp(1.0, e - 1);
    Eigen::Vector3d o;
    for (std::size_t k = 0; k < 3; ++k) {
      const double c = lo_[k] <= hi_[k] ? 0.5 * lo_[k] + 0.5 * hi_[k] : 0.0;
      o[static_cast<Eigen::Index>(k)] = std::nearbyint(c / step) * step;
    }
    return o;
  }

  /// Throws IoError("<name>: <what> <row>, <axis>: ...") when float32 loses more than allowed.
  void check(const std::string& name, const char* what) const {
    const double diag = diagonal();
    if (fits()) return;
    static constexpr std::array<const char*, 3> kAxis{"x", "y", "z"};
    throw IoError(fmt::format(
        "{}: {} {}, {}: coordinate {} is off by {:.2g} as float32, {:.1e} of the data's extent "
        "{:.6g} (more than {:g}): the local origin the file states is too far from its data; "
        "remove the scanbench_origin comment (e.g. {:.0f} {:.0f} {:.0f} would do)",
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

/// The positions of a reader, from their values in double (`get(axis, i)`, i < n), with the local
/// origin chosen as described above: `out` holds float(get - origin) and the origin is returned.
/// `stated` is the origin the file states, if any. Throws IoError (check()) only when a stated
/// origin leaves more than the allowed error.
template <class Get>
Eigen::Vector3d localize(Eigen::Index n, Get get, Eigen::Matrix3Xf& out, const std::string& name,
                         const char* what, const std::optional<Eigen::Vector3d>& stated = {}) {
  out.resize(3, n);
  PositionPrecision at_zero;
  if (!stated) {
    for (int k = 0; k < 3; ++k)
      for (Eigen::Index i = 0; i < n; ++i)
        out(k, i) = at_zero.add(k, get(k, i), static_cast<std::size_t>(i));
    if (at_zero.fits()) return Eigen::Vector3d::Zero();  // the file's floats, bit for bit
  }
  const Eigen::Vector3d o = stated ? *stated : at_zero.local_origin();
  PositionPrecision local;
  for (int k = 0; k < 3; ++k)
    for (Eigen::Index i = 0; i < n; ++i)
      out(k, i) = local.add(k, get(k, i) - o[k], static_cast<std::size_t>(i));
  local.check(name, what);
  return o;
}

/// Parses `comment scanbench_origin X Y Z` (the comment our PLY writers add when the origin is not
/// zero); nullopt when absent. Throws IoError naming the file when the comment is malformed.
std::optional<Eigen::Vector3d> stated_origin(const std::vector<std::string>& comments,
                                             const std::string& name);
/// The comment text for an origin (17 significant digits: reads back bit for bit).
std::string origin_comment(const Eigen::Vector3d& o);

}  // namespace scanbench::io_detail
