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
//  - IoU (eval_geometry -> check_mesh_contains, compute_iou): occupancy of the output mesh by
//    ray parity at the dataset's precomputed query points (points.npz, made by Occupancy
//    Networks' sample_mesh.py: uniform in the padded bounding box and surface samples moved by
//    Gaussian noise) against their stored ground-truth occupancy; here the queries are drawn
//    (dsr_iou_queries) and both occupancies come from the same parity test. The reported row
//    takes eval_geometry's IoU for every mesh: the "IoU 0 when not watertight" of
//    eval_topology is never copied into it (mesh.facts' mesh_closed says whether it is).
//
// PD-Flow (A. Mao et al., "PD-Flow: A Point Cloud Denoising Framework with Normalizing Flows",
// ECCV 2022; github.com/unknownue/pdflow at 78c4a67, eval/evaluation.py: evaluation and
// point2surface_distance), on the point clouds as its script reads them:
//  - CD = point-cloud-utils' chamfer_distance(pred, gt): mean over pred of the Euclidean
//    (unsquared) distance to the nearest gt point PLUS the mean the other way (a sum of the two
//    means, point-cloud-utils issue 89);
//  - HD = point-cloud-utils' hausdorff_distance: the larger directed maximum, unsquared;
//  - P2S = mean over pred of min over its 16 nearest gt points g (sklearn, ball tree) of
//    |p . n_g - g . n_g| / |n_g|: the distance to the nearest of 16 tangent planes, n_g the gt
//    point's normal.
// Its script scores the files in whatever frame they are in; its test clouds are ScoreDenoise's
// (PU-Net meshes' Poisson-disk samples). Here both clouds are first put in the ground-truth
// points' unit sphere (normalize_sphere above), unless normalize = false.
// Its eval/eval2.py adds PU-GAN's uniformity (R. Li et al., "PU-GAN: a Point Cloud Upsampling
// Adversarial Network", ICCV 2019), eval/uniformity/uniformity.cpp and uniform.py, on the
// ground-truth mesh (the .off files) and the output file, unnormalised:
//  - 1000 disk centres: a face by area, barycentric U(0.01, 1)^3 normalised; radii
//    sqrt(area x p / pi) for p = 0.4, 0.6, 0.8, 1.0, 1.2 % of the mesh's area;
//  - each output point moved to its closest point on the mesh; a disk holds the points within
//    that geodesic distance of its centre (CGAL's Surface_mesh_shortest_path, exact), tried only
//    within the Euclidean distance of the largest radius;
//  - per p, over disks with n >= 5 points: (n - pN)^2 / (pN) x the mean over the disk's points
//    of (d - e)^2 / e, d the distance to the nearest other point of the disk, e the hexagonal
//    spacing sqrt(2 pi r^2 / (1.732 n)); the mean over those disks.
// Here mesh and points are in the frame of the other scores (the ground-truth points' unit
// sphere unless normalize = false), the centres drawn from the run ("metric.pdflow").
//
// Tanks and Temples (A. Knapitsch et al., "Tanks and Temples: Benchmarking Large-Scale Scene
// Reconstruction", SIGGRAPH 2017; github.com/isl-org/TanksAndTemples at 3c2c212,
// python_toolbox/evaluation/evaluation.py: EvaluateHisto and get_f1_score_histo2, called by
// run.py with voxel_size = tau / 2):
//  - both clouds voxel-downsampled at tau / 2 by Open3D's VoxelDownSample (grid origin at the
//    cloud's min bound - voxel / 2, cell = floor((p - origin) / voxel), the mean of a cell's
//    points); the scene's crop volume and the alignment of the submission are not applied (the
//    output is in the ground truth's frame, and the ground truth is the whole shape);
//  - distances point to point (Open3D's compute_point_cloud_distance, nearest neighbour);
//  - precision = share of output points with distance < tau, recall = share of ground-truth
//    points with distance < tau (strict), F = 2 P R / (P + R), 0 when either cloud is empty;
//  - tau is per scene in the benchmark (3 mm to 25 mm): here a fraction of the diagonal.
//
// DTU (R. Jensen et al., "Large Scale Multi-view Stereopsis Evaluation", CVPR 2014; the
// community's Python evaluator github.com/jzhangbs/DTUeval-python at 45b4fec, eval.py, mode
// pcd):
//  - the output points shuffled (eval.py: an unseeded numpy shuffle, so its own accuracy moves
//    from run to run; here seeded from the run), then thinned greedily in that order: a point
//    is kept unless an earlier kept point lies within downsample_density of it (sklearn's
//    radius_neighbors, distance <= density; DTU's 0.2 mm);
//  - accuracy = mean over the thinned points of the distance to the nearest ground-truth point,
//    over the distances below max_dist only (DTU's 20 mm); completeness = the same from the
//    ground-truth points to the thinned points; overall = their mean;
//  - DTU's observation mask (ObsMask*.mat) and ground plane have no counterpart on a shape
//    scanned here: every thinned point and every ground-truth point counts;
//  - DTU's lengths are absolute (mm): here fractions of the diagonal, by default DTU's 0.2 mm and
//    20 mm on a shape of 400 mm diagonal.
//
// ETH3D (T. Schoeps et al., "A Multi-View Stereo Benchmark with High-Resolution Images and
// Multi-Camera Videos", CVPR 2017; github.com/ETH3D/multi-view-evaluation at 0daa4f4,
// src/accuracy.cc ComputeAccuracy and ClassifyPoint, src/completeness.cc ComputeCompleteness,
// src/main.cc), at one tolerance t (the program takes a list; each is independent):
//  - the ground truth is laser scans with their scanner origins; here the scan's noise-free hits
//    (clean_x/y/z of its inliers) with the sensor origin of their view;
//  - a beam leaves each ground-truth point's scanner through the point, of radius beam_start +
//    r tan(divergence) at the distance r of the tested point from the scanner. An output point x
//    is accurate when some ground-truth point p whose beam contains x (x on the beam's side of the
//    scanner) has |p - x| <= t; else inaccurate when some beam containing x ends behind it (the
//    scanner saw through x: x is in observed free space); else unobserved, and left out;
//  - accuracy = the mean over voxel cells (side `voxel`, two grids shifted by half a cell) holding
//    accurate or inaccurate points of accurate / (accurate + inaccurate), 0 without such a cell;
//    completeness = the mean over the cells of the ground-truth points of the share of them with
//    an output point within t; F1 = 2 A C / (A + C), 0 when both are 0;
//  - ETH3D's beam (1.125 mm at the scanner, 0.011 degrees divergence) is its Faro scanner's at
//    its scans' density; a simulated scan is sparser, so the beam radius here is `beam_radius`
//    (a fraction of the diagonal, default 0: half the median spacing of the ground-truth points,
//    so the beams of neighbouring rays touch) plus the divergence term. A misaligned scan's
//    beams start at its registered sensor origins.
#include <array>
#include <vector>

