#include "scanbench/metrics/conventions.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <vector>

#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/outlier_residue.h"
#include "stats.h"

namespace scanbench::metrics {

namespace {

using V3 = Eigen::Vector3d;

// score-denoise models/utils.py normalize_sphere: c = (max + min) / 2, s = max_i |p_i - c|.
struct Sphere {
  V3 c = V3::Zero();
  double s = 1.0;
};

Sphere normalize_sphere(const Eigen::Matrix3Xf& p) {
  const Eigen::Matrix3Xd d = p.cast<double>();
  Sphere n;
  n.c = (d.rowwise().maxCoeff() + d.rowwise().minCoeff()) / 2.0;
  n.s = (d.colwise() - n.c).colwise().norm().maxCoeff();
  if (!(n.s > 0.0)) throw InputError("convention.scoredenoise: the normalising cloud is one point");
  return n;
}

Eigen::Matrix3Xd normalized(const Eigen::Matrix3Xf& p, const Sphere& n) {
  return (p.cast<double>().colwise() - n.c) / n.s;
}

// PyTorch3D's constants (csrc/utils/geometry_utils.h, pytorch3d/csrc/utils/vec3.h).
constexpr double kEpsilon = 1e-8;   // BarycentricCoords3Forward's denominator, degenerate edges
constexpr double kVEpsilon = 1e-8;  // the normal's normalisation

/// PointLine3DistanceForward: squared distance from p to the segment v0 v1.
double point_segment2(const V3& p, const V3& v0, const V3& v1) {
  const V3 e = v1 - v0;
  const double l2 = e.squaredNorm();
  if (l2 <= kEpsilon) return (p - v1).squaredNorm();
  const double t = std::clamp(e.dot(p - v0) / l2, 0.0, 1.0);
  return (p - (v0 + t * e)).squaredNorm();
}

/// PointTriangle3DistanceForward with IsInsideTriangle's area threshold.
double point_triangle2(const V3& p, const V3& v0, const V3& v1, const V3& v2, double min_area) {
  V3 normal = (v2 - v0).cross(v1 - v0);
  const double norm_normal = normal.norm();
  normal /= norm_normal + kVEpsilon;
  const double t = (v0 - p).dot(normal);
  const V3 p0 = p + t * normal;
  bool inside = false;
  if (0.5 * norm_normal >= min_area) {  // AreaOfTriangle: the same cross product's length / 2
    // BarycentricCoords3Forward
    const V3 a = v1 - v0, b = v2 - v0, c = p0 - v0;
    const double d00 = a.dot(a), d01 = a.dot(b), d11 = b.dot(b), d20 = c.dot(a), d21 = c.dot(b);
    const double denom = d00 * d11 - d01 * d01 + kEpsilon;
    const double w1 = (d11 * d20 - d01 * d21) / denom, w2 = (d00 * d21 - d01 * d20) / denom;
    const double w0 = 1.0 - w1 - w2;
    inside = 0.0 <= w0 && w0 <= 1.0 && 0.0 <= w1 && w1 <= 1.0 && 0.0 <= w2 && w2 <= 1.0;
  }
  if (inside && norm_normal > kEpsilon) return t * t;
  return std::min(
      {point_segment2(p, v0, v1), point_segment2(p, v0, v2), point_segment2(p, v1, v2)});
}

/// A relative slack on kd-tree radii, for the float tree against double distances.
float search_radius(double r) {
  return static_cast<float>(r * (1.0 + 1e-5) + 1e-7);
}

double mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v)
    s += x;
  return s / static_cast<double>(v.size());
}

/// For every column of `from`, the squared distance to its nearest column of `to`, in double,
/// and that column's index (the lower on a tie): the float kd-tree's nearest, then every column
/// within its distance (plus float slack) measured in double, so the nearest is exact.
void nearest_points(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                    std::vector<double>& dist2, std::vector<Eigen::Index>& index) {
  const Eigen::Matrix3Xf tf = to.cast<float>();
  const KdTree tree(tf);
  dist2.assign(static_cast<std::size_t>(from.cols()), 0.0);
  index.assign(static_cast<std::size_t>(from.cols()), 0);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, from.cols(), 1024),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      std::vector<std::pair<Eigen::Index, float>> near;
                      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
                        const V3 q = from.col(i);
                        const Eigen::Vector3f qf = q.cast<float>();
                        Eigen::Index best = tree.nearest(qf);
                        double d = (to.col(best) - q).squaredNorm();
                        tree.radius(qf, search_radius(std::sqrt(d)), near);
                        for (const auto& [j, unused] : near) {
                          const double dj = (to.col(j) - q).squaredNorm();
                          if (dj < d || (dj == d && j < best)) {
                            d = dj;
                            best = j;
                          }
                        }
                        dist2[static_cast<std::size_t>(i)] = d;
                        index[static_cast<std::size_t>(i)] = best;
                      }
                    });
}

}  // namespace

