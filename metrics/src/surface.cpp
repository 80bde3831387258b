#include "scanbench/metrics/surface.h"

#include <cmath>

#include "scanbench/metrics/chamfer.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/normal_angle.h"
#include "scanbench/metrics/surface_sampling.h"
#include "stats.h"

namespace scanbench::metrics {

std::uint64_t output_surface_samples_seed(const RunContext& ctx) {
  return ctx.stream_seed("eval.mesh_samples");
}

PointCloud output_surface_samples(const TriangleMesh& mesh, Eigen::Index count,
                                  const RunContext& ctx) {
  PointCloud pts = sample_surface(mesh, count, output_surface_samples_seed(ctx));
  pts.properties.clear();
  return pts;
}

namespace {

void require_mesh(const MetricInput& in, const char* name) {
  if (!in.output_mesh) throw NotApplicable(std::string(name) + ": the output is not a mesh");
}

const GroundTruth& oracle(const MetricInput& in, const char* name) {
  require_mesh(in, name);
  if (!in.output_oracle) throw Error(std::string(name) + ": no oracle of the output mesh");
  return *in.output_oracle;
}

}  // namespace

Json surface_chamfer_metric(const MetricInput& in, const ChamferParams& p) {
  const GroundTruth& out = oracle(in, "surface.chamfer");
  if (in.output.empty()) throw InputError("surface.chamfer: no output surface samples");
  Eigen::Index fallbacks = 0;
  const Eigen::VectorXf acc = accuracy_distances(in, p, &fallbacks);
  const PointCloud& samples = in.truth.surface_samples(p.samples);
  const Eigen::VectorXf comp = out.distances(samples.positions, DistancePath::Exact);
  const auto observed = observed_samples(in, samples, p.observed_radius * in.truth.diagonal());
  return chamfer_scores(acc, comp, in.truth.diagonal(), p, fallbacks,
                        observed ? &*observed : nullptr);
}

Json surface_normals_metric(const MetricInput& in, const NormalAngleParams& p) {
  require_mesh(in, "surface.normals");
  return normal_angle_metric(in, p);
}

Json input_distance_metric(const MetricInput& in, const InputDistanceParams& p) {
  const GroundTruth& out = oracle(in, "surface.input_distance");
  const bool of_scan = p.of == "scan";
  if (of_scan && !in.scan) throw NotApplicable("surface.input_distance: no input scan");
  if (!of_scan && !in.step_input) {
    throw NotApplicable(
        "surface.input_distance: of=step_input, but the chain holds no points that its "
        "reconstruction consumed");
  }
  const PointCloud& cloud = of_scan ? *in.scan : *in.step_input;
  Eigen::Matrix3Xf q;
  if (p.skip_outliers && cloud.has_property("outlier")) {
    const Eigen::VectorXf& o = cloud.properties.at("outlier");
    q.resize(3, (o.array() == 0.0f).count());
    Eigen::Index k = 0;
    for (Eigen::Index i = 0; i < cloud.size(); ++i)
      if (o[i] == 0.0f) q.col(k++) = cloud.positions.col(i);
  } else {
    q = cloud.positions;
  }
  if (p.max_truth_distance > 0.0 && q.cols() > 0) {
    // Residual outliers by the ground truth: the points farther from it than the limit.
    const Eigen::VectorXf dt = in.truth.distances(q, DistancePath::Exact);
    const auto limit = static_cast<float>(p.max_truth_distance * in.truth.diagonal());
    Eigen::Index k = 0;
    for (Eigen::Index i = 0; i < q.cols(); ++i)
      if (dt[i] <= limit) q.col(k++) = q.col(i);
    q.conservativeResize(3, k);
  }
  if (q.cols() == 0) {
    throw InputError(std::string("surface.input_distance: the ") +
                     (of_scan ? "scan" : "step input") + " has no (inlier) points");
  }
  const Eigen::VectorXf d = out.distances(q, DistancePath::Exact);
  const double diag = in.truth.diagonal();
  const auto n = static_cast<double>(d.size());
  double sq = 0.0;
  for (Eigen::Index i = 0; i < d.size(); ++i)
    sq += double(d[i]) * d[i];
  Json j = Json::object();
  detail::put_length(j, "input_distance_mean", detail::ordered_sum(d) / n, diag);
  detail::put_length(j, "input_distance_rms", std::sqrt(sq / n), diag);
  detail::put_length(j, "input_distance_max", d.maxCoeff(), diag);
  j["input_distance_points"] = d.size();
  j["histograms"]["input_distance"] =
      detail::histogram(d / static_cast<float>(diag), 0.0, p.hist_max, p.bins, "diag");
  return j;
}

}  // namespace scanbench::metrics
