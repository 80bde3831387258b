#include "scanbench/metrics/sharp_edges.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/ground_truth.h"

namespace scanbench::metrics {

namespace {

struct Piece {
  Eigen::Vector3f a, b;
};

float distance_to_piece(const Eigen::Vector3f& q, const Piece& s) {
  const Eigen::Vector3f d = s.b - s.a;
  const float len2 = d.squaredNorm();
  const float t = len2 > 0.0f ? std::clamp((q - s.a).dot(d) / len2, 0.0f, 1.0f) : 0.0f;
  return (q - (s.a + t * d)).norm();
}

}  // namespace

std::vector<bool> near_sharp_edges(const GroundTruth& truth, const std::vector<ClosestPoint>& cps,
                                   const SharpEdgeParams& p) {
  const TriangleMesh& mesh = truth.mesh();
  std::map<std::pair<int, int>, std::vector<Eigen::Index>> faces_of;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.faces(k, f), b = mesh.faces((k + 1) % 3, f);
      faces_of[std::minmax(a, b)].push_back(f);
    }
  const float band = static_cast<float>(p.band) * truth.diagonal();
  const float cos_max = static_cast<float>(std::cos(p.angle_deg * M_PI / 180.0));
  std::vector<Piece> pieces;
  for (const auto& [e, fs] : faces_of) {
    if (fs.size() != 2) continue;
    if (mesh.face_normal(fs[0]).dot(mesh.face_normal(fs[1])) >= cos_max) continue;
    const Eigen::Vector3f a = mesh.vertices.col(e.first), b = mesh.vertices.col(e.second);
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / band)));
    for (int i = 0; i < n; ++i)
      pieces.push_back({a + (b - a) * (float(i) / n), a + (b - a) * (float(i + 1) / n)});
  }
  if (pieces.empty()) {
    throw NotApplicable(fmt::format("no ground-truth edge sharper than {} degrees", p.angle_deg));
  }
  Eigen::Matrix3Xf mids(3, static_cast<Eigen::Index>(pieces.size()));
  for (std::size_t i = 0; i < pieces.size(); ++i)
    mids.col(static_cast<Eigen::Index>(i)) = 0.5f * (pieces[i].a + pieces[i].b);
  const KdTree tree(mids);
  std::vector<bool> near(cps.size(), false);
  std::vector<std::pair<Eigen::Index, float>> found;
  for (std::size_t i = 0; i < cps.size(); ++i) {
    // A piece is at most `band` long: a point within band of it is within 1.5 band of its middle.
    tree.radius(cps[i].point, 1.5f * band, found);
    for (const auto& [k, d2] : found) {
      if (distance_to_piece(cps[i].point, pieces[static_cast<std::size_t>(k)]) <= band) {
        near[i] = true;
        break;
      }
    }
  }
  return near;
}

Json sharp_edge_p2plane_metric(const MetricInput& in, const SharpEdgeParams& p) {
  if (in.output.empty()) throw InputError("edges.p2plane: output has no points");
  const auto cps = closest_points_of(in);
  const std::vector<bool> near = near_sharp_edges(in.truth, cps, p);
  double sum = 0.0;
  long count = 0;
  for (Eigen::Index i = 0; i < in.output.size(); ++i) {
    const auto& cp = cps[static_cast<std::size_t>(i)];
    if (!near[static_cast<std::size_t>(i)]) continue;
    sum += std::abs(double((in.output.positions.col(i) - cp.point).dot(cp.normal)));
    ++count;
  }
  if (count == 0) throw NotApplicable("edges.p2plane: no output point near a sharp edge");
  const double mean = sum / static_cast<double>(count);
  Json j = Json::object();
  j["edge_p2plane_mean"] = mean;
  j["edge_p2plane_mean_rel"] = mean / in.truth.diagonal();
  j["edge_points"] = count;
  j["edge_share"] = static_cast<double>(count) / static_cast<double>(in.output.size());
  return j;
}

Json sharp_edge_normals_metric(const MetricInput& in, const SharpEdgeParams& p) {
  if (!in.output.has_normals()) throw NotApplicable("edges.normals: output has no normals");
  if (in.output.empty()) throw InputError("edges.normals: output has no points");
  const auto cps = closest_points_of(in);
  const std::vector<bool> near = near_sharp_edges(in.truth, cps, p);
  double sum = 0.0;
  long count = 0, under10 = 0;
  for (Eigen::Index i = 0; i < in.output.size(); ++i) {
    if (!near[static_cast<std::size_t>(i)]) continue;
    const Eigen::Vector3d v = in.output.normals.col(i).cast<double>();
    const double len = v.norm();
    if (!(len > 0.0))
      throw InputError("edges.normals: output normal " + std::to_string(i) + " is zero");
    const double c = std::abs(v.dot(cps[static_cast<std::size_t>(i)].normal.cast<double>()) / len);
    const double deg = std::acos(std::min(1.0, c)) * 180.0 / M_PI;
    sum += deg;
    under10 += deg < 10.0 ? 1 : 0;
    ++count;
  }
  if (count == 0) throw NotApplicable("edges.normals: no output point near a sharp edge");
  Json j = Json::object();
  j["edge_normal_angle_mean_deg"] = sum / static_cast<double>(count);
  j["edge_normal_pgp10"] = static_cast<double>(under10) / static_cast<double>(count);
  j["edge_points"] = count;
  return j;
}

}  // namespace scanbench::metrics
