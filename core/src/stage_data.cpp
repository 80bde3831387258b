#include "scanbench/core/stage_data.h"

#include <fmt/format.h>

#include <array>

#include "scanbench/core/errors.h"

namespace scanbench {

namespace {

constexpr std::array<DataKind, 4> kAllKinds{DataKind::Points, DataKind::Mixture, DataKind::Mesh,
                                            DataKind::CovarianceMesh};

[[noreturn]] void missing(std::string_view where, DataKind k, DataKinds have) {
  throw InputError(fmt::format("{}: needs {}, but its input holds only {}", where, kind_name(k),
                               kinds_names(have)));
}

}  // namespace

std::string_view kind_name(DataKind k) {
  switch (k) {
    case DataKind::Points:
      return "points";
    case DataKind::Mixture:
      return "mixture";
    case DataKind::Mesh:
      return "mesh";
    case DataKind::CovarianceMesh:
      return "covariance_mesh";
  }
  return "?";
}

std::string kinds_names(DataKinds k) {
  std::string s;
  for (DataKind d : kAllKinds) {
    if (!k.has(d)) continue;
    if (!s.empty()) s += " and ";
    s += kind_name(d);
  }
  return s.empty() ? "nothing" : s;
}

DataKind kind_from_name(std::string_view name, std::string_view where) {
  for (DataKind d : kAllKinds)
    if (kind_name(d) == name) return d;
  throw ParamError(fmt::format(
      "{}: expected one of points|mixture|mesh|covariance_mesh, got \"{}\"", where, name));
}

DataKinds StageData::kinds() const {
  DataKinds k;
  if (!points.empty()) k = k | DataKind::Points;
  if (mixture) k = k | DataKind::Mixture;
  if (mesh) k = k | DataKind::Mesh;
  if (covariance_mesh) k = k | DataKind::CovarianceMesh;
  return k;
}

const GaussianMixture& StageData::require_mixture(std::string_view where) const {
  if (!mixture) missing(where, DataKind::Mixture, kinds());
  return *mixture;
}

const TriangleMesh& StageData::require_mesh(std::string_view where) const {
  if (!mesh) missing(where, DataKind::Mesh, kinds());
  return *mesh;
}

const CovarianceMesh& StageData::require_covariance_mesh(std::string_view where) const {
  if (!covariance_mesh) missing(where, DataKind::CovarianceMesh, kinds());
  return *covariance_mesh;
}

StageData StageData::carry(StageData produced, const StageData& input, DataKinds kinds) {
  if (!kinds.has(DataKind::Points)) produced.points = input.points;
  if (!kinds.has(DataKind::Mixture)) produced.mixture = input.mixture;
  if (!kinds.has(DataKind::Mesh)) produced.mesh = input.mesh;
  if (!kinds.has(DataKind::CovarianceMesh)) produced.covariance_mesh = input.covariance_mesh;
  return produced;
}

Eigen::Vector3d StageData::origin(std::string_view where) const {
  std::optional<Eigen::Vector3d> o;
  auto take = [&](const Eigen::Vector3d& x, DataKind k) {
    if (!o) {
      o = x;
    } else if (*o != x) {
      throw InputError(fmt::format("{}: the {} has local origin ({} {} {}), other data ({} {} {})",
                                   where, kind_name(k), x.x(), x.y(), x.z(), o->x(), o->y(),
                                   o->z()));
    }
  };
  if (!points.empty()) take(points.origin, DataKind::Points);
  if (mixture) take(mixture->origin, DataKind::Mixture);
  if (mesh) take(mesh->origin, DataKind::Mesh);
  if (covariance_mesh) take(covariance_mesh->origin, DataKind::CovarianceMesh);
  return o ? *o : Eigen::Vector3d::Zero();
}

namespace {

void shift(Eigen::Matrix3Xf& m, const Eigen::Vector3d& d) {
  for (Eigen::Index i = 0; i < m.cols(); ++i)
    m.col(i) = (m.col(i).cast<double>() + d).cast<float>();
}

}  // namespace

void rebase(PointCloud& cloud, const Eigen::Vector3d& o) {
  if (cloud.origin == o) return;
  const Eigen::Vector3d d = cloud.origin - o;
  shift(cloud.positions, d);
  shift(cloud.sensor_origins, d);
  static constexpr std::array<const char*, 3> kClean{"clean_x", "clean_y", "clean_z"};
  for (int k = 0; k < 3; ++k) {
    const auto it = cloud.properties.find(kClean[static_cast<std::size_t>(k)]);
    if (it == cloud.properties.end()) continue;
    for (Eigen::Index i = 0; i < it->second.size(); ++i)
      it->second[i] = static_cast<float>(static_cast<double>(it->second[i]) + d[k]);
  }
  cloud.origin = o;
}

void rebase(TriangleMesh& mesh, const Eigen::Vector3d& o) {
  if (mesh.origin == o) return;
  shift(mesh.vertices, mesh.origin - o);
  mesh.origin = o;
}

void rebase(GaussianMixture& mixture, const Eigen::Vector3d& o) {
  if (mixture.origin == o) return;
  shift(mixture.means, mixture.origin - o);
  mixture.origin = o;
}

void rebase(CovarianceMesh& mesh, const Eigen::Vector3d& o) {
  if (mesh.origin == o) return;
  mesh.means.colwise() += mesh.origin - o;
  mesh.origin = o;
}

void StageData::rebase(const Eigen::Vector3d& o) {
  scanbench::rebase(points, o);
  if (mixture) scanbench::rebase(*mixture, o);
  if (mesh) scanbench::rebase(*mesh, o);
  if (covariance_mesh) scanbench::rebase(*covariance_mesh, o);
}

void StageData::set_origin(const Eigen::Vector3d& o) {
  points.origin = o;
  if (mixture) mixture->origin = o;
  if (mesh) mesh->origin = o;
  if (covariance_mesh) covariance_mesh->origin = o;
}

}  // namespace scanbench
