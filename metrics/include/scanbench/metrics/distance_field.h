#pragma once
// Narrow-band distance field of a triangle mesh on an OpenVDB grid (OpenVDB stays inside this
// module: the public type only holds a pointer to its implementation).
//
// Kind::Signed uses tools::meshToLevelSet (closed meshes; negative inside), Kind::Unsigned uses
// tools::meshToUnsignedDistanceField (open meshes). Voxels within `band_voxels` of the surface
// hold the distance to the nearest triangle computed by OpenVDB; the grid transform is a plain
// scale by the voxel size with the lattice at the world origin, so two fields with the same voxel
// size share their lattice and compare voxel by voxel.
//
// Queries interpolate trilinearly (BoxSampler stencil) and succeed only when all 8 stencil voxels
// are active (inside the band); otherwise they report "outside" and the caller falls back to the
// exact oracle. The field provides the distance only (no closest point, no normal). Near the
// surface an unsigned field has a kink, so trilinear interpolation over-estimates distances of
// points closer than a voxel by up to about half a voxel; the signed field does not.
#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {

class DistanceField {
 public:
  enum class Kind { Signed, Unsigned };

  /// Builds the field. voxel > 0 (world units), band_voxels >= 2 (half-width of the band).
  /// Throws InputError for an invalid mesh or ParamError for a bad voxel size or band.
  DistanceField(const TriangleMesh& mesh, float voxel, float band_voxels, Kind kind);
  ~DistanceField();
  DistanceField(DistanceField&&) noexcept;
  DistanceField& operator=(DistanceField&&) noexcept;

  Kind kind() const { return kind_; }
  float voxel_size() const { return voxel_; }
  /// Half-width of the band in world units (band_voxels * voxel).
  float band_width() const { return voxel_ * band_voxels_; }
  /// Number of active (in-band) voxels.
  std::uint64_t active_voxels() const;

  /// Unsigned distance |d(q)| (interpolated), or nullopt outside the band. Thread-safe.
  std::optional<float> distance(const Eigen::Vector3f& q) const;
  /// Signed (Kind::Signed) or unsigned value at q, or nullopt outside the band.
  std::optional<float> value(const Eigen::Vector3f& q) const;
  /// Batch form of distance(): out[i] = |d(q_i)| for the queries inside the band; `outside`
  /// receives the indices of the others (out[i] undefined for them) in the order the field
  /// visited them: sorted by the Morton code of their 8^3 leaf, then by index, so spatially
  /// coherent and a function of q alone (not of the thread count). Parallel (TBB).
  void distances(const Eigen::Matrix3Xf& q, Eigen::VectorXf& out,
                 std::vector<Eigen::Index>& outside) const;

  /// Writes the grid to a .vdb file as a FloatGrid named `grid_name` with metadata
  /// (voxel size, band, kind). Throws IoError.
  void write_vdb(const std::filesystem::path& path, const std::string& grid_name) const;

  /// Volumetric comparison of two fields with the same voxel size (an extension of the point
  /// metrics):
  ///  mean_abs_diff = mean over the union of both bands of | |d_a| - |d_b| |, each distance
  ///  clamped to its field's band width (a voxel outside a band counts as band width);
  ///  iou = |inside_a ∩ inside_b| / |inside_a ∪ inside_b| in voxels when both are Signed, else
  ///  nullopt. Throws InputError for different voxel sizes.
  struct Comparison {
    double mean_abs_diff = 0.0;
    std::uint64_t voxels = 0;
    std::optional<double> iou;
  };
  static Comparison compare(const DistanceField& a, const DistanceField& b);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  Kind kind_;
  float voxel_;
  float band_voxels_;
};

/// Reads the first FloatGrid of a .vdb file and returns (grid name, active voxel count, voxel
/// size); for tests and tools. Throws IoError.
struct VdbInfo {
  std::string name;
  std::uint64_t active_voxels = 0;
  double voxel_size = 0.0;
};
VdbInfo read_vdb_info(const std::filesystem::path& path);

}  // namespace scanbench::metrics
