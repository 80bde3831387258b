#pragma once
// StageData: what one step of a chain consumes and produces. A scan enters a chain as points; a
// step may turn them into a Gaussian mixture (mixture.hem), a covariance mesh (a triangulation of a
// mixture) or a triangle mesh (a reconstruction), and the next step consumes what it declares.
// A step's result carries every kind it does not produce unchanged from its input, so a chain
// `normals.pca -> reconstruct.poisson` ends with the mesh and still holds the points.
#include <optional>
#include <string>
#include <string_view>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

/// One kind of stage data. Values are bits so that a set of kinds is a `DataKinds` mask.
enum class DataKind : unsigned { Points = 1, Mixture = 2, Mesh = 4, CovarianceMesh = 8 };

/// A set of kinds (bit mask of DataKind values).
struct DataKinds {
  unsigned bits = 0;
  constexpr DataKinds() = default;
  constexpr DataKinds(DataKind k)
      : bits(static_cast<unsigned>(k)) {}  // NOLINT: implicit on purpose
  constexpr explicit DataKinds(unsigned b) : bits(b) {}
  constexpr bool has(DataKind k) const { return (bits & static_cast<unsigned>(k)) != 0; }
  /// True when every kind of `o` is in this set.
  constexpr bool contains(DataKinds o) const { return (bits & o.bits) == o.bits; }
  constexpr bool empty() const { return bits == 0; }
  constexpr DataKinds operator|(DataKinds o) const { return DataKinds(bits | o.bits); }
  constexpr DataKinds operator-(DataKinds o) const { return DataKinds(bits & ~o.bits); }
  constexpr bool operator==(const DataKinds&) const = default;
};
constexpr DataKinds operator|(DataKind a, DataKind b) {
  return DataKinds(a) | DataKinds(b);
}

/// "points", "mixture", "mesh", "covariance_mesh".
std::string_view kind_name(DataKind k);
/// Names joined by " and ", e.g. "points and mixture"; "nothing" for an empty set.
std::string kinds_names(DataKinds k);
/// The kind of a name above; throws ParamError naming `where` for another name.
DataKind kind_from_name(std::string_view name, std::string_view where);

struct StageData {
  StageData() = default;
  /// Data holding only points (a scan entering a chain).
  StageData(PointCloud p) : points(std::move(p)) {}  // NOLINT: implicit on purpose

  /// The points (empty when the data holds none).
  PointCloud points;
  std::optional<GaussianMixture> mixture;
  std::optional<TriangleMesh> mesh;
  std::optional<CovarianceMesh> covariance_mesh;

  /// The kinds present (points when the cloud is not empty).
  DataKinds kinds() const;

  /// Each throws InputError("<where>: needs <kind>, but ... holds only <kinds>") when absent.
  const GaussianMixture& require_mixture(std::string_view where) const;
  const TriangleMesh& require_mesh(std::string_view where) const;
  const CovarianceMesh& require_covariance_mesh(std::string_view where) const;

  /// `produced` with every kind it does not hold (of `kinds`) taken from `input`: the result of a
  /// step that produces `kinds`.
  static StageData carry(StageData produced, const StageData& input, DataKinds kinds);
};

}  // namespace scanbench
