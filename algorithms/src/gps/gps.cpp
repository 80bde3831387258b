#include "scanbench/algorithms/gps/gps.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

#include "scanbench/core/errors.h"

namespace scanbench::algorithms {

Vector6d vech(const Eigen::Matrix3d& s) {
  Vector6d v;
  v << s(0, 0), s(1, 0), s(2, 0), s(1, 1), s(2, 1), s(2, 2);
  return v;
}

Eigen::Matrix3d unvech(const Vector6d& v) {
  Eigen::Matrix3d s;
  s << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];
  return s;
}

Vector9d gaussian_to_dual(const Eigen::Vector3d& mu, const Eigen::Matrix3d& sigma) {
  const Eigen::Matrix3d inv = sigma.llt().solve(Eigen::Matrix3d::Identity());
  Vector9d q;
  q.head<6>() = vech(inv);
  q.tail<3>() = inv * mu;
  return q;
}

bool dual_to_gaussian(const Vector9d& q, Eigen::Vector3d& mu, Eigen::Matrix3d& sigma) {
  const Eigen::LLT<Eigen::Matrix3d> llt(unvech(q.head<6>()));
  if (llt.info() != Eigen::Success) return false;
  sigma = llt.solve(Eigen::Matrix3d::Identity());
  sigma = 0.5 * (sigma + sigma.transpose()).eval();
  mu = llt.solve(q.tail<3>());
  return true;
}

namespace {

Eigen::Matrix3d cov_at(const CovarianceMesh& m, Eigen::Index i) {
  return unvech(m.covariances.col(i));
}

// Smallest and largest eigenvalue of a symmetric 3x3 matrix (closed form).
std::pair<double, double> eig_range(const Eigen::Matrix3d& s) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(s, Eigen::EigenvaluesOnly);
  return {es.eigenvalues()[0], es.eigenvalues()[2]};
}

}  // namespace

PolygonFaces faces_of(const TriangleMesh& m) {
  PolygonFaces f;
  f.offsets.resize(m.num_faces() + 1);
  f.indices.resize(3 * m.num_faces());
  for (Eigen::Index i = 0; i <= m.num_faces(); ++i)
    f.offsets[i] = static_cast<int>(3 * i);
  for (Eigen::Index i = 0; i < m.num_faces(); ++i)
    for (int k = 0; k < 3; ++k)
      f.indices[3 * i + k] = m.faces(k, i);
  return f;
}

TriangleMesh triangle_mesh_of(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces) {
  TriangleMesh t;
  t.vertices = positions.cast<float>();
  Eigen::Index n = 0;
  for (int f = 0; f < faces.num_faces(); ++f)
    n += faces.size(f) - 2;
  t.faces.resize(3, n);
  n = 0;
  for (int f = 0; f < faces.num_faces(); ++f) {
    const int b = faces.offsets[f];
    for (int k = 1; k + 1 < faces.size(f); ++k)
      t.faces.col(n++) << faces.indices[b], faces.indices[b + k], faces.indices[b + k + 1];
  }
  return t;
}

void subdivide_linear(Eigen::Matrix3Xd& positions, PolygonFaces& faces, SubdivisionScheme scheme,
                      const SubdivideParams& p, std::string_view where) {
  if (!positions.allFinite())
    for (Eigen::Index i = 0; i < positions.cols(); ++i)
      if (!positions.col(i).allFinite())
        throw InputError(fmt::format("{}: vertex {}: position is not finite", where, i));
  const SubdivisionOptions o = p.options(scheme);
  ValueMatrix<3> v = positions;
  subdivide_values<3>(v, faces, p.levels, o, where);
  if (p.limit) v = limit_jets<3>(v, faces, o, where).value;
  positions = std::move(v);
}

