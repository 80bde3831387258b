#include "surface_samples.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "noise.h"
#include "scanbench/core/errors.h"

namespace scanbench::scanner::detail {

Scan surface_samples_scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx) {
  validate(p, "scanner");
  mesh.validate("scan");
  const Eigen::Index degenerate = mesh.count_degenerate_faces();
  if (degenerate == mesh.num_faces()) {
    throw InputError(fmt::format("scan: all {} triangles of the mesh are degenerate (zero area)",
                                 mesh.num_faces()));
  }
  const NoiseLaw law = noise_law(p, "scanner");
  auto phase = ctx.phase("scan");
  // The bounding sphere of ScoreDenoise's normalize_sphere (models/utils.py): centre = bbox
  // centre of the vertices, radius = the largest vertex distance from it (the farthest surface
  // point of a triangle mesh is a vertex). Referenced vertices only, as the range scanner's bbox.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d v = mesh.vertices.col(mesh.faces(k, f)).cast<double>();
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double diag = (hi - lo).norm();
  double radius = 0;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      radius =
          std::max(radius, (mesh.vertices.col(mesh.faces(k, f)).cast<double>() - centre).norm());
    }
  }
  const double unit = p.noise_scale == "sphere_radius" ? radius : diag;
  const double sigma = p.noise_sigma * unit;

  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const std::uint32_t sample_seed =
      static_cast<std::uint32_t>(ctx.stream_seed("scan.samples") & 0x7fffffffu);
  const SurfaceSamples s = poisson_disk_samples(mesh, p.points, sample_seed);
  const auto t1 = Clock::now();

  // Serial, in sample order: one stream, so no thread count changes a draw.
  const Eigen::Index n = s.points.cols();
  Scan out;
  PointCloud& cloud = out.cloud;
  cloud.resize(n);
  Eigen::VectorXf cx(n), cy(n), cz(n);
  Rng rng(ctx.stream_seed("scan.sample_noise"));
  const ZigguratNormal& normal = ZigguratNormal::instance();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d q = s.points.col(i);
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    if (sigma > 0.0) {
      e = law.direction == NoiseDirection::kNormal
              ? Eigen::Vector3d(law.along(rng, normal) * s.normals.col(i))
              : law.spread(rng, normal);
    }
    cloud.positions.col(i) = (q + sigma * e).cast<float>();
    cx[i] = static_cast<float>(q.x());
    cy[i] = static_cast<float>(q.y());
    cz[i] = static_cast<float>(q.z());
  }
  cloud.scan_ids.resize(0);
  cloud.sensor_origins.resize(3, 0);
  cloud.properties["outlier"] = Eigen::VectorXf::Zero(n);
  cloud.properties["clean_x"] = std::move(cx);
  cloud.properties["clean_y"] = std::move(cy);
  cloud.properties["clean_z"] = std::move(cz);
  ctx.add_phase_time("scan.samples", std::chrono::duration<double>(t1 - t0).count());
  ctx.add_phase_time("scan.noise", std::chrono::duration<double>(Clock::now() - t1).count());

  Json& rec = out.record;
  rec = Json::object();
  rec["params"] = params_to_json(p);
  rec["noise"] = law.to_json();
  rec["noise"]["sigma"] = sigma;
  rec["noise"]["unit"] = p.noise_scale;
  rec["seed"] = ctx.seed();
  Json m = Json::object();
  m["vertices"] = mesh.num_vertices();
  m["faces"] = mesh.num_faces();
  m["degenerate_faces"] = degenerate;
  m["bbox_min"] = {lo.x(), lo.y(), lo.z()};
  m["bbox_max"] = {hi.x(), hi.y(), hi.z()};
  m["diagonal"] = diag;
  m["sphere_centre"] = {centre.x(), centre.y(), centre.z()};
  m["sphere_radius"] = radius;
  rec["mesh"] = m;
  rec["sampler"] = "open3d.SamplePointsPoissonDisk (init_factor 5)";
  rec["sensor"] = "none: surface samples have no sensor origin, rays or scan ids";
  rec["counts"] = {{"points", static_cast<std::int64_t>(n)}, {"outliers", 0}};
  rec["scans"] = Json::array();
  return out;
}

}  // namespace scanbench::scanner::detail