ScoreDenoiseScores scoredenoise_scores(const Eigen::Matrix3Xf& gen, const Eigen::Matrix3Xf& ref,
                                       const TriangleMesh& mesh, double min_triangle_area) {
  if (gen.cols() == 0 || ref.cols() == 0)
    throw InputError("convention.scoredenoise: an empty point cloud");
  if (mesh.num_faces() == 0) throw InputError("convention.scoredenoise: a mesh without faces");
  ScoreDenoiseScores s;
  {  // cd_sph and hd_sph: both clouds in the reference's unit sphere.
    const Sphere n = normalize_sphere(ref);
    const Eigen::Matrix3Xd g = normalized(gen, n), r = normalized(ref, n);
    std::vector<double> ab, ba;
    std::vector<Eigen::Index> unused;
    nearest_points(g, r, ab, unused);
    nearest_points(r, g, ba, unused);
    s.cd_sph = mean(ab) + mean(ba);
    s.hd_sph =
        std::max(*std::max_element(ab.begin(), ab.end()), *std::max_element(ba.begin(), ba.end()));
  }
  // p2f: both in the unit sphere of the mesh's vertices.
  const Sphere n = normalize_sphere(mesh.vertices);
  const Eigen::Matrix3Xd p = normalized(gen, n), v = normalized(mesh.vertices, n);
  const Eigen::Index nf = mesh.num_faces();
  Eigen::Matrix3Xf centroid(3, nf);
  std::vector<double> reach(static_cast<std::size_t>(nf));  // farthest corner from the centroid
  double reach_max = 0.0;
  for (Eigen::Index f = 0; f < nf; ++f) {
    const V3 c =
        (v.col(mesh.faces(0, f)) + v.col(mesh.faces(1, f)) + v.col(mesh.faces(2, f))) / 3.0;
    centroid.col(f) = c.cast<float>();
    double r = 0.0;
    for (int k = 0; k < 3; ++k)
      r = std::max(r, (v.col(mesh.faces(k, f)) - c).norm());
    reach[static_cast<std::size_t>(f)] = r;
    reach_max = std::max(reach_max, r);
  }
  const auto face_distance = [&](const V3& q, Eigen::Index f) {
    return point_triangle2(q, v.col(mesh.faces(0, f)), v.col(mesh.faces(1, f)),
                           v.col(mesh.faces(2, f)), min_triangle_area);
  };
  // A face's distance is at least (|q - centroid| - reach)^2, so once one face gives U every
  // face that can do better has its centroid within sqrt(U) + reach of q.
  const KdTree faces(centroid);
  std::vector<double> point_to_face(static_cast<std::size_t>(p.cols()));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, p.cols(), 256),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      std::vector<std::pair<Eigen::Index, float>> near;
                      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
                        const V3 q = p.col(i);
                        double best = face_distance(q, faces.nearest(q.cast<float>()));
                        faces.radius(q.cast<float>(), search_radius(std::sqrt(best) + reach_max),
                                     near);
                        for (const auto& [f, d2] : near)
                          best = std::min(best, face_distance(q, f));
                        point_to_face[static_cast<std::size_t>(i)] = best;
                      }
                    });
  const Eigen::Matrix3Xf pf = p.cast<float>();
  const KdTree points(pf);
  std::vector<double> face_to_point(static_cast<std::size_t>(nf));
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, nf, 256), [&](const tbb::blocked_range<Eigen::Index>& r) {
        std::vector<std::pair<Eigen::Index, float>> near;
        for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
          const Eigen::Vector3f c = centroid.col(f);
          double best = face_distance(p.col(points.nearest(c)), f);
          points.radius(c, search_radius(std::sqrt(best) + reach[static_cast<std::size_t>(f)]),
                        near);
          for (const auto& [i, d2] : near)
            best = std::min(best, face_distance(p.col(i), f));
          face_to_point[static_cast<std::size_t>(f)] = best;
        }
      });
  s.p2f = mean(point_to_face) + mean(face_to_point);
  return s;
}

Json scoredenoise_metric(const MetricInput& in, const ScoreDenoiseParams& p) {
  const Eigen::Index n = p.reference_points > 0 ? p.reference_points : in.output.size();
  const PointCloud& ref = in.truth.surface_samples(n);
  const ScoreDenoiseScores s =
      scoredenoise_scores(in.output.positions, ref.positions, in.truth.mesh(), p.min_triangle_area);
  Json j = Json::object();
  j["sd_cd_sph_x1e4"] = s.cd_sph * 1e4;
  j["sd_p2f_x1e4"] = s.p2f * 1e4;
  j["sd_hd_sph"] = s.hd_sph;
  j["sd_reference_points"] = n;
  return j;
}

