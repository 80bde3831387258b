#include "scanbench/scanner/throughput.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

#include "scanbench/core/errors.h"
#include "scanbench/core/timing.h"
#include "scanner_engine.h"

namespace scanbench::scanner {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

ThroughputResult measure_throughput(const TriangleMesh& mesh, const ScannerParams& p, int repeats,
                                    RunContext& ctx) {
  if (repeats < 1) throw ParamError("bench scanner: repeats: expected >= 1");
  const detail::ScannerEngine engine(mesh, p);
  ThroughputResult res;
  res.triangles = mesh.num_faces();
  res.rays_per_run = engine.rays_per_run();
  const std::vector<RTCRayHit> pristine = engine.make_all_rays();
  std::vector<RTCRayHit> rays;
  // One untimed warm-up of each side.
  rays = pristine;
  engine.cast_all(rays);
  {
    const Scan s = engine.run(ctx);
    res.points = s.cloud.size();
    res.scanner_beams_returned = s.record["counts"]["pixels"].get<std::int64_t>() -
                                 s.record["counts"]["misses"].get<std::int64_t>();
    const int sub = p.sub_rays;
    for (std::size_t b = 0; b + static_cast<std::size_t>(sub) <= rays.size();
         b += static_cast<std::size_t>(sub)) {
      int hits = 0;
      for (int k = 0; k < sub; ++k)
        hits += rays[b + static_cast<std::size_t>(k)].hit.geomID != RTC_INVALID_GEOMETRY_ID;
      res.bare_beams_returned += hits >= (sub + 1) / 2;
    }
  }
  for (int r = 0; r < repeats; ++r) {
    rays = pristine;  // untimed reset of tfar / geomID
    double c0 = process_cpu_seconds();
    auto t0 = std::chrono::steady_clock::now();
    engine.cast_all(rays);
    res.bare_seconds.push_back(seconds_since(t0));
    res.bare_cpu_seconds.push_back(process_cpu_seconds() - c0);
    c0 = process_cpu_seconds();
    t0 = std::chrono::steady_clock::now();
    const Scan s = engine.run(ctx);
    res.scanner_seconds.push_back(seconds_since(t0));
    res.scanner_cpu_seconds.push_back(process_cpu_seconds() - c0);
  }
  const double n = static_cast<double>(res.rays_per_run);
  res.scanner_rays_per_second = n / median(res.scanner_seconds);
  res.bare_rays_per_second = n / median(res.bare_seconds);
  res.ratio = res.scanner_rays_per_second / res.bare_rays_per_second;
  res.cpu_ratio = median(res.bare_cpu_seconds) / median(res.scanner_cpu_seconds);
  return res;
}

ScannerParams all_artifacts_params() {
  ScannerParams p;
  p.views = 8;
  p.resolution = 128;
  p.noise_sigma = 0.002;
  p.noise_range_slope = 0.001;
  p.noise_incidence_slope = 0.001;
  p.max_incidence_deg = 80.0;
  p.beam_divergence_deg = 0.25;
  p.sub_rays = 4;
  p.flying_pixel_prob = 0.3;
  p.misalign_fraction = 0.5;
  p.misalign_deg = 1.0;
  p.misalign_shift = 0.005;
  p.outlier_fraction = 0.05;
  return p;
}

TriangleMesh uv_sphere(int target_triangles) {
  // rings x segments with segments = 2 rings: 2 * segments * (rings - 1) triangles.
  const int rings = std::max(2, static_cast<int>(std::lround(std::sqrt(target_triangles / 4.0))));
  const int segs = 2 * rings;
  TriangleMesh m;
  m.vertices.resize(3, 2 + (rings - 1) * segs);
  m.vertices.col(0) = Eigen::Vector3f(0, 0, 1);
  m.vertices.col(1) = Eigen::Vector3f(0, 0, -1);
  for (int i = 1; i < rings; ++i) {
    const double th = M_PI * i / rings;
    for (int j = 0; j < segs; ++j) {
      const double ph = 2.0 * M_PI * j / segs;
      m.vertices.col(2 + (i - 1) * segs + j) =
          Eigen::Vector3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th))
              .cast<float>();
    }
  }
  auto vid = [&](int i, int j) { return 2 + (i - 1) * segs + (j % segs); };
  std::vector<Eigen::Vector3i> f;
  for (int j = 0; j < segs; ++j) {
    f.emplace_back(0, vid(1, j), vid(1, j + 1));
    f.emplace_back(1, vid(rings - 1, j + 1), vid(rings - 1, j));
    for (int i = 1; i + 1 < rings; ++i) {
      f.emplace_back(vid(i, j), vid(i + 1, j), vid(i + 1, j + 1));
      f.emplace_back(vid(i, j), vid(i + 1, j + 1), vid(i, j + 1));
    }
  }
  m.faces.resize(3, static_cast<Eigen::Index>(f.size()));
  for (std::size_t k = 0; k < f.size(); ++k)
    m.faces.col(static_cast<Eigen::Index>(k)) = f[k];
  return m;
}

}  // namespace scanbench::scanner
