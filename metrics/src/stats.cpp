#include "stats.h"

#include <cmath>
#include <limits>

namespace scanbench::metrics::detail {

double quantile_sorted(const std::vector<float>& sorted, double p) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double h = p * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - static_cast<double>(lo)) * (double(sorted[hi]) - double(sorted[lo]));
}

double ordered_sum(const Eigen::VectorXf& v) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    s += v[i];
  return s;
}

Json histogram(const Eigen::VectorXf& values, double lo, double hi, int bins,
               const std::string& unit) {
  std::vector<std::int64_t> counts(static_cast<std::size_t>(bins), 0);
  std::int64_t under = 0, over = 0;
  const double w = (hi - lo) / bins;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (v < lo) {
      ++under;
    } else if (v >= hi) {
      ++over;
    } else {
      auto b = static_cast<std::size_t>((v - lo) / w);
      if (b >= counts.size()) b = counts.size() - 1;
      ++counts[b];
    }
  }
  Json j = Json::object();
  j["unit"] = unit;
  j["min"] = lo;
  j["max"] = hi;
  j["bins"] = bins;
  j["counts"] = counts;
  j["underflow"] = under;
  j["overflow"] = over;
  j["count"] = values.size();
  return j;
}

Json number(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

void put_length(Json& out, const std::string& key, double v, double diag) {
  out[key] = number(v);
  out[key + "_rel"] = diag > 0.0 ? number(v / diag) : Json(nullptr);
}

}  // namespace scanbench::metrics::detail
