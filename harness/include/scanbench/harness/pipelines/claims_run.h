#pragma once
// The claims pipeline (`scanbench claims`, and `scanbench nightly` after its run): every claim of
// configs/claims/ (results/claims.h) through the experiment runner. Each claim's experiment goes
// to DIR/<id>/ (records, report) with one scan cache for all claims (DIR/scans, linked as
// DIR/<id>/scans), then its rules judge the records. A claim whose experiment declares a
// parameter protocol (config/protocol.h) is tuned first (DIR/<id>/tuning-<variant>/,
// results/tuning.h), then run at the protocol's values and over its ranges; the verdict uses the
// records at the values, the sensitivity all. Writes DIR/claims.json, DIR/claims.md and
// DIR/index.html.
#include <filesystem>
#include <string>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct ClaimsOptions {
  std::filesystem::path out;         ///< results folder (DIR/<claim id>/, DIR/claims.json)
  std::filesystem::path claims_dir;  ///< default configs/claims
  std::filesystem::path baseline;    ///< claims.json to compare with; empty = none
  std::string filter;                ///< regex on the claim id
  bool quick = false;
  bool resume = false;
  bool quiet = false;
  int jobs = 2;
};
/// Runs and judges the claims into o.out; returns the summary written to o.out/claims.json (with
/// "regressions": ids that held in o.baseline and failed now).
Json run_claims(const ClaimsOptions& o);

}  // namespace scanbench::harness