#include "scanbench/core/run_context.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {
class GroundTruth;
}

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
  std::int64_t iou_points = 100000;        ///< occupancy queries
  double iou_uniform_share = 0.5;          ///< share of them uniform in the padded box
  double iou_padding = 0.1;                ///< the box grown by this share of each side
  double iou_sigma = 0.05;                 ///< near-surface query offsets, fraction of diag
  static void declare(ParamDeclarer<DsrParams>& d) {
    d.integer("reference_points", &DsrParams::reference_points, Range::closed(1, 100000000), "",
              "ground-truth points with normals (the ground truth's seeded samples; the "
              "dsr-benchmark's evaluation clouds have 100,000)");
    d.integer("iou_points", &DsrParams::iou_points, Range::closed(1, 100000000), "",
              "occupancy queries of the volumetric IoU (seeded from the ground truth, the same "
              "for every method on a dataset)");
    d.real("iou_uniform_share", &DsrParams::iou_uniform_share, Range::closed(0.0, 1.0), "",
           "share of the queries uniform in the ground truth's bounding box grown by "
           "iou_padding; the rest are its surface samples moved by N(0, iou_sigma^2) per axis");
    d.real("iou_padding", &DsrParams::iou_padding, Range::at_least(0.0), "",
           "the uniform queries' box: the bounding box with each side grown by this share "
           "about its centre (0.1: 1.1 x)");
    d.real("iou_sigma", &DsrParams::iou_sigma, Range::at_least(0.0), "diag",
           "standard deviation per axis of the near-surface queries' offsets");
  }
};

/// The occupancy queries of the dsr IoU: round(n x uniform_share) uniform in the ground truth's
/// bounding box grown by `padding` (each side about the centre), then the first n - that many of
/// its fixed surface samples moved by N(0, (sigma x diag)^2) per axis; seeded from the ground
/// truth's sample seed (stream "dsr.iou"), so every method on a dataset meets the same queries.
Eigen::Matrix3Xf dsr_iou_queries(const GroundTruth& truth, const DsrParams& p);

