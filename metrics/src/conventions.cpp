#include "scanbench/metrics/conventions.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/ground_truth.h"

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

Json dsr_metric(const MetricInput& in, const DsrParams& p) {
  if (!in.output_mesh) throw NotApplicable("convention.dsr: scores mesh outputs");
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
  return j;
}

}  // namespace scanbench::metrics