namespace {

/// Mean of |n_from . n_to(nearest)| with both normals normalised (eval.py's distance_p2p).
double normal_dot_mean(const Eigen::Matrix3Xf& from, const Eigen::Matrix3Xf& to,
                       const std::vector<Eigen::Index>& index) {
  double sum = 0.0;
  for (Eigen::Index i = 0; i < from.cols(); ++i) {
    const V3 a = from.col(i).cast<double>().normalized();
    const V3 b = to.col(index[static_cast<std::size_t>(i)]).cast<double>().normalized();
    sum += std::abs(a.dot(b));
  }
  return sum / static_cast<double>(from.cols());
}

}  // namespace

DsrScores dsr_scores(const PointCloud& output, const PointCloud& truth) {
  if (output.empty() || truth.empty()) throw InputError("convention.dsr: an empty point cloud");
  if (!output.has_normals() || !truth.has_normals())
    throw InputError("convention.dsr: the output samples and the ground-truth points need normals");
  const Eigen::Matrix3Xd t = truth.positions.cast<double>(), o = output.positions.cast<double>();
  std::vector<double> comp, acc;  // squared, then Euclidean (cKDTree's distances)
  std::vector<Eigen::Index> comp_index, acc_index;
  nearest_points(t, o, comp, comp_index);  // completeness
  nearest_points(o, t, acc, acc_index);    // accuracy
  for (auto* v : {&comp, &acc})
    for (double& d : *v)
      d = std::sqrt(d);
  DsrScores s;
  s.cd_gt_r = mean(comp);
  s.cd_r_gt = mean(acc);
  s.chamfer = 0.5 * (s.cd_gt_r + s.cd_r_gt);
  s.hd_gt_r = *std::max_element(comp.begin(), comp.end());
  s.hd_r_gt = *std::max_element(acc.begin(), acc.end());
  s.hausdorff = std::max(s.hd_gt_r, s.hd_r_gt);
  s.normal_consistency = 0.5 * normal_dot_mean(truth.normals, output.normals, comp_index) +
                         0.5 * normal_dot_mean(output.normals, truth.normals, acc_index);
  s.diag = (t.rowwise().maxCoeff() - t.rowwise().minCoeff()).norm();
  return s;
}

Eigen::Matrix3Xf dsr_iou_queries(const GroundTruth& truth, const DsrParams& p) {
  const Eigen::Index n = p.iou_points;
  const auto n_uniform =
      static_cast<Eigen::Index>(std::llround(static_cast<double>(n) * p.iou_uniform_share));
  const BoundingBox box = truth.bbox();
  const Eigen::Vector3d centre = 0.5 * (box.min + box.max).cast<double>(),
                        half = 0.5 * (1.0 + p.iou_padding) * (box.max - box.min).cast<double>();
  Rng rng(derive_seed(truth.sample_seed(), "dsr.iou"));
  Eigen::Matrix3Xf q(3, n);
  for (Eigen::Index i = 0; i < n_uniform; ++i)
    for (int a = 0; a < 3; ++a)
      q(a, i) = static_cast<float>(centre(a) + half(a) * (2.0 * rng.uniform() - 1.0));
  const double sigma = p.iou_sigma * truth.diagonal();
  if (n > n_uniform) {
    const PointCloud& near = truth.surface_samples(n - n_uniform);
    for (Eigen::Index i = n_uniform; i < n; ++i)
      for (int a = 0; a < 3; ++a)
        q(a, i) = static_cast<float>(near.positions(a, i - n_uniform) + rng.normal(0.0, sigma));
  }
  return q;
}

double occupancy_iou(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  std::size_t both = 0, either = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    both += a[i] && b[i];
    either += a[i] || b[i];
  }
  return either ? static_cast<double>(both) / static_cast<double>(either)
                : std::numeric_limits<double>::quiet_NaN();
}