CovarianceMesh gp_subdivide(const CovarianceMesh& in, SubdivisionScheme scheme,
                            const SubdivideParams& p, RunContext& ctx, std::string_view where) {
  in.validate(where);
  PolygonFaces faces = in.faces;
  const SubdivisionOptions o = p.options(scheme);
  // Refuse before the dual-space copy is allocated.
  check_subdivision_memory(faces, static_cast<int>(in.means.cols()), p.levels, scheme, 72.0, where);
  ValueMatrix<9> q(9, in.means.cols());
  {
    auto t = ctx.phase("dual_map");
    tbb::parallel_for(Eigen::Index{0}, in.means.cols(), [&](Eigen::Index i) {
      q.col(i) = gaussian_to_dual(in.means.col(i), cov_at(in, i));
    });
  }
  {
    auto t = ctx.phase("subdivide");
    subdivide_values<9>(q, faces, p.levels, o, where);
  }
  if (p.limit) {
    auto t = ctx.phase("limit");
    q = limit_jets<9>(q, faces, o, where).value;
  }
  CovarianceMesh out;
  out.means.resize(3, q.cols());
  out.covariances.resize(6, q.cols());
  {
    auto t = ctx.phase("dual_map");
    tbb::parallel_for(Eigen::Index{0}, q.cols(), [&](Eigen::Index i) {
      Eigen::Vector3d mu;
      Eigen::Matrix3d s;
      // Convex weights keep q in the positive-definite cone (GPS sec. 5); a failure here means
      // round-off at a nearly singular input covariance.
      if (!dual_to_gaussian(q.col(i), mu, s)) {
        mu.setConstant(std::numeric_limits<double>::quiet_NaN());
        s.setZero();
      }
      out.means.col(i) = mu;
      out.covariances.col(i) = vech(s);
    });
  }
  for (Eigen::Index i = 0; i < out.means.cols(); ++i)
    if (!out.means.col(i).allFinite())
      throw InputError(
          fmt::format("{}: refined vertex {}: the dual-space quadric is not positive "
                      "definite (an input covariance is too close to singular)",
                      where, i));
  out.faces = std::move(faces);
  return out;
}

namespace {

// Normal and curvatures from the jets of a surface (Appendix B's first and second forms).
void differential_geometry(const Eigen::Vector3d& mu_u, const Eigen::Vector3d& mu_v,
                           const Eigen::Vector3d& mu_uu, const Eigen::Vector3d& mu_uv,
                           const Eigen::Vector3d& mu_vv, Eigen::Vector3d& n, double& H, double& K) {
  const Eigen::Vector3d c = mu_u.cross(mu_v);
  const double len = c.norm();
  n = len > 0 ? Eigen::Vector3d(c / len) : Eigen::Vector3d::Zero();
  const double E = mu_u.dot(mu_u), F = mu_u.dot(mu_v), G = mu_v.dot(mu_v);
  const double L = mu_uu.dot(n), M = mu_uv.dot(n), N = mu_vv.dot(n);
  const double det = E * G - F * F;
  if (!(det > 0)) {
    H = K = 0;
    return;
  }
  K = (L * N - M * M) / det;
  H = -(E * N - 2 * F * M + G * L) / (2 * det);
}

// Curvature at non-regular vertices: mean over regular neighbours (flagged by kind).
void fill_irregular_curvature(SurfaceAnalysis& a, const PolygonFaces& faces) {
  const auto nv = a.positions.cols();
  std::vector<double> hs(nv, 0), ks(nv, 0);
  std::vector<int> cnt(nv, 0);
  for (int f = 0; f < faces.num_faces(); ++f)
    for (int k = faces.offsets[f]; k < faces.offsets[f + 1]; ++k) {
      const int v = faces.indices[k];
      const int w = faces.indices[k + 1 == faces.offsets[f + 1] ? faces.offsets[f] : k + 1];
      for (auto [x, y] : {std::pair{v, w}, std::pair{w, v}})
        if (a.kind[x] != VertexKind::Regular && a.kind[y] == VertexKind::Regular) {
          hs[x] += a.mean_curvature[y];
          ks[x] += a.gaussian_curvature[y];
          ++cnt[x];
        }
    }
  for (Eigen::Index v = 0; v < nv; ++v)
    if (a.kind[v] != VertexKind::Regular) {
      a.mean_curvature[v] = cnt[v] ? hs[v] / cnt[v] : 0.0;
      a.gaussian_curvature[v] = cnt[v] ? ks[v] / cnt[v] : 0.0;
    }
}

SurfaceAnalysis allocate(Eigen::Index nv) {
  SurfaceAnalysis a;
  a.positions.resize(3, nv);
  a.normals.resize(3, nv);
  a.mean_curvature.resize(nv);
  a.gaussian_curvature.resize(nv);
  return a;
}

}  // namespace

SurfaceAnalysis linear_limit_analysis(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces,
                                      const SubdivisionOptions& options, std::string_view where) {
  const LimitJets<3> j = limit_jets<3>(positions, faces, options, where);
  SurfaceAnalysis a = allocate(positions.cols());
  a.kind = j.kind;
  a.positions = j.value;
  for (Eigen::Index v = 0; v < positions.cols(); ++v) {
    Eigen::Vector3d n;
    double H, K;
    differential_geometry(j.du.col(v), j.dv.col(v), j.duu.col(v), j.duv.col(v), j.dvv.col(v), n, H,
                          K);
    a.normals.col(v) = n;
    a.mean_curvature[v] = H;
    a.gaussian_curvature[v] = K;
  }
  fill_irregular_curvature(a, faces);
  return a;
}

