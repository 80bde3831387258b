#pragma once
// Comparison tables from records (`scanbench table DIR`).
//
// Rows and columns are record fields joined with '+': dataset, scanner, variant, point (the sweep
// assignment), seed, or param:<flat parameter key> (e.g. param:resample.clop.alpha). A cell
// aggregates every matching record that finished ok: for accuracy metrics one value per record
// (seeds are the repeats), for time.* every timing sample of every record. The cell shows the
// median and the spread (sample standard deviation over the values; "-" for a single value);
// the best median of each row is marked (bold in md/tex/html, best=1 in csv). Cells whose jobs
// all failed show the status (crash, timeout, ...).
// Quantities: a metric key (p2plane_mean_rel, fscore, ...), time.total, time.cpu,
// time.<phase>, peak_rss_mb, sizes.<key>. The direction is quantity_direction (compare.h): the
// one the metric declares; informational quantities (counts) mark no best.
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct TableSpec {
  std::string rows = "dataset+scanner+point";
  std::string cols = "variant";
  std::string metric;  ///< empty: p2plane_mean_rel, else chamfer_rel, else the first metric
};

struct TableCell {
  double median = 0;
  double spread = 0;   ///< sample standard deviation (0 for n < 2)
  int n = 0;           ///< values aggregated
  std::string status;  ///< when n == 0: the failing status of the jobs (or empty: no job)
  bool best = false;
};

struct Table {
  std::string metric;
  bool higher_better = false;
  int better = -1;  ///< quantity_direction: -1 lower, +1 higher, 0 informational (no best)
  std::string row_title, col_title;
  std::vector<std::string> row_labels, col_labels;
  std::vector<std::vector<TableCell>> cells;  ///< [row][col]
};

/// Builds the table; throws ParamError for an unknown row/column field.
Table build_table(const std::vector<Json>& records, const TableSpec& spec);
/// The default metric of a record set (see TableSpec::metric).
std::string default_metric(const std::vector<Json>& records);
/// Renders as "md", "csv" (long format: row,col,median,spread,n,best,status), "tex" or "html"
/// (a <table> element). Throws ParamError for another format.
std::string render_table(const Table& t, const std::string& format);
/// The value of a row/column field of a record ("dataset", "param:x", ...).
std::string field_value(const Json& record, const std::string& field);
/// Numbers in tables: 4 significant digits.
std::string format_number(double v);
/// Escapes <, >, & and " for HTML text and attribute values.
std::string html_escape(const std::string& s);

}  // namespace scanbench::harness
