#pragma once
// The options of a comparison (`scanbench compare`, `nightly`, an experiment's "compare" object):
// the tolerances of accuracy and the timing test's thresholds, as compare reads them. The format
// and the verdicts are described in results/compare.h; this part is read when a config loads, so
// a typo in it fails before any job runs.
#include <map>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct Tolerance {
  double rel = 0.05;
  double abs = 1e-9;
  int better = -1;  ///< -1 lower is better, +1 higher is better, 0 neutral
};

struct CompareOptions {
  double alpha = 0.05;
  double time_threshold = 0.10;
  double min_time_s = 0.001;
  bool timing = true;
  Tolerance default_tolerance;
  std::map<std::string, Tolerance> metric_tolerances;  ///< explicit per metric key
  std::vector<std::string> ignore;
  /// When not empty: compare only these quantities (and the status); `compare --metric`.
  std::vector<std::string> only;
  /// Where the options came from (from_json's `where`), for the messages of unknown names.
  std::string source = "compare";

  /// Options from a "compare" JSON object (see above); throws ParamError naming `where`.
  static CompareOptions from_json(const Json& j, const std::string& where);
  /// The tolerance of a metric key (explicit, else default with the direction rule above).
  Tolerance tolerance(const std::string& metric) const;
};

/// Which way a quantity is better: -1 lower, +1 higher, 0 informational. time.* and peak_rss_mb
/// lower, sizes.* informational, metric keys as their metric declares (metrics::key_direction),
/// undeclared keys informational. compare, table and report all use this.
int quantity_direction(const std::string& quantity);

}  // namespace scanbench::harness
