#include "scanbench/metrics/mesh_volume.h"

#include "scanbench/metrics/ground_truth.h"
#include "stats.h"

namespace scanbench::metrics {

DistanceField output_field(const GroundTruth& gt, const TriangleMesh& mesh) {
  const DistanceField& f = gt.field();
  return DistanceField(
      mesh, f.voxel_size(), gt.options().band_voxels,
      mesh.is_closed_and_oriented() ? DistanceField::Kind::Signed : DistanceField::Kind::Unsigned);
}

Json mesh_volume_metric(const MetricInput& in, const MeshVolumeParams&) {
  if (!in.output_mesh) throw NotApplicable("mesh.volume: no reconstructed mesh");
  const DistanceField out = output_field(in.truth, *in.output_mesh);
  const auto c = DistanceField::compare(in.truth.field(), out);
  Json j = Json::object();
  detail::put_length(j, "volume_mean_abs_diff", c.mean_abs_diff, in.truth.diagonal());
  j["volume_iou"] = c.iou ? Json(*c.iou) : Json(nullptr);
  j["volume_band_voxels"] = c.voxels;
  detail::put_length(j, "volume_voxel", out.voxel_size(), in.truth.diagonal());
  return j;
}

}  // namespace scanbench::metrics
