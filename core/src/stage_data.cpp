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

}  // namespace scanbench
