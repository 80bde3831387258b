#include "scanbench/algorithms/csw.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "mixture_index.h"
#include "projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms {

namespace {

using Eigen::Index;

struct Weighted {
  Index s;
  float w;
};

// The point at angle t * angle(n, m) from n towards m on their great circle (n, m unit).
Eigen::Vector3f towards(const Eigen::Vector3f& n, const Eigen::Vector3f& m, float t) {
  const float c = std::clamp(n.dot(m), -1.0f, 1.0f);
  const float theta = std::acos(c);
  if (theta < 1e-4f) return ((1.0f - t) * n + t * m).normalized();
  const float s = std::sin(theta);
  return ((std::sin((1.0f - t) * theta) / s) * n + (std::sin(t * theta) / s) * m).normalized();
}

}  // namespace

Eigen::Matrix3Xf csw_normals(const GaussianMixture& m, const Eigen::Matrix3Xf& particles,
                             const Eigen::Matrix3Xf& initial, double normal_h, int iterations,
                             RunContext& ctx) {
  constexpr const char* stage = "normals.csw";
  if (m.size() == 0) throw InputError(fmt::format("{}: empty mixture", stage));
  if (!m.has_normal_axes())
    throw InputError(fmt::format("{}: the mixture carries no normal axes", stage));
  const Index n = particles.cols();
  if (initial.cols() != 0 && initial.cols() != n) {
    throw InputError(
        fmt::format("{}: {} initial normals for {} particles", stage, initial.cols(), n));
  }
  // Per component: Lambda^-1 and the eq. 24 prefactor for the spatial kernel of width normal_h.
  const Index k = m.size();
  const double var = normal_h * normal_h / 32.0;
  std::vector<Eigen::Matrix3f> inv(static_cast<std::size_t>(k));
  std::vector<float> coef(static_cast<std::size_t>(k));
  for (Index s = 0; s < k; ++s) {
    const Eigen::Matrix3d cov = m.covariance(s).cast<double>();
    const Eigen::Matrix3d lambda = cov + var * Eigen::Matrix3d::Identity();
    inv[static_cast<std::size_t>(s)] = lambda.inverse().cast<float>();
    coef[static_cast<std::size_t>(s)] =
        static_cast<float>(m.weights(s) * std::pow(var, 1.5) / std::sqrt(lambda.determinant()));
  }
  const detail::MixtureGrid index(m, var, var);
  const std::vector<float> radii = index.radii(var);
  std::array<float, 3> wk, s2k;
  for (int j = 0; j < 3; ++j) {
    wk[j] = static_cast<float>(kClopFitWeights[j]);
    s2k[j] = static_cast<float>(kClopFitSigmas[j] * kClopFitSigmas[j] * M_PI * M_PI);  // H = pi
  }

  Eigen::Matrix3Xf out(3, n);
  auto timer = ctx.phase("csw");
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 64), [&](const tbb::blocked_range<Index>& r) {
    std::vector<detail::GridRange> ranges;
    std::vector<Index> ids;
    std::vector<float> d2;
    std::vector<Weighted> near;
    for (Index i = r.begin(); i != r.end(); ++i) {
      const Eigen::Vector3f q = particles.col(i);
      near.clear();
      ids.clear();
      d2.clear();
      index.gather(q, radii, ranges, ids, d2);
      for (const Index s : ids) {
        const auto us = static_cast<std::size_t>(s);
        const Eigen::Vector3f d = m.means.col(s) - q;
        const float w = coef[us] * std::exp(-0.5f * d.dot(inv[us] * d));
        if (w > 0.0f) near.push_back({s, w});
      }
      // Components whose spatial weight is below 1e-6 of the largest one are negligible for the
      // weighted median and would only cost time (large flat Gaussians reach far).
      float wmax = 0.0f;
      for (const auto& e : near)
        wmax = std::max(wmax, e.w);
      near.erase(std::remove_if(near.begin(), near.end(),
                                [&](const Weighted& e) { return e.w < 1e-6f * wmax; }),
                 near.end());
      if (near.empty()) {
        out.col(i) = initial.cols() ? Eigen::Vector3f(initial.col(i)) : Eigen::Vector3f::UnitZ();
        continue;
      }
      Eigen::Vector3f nrm;
      if (initial.cols()) {
        nrm = initial.col(i).normalized();
      } else {
        // Continuous PCA: second moment of the kernel-weighted mixture about its weighted mean.
        float wsum = 0.0f;
        Eigen::Vector3f c = Eigen::Vector3f::Zero();
        for (const auto& e : near) {
          c += e.w * m.means.col(e.s);
          wsum += e.w;
        }
        c /= wsum;
        Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
        for (const auto& e : near) {
          const Eigen::Vector3f d = m.means.col(e.s) - c;
          cov += e.w * (m.covariance(e.s) + d * d.transpose());
        }
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> es(cov / wsum);
        nrm = es.eigenvectors().col(0).normalized();
      }
      const Eigen::Vector3f start = nrm;
      for (int it = 0; it < iterations; ++it) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (const auto& e : near) {
          Eigen::Vector3f axis = m.normal_axes.col(e.s);
          if (axis.dot(nrm) < 0.0f) axis = -axis;  // unoriented: the closer pole
          const float dg = std::acos(std::clamp(axis.dot(nrm), -1.0f, 1.0f));
          const float spread = std::max(m.normal_spreads(e.s), 0.0f);
          for (int j = 0; j < 3; ++j) {
            const float lambda = spread + s2k[j];
            const float t = s2k[j] / lambda;                                       // eq. 34
            const float w = e.w * wk[j] * t * std::exp(-0.5f * dg * dg / lambda);  // eq. 32
            sum += w * towards(nrm, axis, t);                                      // eq. 33
          }
        }
        const float len = sum.norm();
        if (!(len > 0.0f)) break;
        nrm = sum / len;
      }
      out.col(i) = nrm.dot(start) < 0.0f ? Eigen::Vector3f(-nrm) : nrm;
    }
  });
  return out;
}

