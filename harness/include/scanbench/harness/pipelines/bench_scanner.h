#pragma once
// The scanner benchmark (`scanbench bench scanner`): rays per second of the full scanner (every
// artifact on) against a bare rtcIntersect1M loop over the same scene and the same rays (same
// order, same coherent-context flag, same per-tile streams; scanbench/scanner/throughput.h),
// measured in one run, for procedural spheres of increasing size. Wall-clock ratios are the
// result; process-CPU ratios are given next to them because the machine may be shared (other
// processes disturb wall clocks more than CPU seconds).
#include <functional>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct ScannerBenchOptions {
  std::vector<int> sizes{1000, 10000, 100000, 1000000};  ///< triangles of the spheres
  int repeats = 5;                                       ///< timed repeats per size (medians)
  int threads = 0;                                       ///< worker threads (0 = all)
  /// Called with each line of the table as it is measured (header first, then one per size).
  std::function<void(const std::string& line)> progress;
};

struct ScannerBenchResult {
  Json json;         ///< what `--json` writes: context, params, cases, ratios, target
  std::string text;  ///< the summary line (median and smallest ratio, CPU-time median)
  const Json& to_json() const { return json; }
};

/// Runs the benchmark. Throws Error when the bare loop and the scanner returned different beams
/// (not the same rays).
ScannerBenchResult run_scanner_bench(const ScannerBenchOptions& o);

}  // namespace scanbench::harness
