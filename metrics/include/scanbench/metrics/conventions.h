#pragma once
// Metrics as published evaluators compute them, so a number can stand beside a published table.
//
// ScoreDenoise (S. Luo and W. Hu, "Score-Based Point Cloud Denoising", ICCV 2021; its evaluator,
// github.com/luost26/score-denoise at bdf0eab, utils/evaluate.py with models/utils.py, reused by
// IterativePFN, StraightPCF and others), on the PyTorch3D it pins (0.5.0):
//  - normalize_sphere: centre c = (max + min) / 2 per axis, scale s = max_i |p_i - c|, p' = (p - c) / s;
//  - cd_sph = chamfer_distance_unit_sphere(gen, ref): both normalised by the reference cloud's c
//    and s; PyTorch3D's chamfer_distance: mean over gen of the squared distance to the nearest
//    ref point plus mean over ref of the squared distance to the nearest gen point;
//  - hd_sph = hausdorff_distance_unit_sphere: max of the two directed maxima of those squared
//    nearest distances (knn_points returns squared distances);
//  - p2f = point_mesh_bidir_distance_single_unit_sphere(gen, mesh): both normalised by the mesh
//    vertices' c and s; PyTorch3D's point_mesh_face_distance: mean over points of the squared
//    distance to the closest face plus mean over faces of the squared distance to the closest
//    point, where a face's distance is PointTriangle3DistanceForward (the projection onto the
//    plane when it falls inside, else the nearest of the three edges) and a face of area below
//    min_triangle_area counts as its edges only: 1e-5 in PyTorch3D <= 0.6.1, 5e-3 from 0.6.2
//    (commit ee71c7c4): the reason p2f moves with the PyTorch3D version (score-denoise issue 12).
// The papers print cd_sph and p2f x 1e4; so do the keys here.
//
// dsr-benchmark (R. Sulzer et al., "A Survey and Benchmark of Automatic Surface Reconstruction
// from Point Clouds", TPAMI 2024; github.com/raphaelsulzer/dsr-benchmark at ffbc98a,
// dsrb/eval.py: MeshEvaluator.eval_pointcloud and eval), for mesh outputs:
//  - the output surface sampled area-uniformly (trimesh's mesh.sample, 100,000 points; here the
//    harness's seeded output samples) against the ground-truth point cloud (100,000 points with
//    normals; here the ground truth's seeded samples with their face normals);
//  - point to point, Euclidean (scipy's cKDTree): CD_gt->r = mean over ground-truth points of the
//    distance to the nearest output sample (completeness), CD_r->gt the other way (accuracy),
//    Chamfer = 0.5 (CD_gt->r + CD_r->gt) (a mean of the two means, unsquared), HD_* the maxima and
//    Hausdorff the larger; every length divided by diag / 100, diag the ground-truth points'
//    bounding-box diagonal (the tables' "(x10^2)");
//  - Normal Consistency = 0.5 (mean |n_gt . n_r(nearest)| + mean |n_r . n_gt(nearest)|), unit
//    normals, unoriented.
// Its IoU needs the dataset's precomputed occupancy queries and is not computed here.
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct ScoreDenoiseParams {
  std::int64_t reference_points = 0;  ///< ref cloud size; 0 = as many as the output points
  double min_triangle_area = 1e-5;    ///< PyTorch3D's threshold, unit-sphere units
  static void declare(ParamDeclarer<ScoreDenoiseParams>& d) {
    d.integer("reference_points", &ScoreDenoiseParams::reference_points,
              Range::closed(0, 100000000), "",
              "size of the clean reference cloud (the ground truth's seeded area-uniform "
              "samples; ScoreDenoise uses Poisson-disk samples at the input's resolution); 0 = "
              "as many as the output points");
    d.real("min_triangle_area", &ScoreDenoiseParams::min_triangle_area, Range::at_least(0.0),
           "sphere^2",
           "faces smaller than this (in the unit-sphere frame) count as their edges in p2f: "
           "1e-5 as in PyTorch3D 0.5.0, which ScoreDenoise pins; 5e-3 as from PyTorch3D 0.6.2");
  }
};

struct ScoreDenoiseScores {
  double cd_sph = 0.0;  ///< unit-sphere Chamfer, squared distances (not x 1e4)
  double hd_sph = 0.0;  ///< unit-sphere Hausdorff, squared
  double p2f = 0.0;     ///< point-to-face + face-to-point, squared (not x 1e4)
};

/// The three ScoreDenoise scores of `gen` against the reference cloud `ref` and the mesh, in
/// double precision (PyTorch3D works in float32: its values differ in the sixth digit or so).
/// Exact nearest neighbours and closest faces (kd-tree candidates, then the formulas above).
/// InputError for empty clouds or a mesh without faces.
ScoreDenoiseScores scoredenoise_scores(const Eigen::Matrix3Xf& gen, const Eigen::Matrix3Xf& ref,
                                       const TriangleMesh& mesh, double min_triangle_area);

/// Metric "convention.scoredenoise": sd_cd_sph_x1e4, sd_p2f_x1e4, sd_hd_sph, sd_reference_points.
Json scoredenoise_metric(const MetricInput& in, const ScoreDenoiseParams& p);

struct DsrParams {
  std::int64_t reference_points = 100000;  ///< ground-truth points (dsr: 100,000)
  static void declare(ParamDeclarer<DsrParams>& d) {
    d.integer("reference_points", &DsrParams::reference_points, Range::closed(1, 100000000), "",
              "ground-truth points with normals (the ground truth's seeded samples; the "
              "dsr-benchmark's evaluation clouds have 100,000)");
  }
};

struct DsrScores {
  double cd_gt_r = 0.0, cd_r_gt = 0.0, chamfer = 0.0;  ///< ground-truth units (not / diag)
  double hd_gt_r = 0.0, hd_r_gt = 0.0, hausdorff = 0.0;
  double normal_consistency = 0.0;
  double diag = 0.0;  ///< the ground-truth points' bbox diagonal
};

/// The dsr-benchmark's point scores of the output samples against the ground-truth points (both
/// with unit normals; InputError for empty clouds or missing normals). Exact nearest neighbours
/// (kd-tree candidates, distances in double).
DsrScores dsr_scores(const PointCloud& output, const PointCloud& truth);

/// Metric "convention.dsr" (mesh outputs): dsr_chamfer_x1e2, dsr_cd_gt_r_x1e2, dsr_cd_r_gt_x1e2,
/// dsr_hausdorff_x1e2, dsr_hd_gt_r_x1e2, dsr_hd_r_gt_x1e2, dsr_normal_consistency.
Json dsr_metric(const MetricInput& in, const DsrParams& p);

}  // namespace scanbench::metrics