Json dsr_metric(const MetricInput& in, const DsrParams& p) {
  if (!in.output_mesh || !in.output_oracle)
    throw NotApplicable("convention.dsr: scores mesh outputs");
  const DsrScores s = dsr_scores(in.output, in.truth.surface_samples(p.reference_points));
  const double scale = s.diag / 100.0;  // eval.py: scale_with_diag, "(x10^2)"
  Json j = Json::object();
  j["dsr_chamfer_x1e2"] = s.chamfer / scale;
  j["dsr_cd_gt_r_x1e2"] = s.cd_gt_r / scale;
  j["dsr_cd_r_gt_x1e2"] = s.cd_r_gt / scale;
  j["dsr_hausdorff_x1e2"] = s.hausdorff / scale;
  j["dsr_hd_gt_r_x1e2"] = s.hd_gt_r / scale;
  j["dsr_hd_r_gt_x1e2"] = s.hd_r_gt / scale;
  j["dsr_normal_consistency"] = s.normal_consistency;
  if (in.truth.closed()) {
    const Eigen::Matrix3Xf q = dsr_iou_queries(in.truth, p);
    j["dsr_iou"] =
        detail::number(occupancy_iou(in.output_oracle->contains(q), in.truth.contains(q)));
  } else {
    j["dsr_iou"] = nullptr;  // no inside to compare with
  }
  return j;
}

}  // namespace scanbench::metrics

namespace scanbench::metrics {

namespace {

double max_of(const std::vector<double>& v) {
  return *std::max_element(v.begin(), v.end());
}

/// Euclidean nearest distances (nearest_points, then the square root).
std::vector<double> nearest_distances(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to) {
  std::vector<double> d;
  std::vector<Eigen::Index> unused;
  nearest_points(from, to, d, unused);
  for (double& x : d)
    x = std::sqrt(x);
  return d;
}

}  // namespace

PdflowScores pdflow_scores(const Eigen::Matrix3Xf& pred, const PointCloud& gt) {
  if (pred.cols() == 0 || gt.empty()) throw InputError("convention.pdflow: an empty point cloud");
  if (!gt.has_normals())
    throw InputError("convention.pdflow: the ground-truth points need normals");
  const Eigen::Matrix3Xd p = pred.cast<double>(), g = gt.positions.cast<double>();
  const std::vector<double> pg = nearest_distances(p, g), gp = nearest_distances(g, p);
  PdflowScores s;
  s.cd = mean(pg) + mean(gp);  // chamfer_distance: the two means summed
  s.hd = std::max(max_of(pg), max_of(gp));
  // point2surface_distance: the 16 nearest gt points (exact in double: the float tree's 16, then
  // every point within the 16th distance plus slack, sorted in double, lower index on a tie).
  const int k = static_cast<int>(std::min<Eigen::Index>(16, g.cols()));
  const KdTree tree(gt.positions);
  std::vector<double> p2s(static_cast<std::size_t>(p.cols()));
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, p.cols(), 512),
      [&](const tbb::blocked_range<Eigen::Index>& r) {
        std::vector<Eigen::Index> knn;
        std::vector<float> knn_d2;
        std::vector<std::pair<Eigen::Index, float>> near;
        std::vector<std::pair<double, Eigen::Index>> cand;
        for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
          const V3 q = p.col(i);
          const Eigen::Vector3f qf = pred.col(i);
          tree.knn(qf, k, knn, knn_d2);
          double far = 0.0;
          for (Eigen::Index j : knn)
            far = std::max(far, (g.col(j) - q).norm());
          tree.radius(qf, search_radius(far), near);
          cand.clear();
          for (const auto& [j, unused] : near)
            cand.emplace_back((g.col(j) - q).squaredNorm(), j);
          std::partial_sort(cand.begin(), cand.begin() + std::min<std::size_t>(k, cand.size()),
                            cand.end());
          double best = std::numeric_limits<double>::infinity();
          for (std::size_t m = 0; m < cand.size() && m < static_cast<std::size_t>(k); ++m) {
            const Eigen::Index j = cand[m].second;
            const V3 n = gt.normals.col(j).cast<double>();
            best = std::min(best, std::abs(q.dot(n) - g.col(j).dot(n)) / n.norm());
          }
          p2s[static_cast<std::size_t>(i)] = best;
        }
      });
  s.p2s = mean(p2s);
  return s;
}

namespace {
// uniform.py's precentages, float64 (uniformity.cpp's radii take the float kUniformityShares).
constexpr std::array<double, 5> kUniformPyShares = {0.004, 0.006, 0.008, 0.010, 0.012};
}  // namespace

