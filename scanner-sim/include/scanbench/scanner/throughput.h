#pragma once
// Throughput of the virtual scanner against bare Embree (used by `scanbench bench scanner` and
// bench/bench_scanner.cpp). Both sides use one BVH (RTC_SCENE_FLAG_ROBUST, high build quality) and
// the very same rays, bit for bit: every sub-ray of every pixel of every view, in the scanner's
// order (view, 8 x 8 pixel tile, pixel row-major, sub-ray), cast as one rtcIntersect1M stream of
// AoS RTCRayHit per (view, tile) with the same context (RTC_INTERSECT_CONTEXT_FLAG_COHERENT). The
// bare side is a TBB-parallel loop of those calls over the precomputed rays (resetting the rays
// between repeats is untimed); the scanner side is the full scan: generating the rays into a
// per-thread tile buffer, casting them, every artifact, the output cloud and its record. BVH
// construction is excluded from both. Wall seconds are the measure; process CPU seconds are
// recorded too (on a shared machine they are less disturbed by other processes; with more than
// one thread they include TBB workers' spinning at the scanner's extra fork-joins).
#include <cstdint>
#include <vector>

#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::scanner {

struct ThroughputResult {
  std::int64_t triangles = 0;
  std::int64_t rays_per_run = 0;  ///< views * resolution^2 * sub_rays
  std::int64_t points = 0;        ///< points of one scan
  /// Pixels whose beam returned (at least ceil(sub_rays / 2) sub-rays hit), from the bare loop's
  /// hits and from the scan's record (pixels - misses): equal when both cast the same rays.
  std::int64_t bare_beams_returned = 0;
  std::int64_t scanner_beams_returned = 0;
  std::vector<double> scanner_seconds;      ///< wall, every repeat
  std::vector<double> bare_seconds;         ///< wall, every repeat
  std::vector<double> scanner_cpu_seconds;  ///< process CPU, every repeat
  std::vector<double> bare_cpu_seconds;     ///< process CPU, every repeat
  double scanner_rays_per_second = 0;       ///< rays_per_run / median(scanner_seconds)
  double bare_rays_per_second = 0;          ///< rays_per_run / median(bare_seconds)
  double ratio = 0;                         ///< scanner / bare rays per wall second
  double cpu_ratio = 0;  ///< median(bare_cpu_seconds) / median(scanner_cpu_seconds)
};

/// Runs `repeats` (>= 1) alternating repeats of the scanner and of bare rtcIntersect1M on `mesh`.
/// Throws like scan().
ThroughputResult measure_throughput(const TriangleMesh& mesh, const ScannerParams& p, int repeats,
                                    RunContext& ctx);

/// The benchmark's scanner: every artifact on (noise with range and incidence growth, grazing
/// drop-out, 4 sub-rays with 0.25 deg divergence, flying pixels, misalignment, 5% outliers),
/// 8 views of 128 x 128 pixels.
ScannerParams all_artifacts_params();

/// A closed latitude-longitude sphere of radius 1 at the origin with about `target_triangles`
/// triangles (at least 8); counter-clockwise from outside.
TriangleMesh uv_sphere(int target_triangles);

}  // namespace scanbench::scanner
