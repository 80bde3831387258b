#include "scanbench/metrics/chamfer.h"

#include <tbb/parallel_for.h>

#include <cmath>

#include "scanbench/core/kdtree.h"
#include "stats.h"

namespace scanbench::metrics {

Eigen::VectorXf accuracy_distances(const MetricInput& in, const ChamferParams& p,
                                   Eigen::Index* fallbacks) {
  const Eigen::Index n = in.output.size();
  *fallbacks = 0;
  if (p.path == "field")
    return in.truth.distances(in.output.positions, DistancePath::Field, fallbacks);
  if (in.closest) {
    Eigen::VectorXf acc(n);
    for (Eigen::Index i = 0; i < n; ++i)
      acc[i] = (*in.closest)[static_cast<std::size_t>(i)].distance;
    return acc;
  }
  return in.truth.distances(in.output.positions, DistancePath::Exact);
}

Json chamfer_scores(const Eigen::VectorXf& acc, const Eigen::VectorXf& comp, double diag,
                    const ChamferParams& p, Eigen::Index fallbacks) {
  const double tau = p.tau * diag;
  const auto n = static_cast<double>(acc.size());
  const double accuracy = detail::ordered_sum(acc) / n;
  const double completeness = detail::ordered_sum(comp) / static_cast<double>(comp.size());
  const double precision = static_cast<double>((acc.array() < tau).count()) / n;
  const double recall = static_cast<double>((comp.array() < tau).count()) / comp.size();
  const double fscore =
      precision + recall > 0.0 ? 2.0 * precision * recall / (precision + recall) : 0.0;

  Json j = Json::object();
  detail::put_length(j, "accuracy", accuracy, diag);
  detail::put_length(j, "completeness", completeness, diag);
  detail::put_length(j, "chamfer", accuracy + completeness, diag);
  detail::put_length(j, "hausdorff", std::max(acc.maxCoeff(), comp.maxCoeff()), diag);
  j["precision"] = precision;
  j["recall"] = recall;
  j["fscore"] = fscore;
  detail::put_length(j, "fscore_tau", tau, diag);
  j["chamfer_samples"] = comp.size();
  j["chamfer_field_fallbacks"] = fallbacks;
  const float inv = static_cast<float>(1.0 / diag);
  j["histograms"]["accuracy"] = detail::histogram(acc * inv, 0.0, p.hist_max, p.bins, "diag");
  j["histograms"]["completeness"] = detail::histogram(comp * inv, 0.0, p.hist_max, p.bins, "diag");
  return j;
}

Json chamfer_metric(const MetricInput& in, const ChamferParams& p) {
  if (in.output.empty()) throw InputError("accuracy.chamfer: output has no points");
  Eigen::Index fallbacks = 0;
  const Eigen::VectorXf acc = accuracy_distances(in, p, &fallbacks);

  const PointCloud& samples = in.truth.surface_samples(p.samples);
  const KdTree tree(in.output.positions);
  Eigen::VectorXf comp(samples.size());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, samples.size(), 1024),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
                        float d2 = 0.0f;
                        tree.nearest(samples.positions.col(i), &d2);
                        comp[i] = std::sqrt(d2);
                      }
                    });
  return chamfer_scores(acc, comp, in.truth.diagonal(), p, fallbacks);
}

}  // namespace scanbench::metrics