std::array<double, 5> pdflow_uniformity_scores(const UniformityDisks& disks) {
  const auto points = static_cast<double>(disks.mapped.cols());
  const std::size_t shares = kUniformityShares.size();
  const std::size_t centres = disks.members.size() / shares;
  std::array<double, 5> u{};
  for (std::size_t k = 0; k < shares; ++k) {
    const double expected = kUniformPyShares[k] * points;
    const double r = disks.radius[k];
    double sum = 0.0;
    std::size_t counted = 0;
    for (std::size_t d = 0; d < centres; ++d) {
      const std::vector<Eigen::Index>& idx = disks.members[d * shares + k];
      const auto n = static_cast<double>(idx.size());
      if (idx.size() < 5) continue;  // uniform.py: the disk is left out, coverage and all
      const double coverage = (n - expected) * (n - expected) / expected;
      const double e = std::sqrt(2.0 * (M_PI * r * r / n) / 1.732);  // "using hexagon"
      double dis = 0.0;
      for (const Eigen::Index i : idx) {
        double nearest = std::numeric_limits<double>::infinity();
        for (const Eigen::Index j : idx)
          if (j != i)
            nearest = std::min(nearest, (disks.mapped.col(i) - disks.mapped.col(j)).norm());
        dis += (nearest - e) * (nearest - e) / e;
      }
      sum += coverage * dis / n;
      ++counted;
    }
    u[k] = counted ? sum / static_cast<double>(counted) : 0.0;
  }
  return u;
}

Json pdflow_metric(const MetricInput& in, const PdflowParams& p, RunContext& ctx) {
  const Eigen::Index n = p.reference_points > 0 ? p.reference_points : in.output.size();
  PointCloud gt = in.truth.surface_samples(n);
  Eigen::Matrix3Xf pred = in.output.positions;
  // The uniformity's mesh and points in double, in the frame of the other scores.
  Eigen::Matrix3Xd vertices = in.truth.mesh().vertices.cast<double>();
  Eigen::Matrix3Xd points = pred.cast<double>();
  if (p.normalize) {
    const Sphere s = normalize_sphere(gt.positions);
    gt.positions = normalized(gt.positions, s).cast<float>();
    vertices = (vertices.colwise() - s.c) / s.s;
    points = normalized(pred, s);
    pred = points.cast<float>();
  }
  const PdflowScores s = pdflow_scores(pred, gt);
  Json j = Json::object();
  j["pdflow_cd"] = s.cd;
  j["pdflow_p2s"] = s.p2s;
  j["pdflow_hd"] = s.hd;
  j["pdflow_reference_points"] = n;
  std::optional<std::array<double, 5>> u;
  if (p.uniformity) {
    Rng rng = ctx.rng("metric.pdflow");
    const Eigen::Matrix3Xi& faces = in.truth.mesh().faces;
    try {
      u = pdflow_uniformity_scores(pdflow_uniformity_disks(
          points, vertices, faces,
          pdflow_uniformity_centres(vertices, faces, p.uniformity_disks, rng)));
    } catch (const NotApplicable&) {  // a mesh CGAL cannot build: no uniformity, the rest stands
    }
  }
  for (std::size_t k = 0; k < kUniformityKeys.size(); ++k)
    j[kUniformityKeys[k]] = u ? detail::number((*u)[k]) : Json(nullptr);
  return j;
}

Eigen::Matrix3Xd voxel_down_sample(const Eigen::Matrix3Xd& points, double voxel) {
  if (points.cols() == 0) return points;
  const V3 origin = points.rowwise().minCoeff().array() - voxel * 0.5;
  std::map<std::array<int, 3>, std::pair<V3, int>> cells;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const V3 ref = (points.col(i) - origin) / voxel;
    const std::array<int, 3> key{static_cast<int>(std::floor(ref(0))),
                                 static_cast<int>(std::floor(ref(1))),
                                 static_cast<int>(std::floor(ref(2)))};
    auto& [sum, count] = cells.try_emplace(key, V3::Zero(), 0).first->second;
    sum += points.col(i);
    ++count;
  }
  Eigen::Matrix3Xd out(3, static_cast<Eigen::Index>(cells.size()));
  Eigen::Index c = 0;
  for (const auto& [key, acc] : cells)
    out.col(c++) = acc.first / static_cast<double>(acc.second);
  return out;
}

TntScores tnt_scores(const Eigen::Matrix3Xf& output, const Eigen::Matrix3Xf& truth, double tau,
                     double voxel) {
  const Eigen::Matrix3Xd s = voxel_down_sample(output.cast<double>(), voxel),
                         t = voxel_down_sample(truth.cast<double>(), voxel);
  TntScores r;
  if (s.cols() == 0 || t.cols() == 0) return r;  // get_f1_score_histo2: all 0
  r.precision_distances = nearest_distances(s, t);
  r.recall_distances = nearest_distances(t, s);
  const auto share_below = [tau](const std::vector<double>& d) {
    return static_cast<double>(
               std::count_if(d.begin(), d.end(), [tau](double x) { return x < tau; })) /
           static_cast<double>(d.size());
  };
  r.precision = share_below(r.precision_distances);
  r.recall = share_below(r.recall_distances);
  // eval: 2 R P / (R + P), NaN (0 / 0) when neither has a point below tau; here 0.
  r.fscore =
      r.precision + r.recall > 0.0 ? 2.0 * r.recall * r.precision / (r.recall + r.precision) : 0.0;
  return r;
}

