#include "scanbench/core/closest_point.h"

#include <Eigen/Geometry>
#include <algorithm>

namespace scanbench {

PreparedTriangle::PreparedTriangle(const Eigen::Vector3d& a_in, const Eigen::Vector3d& b_in,
                                   const Eigen::Vector3d& c_in)
    : a(a_in), b(b_in), c(c_in) {
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  abab = ab.dot(ab);
  abac = ab.dot(ac);
  acac = ac.dot(ac);
  // Degenerate (collinear or repeated) vertices break the region tests (a zero edge makes two
  // regions coincide): the nearest point of the three edges is the answer then.
  degenerate = ab.cross(ac).squaredNorm() <= 1e-20 * abab * acac;
}

Eigen::Vector3d PreparedTriangle::closest_point(const Eigen::Vector3d& p) const {
  if (degenerate) {
    auto on_segment = [&](const Eigen::Vector3d& s, const Eigen::Vector3d& e) {
      const Eigen::Vector3d d = e - s;
      const double l2 = d.squaredNorm();
      const double t = l2 > 0.0 ? std::clamp((p - s).dot(d) / l2, 0.0, 1.0) : 0.0;
      return Eigen::Vector3d(s + t * d);
    };
    Eigen::Vector3d best = on_segment(a, b);
    for (const Eigen::Vector3d& q : {on_segment(b, c), on_segment(c, a)})
      if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
    return best;
  }
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const Eigen::Vector3d ap = p - a;
  // With bp = ap - ab and cp = ap - ac, the six dot products of Ericson's routine need only two
  // per query: d3 = ab.bp, d4 = ac.bp, d5 = ab.cp, d6 = ac.cp.
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;  // vertex region A

  const double d3 = d1 - abab;
  const double d4 = d2 - abac;
  if (d3 >= 0.0 && d4 <= d3) return b;  // vertex region B

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {  // edge region AB
    const double denom = d1 - d3;
    return denom > 0.0 ? Eigen::Vector3d(a + (d1 / denom) * ab) : a;
  }

  const double d5 = d1 - abac;
  const double d6 = d2 - acac;
  if (d6 >= 0.0 && d5 <= d6) return c;  // vertex region C

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {  // edge region AC
    const double denom = d2 - d6;
    return denom > 0.0 ? Eigen::Vector3d(a + (d2 / denom) * ac) : a;
  }

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {  // edge region BC
    const double denom = (d4 - d3) + (d5 - d6);
    return denom > 0.0 ? Eigen::Vector3d(b + ((d4 - d3) / denom) * (c - b)) : b;
  }

  const double denom = 1.0 / (va + vb + vc);  // face region
  const double v = vb * denom;
  const double w = vc * denom;
  return a + ab * v + ac * w;
}

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return PreparedTriangle(a, b, c).closest_point(p);
}

}  // namespace scanbench
