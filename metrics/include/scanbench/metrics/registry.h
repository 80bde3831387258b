#pragma once
// The metric registry: every metric by dotted name with its declared parameters, what it scores
// and, for every key it can emit, which way is better. A metric maps (ground truth, output) to a
// JSON object of named values (the keys listed below) and may add histograms under
// "histograms".
//
// Registered metrics (metrics/src/registry.cpp), what they score, and their keys. Every length
// is reported twice, `key` in the units of the ground-truth mesh and `key_rel` as a fraction of
// the ground-truth bounding-box diagonal (variances: `_rel` divides by diagonal^2).
//   points:  accuracy.p2plane     p2plane_mean|rms|max|p50|p90|p99                 (p2plane.h)
//            accuracy.chamfer     accuracy completeness chamfer hausdorff precision recall fscore
//                                                                                   (chamfer.h)
//            regularity.nn_dist   nn_dist_mean nn_dist_var nn_dist_cv           (regularity.h)
//            outliers.residue     outlier_residue (+ outlier_threshold, scan_noise)
//   normals: normals.angle        normal_angle_mean_deg normal_angle_rms_deg normal_pgp5|10
//   mesh:    surface.chamfer      the accuracy.chamfer keys on the output surface (surface.h)
//            surface.normals      the normals.angle keys on the output surface    (surface.h)
//            surface.input_distance input_distance_mean|rms|max (GPS paper sec. 7.2)
//            mesh.volume          volume_mean_abs_diff volume_iou             (mesh_volume.h)
//            mesh.facts           mesh_vertices mesh_faces mesh_boundary_edges ... (mesh_facts.h)
// Points and normals metrics run on a point output (metrics::evaluate), mesh metrics on a mesh
// output (metrics::evaluate_mesh); a metric of the other kind is skipped with the reason recorded
// under "skipped", also when asked for by name (one metric list serves experiments whose chains
// end in points and in meshes).
//
// Directions: `better` of every emitted key is declared with the entry (Better::Lower: errors;
// Better::Higher: shares and scores such as fscore, precision, recall, normal_pgp*, volume_iou;
// Better::None: informational counts and context such as sample counts, thresholds, mesh vertex
// and face counts). evaluate() refuses (Error) a key its metric did not declare, so the
// declarations cannot fall behind the code; `scanbench compare`, `table` and `report` read them
// through key_direction().
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/metrics/metric_input.h"

namespace scanbench::metrics {

struct PointTruthInput;  // metrics/point_truth.h: a point-cloud ground truth

/// What a metric scores: the output points, their normals, or the output surface (mesh).
enum class Scores { Points, Normals, Mesh };
const char* scores_name(Scores s);

/// Which way a key is better: lower (errors), higher (shares, scores) or none (informational).
enum class Better { Lower, Higher, None };
const char* better_name(Better b);

/// One key a metric emits and its direction.
struct MetricKey {
  std::string key;
  Better better = Better::Lower;
};

/// A published evaluator whose definitions a metric follows (docs/metrics.md "Conventions").
struct Convention {
  std::string name;    ///< "scanbench" (the harness's own), "scoredenoise", "dsr", ...
  std::string title;   ///< as a table header shows it, e.g. "ScoreDenoise"
  std::string source;  ///< repository, commit, file and function
};
/// Every convention, scanbench's own first.
const std::vector<Convention>& conventions();
/// The convention of `name`; Error for an unknown name.
const Convention& convention(std::string_view name);

/// A registered metric: its function, what it scores, the keys it emits and what it needs.
struct Metric {
  Scores scores = Scores::Points;
  std::string convention = "scanbench";  ///< whose definitions every key of it follows
  std::vector<MetricKey> keys;
  bool needs_closest = false;        ///< uses in.closest (shared exact closest points)
  bool needs_output_oracle = false;  ///< uses in.output_oracle (mesh outputs)
  std::function<Json(const MetricInput& in, const Json& params, RunContext& ctx)> run;
  /// The metric on a point-cloud ground truth (point_truth.h); empty when it needs a mesh (then
  /// it is "not applicable" there).
  std::function<Json(const PointTruthInput& in, const Json& params, RunContext& ctx)>
      run_point_truth;

  Json operator()(const MetricInput& in, const Json& params, RunContext& ctx) const {
    return run(in, params, ctx);
  }
  /// The declared key, or null.
  const MetricKey* find_key(std::string_view key) const;
  /// Adds "scores", "keys" ({key: lower|higher|none}), "convention" ({name, title, source}) and
  /// "key_conventions" ({key: convention name}) to a `scanbench list --json` entry.
  void describe(Json& j) const;
};

using MetricFn = Metric;
using MetricRegistry = Registry<Metric>;

/// Every registered metric, in one explicit list (metrics/src/registry.cpp).
const MetricRegistry& registry();
/// Adds a plugin's entry to registry() (the harness's plugin loader, scanbench/plugin.h), before
/// any metric runs; not thread-safe. Throws Error on a duplicate name.
void add_plugin_entry(MetricRegistry::Entry e);

/// Keys evaluate() adds to every record besides the metrics' own (output_points, gt_diagonal,
/// gt_closed, output_mesh_samples; gt_points for a point-cloud ground truth), all Better::None.
const std::vector<MetricKey>& record_keys();

/// The declared direction of a record metric key (any registered metric's or record_keys()), or
/// nullopt for a key nothing declares. A key declared by several metrics (surface.chamfer reuses
/// the accuracy.chamfer keys) has one direction (tested).
std::optional<Better> key_direction(std::string_view key);

/// The convention of a record metric key (its metric's; "scanbench" for record_keys()), or
/// nullopt for a key nothing declares.
std::optional<std::string> key_convention(std::string_view key);

/// True when a metric scoring `s` applies to a mesh output (Scores::Mesh) or to points (the
/// others).
inline bool scores_mesh(Scores s) {
  return s == Scores::Mesh;
}

}  // namespace scanbench::metrics
