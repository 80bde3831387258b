// Ground truth as a point cloud (point_truth.h).
#include "scanbench/metrics/point_truth.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/chamfer.h"
#include "scanbench/metrics/p2plane.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::metrics {

namespace {

std::vector<double> numbers(std::string text, const std::string& where, const char* what) {
  for (char& c : text)
    if (c == ',' || c == ';') c = ' ';
  std::istringstream in(text);
  std::vector<double> v;
  std::string tok;
  while (in >> tok) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(tok, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != tok.size() || !std::isfinite(x))
      throw ParamError(fmt::format("{}: {}: '{}' is not a finite number", where, what, tok));
    v.push_back(x);
  }
  return v;
}

/// Distance of every column of `q` to its nearest column of the tree's points (and its index).
Eigen::VectorXf nearest_distances(const KdTree& tree, const Eigen::Matrix3Xf& q,
                                  std::vector<Eigen::Index>* index = nullptr) {
  Eigen::VectorXf d(q.cols());
  if (index) index->resize(static_cast<std::size_t>(q.cols()));
  tbb::parallel_for(Eigen::Index{0}, q.cols(), [&](Eigen::Index i) {
    float d2 = 0;
    const Eigen::Index j = tree.nearest(q.col(i), &d2);
    d[i] = std::sqrt(d2);
    if (index) (*index)[static_cast<std::size_t>(i)] = j;
  });
  return d;
}

}  // namespace

Eigen::Matrix4d parse_transform(const std::string& text_or_file, const std::string& where) {
  std::string text = text_or_file;
  if (std::filesystem::is_regular_file(text_or_file)) {
    std::ifstream in(text_or_file);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const std::vector<double> v = numbers(text, where, "transform");
  if (v.size() != 16)
    throw ParamError(
        fmt::format("{}: expected 16 numbers (a row-major 4x4 matrix), got {}", where, v.size()));
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      m(r, c) = v[static_cast<std::size_t>(4 * r + c)];
  if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
    throw ParamError(fmt::format("{}: the last row must be 0 0 0 1", where));
  return m;
}

BoundingBox parse_crop(const std::string& text, const std::string& where) {
  const std::vector<double> v = numbers(text, where, "crop");
  if (v.size() != 6)
    throw ParamError(
        fmt::format("{}: expected xmin,ymin,zmin,xmax,ymax,zmax, got {} numbers", where, v.size()));
  BoundingBox b;
  b.min = Eigen::Vector3d(v[0], v[1], v[2]).cast<float>();
  b.max = Eigen::Vector3d(v[3], v[4], v[5]).cast<float>();
  if ((b.max.array() < b.min.array()).any())
    throw ParamError(fmt::format("{}: a minimum is above its maximum", where));
  return b;
}

PointCloud transformed(const PointCloud& c, const Eigen::Matrix4d& m) {
  PointCloud out = c;
  const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = m.topRightCorner<3, 1>();
  for (Eigen::Index i = 0; i < c.size(); ++i)
    out.positions.col(i) = (a * (c.origin + c.positions.col(i).cast<double>()) + t).cast<float>();
  for (Eigen::Index i = 0; i < c.sensor_origins.cols(); ++i)
    out.sensor_origins.col(i) =
        (a * (c.origin + c.sensor_origins.col(i).cast<double>()) + t).cast<float>();
  if (c.has_normals()) {
    const Eigen::Matrix3d nt = a.inverse().transpose();
    for (Eigen::Index i = 0; i < c.size(); ++i)
      out.normals.col(i) = (nt * c.normals.col(i).cast<double>()).normalized().cast<float>();
  }
  out.origin.setZero();
  return out;
}

PointCloud cropped(const PointCloud& c, const BoundingBox& box) {
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    const Eigen::Vector3f p = c.positions.col(i);
    if ((p.array() >= box.min.array()).all() && (p.array() <= box.max.array()).all())
      keep.push_back(i);
  }
  return c.subset(keep);
}