Json tnt_metric(const MetricInput& in, const TntParams& p) {
  const double diag = in.truth.diagonal();
  const double tau = p.tau * diag;
  const TntScores s =
      tnt_scores(in.output.positions, in.truth.surface_samples(p.reference_points).positions, tau,
                 p.voxel * tau);
  Json j = Json::object();
  j["tnt_precision"] = s.precision;
  j["tnt_recall"] = s.recall;
  j["tnt_fscore"] = s.fscore;
  detail::put_length(j, "tnt_tau", tau, diag);
  j["tnt_output_points"] = s.precision_distances.size();
  j["tnt_reference_points"] = s.recall_distances.size();
  // The curves of the benchmark's plots (plot_stretch 5, bins of tau / 100), in tau.
  const auto in_tau = [tau](const std::vector<double>& d) {
    Eigen::VectorXf v(static_cast<Eigen::Index>(d.size()));
    for (std::size_t i = 0; i < d.size(); ++i)
      v(static_cast<Eigen::Index>(i)) = static_cast<float>(d[i] / tau);
    return v;
  };
  j["histograms"]["tnt_precision"] =
      detail::histogram(in_tau(s.precision_distances), 0.0, 5.0, 500, "tau");
  j["histograms"]["tnt_recall"] =
      detail::histogram(in_tau(s.recall_distances), 0.0, 5.0, 500, "tau");
  return j;
}

std::vector<Eigen::Index> dtu_thin(const Eigen::Matrix3Xd& points, double density) {
  const Eigen::Matrix3Xf pf = points.cast<float>();
  const KdTree tree(pf);
  std::vector<char> dropped(static_cast<std::size_t>(points.cols()), 0);
  std::vector<Eigen::Index> kept;
  std::vector<std::pair<Eigen::Index, float>> near;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    if (dropped[static_cast<std::size_t>(i)]) continue;
    kept.push_back(i);
    tree.radius(pf.col(i), search_radius(density), near);
    for (const auto& [j, unused] : near)
      if ((points.col(j) - points.col(i)).norm() <= density)
        dropped[static_cast<std::size_t>(j)] = 1;
  }
  return kept;
}

DtuScores dtu_scores(const Eigen::Matrix3Xf& output, const Eigen::Matrix3Xf& truth, double density,
                     double max_dist) {
  if (output.cols() == 0 || truth.cols() == 0)
    throw InputError("convention.dtu: an empty point cloud");
  const Eigen::Matrix3Xd o = output.cast<double>(), t = truth.cast<double>();
  const std::vector<Eigen::Index> kept = dtu_thin(o, density);
  Eigen::Matrix3Xd down(3, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i)
    down.col(static_cast<Eigen::Index>(i)) = o.col(kept[i]);
  const auto mean_below = [max_dist](const std::vector<double>& d, const char* what) {
    double sum = 0.0;
    std::size_t n = 0;
    for (double x : d)
      if (x < max_dist) {
        sum += x;
        ++n;
      }
    if (n == 0)
      throw NotApplicable(fmt::format(
          "convention.dtu: no {} distance is below max_dist (DTU's mean is undefined)", what));
    return sum / static_cast<double>(n);
  };
  DtuScores s;
  s.accuracy = mean_below(nearest_distances(down, t), "accuracy");
  s.completeness = mean_below(nearest_distances(t, down), "completeness");
  s.overall = 0.5 * (s.accuracy + s.completeness);
  s.thinned_points = down.cols();
  return s;
}

Json dtu_metric(const MetricInput& in, const DtuParams& p, RunContext& ctx) {
  const double diag = in.truth.diagonal();
  // eval.py shuffles before thinning (unseeded); here the run's stream "metric.dtu".
  Eigen::Matrix3Xf shuffled = in.output.positions;
  Rng rng = ctx.rng("metric.dtu");
  for (Eigen::Index i = shuffled.cols() - 1; i > 0; --i) {
    const auto j = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(i) + 1));
    shuffled.col(i).swap(shuffled.col(j));
  }
  const DtuScores s = dtu_scores(shuffled, in.truth.surface_samples(p.reference_points).positions,
                                 p.downsample_density * diag, p.max_dist * diag);
  Json j = Json::object();
  detail::put_length(j, "dtu_accuracy", s.accuracy, diag);
  detail::put_length(j, "dtu_completeness", s.completeness, diag);
  detail::put_length(j, "dtu_overall", s.overall, diag);
  j["dtu_points"] = s.thinned_points;
  return j;
}

}  // namespace scanbench::metrics

