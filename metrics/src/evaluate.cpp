#include "scanbench/metrics/evaluate.h"

#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface_sampling.h"

namespace scanbench::metrics {

namespace {

bool needs_closest(const std::string& name) {
  return name == "accuracy.p2plane" || name == "accuracy.chamfer" || name == "normals.angle" ||
         name == "outliers.residue";
}

Json run(const GroundTruth& gt, const PointCloud& output, const PointCloud* scan,
         const TriangleMesh* output_mesh, const std::vector<std::string>& metric_names,
         const Json& metric_params, RunContext& ctx) {
  output.validate("evaluate: output");
  if (output.empty()) throw InputError("evaluate: output has no points");
  if (scan) scan->validate("evaluate: scan");
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

  std::vector<ClosestPoint> closest;
  bool have_closest = false;
  MetricInput in{gt, output, scan, output_mesh, nullptr};
  for (const auto* e : selected) {
    const Json params =
        metric_params.contains(e->name) ? metric_params.at(e->name) : Json::object();
    effective[e->name] = e->params.validate(params, "metric_params." + e->name);
    if (needs_closest(e->name) && !have_closest) {
      auto t = ctx.phase("metric.closest_points");
      closest = gt.closest_points(output.positions);
      have_closest = true;
      in.closest = &closest;
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
      } else {
        record[key] = value;
      }
    }
  }
  record["output_points"] = output.size();
  record["gt_diagonal"] = gt.diagonal();
  record["gt_closed"] = gt.closed();
  record["metric_params"] = std::move(effective);
  record["skipped"] = std::move(skipped);
  record["histograms"] = std::move(histograms);
  return record;
}

}  // namespace

Json evaluate(const GroundTruth& gt, const PointCloud& output, const PointCloud* scan,
              const std::vector<std::string>& metric_names, const Json& metric_params,
              RunContext& ctx) {
  return run(gt, output, scan, nullptr, metric_names, metric_params, ctx);
}

Json evaluate_mesh(const GroundTruth& gt, const TriangleMesh& output_mesh, const PointCloud* scan,
                   const std::vector<std::string>& metric_names, const Json& metric_params,
                   RunContext& ctx, Eigen::Index samples) {
  output_mesh.validate("evaluate: output mesh");
  PointCloud pts = sample_surface(output_mesh, samples, ctx.stream_seed("eval.mesh_samples"));
  pts.properties.clear();
  Json r = run(gt, pts, scan, &output_mesh, metric_names, metric_params, ctx);
  r["output_mesh_samples"] = samples;
  return r;
}

}  // namespace scanbench::metrics