/// |inside a and inside b| / |inside a or inside b| (eval.py compute_iou); NaN for an empty union.
double occupancy_iou(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b);

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
/// dsr_hausdorff_x1e2, dsr_hd_gt_r_x1e2, dsr_hd_r_gt_x1e2, dsr_normal_consistency, and dsr_iou
/// (GroundTruth::contains on both meshes at dsr_iou_queries; null when the ground truth is not
/// closed: its inside is then undefined).
Json dsr_metric(const MetricInput& in, const DsrParams& p);

struct PdflowParams {
  std::int64_t reference_points = 0;     ///< gt cloud size; 0 = as many as the output points
  bool normalize = true;                 ///< score in the gt points' unit sphere
  bool uniformity = false;               ///< PU-GAN's uniformity on the ground-truth mesh (slow)
  std::int64_t uniformity_disks = 1000;  ///< disk centres (uniformity.cpp: 1000)
  static void declare(ParamDeclarer<PdflowParams>& d) {
    d.integer("reference_points", &PdflowParams::reference_points, Range::closed(0, 100000000), "",
              "size of the clean ground-truth cloud with normals (the ground truth's seeded "
              "area-uniform samples); 0 = as many as the output points");
    d.flag("normalize", &PdflowParams::normalize,
           "put both clouds in the ground-truth points' unit sphere first (ScoreDenoise's "
           "normalize_sphere; PD-Flow's test clouds are in it); false: the dataset's own units");
    d.flag("uniformity", &PdflowParams::uniformity,
           "compute PU-GAN's uniformity (pdflow_uniformity_*: exact geodesic disks on the "
           "ground-truth mesh, about 1.2 s per disk on 2 cores for 10K points on a 20K-face "
           "mesh, 20 minutes at 1,000 disks); off by default: the keys are then null");
    d.integer("uniformity_disks", &PdflowParams::uniformity_disks, Range::closed(1, 1000000), "",
              "disk centres of the uniformity (uniformity.cpp: 1000), drawn from the run's "
              "stream \"metric.pdflow\"");
  }
};

struct PdflowScores {
  double cd = 0.0;   ///< sum of the two mean nearest distances (unsquared)
  double hd = 0.0;   ///< the larger directed maximum (unsquared)
  double p2s = 0.0;  ///< mean distance to the nearest of 16 ground-truth tangent planes
};

/// PD-Flow's three scores of `pred` against the ground-truth points (with normals; InputError
/// for empty clouds or missing normals), in the frame given. Exact neighbours in double.
PdflowScores pdflow_scores(const Eigen::Matrix3Xf& pred, const PointCloud& gt);

/// PU-GAN's disk area shares (uniformity.cpp's `precentage`, float; uniform.py's `precentages`,
/// double): 0.4, 0.6, 0.8, 1.0 and 1.2 % of the mesh's area.
inline constexpr std::array<float, 5> kUniformityShares = {0.004f, 0.006f, 0.008f, 0.010f, 0.012f};
/// Their keys in convention.pdflow's records.
inline constexpr std::array<const char*, 5> kUniformityKeys = {
    "pdflow_uniformity_p04", "pdflow_uniformity_p06", "pdflow_uniformity_p08",
    "pdflow_uniformity_p10", "pdflow_uniformity_p12"};

/// A disk centre on a mesh as uniformity.cpp's Face_location: a face index and barycentric
/// coordinates in CGAL's order of the face's corners (Surface_mesh_shortest_path, the face built
/// by CGAL::Euler::add_face from faces.col(face) as CGAL's OFF reader builds it).
struct UniformityCentre {
  Eigen::Index face = 0;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
};

/// uniformity.cpp's random centres, `count` of them from `rng` in order: a face with probability
/// proportional to its area (CGAL's face_area; cumulative shares in double, where the original's
/// float sums can fall short of 1 and then pick face 0), then x_k = U(0.01, 1) for k = 1..3 and
/// barycentric = x / sum(x): the original's draw, denser towards the face's centroid than a
/// uniform point of the face. InputError for a mesh without area.
std::vector<UniformityCentre> pdflow_uniformity_centres(const Eigen::Matrix3Xd& vertices,
                                                        const Eigen::Matrix3Xi& faces,
                                                        Eigen::Index count, Rng& rng);