namespace scanbench::metrics {

namespace {

/// ETH3D's CalcCellCoordinates: floor(x / voxel + shift) per axis, in float.
std::array<int, 3> eth3d_cell(const Eigen::Vector3f& p, float voxel_inv, float shift) {
  std::array<int, 3> c{};
  for (int a = 0; a < 3; ++a)
    c[static_cast<std::size_t>(a)] = static_cast<int>(std::floor(p(a) * voxel_inv + shift));
  return c;
}

constexpr float kEth3dShifts[2] = {0.0f, 0.5f};

}  // namespace

Eth3dScores eth3d_scores(const Eigen::Matrix3Xf& output, const std::vector<Eth3dScan>& truth,
                         double tolerance, double voxel, double beam_radius,
                         double beam_divergence_deg) {
  const float tol2 = static_cast<float>(tolerance * tolerance);
  const float voxel_inv = static_cast<float>(1.0 / voxel);
  const float beam_start = static_cast<float>(beam_radius);
  const float tan_div = static_cast<float>(std::tan(beam_divergence_deg * M_PI / 180.0));
  // Per scan: the points relative to the scanner, their unit directions (in a kd-tree) and ranges.
  struct Scan {
    Eigen::Matrix3Xf rel, dir;
    std::vector<float> range;
    std::unique_ptr<KdTree> tree;
  };
  std::vector<Scan> scans(truth.size());
  for (std::size_t s = 0; s < truth.size(); ++s) {
    Scan& sc = scans[s];
    sc.rel = truth[s].points.colwise() - truth[s].origin;
    sc.dir.resize(3, sc.rel.cols());
    sc.range.resize(static_cast<std::size_t>(sc.rel.cols()));
    for (Eigen::Index j = 0; j < sc.rel.cols(); ++j) {
      sc.range[static_cast<std::size_t>(j)] = sc.rel.col(j).norm();
      sc.dir.col(j) = sc.rel.col(j).normalized();
    }
    sc.tree = std::make_unique<KdTree>(sc.dir);
  }
  // ClassifyPoint over every scan: 1 accurate, 2 inaccurate, 0 unobserved.
  std::vector<std::uint8_t> cls(static_cast<std::size_t>(output.cols()), 0);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, output.cols(), 256),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      std::vector<std::pair<Eigen::Index, float>> near;
                      for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
                        bool inaccurate = false, accurate = false;
                        for (std::size_t s = 0; s < scans.size() && !accurate; ++s) {
                          const Scan& sc = scans[s];
                          const Eigen::Vector3f y = output.col(i) - truth[s].origin;
                          const float ry = y.norm();
                          const float b = beam_start + ry * tan_div;
                          const float b2 = b * b;
                          // The rays that can pass within b of y: directions within asin(b / ry) of y's.
                          const auto visit = [&](Eigen::Index j) {
                            const Eigen::Vector3f d = sc.dir.col(j);
                            const float along = d.dot(y);
                            if (along < 0.0f)
                              return;  // the opposite side of the scanner: unobserved
                            if ((y - along * d).squaredNorm() > b2) return;
                            if ((sc.rel.col(j) - y).squaredNorm() <= tol2) {
                              accurate = true;
                              return;
                            }
                            if (along < sc.range[static_cast<std::size_t>(j)]) inaccurate = true;
                          };
                          if (b >= ry) {
                            for (Eigen::Index j = 0; j < sc.dir.cols() && !accurate; ++j)
                              visit(j);
                          } else {
                            const double angle = std::asin(static_cast<double>(b) / ry);
                            sc.tree->radius(
                                y / ry, search_radius(2.0 * std::sin(angle / 2.0)) * 1.001f, near);
                            for (const auto& [j, unused] : near) {
                              visit(j);
                              if (accurate) break;
                            }
                          }
                        }
                        cls[static_cast<std::size_t>(i)] = accurate ? 1 : inaccurate ? 2 : 0;
                      }
                    });
  Eth3dScores out;
  std::map<std::array<int, 3>, std::pair<Eigen::Index, Eigen::Index>> acc_cells[2];
  for (Eigen::Index i = 0; i < output.cols(); ++i) {
    const std::uint8_t c = cls[static_cast<std::size_t>(i)];
    if (c == 0) {
      ++out.unobserved;
      continue;
    }
    (c == 1 ? out.accurate : out.inaccurate) += 1;
    for (int g = 0; g < 2; ++g) {
      auto& cell = acc_cells[g][eth3d_cell(output.col(i), voxel_inv, kEth3dShifts[g])];
      (c == 1 ? cell.first : cell.second) += 1;
    }
  }
  double acc_sum = 0.0;
  std::size_t acc_n = 0;
  for (const auto& grid : acc_cells)
    for (const auto& [key, counts] : grid) {
      acc_sum += static_cast<double>(static_cast<float>(counts.first) /
                                     static_cast<float>(counts.first + counts.second));
      ++acc_n;
    }
  out.accuracy = acc_n ? acc_sum / static_cast<double>(acc_n) : 0.0;
  // ComputeCompleteness: every ground-truth point, complete when an output point is within t.
  if (output.cols() > 0) {
    const KdTree tree(output);
    std::map<std::array<int, 3>, std::pair<Eigen::Index, Eigen::Index>> comp_cells[2];
    for (std::size_t s = 0; s < truth.size(); ++s)
      for (Eigen::Index j = 0; j < truth[s].points.cols(); ++j) {
        const Eigen::Vector3f p = truth[s].points.col(j);
        const bool complete = (output.col(tree.nearest(p)) - p).squaredNorm() <= tol2;
        for (int g = 0; g < 2; ++g) {
          auto& cell = comp_cells[g][eth3d_cell(p, voxel_inv, kEth3dShifts[g])];
          cell.first += complete;
          cell.second += 1;
        }
      }
    double comp_sum = 0.0;
    std::size_t comp_n = 0;
    for (const auto& grid : comp_cells)
      for (const auto& [key, counts] : grid) {
        comp_sum += static_cast<double>(counts.first) / static_cast<double>(counts.second);
        ++comp_n;
      }
    out.completeness = comp_n ? comp_sum / static_cast<double>(comp_n) : 0.0;
  }
  out.f1 = out.accuracy <= 0.0 && out.completeness <= 0.0
               ? 0.0
               : 2.0 * out.accuracy * out.completeness / (out.accuracy + out.completeness);
  return out;
}

