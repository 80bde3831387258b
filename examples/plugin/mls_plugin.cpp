// An example scanbench plugin (docs/plugins.md): one algorithm and one metric, registered
// exactly as the built-in ones.
//
// smooth.mls: projection onto the moving-least-squares surface of the input points, the simple
// plane-fit variant of point-set surfaces (Alexa et al. 2003, "Computing and rendering point set
// surfaces", sec. 3; the iteration of Adamson and Alexa 2004, "On normals and projection
// operators for surfaces defined by point sets", sec. 4): at the current position x, the
// Gaussian-weighted centroid a(x) = sum w_i p_i / sum w_i, w_i = exp(-|p_i - x|^2 / h^2), and the
// normal n(x) = the smallest eigenvector of the weighted covariance about a(x); x moves to its
// projection on the plane (a(x), n(x)); `iterations` times. Neighbours within 3h (the weight
// there is exp(-9) ~ 1e-4) come from scanbench's kd-tree. Each point's result depends only on the
// input, so the output does not depend on the thread count.
//
// accuracy.p2s_quantiles: the median and 95th percentile of the output points' exact distances
// to the ground-truth surface (the shared closest points, MetricInput::closest), absolute and
// as a fraction of the ground truth's bounding-box diagonal.
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/plugin.h"

namespace {

using scanbench::Json;
using scanbench::PointCloud;

struct MlsParams {
  double h = 0.01;
  int iterations = 3;
  static void declare(scanbench::ParamDeclarer<MlsParams>& d) {
    d.real("h", &MlsParams::h, scanbench::Range::open_min(0.0, 0.5), "diag",
           "Gaussian weight width h (fraction of the input's bounding-box diagonal)");
    d.integer("iterations", &MlsParams::iterations, {1, 50}, "", "plane-fit projections per point");
  }
};

PointCloud mls_project(const PointCloud& in, const MlsParams& p, scanbench::RunContext& ctx) {
  if (in.empty()) throw scanbench::InputError("smooth.mls: no input points");
  const float h = static_cast<float>(p.h) * in.bbox().diagonal();
  if (!(h > 0.0f))
    throw scanbench::InputError("smooth.mls: the input has a zero-size bounding box");
  PointCloud out = in;  // keeps weights, scan ids and properties; positions and normals change
  out.normals.resize(3, in.size());
  scanbench::KdTree tree(in.positions);
  {
    scanbench::RunContext::PhaseTimer t(ctx, "project");
    tbb::parallel_for(Eigen::Index{0}, in.size(), [&](Eigen::Index i) {
      std::vector<std::pair<Eigen::Index, float>> nb;
      Eigen::Vector3f x = in.positions.col(i);
      Eigen::Vector3f n = Eigen::Vector3f::UnitZ();
      for (int it = 0; it < p.iterations; ++it) {
        tree.radius(x, 3.0f * h, nb, /*sorted=*/true);
        if (nb.size() < 3) break;  // too few neighbours for a plane: the point stays
        double wsum = 0.0;
        Eigen::Vector3d a = Eigen::Vector3d::Zero();
        for (const auto& [j, d2] : nb) {
          const double w = std::exp(-static_cast<double>(d2) / (double(h) * h));
          wsum += w;
          a += w * in.positions.col(j).cast<double>();
        }
        a /= wsum;
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& [j, d2] : nb) {
          const double w = std::exp(-static_cast<double>(d2) / (double(h) * h));
          const Eigen::Vector3d d = in.positions.col(j).cast<double>() - a;
          cov += w * d * d.transpose();
        }
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
        const Eigen::Vector3d nd = es.eigenvectors().col(0);  // smallest eigenvalue first
        const Eigen::Vector3d xd = x.cast<double>();
        x = (xd - (xd - a).dot(nd) * nd).cast<float>();
        n = nd.cast<float>();
      }
      // Orient like the input normal where there is one.
      if (in.has_normals() && n.dot(in.normals.col(i)) < 0.0f) n = -n;
      out.positions.col(i) = x;
      out.normals.col(i) = n;
    });
  }
  return out;
}

struct QuantileParams {
  static void declare(scanbench::ParamDeclarer<QuantileParams>&) {}
};

// The q-quantile (nearest rank) of v; v is reordered.
double quantile(std::vector<double>& v, double q) {
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

Json p2s_quantiles(const scanbench::metrics::MetricInput& in, const QuantileParams&) {
  const auto closest = scanbench::metrics::closest_points_of(in);
  if (closest.empty()) throw scanbench::metrics::NotApplicable("accuracy.p2s_quantiles: no points");
  std::vector<double> d;
  d.reserve(closest.size());
  for (const auto& c : closest)
    d.push_back(c.distance);
  const double diag = in.truth.diagonal();
  const double med = quantile(d, 0.5), p95 = quantile(d, 0.95);
  return Json{{"p2s_median", med},
              {"p2s_median_rel", med / diag},
              {"p2s_p95", p95},
              {"p2s_p95_rel", p95 / diag}};
}

}  // namespace

SCANBENCH_PLUGIN(r) {
  using scanbench::metrics::Better;
  r.algorithm<MlsParams>(
      "smooth.mls",
      "MLS projection onto the point-set surface (Alexa et al. 2003 sec. 3; Adamson and Alexa "
      "2004 sec. 4): weighted centroid and weighted-covariance normal with Gaussian weights of "
      "width h, `iterations` plane projections per point; normals = the fitted planes' normals "
      "(example plugin, examples/plugin)",
      mls_project);
  r.metric<QuantileParams>(
      "accuracy.p2s_quantiles",
      "median and 95th percentile of the exact point-to-surface distances to the ground truth "
      "(+ _rel = fraction of the GT diagonal) (example plugin, examples/plugin)",
      scanbench::metrics::Scores::Points,
      {{"p2s_median", Better::Lower},
       {"p2s_median_rel", Better::Lower},
       {"p2s_p95", Better::Lower},
       {"p2s_p95_rel", Better::Lower}},
      p2s_quantiles, scanbench::MetricNeeds{/*closest=*/true});
}
