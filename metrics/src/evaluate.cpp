#include "scanbench/metrics/evaluate.h"

#include <optional>

#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface.h"

namespace scanbench::metrics {

namespace {

struct MeshOutput {
  const TriangleMesh* mesh = nullptr;
  const CovarianceMesh* covariance_mesh = nullptr;
  const PointCloud* step_input = nullptr;  ///< MetricInput::step_input
};

Json run(const GroundTruth& gt, const PointCloud& output, const PointCloud* scan, MeshOutput mesh,
         const std::vector<std::string>& metric_names, const Json& metric_params, RunContext& ctx) {
  output.validate("evaluate: output");
  if (output.empty()) throw InputError("evaluate: output has no points");
  if (scan) scan->validate("evaluate: scan");
  if (mesh.step_input) mesh.step_input->validate("evaluate: the chain's points");
  if (!metric_params.is_object())
    throw ParamError("metric_params: expected an object of metric name -> params");
  const MetricRegistry& reg = registry();
  for (const auto& [name, value] : metric_params.items()) {
    if (!reg.find(name))
      throw ParamError("metric_params." + name + ": unknown metric (see scanbench list metrics)");
    if (!value.is_object()) throw ParamError("metric_params." + name + ": expected an object");
  }
  const bool all = metric_names.empty();
  std::vector<const MetricRegistry::Entry*> selected;
  if (all) {
    for (const auto& e : reg.entries())
      selected.push_back(&e);
  } else {
    for (const auto& n : metric_names)
      selected.push_back(&reg.at(n));
  }

  Json record = Json::object();
  Json histograms = Json::object();
  Json effective = Json::object();
  Json skipped = Json::object();

  const bool is_mesh = mesh.mesh != nullptr;
  std::vector<ClosestPoint> closest;
  bool have_closest = false;
  // The exact oracle of the output mesh (Embree BVH on it), built when a metric needs it.
  std::optional<GroundTruth> output_oracle;
  MetricInput in{gt, output, scan, mesh.step_input, mesh.mesh, mesh.covariance_mesh};
  for (const auto* e : selected) {
    const Json params =
        metric_params.contains(e->name) ? metric_params.at(e->name) : Json::object();
    effective[e->name] = e->params.validate(params, "metric_params." + e->name);
    // A metric of the other output kind is skipped with its reason, also when named: one metric
    // list serves chains ending in points and in meshes.
    if (scores_mesh(e->fn.scores) != is_mesh) {
      skipped[e->name] = std::string("scores ") + scores_name(e->fn.scores) + "; this output is " +
                         (is_mesh ? "a mesh" : "points");
      continue;
    }
    if (e->fn.needs_closest && !have_closest) {
      auto t = ctx.phase("metric.closest_points");
      closest = gt.closest_points(output.positions);
      have_closest = true;
      in.closest = &closest;
    }
    if (e->fn.needs_output_oracle && !output_oracle) {
      auto t = ctx.phase("metric.output_oracle");
      output_oracle.emplace(*mesh.mesh, ctx.stream_seed("eval.output_oracle"));
      in.output_oracle = &*output_oracle;
    }
    Json result;
    try {
      auto t = ctx.phase("metric." + e->name);
      result = e->fn(in, params, ctx);
    } catch (const NotApplicable& ex) {
      if (!all) throw;
      skipped[e->name] = ex.what();
      continue;
    }
    for (auto& [key, value] : result.items()) {
      if (key == "histograms") {
        for (auto& [hk, hv] : value.items())
          histograms[hk] = hv;
        continue;
      }
      if (!e->fn.find_key(key))
        throw Error("metric " + e->name + " emitted key '" + key +
                    "' without declaring its direction (metrics/src/registry.cpp)");
      record[key] = value;
    }
  }
  if (!is_mesh) record["output_points"] = output.size();
  // Everything random in the scoring, so that `scanbench eval --from-record` can score the same
  // samples again: the ground truth's surface samples, and (evaluate_mesh) the output mesh's.
  Json scoring = Json::object();
  scoring["seed"] = ctx.seed();
  scoring["metrics"] = metric_names;
  scoring["ground_truth_samples_seed"] = gt.sample_seed();
  scoring["field_voxel_rel"] = gt.options().field_voxel;
  scoring["field_band_voxels"] = gt.options().band_voxels;
  if (output_oracle) scoring["output_oracle_seed"] = output_oracle->sample_seed();
  record["scoring"] = std::move(scoring);
  record["gt_diagonal"] = gt.diagonal();
  record["gt_closed"] = gt.closed();
  record["metric_params"] = std::move(effective);
  record["skipped"] = std::move(skipped);
  record["histograms"] = std::move(histograms);
  return record;
}

Json run_mesh(const GroundTruth& gt, const TriangleMesh& output_mesh,
              const CovarianceMesh* covariance_mesh, const PointCloud* scan,
              const PointCloud* step_input, const std::vector<std::string>& metric_names,
              const Json& metric_params, RunContext& ctx, Eigen::Index samples) {
  output_mesh.validate("evaluate: output mesh");
  if (!(output_mesh.area() > 0.0)) throw InputError("evaluate: output mesh has zero area");
  const PointCloud pts = output_surface_samples(output_mesh, samples, ctx);
  Json r = run(gt, pts, scan, MeshOutput{&output_mesh, covariance_mesh, step_input}, metric_names,
               metric_params, ctx);
  r["output_mesh_samples"] = samples;
  r["scoring"]["output_mesh_samples"] = samples;
  r["scoring"]["output_mesh_samples_seed"] = output_surface_samples_seed(ctx);
  return r;
}

Json score_covariance_mesh(const GroundTruth& gt, const CovarianceMesh& output,
                           const PointCloud* scan, const PointCloud* step_input,
                           const std::vector<std::string>& metric_names, const Json& metric_params,
                           RunContext& ctx, Eigen::Index samples) {
  output.validate("evaluate: output covariance mesh");
  const TriangleMesh mean = output.mean_mesh();
  return run_mesh(gt, mean, &output, scan, step_input, metric_names, metric_params, ctx, samples);
}

}  // namespace

Json evaluate(const GroundTruth& gt, const PointCloud& output, const PointCloud* scan,
              const std::vector<std::string>& metric_names, const Json& metric_params,
              RunContext& ctx) {
  return run(gt, output, scan, MeshOutput{}, metric_names, metric_params, ctx);
}

Json evaluate_mesh(const GroundTruth& gt, const TriangleMesh& output_mesh, const PointCloud* scan,
                   const std::vector<std::string>& metric_names, const Json& metric_params,
                   RunContext& ctx, Eigen::Index samples) {
  return run_mesh(gt, output_mesh, nullptr, scan, nullptr, metric_names, metric_params, ctx,
                  samples);
}

Json evaluate_covariance_mesh(const GroundTruth& gt, const CovarianceMesh& output,
                              const PointCloud* scan, const std::vector<std::string>& metric_names,
                              const Json& metric_params, RunContext& ctx, Eigen::Index samples) {
  return score_covariance_mesh(gt, output, scan, nullptr, metric_names, metric_params, ctx,
                               samples);
}

Json evaluate(const GroundTruth& gt, const StageData& output, DataKind primary,
              const PointCloud* scan, const std::vector<std::string>& metric_names,
              const Json& metric_params, RunContext& ctx, Eigen::Index samples) {
  // A mesh output's points are those the chain carried to its reconstruction (StageData::carry):
  // the step input of surface.input_distance.
  const PointCloud* step_input = output.points.empty() ? nullptr : &output.points;
  switch (primary) {
    case DataKind::CovarianceMesh:
      return score_covariance_mesh(gt, output.require_covariance_mesh("evaluate"), scan, step_input,
                                   metric_names, metric_params, ctx, samples);
    case DataKind::Mesh:
      return run_mesh(gt, output.require_mesh("evaluate"), nullptr, scan, step_input, metric_names,
                      metric_params, ctx, samples);
    case DataKind::Mixture:
      return evaluate(gt, output.require_mixture("evaluate").component_points(), scan, metric_names,
                      metric_params, ctx);
    case DataKind::Points:
      break;
  }
  return evaluate(gt, output.points, scan, metric_names, metric_params, ctx);
}

}  // namespace scanbench::metrics