Json eth3d_metric(const MetricInput& in, const Eth3dParams& p) {
  if (!in.scan || !in.scan->has_scan_ids() || in.scan->sensor_origins.cols() == 0)
    throw NotApplicable(
        "convention.eth3d: needs the chain's scan with scan ids and sensor origins");
  const std::optional<CleanHits> hits = clean_hits(*in.scan);
  if (!hits || hits->index.empty())
    throw NotApplicable("convention.eth3d: the scan has no noise-free hits (clean_x/y/z)");
  std::vector<Eth3dScan> truth(static_cast<std::size_t>(in.scan->sensor_origins.cols()));
  std::vector<std::vector<Eigen::Index>> members(truth.size());
  for (std::size_t k = 0; k < hits->index.size(); ++k)
    members[static_cast<std::size_t>(in.scan->scan_ids(hits->index[k]))].push_back(
        static_cast<Eigen::Index>(k));
  for (std::size_t s = 0; s < truth.size(); ++s) {
    truth[s].origin = in.scan->sensor_origins.col(static_cast<Eigen::Index>(s));
    truth[s].points.resize(3, static_cast<Eigen::Index>(members[s].size()));
    for (std::size_t m = 0; m < members[s].size(); ++m)
      truth[s].points.col(static_cast<Eigen::Index>(m)) = hits->clean.col(members[s][m]);
  }
  const double diag = in.truth.diagonal();
  double beam = p.beam_radius * diag;
  if (beam == 0.0) {  // half the median nearest-neighbour spacing of the ground-truth points
    const KdTree tree(hits->clean);
    std::vector<float> spacing(static_cast<std::size_t>(hits->clean.cols()));
    std::vector<Eigen::Index> idx;
    std::vector<float> d2;
    for (Eigen::Index k = 0; k < hits->clean.cols(); ++k) {
      tree.knn(hits->clean.col(k), 2, idx, d2);
      spacing[static_cast<std::size_t>(k)] = d2.size() > 1 ? std::sqrt(d2[1]) : 0.0f;
    }
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    beam = 0.5 * spacing[spacing.size() / 2];
  }
  const Eth3dScores s = eth3d_scores(in.output.positions, truth, p.tolerance * diag, p.voxel * diag,
                                     beam, p.beam_divergence_deg);
  Json j = Json::object();
  j["eth3d_accuracy"] = s.accuracy;
  j["eth3d_completeness"] = s.completeness;
  j["eth3d_f1"] = s.f1;
  detail::put_length(j, "eth3d_tolerance", p.tolerance * diag, diag);
  detail::put_length(j, "eth3d_beam_radius", beam, diag);
  j["eth3d_accurate_points"] = s.accurate;
  j["eth3d_inaccurate_points"] = s.inaccurate;
  j["eth3d_unobserved_points"] = s.unobserved;
  return j;
}

}  // namespace scanbench::metrics
