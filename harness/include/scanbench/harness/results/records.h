#pragma once
// Job records and the results folder.
//
// Layout of a results folder DIR (written by `scanbench run`):
//   DIR/config.json        the experiment config as given (plus its source path)
//   DIR/plan.json          every expanded job, in expansion order
//   DIR/jobs/<id>.json     one record per finished job, written atomically (temp file + rename)
//   DIR/scans/<hash>.ply   scan cache (+ .ply.json sidecar), keyed by mesh, scanner params, seed
//   DIR/outputs/<id>*.ply  algorithm outputs (points; .mixture.ply; .mesh.ply)
//   DIR/runs.jsonl         all records merged, one per line, in plan order
//   DIR/runs.csv           the same, flattened (params.*, metrics.*, time.* medians)
//   DIR/tables.md          the accuracy and time tables, written as every run ends (finish.h)
//
// A record: {"id","key","experiment","status","error","dataset":{label,name,params},
// "scanner":{label,preset,params},"variant":{label,chain:[{algorithm,label,params}]},"point",
// "point_label","seed","repeats","params" (flat effective parameters),"metrics" (flat numbers),
// "histograms","timing":{"total_s":[...],"cpu_s":[...],"phases":{name:[...]},"scan_s",
// "scan_cached","metrics_s","job_wall_s"},"peak_rss_mb","sizes","artifacts","context"}.
// status: "ok", "error" (a typed exception: bad input or parameters), "crash" (killed by a
// signal), "timeout" (killed after timeout_s, or by a Slurm time limit), "memory" (allocation
// failed under memory_limit_mb, or Slurm's OUT_OF_MEMORY), "interrupted" (the scheduler stopped
// the job: scancel, node failure, preemption; `run --resume` runs it again, see slurm.h).
//
// With --executor slurm the folder also holds DIR/slurm/<NNN>/ per submission (slurm.h) and the
// merge job also writes the report DIR/index.html (after a local run: `scanbench report DIR`).
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/files.h"  // write_file_atomic, write_json_file
#include "scanbench/core/params.h"
#include "scanbench/core/timing.h"  // median

namespace scanbench::harness {

/// Where and with what the run happened: commit, compiler, library versions, host, CPU model,
/// hardware threads, date (UTC, ISO 8601).
Json run_context_json();

/// The current UTC time by strftime `format` (default ISO 8601, "2026-12-02T06:30:00Z"), as
/// recorded in run contexts and job records.
std::string utc_now(const char* format = "%Y-%m-%dT%H:%M:%SZ");

/// One CSV field: as is, or quoted (RFC 4180, inner quotes doubled) when it holds a comma, quote
/// or newline; a newline becomes a space so that every row stays on one line.
std::string csv_field(const std::string& s);
/// Reads a whole file; throws IoError.
std::string read_file(const std::filesystem::path& path);
/// Reads a JSON file; throws IoError naming the file for unreadable or invalid JSON.
Json read_json_file(const std::filesystem::path& path);

/// The records of a results folder: runs.jsonl when present and at least as new as every file
/// in jobs/, else jobs/*.json (in plan.json order when present, then by id). Throws IoError when
/// DIR holds neither.
std::vector<Json> load_records(const std::filesystem::path& dir);
/// Refuses (IoError naming WHERE and the field) a record that is not an object with a string
/// "id" or whose fields have other JSON types than scanbench writes (docs/records.md), so that
/// every reader may take the documented types as given. Called for every record loaded.
void check_record(const Json& record, const std::string& where);
/// Reads one job record file (jobs/<id>.json): read_json_file, then check_record.
Json read_record_file(const std::filesystem::path& path);
/// Records in jobs/ only, ordered by plan.json when present.
std::vector<Json> load_job_records(const std::filesystem::path& dir);

/// Writes DIR/runs.jsonl and DIR/runs.csv from the records (atomically).
void write_merged(const std::filesystem::path& dir, const std::vector<Json>& records);
/// The table of runs.csv: {"columns": [...], "rows": [[...], ...]}, one row per record: id, key,
/// status, dataset, scanner, variant, point, seed, repeats, params.<k>, metrics.<k> (numeric
/// keys), time.total_median_s, time.cpu_median_s, time.<phase>_median_s, peak_rss_mb, error.
/// Values at full precision (null where a record has none); the Python module's DataFrame.
Json records_table(const std::vector<Json>& records);
/// The CSV text of the records (records_table's header + one line per record; numbers of the
/// timing columns with 9 significant digits, metrics as written).
std::string records_csv(const std::vector<Json>& records);

/// Reads a numeric quantity of a record: "time.total" (median of total_s), "time.cpu",
/// "time.<phase>", "peak_rss_mb", "sizes.<key>", or a metric key. NaN when absent.
double record_value(const Json& record, const std::string& quantity);
/// The samples behind a quantity: timing samples for time.*, else the one value.
std::vector<double> record_samples(const Json& record, const std::string& quantity);

}  // namespace scanbench::harness
