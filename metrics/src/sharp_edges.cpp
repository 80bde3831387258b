#include "scanbench/metrics/sharp_edges.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/outlier_residue.h"

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

/// The sharp edges of a ground truth cut into pieces no longer than the band (`band_rel`, a
/// fraction of the diagonal), and a kd-tree of the pieces' midpoints.
class SharpEdges {
 public:
  SharpEdges(const GroundTruth& truth, const SharpEdgeParams& p, double band_rel)
      : band_(static_cast<float>(band_rel) * truth.diagonal()) {
    const TriangleMesh& mesh = truth.mesh();
    std::map<std::pair<int, int>, std::vector<Eigen::Index>> faces_of;
    for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = mesh.faces(k, f), b = mesh.faces((k + 1) % 3, f);
        faces_of[std::minmax(a, b)].push_back(f);
      }
    const float cos_max = static_cast<float>(std::cos(p.angle_deg * M_PI / 180.0));
    for (const auto& [e, fs] : faces_of) {
      const float len = (mesh.vertices.col(e.first) - mesh.vertices.col(e.second)).norm();
      total_length_ += len;
      if (fs.size() != 2) continue;
      if (mesh.face_normal(fs[0]).dot(mesh.face_normal(fs[1])) >= cos_max) continue;
      sharp_length_ += len;
      const Eigen::Vector3f a = mesh.vertices.col(e.first), b = mesh.vertices.col(e.second);
      const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / band_)));
      for (int i = 0; i < n; ++i)
        pieces_.push_back({a + (b - a) * (float(i) / n), a + (b - a) * (float(i + 1) / n)});
    }
    if (pieces_.empty()) {
      throw NotApplicable(fmt::format("no ground-truth edge sharper than {} degrees", p.angle_deg));
    }
    mids_.resize(3, static_cast<Eigen::Index>(pieces_.size()));
    for (std::size_t i = 0; i < pieces_.size(); ++i)
      mids_.col(static_cast<Eigen::Index>(i)) = 0.5f * (pieces_[i].a + pieces_[i].b);
    tree_.emplace(mids_);  // views mids_, which lives as long
  }

  /// The share of the mesh's edge length on sharp edges.
  double sharp_length_share() const { return sharp_length_ / total_length_; }

  /// Whether q (on the ground truth) lies within the band of a sharp edge.
  bool near(const Eigen::Vector3f& q, std::vector<std::pair<Eigen::Index, float>>& found) const {
    // A piece is at most `band` long: a point within band of it is within 1.5 band of its middle.
    tree_->radius(q, 1.5f * band_, found);
    for (const auto& [k, d2] : found)
      if (distance_to_piece(q, pieces_[static_cast<std::size_t>(k)]) <= band_) return true;
    return false;
  }

 private:
  float band_;
  double total_length_ = 0.0, sharp_length_ = 0.0;
  std::vector<Piece> pieces_;
  Eigen::Matrix3Xf mids_;
  std::optional<KdTree> tree_;
};

/// The share of the ground truth's area within the band of a sharp edge, estimated on the
/// ground truth's fixed seeded surface samples (its sample seed is recorded in "scoring"); an
/// exact clipped-area integral over every face would be far more code for a threshold test.
double band_area_share(const GroundTruth& truth, const SharpEdges& edges) {
  const PointCloud& s = truth.surface_samples(kEdgeBandAreaSamples);
  std::vector<std::pair<Eigen::Index, float>> found;
  Eigen::Index in = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i)
    in += edges.near(s.positions.col(i), found) ? 1 : 0;
  return static_cast<double>(in) / static_cast<double>(s.size());
}

/// What the features test measured: edge_band_area and edge_sharp_length.
struct FeatureFacts {
  double band_area = 0.0, sharp_length = 0.0;
};

/// The facts when the sharp edges of `truth` are features (see the header); NotApplicable with
/// the stated rule and the measured value otherwise.
FeatureFacts check_features(const GroundTruth& truth, const SharpEdges& edges,
                            const SharpEdgeParams& p, double band_rel, const char* metric) {
  FeatureFacts f;
  f.sharp_length = edges.sharp_length_share();
  if (f.sharp_length > p.max_sharp_length) {
    throw NotApplicable(fmt::format(
        "{}: the ground truth is faceted: {:.0f}% of its edge length bends by more than {} "
        "degrees (max_sharp_length {:.0f}%), so its sharp edges are facets, not features",
        metric, 100.0 * f.sharp_length, p.angle_deg, 100.0 * p.max_sharp_length));
  }
  f.band_area = band_area_share(truth, edges);
  if (f.band_area > p.max_band_area) {
    throw NotApplicable(fmt::format(
        "{}: {:.0f}% of the ground truth's area lies within the band ({} diag) of an edge sharper "
        "than {} degrees (max_band_area {:.0f}%): near an edge would mean nearly everywhere",
        metric, 100.0 * f.band_area, band_rel, p.angle_deg, 100.0 * p.max_band_area));
  }
  return f;
}

