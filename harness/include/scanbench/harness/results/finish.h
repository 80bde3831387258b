#pragma once
// The end of every run, whichever executor ran its jobs (runner.h: child processes on this
// machine; slurm.h: a Slurm array and its merge job). The executor merges the records
// (merge_records: DIR/runs.jsonl, DIR/runs.csv); then, once and here, the run is presented: the
// accuracy table and the time table (DIR/tables.md) and, when asked, the report
// (DIR/index.html, report.h). Executors include no presentation header; the command line calls
// finish_run after them.
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct FinishOptions {
  bool report = false;               ///< also write the report (DIR/index.html)
  std::filesystem::path history_db;  ///< with report: its History section (history.h)
};

struct FinishedRun {
  std::vector<Json> records;     ///< the merged records (load_records), in plan order
  std::string tables;            ///< the accuracy table, a blank line, the time table (Markdown)
  std::filesystem::path report;  ///< the page written; empty without FinishOptions::report
};

/// Presents the merged records of DIR: writes DIR/tables.md when there are records and the
/// report when `o.report`. Throws IoError.
FinishedRun finish_run(const std::filesystem::path& dir, const FinishOptions& o = {});

}  // namespace scanbench::harness
