#pragma once
// Volumetric comparison of a reconstructed mesh with the ground truth through OpenVDB fields
// on the ground truth's lattice (voxel = GroundTruthOptions::field_voxel x diagonal):
//   volume_mean_abs_diff = mean over the union of both narrow bands of | |d_gt| - |d_out| |,
//     each distance clamped to the band half-width (DistanceField::compare); length, with `_rel`;
//   volume_iou = |interior_gt ∩ interior_out| / |interior_gt ∪ interior_out| in voxels when both
//     meshes are closed and oriented (signed fields), else null.
// NotApplicable when the input has no output mesh.
#include <filesystem>

#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct MeshVolumeParams {
  static void declare(ParamDeclarer<MeshVolumeParams>&) {}
};

/// The distance field of a reconstructed mesh on the ground truth's lattice (signed when the
/// mesh is closed and oriented).
DistanceField output_field(const GroundTruth& gt, const TriangleMesh& mesh);

/// Metric "mesh.volume".
Json mesh_volume_metric(const MetricInput& in, const MeshVolumeParams& p);

}  // namespace scanbench::metrics