std::vector<bool> near_of(const SharpEdges& edges, const std::vector<ClosestPoint>& cps) {
  std::vector<bool> near(cps.size(), false);
  std::vector<std::pair<Eigen::Index, float>> found;
  for (std::size_t i = 0; i < cps.size(); ++i)
    near[i] = edges.near(cps[i].point, found);
  return near;
}

}  // namespace

std::vector<bool> near_sharp_edges(const GroundTruth& truth, const std::vector<ClosestPoint>& cps,
                                   const SharpEdgeParams& p) {
  return near_of(SharpEdges(truth, p, p.band), cps);
}

double sharp_edge_band_area(const GroundTruth& truth, const SharpEdgeParams& p) {
  return band_area_share(truth, SharpEdges(truth, p, p.band));
}

double sharp_edge_length_share(const GroundTruth& truth, const SharpEdgeParams& p) {
  return SharpEdges(truth, p, p.band).sharp_length_share();
}

double sharp_edge_band(const MetricInput& in, const SharpEdgeParams& p) {
  if (p.band_noise_multiple == 0.0) return p.band;
  double sigma = p.noise;
  if (sigma == 0.0) {
    const double measured = in.scan ? scan_noise_rms(*in.scan) : std::nan("");
    if (!std::isfinite(measured)) {
      throw NotApplicable(
          "the sharp-edge band: band_noise_multiple needs the scan noise: declare noise, or "
          "score with a scan that has clean_x/y/z properties");
    }
    sigma = measured / in.truth.diagonal();
  }
  return std::max(p.band, p.band_noise_multiple * sigma);
}

Json sharp_edge_p2plane_metric(const MetricInput& in, const SharpEdgeParams& p) {
  if (in.output.empty()) throw InputError("edges.p2plane: output has no points");
  const double band = sharp_edge_band(in, p);
  const SharpEdges edges(in.truth, p, band);
  const FeatureFacts facts = check_features(in.truth, edges, p, band, "edges.p2plane");
  const auto cps = closest_points_of(in);
  const std::vector<bool> near = near_of(edges, cps);
  double plane_sum = 0.0, surface_sum = 0.0;
  long count = 0;
  for (Eigen::Index i = 0; i < in.output.size(); ++i) {
    const auto& cp = cps[static_cast<std::size_t>(i)];
    if (!near[static_cast<std::size_t>(i)]) continue;
    plane_sum += std::abs(double((in.output.positions.col(i) - cp.point).dot(cp.normal)));
    surface_sum += double(cp.distance);
    ++count;
  }
  if (count == 0) throw NotApplicable("edges.p2plane: no output point near a sharp edge");
  const double diag = in.truth.diagonal();
  const double plane = plane_sum / static_cast<double>(count);
  const double surface = surface_sum / static_cast<double>(count);
  Json j = Json::object();
  j["edge_p2plane_mean"] = plane;
  j["edge_p2plane_mean_rel"] = plane / diag;
  j["edge_p2s_mean"] = surface;
  j["edge_p2s_mean_rel"] = surface / diag;
  j["edge_band"] = band * diag;
  j["edge_band_rel"] = band;
  j["edge_points"] = count;
  j["edge_share"] = static_cast<double>(count) / static_cast<double>(in.output.size());
  j["edge_band_area"] = facts.band_area;
  j["edge_sharp_length"] = facts.sharp_length;
  return j;
}

Json sharp_edge_normals_metric(const MetricInput& in, const SharpEdgeParams& p) {
  if (!in.output.has_normals()) throw NotApplicable("edges.normals: output has no normals");
  if (in.output.empty()) throw InputError("edges.normals: output has no points");
  const double band = sharp_edge_band(in, p);
  const SharpEdges edges(in.truth, p, band);
  check_features(in.truth, edges, p, band, "edges.normals");
  const auto cps = closest_points_of(in);
  const std::vector<bool> near = near_of(edges, cps);
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
  j["edge_band"] = band * in.truth.diagonal();
  j["edge_band_rel"] = band;
  j["edge_points"] = count;
  return j;
}

}  // namespace scanbench::metrics