/// uniformity.cpp's output: what it writes to pc_radius.txt, pc_point2mesh_distance.txt and
/// pc_disk_idx.txt.
struct UniformityDisks {
  /// sqrt(area x share / pi) per share, rounded to float as the original stores it; in the
  /// mesh's units (the mesh's total area from CGAL's Polygon_mesh_processing::area).
  std::array<double, 5> radius{};
  /// Each output point's closest point on the mesh (CGAL's AABB locate, then the location's
  /// point), 3 x N.
  Eigen::Matrix3Xd mapped;
  /// members[d x 5 + k]: the output points whose closest point lies within geodesic distance
  /// radius[k] of centre d (CGAL's exact Surface_mesh_shortest_path, distance <= radius), by
  /// ascending index. Only points within Euclidean distance radius[4] of the centre are tried,
  /// as in the original (a geodesic is never shorter).
  std::vector<std::vector<Eigen::Index>> members;
};

/// The geodesic disks of uniformity.cpp for `points` (3 x N, in the mesh's frame) on the mesh,
/// one per centre, in parallel over the centres (each disk's result in its own slot: the same at
/// any thread count). Cost: one exact geodesic propagation over the whole mesh per disk with a
/// point near it (CGAL builds its sequence tree for the entire mesh). NotApplicable when CGAL
/// cannot build the mesh (a non-manifold face), InputError for no points or bad face indices.
UniformityDisks pdflow_uniformity_disks(const Eigen::Matrix3Xd& points,
                                        const Eigen::Matrix3Xd& vertices,
                                        const Eigen::Matrix3Xi& faces,
                                        const std::vector<UniformityCentre>& centres);

/// uniform.py's analyze_uniform, per share k, N the output points and n_d = |members[d x 5 + k]|:
/// over the disks with n_d >= 5 (the others are left out, their coverage too), the mean of
///   (n_d - s_k N)^2 / (s_k N) x nanmean_i (d_i - e)^2 / e,
/// d_i the distance from mapped point i of the disk to its nearest other mapped point of the
/// disk, e = sqrt(2 (pi radius_k^2 / n_d) / 1.732) the hexagonal spacing (the original's 1.732
/// for sqrt 3), s_k the share in double. 0 when no disk has 5 points (the original meant 0.0 but
/// its np.float raises on numpy >= 1.24). In double (the original casts the per-disk values to
/// float32). The unit is the mesh's length unit.
std::array<double, 5> pdflow_uniformity_scores(const UniformityDisks& disks);

/// Metric "convention.pdflow": pdflow_cd, pdflow_p2s, pdflow_hd, pdflow_reference_points, and
/// pdflow_uniformity_p04 ... _p12 (PU-GAN's uniformity at 0.4 ... 1.2 %) on the ground-truth mesh
/// with the same normalisation (null when `uniformity` is off, the default, or CGAL cannot build
/// the mesh).
/// Disk centres from the run's stream "metric.pdflow".
Json pdflow_metric(const MetricInput& in, const PdflowParams& p, RunContext& ctx);

struct TntParams {
  double tau = 0.005;                      ///< distance threshold, fraction of the diagonal
  double voxel = 0.5;                      ///< voxel size as a fraction of tau (run.py: 1/2)
  std::int64_t reference_points = 100000;  ///< ground-truth points before downsampling
  static void declare(ParamDeclarer<TntParams>& d) {
    d.real("tau", &TntParams::tau, Range::above(0.0), "diag",
           "the precision/recall threshold (Tanks and Temples: per scene, 3 to 25 mm)");
    d.real("voxel", &TntParams::voxel, Range::above(0.0), "tau",
           "voxel size of the downsampling of both clouds, as a fraction of tau (run.py: 0.5)");
    d.integer("reference_points", &TntParams::reference_points, Range::closed(1, 100000000), "",
              "ground-truth points (the ground truth's seeded area-uniform samples; the "
              "benchmark's are laser scans) before the voxel downsampling");
  }
};

struct TntScores {
  double precision = 0.0, recall = 0.0, fscore = 0.0;
  std::vector<double> precision_distances;  ///< per downsampled output point
  std::vector<double> recall_distances;     ///< per downsampled ground-truth point
};

/// Open3D's VoxelDownSample: the mean of the points in each cell of the grid anchored at the
/// cloud's min bound - voxel / 2 (sums in input order, so the means are Open3D's to the bit);
/// cells in lexicographic order of their index.
Eigen::Matrix3Xd voxel_down_sample(const Eigen::Matrix3Xd& points, double voxel);

/// The Tanks and Temples scores of `output` against `truth` at `tau` with voxel size `voxel`
/// (both absolute), as EvaluateHisto computes them (no crop, no alignment).
TntScores tnt_scores(const Eigen::Matrix3Xf& output, const Eigen::Matrix3Xf& truth, double tau,
                     double voxel);

