#pragma once
// StageData: what one step of a chain consumes and produces. A scan enters a chain as points; a
// step may turn them into a Gaussian mixture (mixture.hem), a covariance mesh (a triangulation of a
// mixture) or a triangle mesh (a reconstruction), and the next step consumes what it declares.
// A step's result carries every kind it does not produce unchanged from its input, so a chain
// `normals.pca -> reconstruct.poisson` ends with the mesh and still holds the points.
//
// Local origin. Positions are float32 (24 bits: a spacing of 0.06 m at 1e6, 1 m at 1e7), so survey
// and UTM coordinates are held relative to a local origin: every kind carries `origin` (double),
// and world = origin + stored position. The readers choose it (io.h), the writers restore it, the
// scanner gives a scan its mesh's origin, and the runner (`scanbench run`, `algo`) hands every step
// its input in the local frame with the origin set to zero and puts the origin back on the chain's
// result: algorithms and metrics only ever see local coordinates, as at the world origin.
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

  /// The local origin of the data: that of the first kind present (points, mixture, mesh,
  /// covariance mesh); zero when it holds nothing. Throws InputError naming `where` when two kinds
  /// present have different origins.
  Eigen::Vector3d origin(std::string_view where = "stage data") const;
  /// Sets the origin of every kind present (positions unchanged: they stay in the local frame).
  void set_origin(const Eigen::Vector3d& o);
  /// Re-expresses every kind present in the frame of `o` (rebase below).
  void rebase(const Eigen::Vector3d& o);
};

/// Re-expresses data in the local frame of origin `o`: every position p becomes
/// float(p + (old origin - o)), computed in double, and the origin becomes `o` (no change when the
/// origins are equal). For comparing data read with different origins (e.g. `scanbench eval` of a
/// cloud against a mesh). Points: positions, sensor origins and the scanner's clean_x, clean_y,
/// clean_z properties (positions too); normals are unchanged.
void rebase(PointCloud& cloud, const Eigen::Vector3d& o);
void rebase(TriangleMesh& mesh, const Eigen::Vector3d& o);
void rebase(GaussianMixture& mixture, const Eigen::Vector3d& o);
void rebase(CovarianceMesh& mesh, const Eigen::Vector3d& o);

}  // namespace scanbench
