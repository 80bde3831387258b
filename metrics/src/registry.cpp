#include "scanbench/metrics/registry.h"

#include "scanbench/metrics/chamfer.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/mesh_volume.h"
#include "scanbench/metrics/normal_angle.h"
#include "scanbench/metrics/outlier_residue.h"
#include "scanbench/metrics/p2plane.h"
#include "scanbench/metrics/regularity.h"

namespace scanbench::metrics {

namespace {

template <class P, class F>
MetricRegistry::Entry make_metric(std::string name, std::string doc, F f) {
  MetricRegistry::Entry e;
  e.name = name;
  e.doc = std::move(doc);
  e.params = schema_of<P>();
  e.fn = [f, name](const MetricInput& in, const Json& params, RunContext&) {
    return f(in, params_from_json<P>(params, "metric " + name));
  };
  return e;
}

}  // namespace

std::vector<ClosestPoint> closest_points_of(const MetricInput& in) {
  if (in.closest) return *in.closest;
  return in.truth.closest_points(in.output.positions);
}

const MetricRegistry& registry() {
  static const MetricRegistry r = [] {
    MetricRegistry reg("metric");
    // One explicit list; every entry has a create-by-name test (tests/metrics).
    reg.add(make_metric<P2PlaneParams>(
        "accuracy.p2plane",
        "point-to-plane error |<q - p, N_p>| to the exact closest ground-truth point p and its "
        "face normal (CLOP paper 10.2): p2plane_mean/rms/max/p50/p90/p99 (+ _rel = fraction of "
        "the GT diagonal), histogram",
        p2plane_metric));
    reg.add(make_metric<ChamferParams>(
        "accuracy.chamfer",
        "accuracy (mean output->mesh), completeness (mean seeded surface samples->output), "
        "chamfer = sum of the two means, hausdorff = max of both, precision/recall/fscore at tau "
        "(Tanks and Temples); lengths also as _rel",
        chamfer_metric));
    reg.add(make_metric<RegularityParams>(
        "regularity.nn_dist",
        "nearest-neighbour distance of each output point to another: nn_dist_mean, nn_dist_var "
        "(population), nn_dist_cv = std/mean (scale free)",
        regularity_metric));
    reg.add(make_metric<NormalAngleParams>(
        "normals.angle",
        "unoriented normal angle arccos|n . n_gt| to the closest GT face normal, degrees: "
        "normal_angle_mean_deg, normal_angle_rms_deg, normal_pgp5, normal_pgp10 (share under 5 "
        "and 10 degrees); needs output normals",
        normal_angle_metric));
    reg.add(make_metric<OutlierResidueParams>(
        "outliers.residue",
        "outlier_residue: share of output points farther from the GT than multiple x scan noise "
        "sigma (declared, or RMS |p - clean| of the scan's inliers)",
        outlier_residue_metric));
    reg.add(make_metric<MeshVolumeParams>(
        "mesh.volume",
        "reconstructed mesh vs GT through OpenVDB fields on the GT lattice: volume_mean_abs_diff "
        "(mean | |d_gt| - |d_out| | over the union of the bands, clamped to the band) and "
        "volume_iou of the interiors when both meshes are closed",
        mesh_volume_metric));
    return reg;
  }();
  return r;
}

}  // namespace scanbench::metrics