/// Metric "convention.tnt": tnt_precision, tnt_recall, tnt_fscore, tnt_tau(_rel), point counts
/// after downsampling, and the distance histograms behind the benchmark's curves.
Json tnt_metric(const MetricInput& in, const TntParams& p);

struct DtuParams {
  double downsample_density = 0.0005;      ///< DTU's 0.2 mm, fraction of the diagonal
  double max_dist = 0.05;                  ///< DTU's 20 mm, fraction of the diagonal
  std::int64_t reference_points = 100000;  ///< ground-truth points (DTU: the STL scan)
  static void declare(ParamDeclarer<DtuParams>& d) {
    d.real("downsample_density", &DtuParams::downsample_density, Range::above(0.0), "diag",
           "the output is thinned to points at least this far apart (DTU: 0.2 mm)");
    d.real("max_dist", &DtuParams::max_dist, Range::above(0.0), "diag",
           "distances from this on are left out of both means (DTU: 20 mm)");
    d.integer("reference_points", &DtuParams::reference_points, Range::closed(1, 100000000), "",
              "ground-truth points (the ground truth's seeded area-uniform samples; DTU's are "
              "structured-light scans)");
  }
};

struct DtuScores {
  double accuracy = 0.0, completeness = 0.0, overall = 0.0;
  Eigen::Index thinned_points = 0;
};

/// Greedy thinning in the order given: point i is kept unless a kept point j < i lies within
/// `density` (distance <= density, in double). The kept indices, ascending.
std::vector<Eigen::Index> dtu_thin(const Eigen::Matrix3Xd& points, double density);

/// DTU's scores of `output` (already in the order the thinning visits) against `truth`, lengths
/// absolute. NotApplicable when no distance either way is below max_dist (the mean is
/// undefined; eval.py would print NaN).
DtuScores dtu_scores(const Eigen::Matrix3Xf& output, const Eigen::Matrix3Xf& truth, double density,
                     double max_dist);

/// Metric "convention.dtu": dtu_accuracy, dtu_completeness, dtu_overall (lengths, + _rel),
/// dtu_points (after thinning). The output is shuffled with the run's stream "metric.dtu".
Json dtu_metric(const MetricInput& in, const DtuParams& p, RunContext& ctx);

struct Eth3dParams {
  double tolerance = 0.005;  ///< fraction of the diagonal
  double voxel = 0.005;      ///< cell side of the averaging grids, fraction of the diagonal
  double beam_radius = 0.0;  ///< at the scanner, fraction of the diagonal; 0 = from spacing
  double beam_divergence_deg = 0.011;
  static void declare(ParamDeclarer<Eth3dParams>& d) {
    d.real("tolerance", &Eth3dParams::tolerance, Range::above(0.0), "diag",
           "the evaluation tolerance (ETH3D's tables: 1, 2, 5, 10, 20, 50 cm on scenes of tens of "
           "metres)");
    d.real("voxel", &Eth3dParams::voxel, Range::above(0.0), "diag",
           "cell side of the two averaging grids (ETH3D: 1 cm)");
    d.real("beam_radius", &Eth3dParams::beam_radius, Range::at_least(0.0), "diag",
           "beam radius at the scanner; 0 = half the median nearest-neighbour spacing of the "
           "ground-truth points (ETH3D: 1.125 mm, its scanner at its density)");
    d.real("beam_divergence_deg", &Eth3dParams::beam_divergence_deg, Range::closed(0.0, 45.0),
           "deg", "beam divergence half-angle (ETH3D: 0.011)");
  }
};

/// One ground-truth scan for ETH3D: its origin and its points.
struct Eth3dScan {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Matrix3Xf points;
};

struct Eth3dScores {
  double accuracy = 0.0, completeness = 0.0, f1 = 0.0;
  Eigen::Index accurate = 0, inaccurate = 0, unobserved = 0;  ///< output points
};

/// ETH3D's scores at one tolerance (lengths absolute; beam_radius the radius at the scanner).
Eth3dScores eth3d_scores(const Eigen::Matrix3Xf& output, const std::vector<Eth3dScan>& truth,
                         double tolerance, double voxel, double beam_radius,
                         double beam_divergence_deg);

/// Metric "convention.eth3d": eth3d_accuracy, eth3d_completeness, eth3d_f1, eth3d_tolerance
/// (+ _rel), eth3d_beam_radius (+ _rel), counts of accurate, inaccurate and unobserved output
/// points. NotApplicable without a scan with clean hits, scan ids and sensor origins.
Json eth3d_metric(const MetricInput& in, const Eth3dParams& p);

}  // namespace scanbench::metrics
