#pragma once
// GroundTruth: a ground-truth mesh with its two distance oracles and its fixed surface samples.
//
//  - Exact path: closest point on the mesh through an Embree BVH (rtcPointQuery) and our own
//    point-triangle routine (closest_point.h, in double). The query radius starts at the distance
//    to the nearest mesh vertex (kd-tree), a valid upper bound, and shrinks with every hit.
//    Returns the point, the distance and the unit face normal of the closest face (so sharp edges
//    stay sharp); on ties (a point nearest to an edge or vertex) the lowest face index wins.
//  - Field path: an OpenVDB narrow-band distance field (distance_field.h), signed when the mesh
//    is closed and consistently oriented, unsigned otherwise, voxel size = field_voxel x bbox
//    diagonal, band half-width band_voxels. Distance only; queries outside the band fall back to
//    the exact path. Built lazily on first use (thread-safe), together with a coarse lattice
//    (1/64 of the diagonal over 1.5 x the bbox) of nearest mesh vertices: a fallback query far
//    from the mesh starts its exact search from its node's vertex instead of a kd-tree search
//    (any upper bound gives the same answer; this one is cheaper to get).
//  - Surface samples: count uniform area-weighted samples seeded from sample_seed
//    (surface_sampling.h), cached per count, so completeness and recall use the same samples in
//    every run.
// Embree and OpenVDB stay private (pimpl). All const methods are thread-safe.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "scanbench/core/bbox.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/metrics/distance_field.h"

namespace scanbench::metrics {

/// Result of an exact closest-point query.
struct ClosestPoint {
  Eigen::Vector3f point = Eigen::Vector3f::Zero();   ///< closest point on the mesh
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  ///< unit normal of `face` (0 if degenerate)
  float distance = 0.0f;                             ///< |q - point|
  std::int32_t face = -1;                            ///< index of the closest face
};

/// Which oracle answers distance queries.
enum class DistancePath { Exact, Field };

/// The RunContext stream of the ground truth's sample seed, in jobs and in `scanbench eval`
/// (the seed is recorded as "scoring.ground_truth_samples_seed").
inline constexpr std::string_view kGroundTruthSamplesStream = "ground_truth";

struct GroundTruthOptions {
  double field_voxel = 1.0 / 512.0;  ///< voxel size of the field, fraction of the bbox diagonal
  float band_voxels = 5.0f;          ///< half-width of the field's narrow band, in voxels
};

class GroundTruth {
 public:
  /// Validates the mesh (InputError for no faces, non-finite vertices, bad indices, zero area)
  /// and builds the exact oracle. The field is built on first use.
  GroundTruth(const TriangleMesh& mesh, std::uint64_t sample_seed, GroundTruthOptions options = {});
  ~GroundTruth();
  GroundTruth(const GroundTruth&) = delete;
  GroundTruth& operator=(const GroundTruth&) = delete;

  const TriangleMesh& mesh() const;
  /// Diagonal of the mesh's bounding box: the unit of every "_rel" value.
  float diagonal() const;
  BoundingBox bbox() const;
  /// True when the mesh is closed and consistently oriented (then the field is signed).
  bool closed() const;
  std::uint64_t sample_seed() const;
  const GroundTruthOptions& options() const;

  /// Exact closest point (see the header comment). q must be finite (InputError otherwise).
  ClosestPoint closest_point(const Eigen::Vector3f& q) const;
  /// Exact closest points of every column of q, in parallel; out has q.cols() entries.
  std::vector<ClosestPoint> closest_points(const Eigen::Matrix3Xf& q) const;

  /// Unsigned distances of every column of q by the chosen path. Exact: every query through
  /// closest_point, in input order. Field: DistanceField::distances (queries visited in leaf
  /// Morton order), then the queries outside the band through closest_point in that spatial
  /// order; *fallbacks (if given) receives their count. Both are independent of the thread
  /// count; the fallback answers equal the exact path's bit for bit.
  Eigen::VectorXf distances(const Eigen::Matrix3Xf& q, DistancePath path,
                            Eigen::Index* fallbacks = nullptr) const;

  /// Inside or not, for every column of q, by ray parity as Occupancy Networks'
  /// check_mesh_contains (im2mesh/utils/libmesh/inside_mesh.py, which the dsr-benchmark's IoU
  /// calls): a point is inside when the rays from it along +z and along -z each cross the
  /// surface an odd number of times (crossings within 1e-6 of the diagonal and of the distance
  /// count once: a ray through a shared edge or vertex). Points outside the mesh's bounding box are outside. Meaningful for closed
  /// meshes; on an open one it is what the parity gives. Exact in float (Embree's watertight
  /// triangle test), in parallel, independent of the thread count.
  std::vector<std::uint8_t> contains(const Eigen::Matrix3Xf& q) const;

  /// The distance field (built on first call).
  const DistanceField& field() const;

  /// The first `count` fixed surface samples (positions and face normals); cached.
  const PointCloud& surface_samples(Eigen::Index count) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scanbench::metrics
