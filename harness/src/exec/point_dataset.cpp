// A point dataset's input and point-cloud ground truth (point_dataset.h).
#include "exec/point_dataset.h"

#include <filesystem>

#include "scanbench/core/colmap.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

PointCloud read_input_points(const std::string& path) {
  if (fs::is_directory(path)) return colmap::import_dir(path);
  return read_point_cloud(path);
}

PointTruth read_point_truth(const Json& dataset_params) {
  PointTruth t;
  const std::string file = dataset_params.at("gt_points").get<std::string>();
  const std::string transform = dataset_params.value("gt_transform", std::string());
  t.truth = metrics::transformed(
      read_point_cloud(file), transform.empty()
                                  ? Eigen::Matrix4d::Identity()
                                  : metrics::parse_transform(transform, file + ": gt_transform"));
  if (dataset_params.contains("gt_crop")) {
    t.crop = metrics::parse_crop(dataset_params["gt_crop"].get<std::string>(), file + ": gt_crop");
    t.truth = metrics::cropped(t.truth, *t.crop);
  }
  return t;
}

Json evaluate_on_point_truth(const PointTruth& t, const PointCloud& output_points,
                             const TriangleMesh* output_mesh,
                             const std::vector<std::string>& metric_names,
                             const Json& metric_params, RunContext& ctx) {
  constexpr Eigen::Index kMeshSamples = 100000;  // as metrics::evaluate_mesh
  PointCloud out = output_mesh ? metrics::output_surface_samples(*output_mesh, kMeshSamples, ctx)
                               : output_points;
  if (output_mesh) out.origin = output_mesh->origin;  // the samples are in the mesh's frame
  out = metrics::transformed(out, Eigen::Matrix4d::Identity());
  if (t.crop) out = metrics::cropped(out, *t.crop);
  // Named metrics that need a mesh are skipped here as they are for all metrics.
  std::vector<std::string> names;
  Json skipped = Json::object();
  for (const std::string& n : metric_names) {
    if (metrics::registry().at(n).fn.run_point_truth) {
      names.push_back(n);
    } else {
      skipped[n] = n +
                   ": not applicable: needs a ground-truth mesh (the ground truth is a point "
                   "cloud)";
    }
  }
  if (!metric_names.empty() && names.empty()) {
    Json r = {{"skipped", skipped}};
    return r;
  }
  Json r = metrics::evaluate_point_truth(t.truth, out, names, metric_params, ctx);
  for (const auto& [k, v] : skipped.items())
    r["skipped"][k] = v;
  if (output_mesh) r["output_mesh_samples"] = kMeshSamples;
  return r;
}

}  // namespace scanbench::harness
