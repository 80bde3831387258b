#include "scanbench/core/triangle_mesh.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <unordered_map>

#include "scanbench/core/errors.h"

namespace scanbench {

void TriangleMesh::validate(std::string_view where) const {
  if (faces.cols() == 0) throw InputError(fmt::format("{}: mesh has no faces", where));
  for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
    if (!vertices.col(v).allFinite()) {
      throw InputError(fmt::format("{}: vertex {} has a non-finite coordinate", where, v));
    }
  }
  const Eigen::Index nv = vertices.cols();
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (faces(k, f) < 0 || faces(k, f) >= nv) {
        throw InputError(
            fmt::format("{}: face {} refers to vertex {} of {}", where, f, faces(k, f), nv));
      }
    }
  }
}

Eigen::Vector3f TriangleMesh::face_normal(Eigen::Index f) const {
  const Eigen::Vector3f a = vertices.col(faces(0, f));
  const Eigen::Vector3f n = (vertices.col(faces(1, f)) - a).cross(vertices.col(faces(2, f)) - a);
  const float len = n.norm();
  return len > 0.0f ? Eigen::Vector3f(n / len) : Eigen::Vector3f::Zero();
}

float TriangleMesh::face_area(Eigen::Index f) const {
  const Eigen::Vector3f a = vertices.col(faces(0, f));
  return 0.5f * (vertices.col(faces(1, f)) - a).cross(vertices.col(faces(2, f)) - a).norm();
}

double TriangleMesh::area() const {
  double s = 0.0;
  for (Eigen::Index f = 0; f < faces.cols(); ++f)
    s += face_area(f);
  return s;
}

double TriangleMesh::signed_volume() const {
  double v = 0.0;
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    const Eigen::Vector3d a = vertices.col(faces(0, f)).cast<double>();
    const Eigen::Vector3d b = vertices.col(faces(1, f)).cast<double>();
    const Eigen::Vector3d c = vertices.col(faces(2, f)).cast<double>();
    v += a.dot(b.cross(c));
  }
  return v / 6.0;
}

Eigen::Index TriangleMesh::count_degenerate_faces() const {
  Eigen::Index n = 0;
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    const bool repeated =
        faces(0, f) == faces(1, f) || faces(1, f) == faces(2, f) || faces(0, f) == faces(2, f);
    if (repeated || face_area(f) == 0.0f) ++n;
  }
  return n;
}

bool TriangleMesh::is_closed_and_oriented() const {
  // Every directed edge must appear once, and its reverse once.
  std::unordered_map<std::uint64_t, int> directed;
  directed.reserve(static_cast<std::size_t>(faces.cols()) * 3);
  auto key = [](std::int64_t a, std::int64_t b) {
    return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint64_t>(b);
  };
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (++directed[key(faces(k, f), faces((k + 1) % 3, f))] > 1) return false;
    }
  }
  for (const auto& [k, count] : directed) {
    const std::uint64_t reverse = (k << 32) | (k >> 32);
    if (directed.find(reverse) == directed.end()) return false;
  }
  return !directed.empty();
}

}  // namespace scanbench