Json point_truth_chamfer(const PointTruthInput& in, const Json& params, RunContext&) {
  const auto p = params_from_json<ChamferParams>(params, "metric accuracy.chamfer");
  const KdTree gt_tree(in.truth.positions);
  const KdTree out_tree(in.output.positions);
  const Eigen::VectorXf acc = nearest_distances(gt_tree, in.output.positions);
  const Eigen::VectorXf comp = nearest_distances(out_tree, in.truth.positions);
  return chamfer_scores(acc, comp, in.diagonal, p, 0);
}

Json point_truth_p2plane(const PointTruthInput& in, const Json& params, RunContext&) {
  if (!in.truth.has_normals())
    throw NotApplicable("accuracy.p2plane: the ground-truth points have no normals");
  const auto p = params_from_json<P2PlaneParams>(params, "metric accuracy.p2plane");
  const KdTree gt_tree(in.truth.positions);
  std::vector<Eigen::Index> nearest;
  (void)nearest_distances(gt_tree, in.output.positions, &nearest);
  std::vector<ClosestPoint> closest(nearest.size());
  for (std::size_t i = 0; i < nearest.size(); ++i) {
    closest[i].point = in.truth.positions.col(nearest[i]);
    closest[i].normal = in.truth.normals.col(nearest[i]);
  }
  return p2plane_scores(point_to_plane_errors(in.output.positions, closest).cwiseAbs(), in.diagonal,
                        p);
}

Json evaluate_point_truth(const PointCloud& truth, const PointCloud& output,
                          const std::vector<std::string>& metric_names, const Json& metric_params,
                          RunContext& ctx) {
  if (truth.empty()) throw InputError("eval: the ground-truth points are empty (after the crop)");
  if (output.empty()) throw InputError("eval: the output has no points (after the crop)");
  truth.validate("eval: ground-truth points");
  const MetricRegistry& reg = registry();
  const bool all = metric_names.empty();
  std::vector<const MetricRegistry::Entry*> selected;
  for (const auto& e : reg.entries())
    if (all) selected.push_back(&e);
  for (const auto& n : metric_names)
    selected.push_back(&reg.at(n));
  const PointTruthInput in{truth, output, static_cast<double>(truth.bbox().diagonal())};
  Json record = Json::object(), histograms = Json::object(), effective = Json::object(),
       skipped = Json::object();
  for (const auto* e : selected) {
    const Json params =
        metric_params.contains(e->name) ? metric_params.at(e->name) : Json::object();
    effective[e->name] = e->params.validate(params, "metric_params." + e->name);
    try {
      if (!e->fn.run_point_truth)
        throw NotApplicable(e->name +
                            ": not applicable: needs a ground-truth mesh (the ground "
                            "truth is a point cloud)");
      auto t = ctx.phase("metric." + e->name);
      Json result = e->fn.run_point_truth(in, params, ctx);
      for (auto& [key, value] : result.items()) {
        if (key == "histograms") {
          for (auto& [hk, hv] : value.items())
            histograms[hk] = hv;
        } else if (!e->fn.find_key(key)) {
          throw Error("metric " + e->name + " emitted key '" + key +
                      "' without declaring its direction (metrics/src/registry.cpp)");
        } else {
          record[key] = value;
        }
      }
    } catch (const NotApplicable& ex) {
      if (!all) throw;
      skipped[e->name] = ex.what();
    }
  }
  record["output_points"] = output.size();
  record["gt_points"] = truth.size();
  // Nothing here is random; the seed and the metric list let `eval --from-record` score again.
  record["scoring"] = {{"seed", ctx.seed()}, {"metrics", metric_names}};
  record["gt_diagonal"] = in.diagonal;
  record["metric_params"] = std::move(effective);
  record["skipped"] = std::move(skipped);
  record["histograms"] = std::move(histograms);
  return record;
}

}  // namespace scanbench::metrics
