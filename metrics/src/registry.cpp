#include "scanbench/metrics/registry.h"

#include <fmt/format.h>

#include <type_traits>

#include "scanbench/metrics/chamfer.h"
#include "scanbench/metrics/conventions.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/mesh_facts.h"
#include "scanbench/metrics/mesh_volume.h"
#include "scanbench/metrics/normal_angle.h"
#include "scanbench/metrics/outlier_residue.h"
#include "scanbench/metrics/p2plane.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/regularity.h"
#include "scanbench/metrics/sharp_edges.h"
#include "scanbench/metrics/surface.h"

namespace scanbench::metrics {

const char* scores_name(Scores s) {
  switch (s) {
    case Scores::Points:
      return "points";
    case Scores::Normals:
      return "normals";
    default:
      return "mesh";
  }
}

const char* better_name(Better b) {
  switch (b) {
    case Better::Lower:
      return "lower";
    case Better::Higher:
      return "higher";
    default:
      return "none";
  }
}

const MetricKey* Metric::find_key(std::string_view key) const {
  for (const auto& k : keys)
    if (k.key == key) return &k;
  return nullptr;
}

const std::vector<Convention>& conventions() {
  static const std::vector<Convention> c = {
      {"scanbench", "scanbench",
       "this harness (docs/metrics.md): lengths in the ground truth's units and as _rel, a "
       "fraction of its bounding-box diagonal; chamfer = the sum of two mean unsquared "
       "distances"},
      {"scoredenoise", "ScoreDenoise",
       "github.com/luost26/score-denoise bdf0eab, utils/evaluate.py and models/utils.py "
       "(PyTorch3D 0.5.0 chamfer_distance, point_mesh_face_distance)"},
      {"pdflow", "PD-Flow",
       "github.com/unknownue/pdflow 78c4a67, eval/evaluation.py: evaluation, "
       "point2surface_distance (point-cloud-utils chamfer_distance, hausdorff_distance)"},
      {"tnt", "Tanks and Temples",
       "github.com/isl-org/TanksAndTemples 3c2c212, python_toolbox/evaluation/evaluation.py: "
       "EvaluateHisto, get_f1_score_histo2"},
      {"dtu", "DTU", "github.com/jzhangbs/DTUeval-python 45b4fec, eval.py (mode pcd)"},
      {"eth3d", "ETH3D",
       "github.com/ETH3D/multi-view-evaluation 0daa4f4, src/accuracy.cc ComputeAccuracy and "
       "ClassifyPoint, src/completeness.cc ComputeCompleteness, src/main.cc"},
      {"dsr", "dsr-benchmark",
       "github.com/raphaelsulzer/dsr-benchmark ffbc98a, dsrb/eval.py: MeshEvaluator"},
  };
  return c;
}

const Convention& convention(std::string_view name) {
  for (const auto& c : conventions())
    if (c.name == name) return c;
  throw Error(fmt::format("unknown metric convention '{}'", name));
}

void Metric::describe(Json& j) const {
  j["scores"] = scores_name(scores);
  Json k = Json::object(), kc = Json::object();
  for (const auto& mk : keys) {
    k[mk.key] = better_name(mk.better);
    kc[mk.key] = convention;
  }
  j["keys"] = k;
  const Convention& c = metrics::convention(convention);
  j["convention"] = {{"name", c.name}, {"title", c.title}, {"source", c.source}};
  j["key_conventions"] = kc;
  j["point_truth"] = static_cast<bool>(run_point_truth);
}

namespace {

constexpr Better kLower = Better::Lower;
constexpr Better kHigher = Better::Higher;
constexpr Better kNone = Better::None;

// The declared keys of one metric: plain keys, and lengths (key and key_rel, same direction).
struct Keys {
  std::vector<MetricKey> v;
  Keys& plain(std::string k, Better b) {
    v.push_back({std::move(k), b});
    return *this;
  }
  Keys& length(const std::string& k, Better b) {
    v.push_back({k, b});
    v.push_back({k + "_rel", b});
    return *this;
  }
};

Keys pdflow_keys() {
  Keys k;
  k.plain("pdflow_cd", kLower)
      .plain("pdflow_p2s", kLower)
      .plain("pdflow_hd", kLower)
      .plain("pdflow_reference_points", kNone);
  for (const char* u : kUniformityKeys)
    k.plain(u, kLower);
  return k;
}

struct Needs {
  bool closest = false;
  bool output_oracle = false;
};

template <class P, class F>
MetricRegistry::Entry make_metric(std::string name, std::string doc, Scores scores, Keys keys,
                                  Needs needs, F f) {
  MetricRegistry::Entry e;
  e.name = name;
  e.doc = std::move(doc);
  e.params = schema_of<P>();
  e.fn.scores = scores;
  e.fn.keys = std::move(keys.v);
  e.fn.needs_closest = needs.closest;
  e.fn.needs_output_oracle = needs.output_oracle;
  e.fn.run = [f, name](const MetricInput& in, const Json& params, RunContext& ctx) {
    if constexpr (std::is_invocable_v<F, const MetricInput&, const P&, RunContext&>)
      return f(in, params_from_json<P>(params, "metric " + name), ctx);
    else
      return f(in, params_from_json<P>(params, "metric " + name));
  };
  return e;
}

// A metric following a published evaluator's definitions (conventions.h).
MetricRegistry::Entry following(std::string convention, MetricRegistry::Entry e) {
  metrics::convention(convention);  // a known name
  e.fn.convention = std::move(convention);
  return e;
}

// A metric that also runs on a point-cloud ground truth (point_truth.h).
template <class F>
MetricRegistry::Entry point_capable(MetricRegistry::Entry e, F f) {
  e.fn.run_point_truth = f;
  return e;
}
Keys chamfer_keys() {
  return Keys{}
      .length("accuracy", kLower)
      .length("completeness", kLower)
      .length("chamfer", kLower)
      .length("hausdorff", kLower)
      .plain("precision", kHigher)
      .plain("recall", kHigher)
      .plain("fscore", kHigher)
      .length("fscore_tau", kNone)
      .plain("chamfer_samples", kNone)
      .plain("chamfer_field_fallbacks", kNone)
      .length("completeness_observed", kLower)
      .length("chamfer_observed", kLower)
      .plain("recall_observed", kHigher)
      .plain("fscore_observed", kHigher)
      .plain("observed_share", kNone)
      .length("observed_radius", kNone);
}

Keys normal_keys() {
  return Keys{}
      .plain("normal_angle_mean_deg", kLower)
      .plain("normal_angle_rms_deg", kLower)
      .plain("normal_pgp5", kHigher)
      .plain("normal_pgp10", kHigher);
}

}  // namespace

std::vector<ClosestPoint> closest_points_of(const MetricInput& in) {
  if (in.closest) return *in.closest;
  return in.truth.closest_points(in.output.positions);
}

const std::vector<MetricKey>& record_keys() {
  static const std::vector<MetricKey> k = {{"output_points", kNone},
                                           {"gt_diagonal", kNone},
                                           {"gt_closed", kNone},
                                           {"output_mesh_samples", kNone},
                                           {"gt_points", kNone}};
  return k;
}

std::optional<std::string> key_convention(std::string_view key) {
  for (const auto& e : registry().entries())
    if (e.fn.find_key(key)) return e.fn.convention;
  for (const auto& k : record_keys())
    if (k.key == key) return std::string("scanbench");
  return std::nullopt;
}

std::optional<Better> key_direction(std::string_view key) {
  for (const auto& e : registry().entries())
    if (const MetricKey* k = e.fn.find_key(key)) return k->better;
  for (const auto& k : record_keys())
    if (k.key == key) return k.better;
  return std::nullopt;
}

const MetricRegistry& registry() {
  static MetricRegistry r = [] {  // not const: plugins add entries (add_plugin_entry)
    MetricRegistry reg("metric");
    const Needs closest{true, false};
    // One explicit list; every entry has a create-by-name test (tests/metrics).
    reg.add(point_capable(
        make_metric<P2PlaneParams>(
            "accuracy.p2plane",
            "point-to-plane error |<q - p, N_p>| to the exact closest ground-truth point p and its "
            "face normal (CLOP paper 10.2): p2plane_mean/rms/max/p50/p90/p99 (+ _rel = fraction of "
            "the GT diagonal), histogram",
            Scores::Points,
            Keys{}
                .length("p2plane_mean", kLower)
                .length("p2plane_rms", kLower)
                .length("p2plane_max", kLower)
                .length("p2plane_p50", kLower)
                .length("p2plane_p90", kLower)
                .length("p2plane_p99", kLower),
            closest, p2plane_metric),
        point_truth_p2plane));
    reg.add(point_capable(
        make_metric<ChamferParams>(
            "accuracy.chamfer",
            "accuracy (mean output->mesh), completeness (mean seeded surface samples->output), "
            "chamfer = sum of the two means, hausdorff = max of both, precision/recall/fscore at "
            "tau "
            "(Tanks and Temples); lengths also as _rel; _observed: completeness, chamfer, recall "
            "and fscore over the samples within observed_radius of a noise-free scan hit",
            Scores::Points, chamfer_keys(), closest, chamfer_metric),
        point_truth_chamfer));
    // The mean spacing depends on the point count: informational. Its spread (variance, and the
    // scale-free CV) measures regularity: lower is better.
    reg.add(point_capable(
        make_metric<RegularityParams>(
            "regularity.nn_dist",
            "nearest-neighbour distance of each output point to another: nn_dist_mean, "
            "nn_dist_var (population), nn_dist_cv = std/mean (scale free)",
            Scores::Points,
            Keys{}
                .length("nn_dist_mean", kNone)
                .length("nn_dist_var", kLower)
                .plain("nn_dist_cv", kLower),
            Needs{}, regularity_metric),
        point_truth_regularity));
    reg.add(make_metric<NormalAngleParams>(
        "normals.angle",
        "unoriented normal angle arccos|n . n_gt| to the closest GT face normal, degrees: "
        "normal_angle_mean_deg, normal_angle_rms_deg, normal_pgp5, normal_pgp10 (share under 5 "
        "and 10 degrees); needs output normals",
        Scores::Normals, normal_keys(), closest, normal_angle_metric));
    reg.add(make_metric<OutlierResidueParams>(
        "outliers.residue",
        "outlier_residue: share of output points farther from the GT than multiple x scan noise "
        "sigma (declared, or RMS |p - clean| of the scan's inliers)",
        Scores::Points,
        Keys{}
            .plain("outlier_residue", kLower)
            .length("outlier_threshold", kNone)
            .length("scan_noise", kNone)
            .plain("scan_outlier_share", kNone)
            .plain("scan_noise_source", kNone),
        closest, outlier_residue_metric));
    reg.add(make_metric<SharpEdgeParams>(
        "edges.p2plane",
        "errors near the ground truth's sharp edges (GPF paper Fig. 7-9, 17) over the output "
        "points whose closest GT point is within the band (edge_band: max(band, "
        "band_noise_multiple x scan noise)) of an edge sharper than angle_deg: "
        "edge_p2plane_mean (point-to-plane, closest face's normal) and edge_p2s_mean (exact "
        "point-to-surface, to the edge itself outside a convex edge) (+ _rel); edge_points, "
        "edge_share, edge_band_area (share of the GT area in the band), edge_sharp_length "
        "(share of the GT edge length that is sharp); not applicable on a faceted GT (either "
        "share above its max_)",
        Scores::Points,
        Keys{}
            .length("edge_p2plane_mean", kLower)
            .length("edge_p2s_mean", kLower)
            .length("edge_band", kNone)
            .plain("edge_points", kNone)
            .plain("edge_share", kNone)
            .plain("edge_band_area", kNone)
            .plain("edge_sharp_length", kNone),
        closest, sharp_edge_p2plane_metric));
    reg.add(make_metric<SharpEdgeParams>(
        "edges.normals",
        "normal error near the ground truth's sharp edges (CLOP paper Fig. 16): "
        "edge_normal_angle_mean_deg, edge_normal_pgp10 (share under 10 degrees) over the output "
        "points near an edge (as edges.p2plane, edge_band); needs output normals",
        Scores::Normals,
        Keys{}
            .plain("edge_normal_angle_mean_deg", kLower)
            .plain("edge_normal_pgp10", kHigher)
            .length("edge_band", kNone)
            .plain("edge_points", kNone),
        closest, sharp_edge_normals_metric));
    reg.add(make_metric<ChamferParams>(
        "surface.chamfer",
        "the accuracy.chamfer scores of a mesh output: accuracy from seeded area-uniform samples "
        "of the output surface to the GT, completeness from the fixed GT samples to the output "
        "surface (exact closest point on it)",
        Scores::Mesh, chamfer_keys(), Needs{true, true}, surface_chamfer_metric));
    reg.add(make_metric<NormalAngleParams>(
        "surface.normals",
        "the normals.angle scores of a mesh output: unoriented angle between the output face "
        "normal at each surface sample and the GT face normal at its closest point",
        Scores::Mesh, normal_keys(), closest, surface_normals_metric));
    reg.add(make_metric<InputDistanceParams>(
        "surface.input_distance",
        "GPS paper sec. 7.2 (Fig. 13): distance of each input point to the output surface, of "
        "the chain's scan (of=scan) or of the points the reconstruction consumed "
        "(of=step_input); inliers by default: input_distance_mean/rms/max (+ _rel), histogram",
        Scores::Mesh,
        Keys{}
            .length("input_distance_mean", kLower)
            .length("input_distance_rms", kLower)
            .length("input_distance_max", kLower)
            .plain("input_distance_points", kNone),
        Needs{false, true}, input_distance_metric));
    reg.add(make_metric<MeshVolumeParams>(
        "mesh.volume",
        "reconstructed mesh vs GT through OpenVDB fields on the GT lattice: volume_mean_abs_diff "
        "(mean | |d_gt| - |d_out| | over the union of the bands, clamped to the band) and "
        "volume_iou of the interiors when both meshes are closed",
        Scores::Mesh,
        Keys{}
            .length("volume_mean_abs_diff", kLower)
            .plain("volume_iou", kHigher)
            .plain("volume_band_voxels", kNone)
            .length("volume_voxel", kNone),
        Needs{}, mesh_volume_metric));
    reg.add(make_metric<MeshFactsParams>(
        "mesh.facts",
        "the output mesh's facts: vertices, faces, unreferenced vertices, degenerate faces, "
        "boundary and non-manifold edges, components, closed, edges, Euler characteristic, genus "
        "(closed meshes), bytes (float32 positions + int32 "
        "corners; a covariance mesh + 6 float32 per vertex, GPS sec. 7.2)",
        Scores::Mesh,
        Keys{}
            .plain("mesh_vertices", kNone)
            .plain("mesh_faces", kNone)
            .plain("mesh_unreferenced_vertices", kNone)
            .plain("mesh_degenerate_faces", kNone)
            .plain("mesh_boundary_edges", kNone)
            .plain("mesh_nonmanifold_edges", kLower)
            .plain("mesh_components", kNone)
            .plain("mesh_closed", kNone)
            .plain("mesh_edges", kNone)
            .plain("mesh_euler", kNone)
            .plain("mesh_genus", kNone)
            .plain("mesh_bytes", kNone),
        Needs{}, mesh_facts_metric));
    // Published evaluators' conventions (conventions.h, docs/metrics.md "Conventions").
    reg.add(following(
        "scoredenoise",
        make_metric<ScoreDenoiseParams>(
            "convention.scoredenoise",
            "ScoreDenoise's evaluator (luost26/score-denoise utils/evaluate.py, PyTorch3D 0.5.0; "
            "also IterativePFN, StraightPCF): clouds in the unit sphere (bbox centre, max radius), "
            "sd_cd_sph_x1e4 = 1e4 x (mean squared nearest distance output->reference + "
            "reference->output), sd_p2f_x1e4 = 1e4 x (mean squared point->face + face->point, "
            "PyTorch3D's point_mesh_face_distance), sd_hd_sph (squared); as the papers print them",
            Scores::Points,
            Keys{}
                .plain("sd_cd_sph_x1e4", kLower)
                .plain("sd_p2f_x1e4", kLower)
                .plain("sd_hd_sph", kLower)
                .plain("sd_reference_points", kNone),
            Needs{}, scoredenoise_metric)));
    reg.add(following(
        "dsr",
        make_metric<DsrParams>(
            "convention.dsr",
            "the dsr-benchmark's evaluator (raphaelsulzer/dsr-benchmark dsrb/eval.py) for mesh "
            "outputs: point-to-point distances between the output's surface samples and the ground "
            "truth's points, dsr_chamfer_x1e2 = 0.5 x (mean gt->r + mean r->gt), "
            "dsr_hausdorff_x1e2 = max of both maxima, each over diag/100 of the ground-truth "
            "points (the tables' x10^2), the one-sided means and maxima, "
            "dsr_normal_consistency, dsr_iou (occupancy by ray parity at queries uniform in the "
            "padded box and near the surface; null when the ground truth is not closed)",
            Scores::Mesh,
            Keys{}
                .plain("dsr_chamfer_x1e2", kLower)
                .plain("dsr_cd_gt_r_x1e2", kLower)
                .plain("dsr_cd_r_gt_x1e2", kLower)
                .plain("dsr_hausdorff_x1e2", kLower)
                .plain("dsr_hd_gt_r_x1e2", kLower)
                .plain("dsr_hd_r_gt_x1e2", kLower)
                .plain("dsr_normal_consistency", kHigher)
                .plain("dsr_iou", kHigher),
            Needs{false, true}, dsr_metric)));
    reg.add(following(
        "pdflow",
        make_metric<PdflowParams>(
            "convention.pdflow",
            "PD-Flow's evaluator (unknownue/pdflow eval/evaluation.py) in the ground-truth points' "
            "unit sphere: pdflow_cd = mean nearest distance output->gt + gt->output (unsquared, "
            "point-cloud-utils), pdflow_hd = the larger directed maximum, pdflow_p2s = mean "
            "distance to the nearest of the 16 nearest ground-truth points' tangent planes; "
            "pdflow_uniformity_p04 ... _p12 = PU-GAN's uniformity at disks of 0.4 ... 1.2 % of "
            "the area (eval/uniformity: geodesic disks on the ground-truth mesh, seeded centres)",
            Scores::Points, pdflow_keys(), Needs{}, pdflow_metric)));
    reg.add(following(
        "tnt",
        make_metric<TntParams>(
            "convention.tnt",
            "the Tanks and Temples evaluation (isl-org/TanksAndTemples python_toolbox/evaluation): "
            "both clouds voxel-downsampled at voxel x tau (Open3D), tnt_precision and tnt_recall = "
            "shares of point-to-point distances below tau, tnt_fscore = 2PR/(P+R); histograms of "
            "both distances in tau for the curves",
            Scores::Points,
            Keys{}
                .plain("tnt_precision", kHigher)
                .plain("tnt_recall", kHigher)
                .plain("tnt_fscore", kHigher)
                .length("tnt_tau", kNone)
                .plain("tnt_output_points", kNone)
                .plain("tnt_reference_points", kNone),
            Needs{}, tnt_metric)));
    reg.add(following(
        "dtu",
        make_metric<DtuParams>(
            "convention.dtu",
            "DTU's evaluation as DTUeval-python computes it (jzhangbs/DTUeval-python eval.py): the "
            "output shuffled (seeded) and thinned to downsample_density, dtu_accuracy and "
            "dtu_completeness = means of the nearest distances below max_dist each way, "
            "dtu_overall = their mean (+ _rel); no observation mask",
            Scores::Points,
            Keys{}
                .length("dtu_accuracy", kLower)
                .length("dtu_completeness", kLower)
                .length("dtu_overall", kLower)
                .plain("dtu_points", kNone),
            Needs{}, dtu_metric)));
    reg.add(following(
        "eth3d",
        make_metric<Eth3dParams>(
            "convention.eth3d",
            "ETH3D's multi-view evaluation (ETH3D/multi-view-evaluation src/accuracy.cc, "
            "completeness.cc) at one tolerance, the scan's noise-free hits as its laser scans: "
            "output points in observed free space (a ground-truth beam passes them and ends "
            "behind) count against accuracy, unobserved ones not at all; eth3d_accuracy and "
            "eth3d_completeness averaged over voxel cells, eth3d_f1",
            Scores::Points,
            Keys{}
                .plain("eth3d_accuracy", kHigher)
                .plain("eth3d_completeness", kHigher)
                .plain("eth3d_f1", kHigher)
                .length("eth3d_tolerance", kNone)
                .length("eth3d_beam_radius", kNone)
                .plain("eth3d_accurate_points", kNone)
                .plain("eth3d_inaccurate_points", kNone)
                .plain("eth3d_unobserved_points", kNone),
            Needs{}, eth3d_metric)));
    return reg;
  }();
  return r;
}

}  // namespace scanbench::metrics