SurfaceAnalysis gp_limit_analysis(const CovarianceMesh& m, const SubdivisionOptions& options,
                                  std::string_view where) {
  m.validate(where);
  const PolygonFaces& faces = m.faces;
  ValueMatrix<9> q(9, m.means.cols());
  for (Eigen::Index i = 0; i < m.means.cols(); ++i)
    q.col(i) = gaussian_to_dual(m.means.col(i), cov_at(m, i));
  const LimitJets<9> j = limit_jets<9>(q, faces, options, where);
  SurfaceAnalysis a = allocate(q.cols());
  a.kind = j.kind;
  for (Eigen::Index v = 0; v < q.cols(); ++v) {
    Eigen::Vector3d mu;
    Eigen::Matrix3d S;
    if (!dual_to_gaussian(j.value.col(v), mu, S))
      throw InputError(
          fmt::format("{}: vertex {}: limit quadric is not positive definite", where, v));
    // Appendix B: mu_u = Sigma (qbar_u - [qq_u] mu), and the second derivatives.
    auto lin = [](const auto& col) -> Eigen::Vector3d { return col.template tail<3>(); };
    auto quad = [](const auto& col) -> Eigen::Matrix3d { return unvech(col.template head<6>()); };
    const Eigen::Matrix3d Qu = quad(j.du.col(v)), Qv = quad(j.dv.col(v));
    const Eigen::Vector3d mu_u = S * (lin(j.du.col(v)) - Qu * mu);
    const Eigen::Vector3d mu_v = S * (lin(j.dv.col(v)) - Qv * mu);
    const Eigen::Vector3d mu_uu =
        S * (lin(j.duu.col(v)) - quad(j.duu.col(v)) * mu - 2.0 * Qu * mu_u);
    const Eigen::Vector3d mu_vv =
        S * (lin(j.dvv.col(v)) - quad(j.dvv.col(v)) * mu - 2.0 * Qv * mu_v);
    const Eigen::Vector3d mu_uv =
        S * (lin(j.duv.col(v)) - quad(j.duv.col(v)) * mu - Qu * mu_v - Qv * mu_u);
    Eigen::Vector3d n;
    double H, K;
    differential_geometry(mu_u, mu_v, mu_uu, mu_uv, mu_vv, n, H, K);
    a.positions.col(v) = mu;
    a.normals.col(v) = n;
    a.mean_curvature[v] = H;
    a.gaussian_curvature[v] = K;
  }
  fill_irregular_curvature(a, faces);
  return a;
}

