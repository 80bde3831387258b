#pragma once
// A virtual scan (`scanbench scan`): a dataset or a mesh file scanned with a scanner preset (or
// the scanner's defaults) and parameter overrides, every random stream from one seed.
#include <cstdint>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

struct ScanRequest {
  std::string dataset;            ///< a registered dataset, or
  std::string mesh;               ///< a mesh file (exactly one of the two)
  std::string preset;             ///< preset name or JSON file; "" = the scanner's defaults
  std::vector<std::string> sets;  ///< "key=value" overrides, applied in order
  Json values = Json::object();   ///< further overrides (key -> value), applied after `sets`
  std::uint64_t seed = 0;
  int threads = 0;  ///< worker threads (0 = all); never changes results
};

/// The scan, its record holding "input" (dataset, mesh, preset). Throws ParamError (neither or
/// both of dataset and mesh, an unknown or out-of-range parameter), IoError, InputError.
scanner::Scan run_scan(const ScanRequest& r);

}  // namespace scanbench::harness