PointCloud csw(const StageData& data, const CswParams& p, RunContext& ctx) {
  constexpr const char* stage = "normals.csw";
  const PointCloud& in = data.points;
  in.validate(stage);
  if (in.empty()) throw InputError(fmt::format("{}: the input has no points", stage));
  const GaussianMixture& mixture =
      data.require_mixture(fmt::format("{} (chain mixture.hem -> normals.csw)", stage));
  const double diag = in.bbox().diagonal();
  if (!(diag > 0.0))
    throw InputError(fmt::format("{}: the input's bounding box has a zero diagonal", stage));
  const double h = p.h * diag;
  Eigen::Matrix3Xf q;
  Eigen::Matrix3Xf initial;
  if (p.resample) {
    ClopParams cp;
    static_cast<ClopProjectionSettings&>(cp) = p;
    cp.weighted = p.weighted;
    const Index m = kernels::particle_count(p.particles, in.size(), stage);
    {
      auto timer = ctx.phase("init");
      q = kernels::initial_particles(in.positions, m, ctx.stream_seed("particles"),
                                     static_cast<float>(0.01 * h));
    }
    clop_project(mixture, q, cp, h, ctx);
  } else {
    q = in.positions;
    if (in.has_normals()) initial = in.normals;
  }
  Eigen::Matrix3Xf normals =
      csw_normals(mixture, q, initial, p.normal_h * diag, p.csw_iterations, ctx);

  // Orientation from the nearest input point's sensor or normal (see csw.h).
  const bool sensors = in.has_scan_ids() && in.sensor_origins.cols() > 0;
  if (sensors || in.has_normals()) {
    const KdTree tree(in.positions);
    tbb::parallel_for(tbb::blocked_range<Index>(0, q.cols(), 256), [&](const auto& r) {
      for (Index i = r.begin(); i != r.end(); ++i) {
        const Index j = p.resample ? tree.nearest(q.col(i)) : i;
        const Eigen::Vector3f ref =
            sensors ? Eigen::Vector3f(in.sensor_origins.col(in.scan_ids(j)) - q.col(i))
                    : Eigen::Vector3f(in.normals.col(j));
        if (normals.col(i).dot(ref) < 0.0f) normals.col(i) *= -1.0f;
      }
    });
  }
  PointCloud out;
  out.positions = std::move(q);
  out.normals = std::move(normals);
  return out;
}

}  // namespace scanbench::algorithms