CovarianceMesh infer_covariances(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces,
                                 const InferenceParams& p, std::string_view where) {
  const Eigen::Index nv = positions.cols();
  for (Eigen::Index i = 0; i < nv; ++i)
    if (!positions.col(i).allFinite())
      throw InputError(fmt::format("{}: vertex {}: position is not finite", where, i));
  // Connectivity checks (manifold, orientation) as for subdivision: zero levels.
  {
    ValueMatrix<3> v = positions;
    PolygonFaces f = faces;
    subdivide_values<3>(v, f, 0, {SubdivisionScheme::CatmullClark, LoopBeta::Loop}, where);
  }
  const double diag = (positions.rowwise().maxCoeff() - positions.rowwise().minCoeff()).norm();
  const double s0 = p.sigma_0 * diag;
  const bool lambda_bias = p.bias == "lambda_max";
  auto biased = [&](const Eigen::Matrix3d& c) -> Eigen::Matrix3d {
    const double b = lambda_bias ? p.lambda_factor * eig_range(c).second : s0 * s0;
    return c + b * Eigen::Matrix3d::Identity();
  };
  auto population_cov = [&](const std::vector<int>& idx) -> Eigen::Matrix3d {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (int i : idx)
      m += positions.col(i);
    m /= static_cast<double>(idx.size());
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (int i : idx) {
      const Eigen::Vector3d d = positions.col(i) - m;
      c += d * d.transpose();
    }
    return c / static_cast<double>(idx.size());
  };
  CovarianceMesh out;
  out.means = positions;
  out.covariances.resize(6, nv);
  out.faces = faces;
  if (p.method == "isotropic") {
    // sigma_0^2 I at every vertex: by eq. 14 the GP scheme is then the linear one (the check of
    // `scanbench claims`, configs/claims/gps-eq14-isotropic-linear.json).
    for (Eigen::Index i = 0; i < nv; ++i)
      out.covariances.col(i) = vech(Eigen::Matrix3d(s0 * s0 * Eigen::Matrix3d::Identity()));
    return out;
  }
  if (p.method == "vertex") {
    std::vector<std::vector<int>> ring(nv);
    for (Eigen::Index i = 0; i < nv; ++i)
      ring[i].push_back(static_cast<int>(i));
    for (int f = 0; f < faces.num_faces(); ++f)
      for (int k = faces.offsets[f]; k < faces.offsets[f + 1]; ++k) {
        const int v = faces.indices[k];
        const int w = faces.indices[k + 1 == faces.offsets[f + 1] ? faces.offsets[f] : k + 1];
        ring[v].push_back(w);
        ring[w].push_back(v);
      }
    for (Eigen::Index i = 0; i < nv; ++i) {
      auto& r = ring[i];
      std::sort(r.begin() + 1, r.end());
      r.erase(std::unique(r.begin() + 1, r.end()), r.end());
      out.covariances.col(i) = vech(biased(population_cov(r)));
    }
  } else {
    std::vector<Eigen::Matrix3d> info(nv, Eigen::Matrix3d::Zero());
    std::vector<int> idx;
    for (int f = 0; f < faces.num_faces(); ++f) {
      idx.assign(faces.indices.begin() + faces.offsets[f],
                 faces.indices.begin() + faces.offsets[f + 1]);
      const Eigen::Matrix3d inv =
          biased(population_cov(idx)).llt().solve(Eigen::Matrix3d::Identity());
      for (int v : idx)
        info[v] += inv;
    }
    for (Eigen::Index i = 0; i < nv; ++i) {
      // A vertex in no face keeps the isotropic bandwidth (eq. 17 with only itself).
      const Eigen::Matrix3d s =
          info[i].isZero(0) ? Eigen::Matrix3d(s0 * s0 * Eigen::Matrix3d::Identity())
                            : Eigen::Matrix3d(info[i].llt().solve(Eigen::Matrix3d::Identity()));
      out.covariances.col(i) = vech(0.5 * (s + s.transpose()));
    }
  }
  out.validate(where);
  return out;
}

}  // namespace scanbench::algorithms

namespace scanbench::algorithms {

namespace {

StageData linear_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx,
                       SubdivisionScheme scheme, std::string_view name) {
  const TriangleMesh& m = in.require_mesh(name);
  m.validate(name);
  Eigen::Matrix3Xd x = m.vertices.cast<double>();
  PolygonFaces f = faces_of(m);
  {
    auto t = ctx.phase("subdivide");
    subdivide_linear(x, f, scheme, p, name);
  }
  StageData out;
  out.mesh = triangle_mesh_of(x, f);
  return out;
}

StageData gp_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx,
                   SubdivisionScheme scheme, std::string_view name) {
  StageData out;
  out.covariance_mesh = gp_subdivide(in.require_covariance_mesh(name), scheme, p, ctx, name);
  out.mesh = out.covariance_mesh->mean_mesh();
  return out;
}

}  // namespace

StageData subdivide_loop_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx) {
  return linear_stage(in, p, ctx, SubdivisionScheme::Loop, "subdivide.loop");
}
StageData subdivide_catmull_clark_stage(const StageData& in, const SubdivideParams& p,
                                        RunContext& ctx) {
  return linear_stage(in, p, ctx, SubdivisionScheme::CatmullClark, "subdivide.catmull_clark");
}
StageData gp_loop_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx) {
  return gp_stage(in, p, ctx, SubdivisionScheme::Loop, "subdivide.gp_loop");
}
StageData gp_catmull_clark_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx) {
  return gp_stage(in, p, ctx, SubdivisionScheme::CatmullClark, "subdivide.gp_catmull_clark");
}
StageData infer_covariances_stage(const StageData& in, const InferenceParams& p, RunContext& ctx) {
  const char* name = "subdivide.infer_covariances";
  const TriangleMesh& m = in.require_mesh(name);
  m.validate(name);
  auto t = ctx.phase("infer");
  StageData out;
  out.covariance_mesh = infer_covariances(m.vertices.cast<double>(), faces_of(m), p, name);
  return out;
}

}  // namespace scanbench::algorithms
