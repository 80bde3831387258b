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
//
// Sweep points are never pooled silently: when neither the rows nor the columns name `point` and a
// cell would hold records of different sweep points, the point joins the columns (the variant
// axis: "CLOP (h=0.04)"), unless TableSpec::pool_sweeps asks to pool them. Every rendering states
// what a cell aggregates (Table::aggregates: seeds, repeats, and whatever else a cell mixes:
// pooled sweep points, datasets, scanners).
//
// Mesh outputs and point outputs scored on the same key (the accuracy.chamfer keys that
// surface.chamfer reuses: a mesh is scored on its surface samples, points on themselves) are not
// comparable: a row that mixes them marks no best on such a key and the table says so (note).
//
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
  std::string metric;        ///< empty: p2plane_mean_rel, else chamfer_rel, else the first metric
  bool pool_sweeps = false;  ///< pool the sweep points of a variant into one cell (said so)
};

struct TableCell {
  double median = 0;
  double spread = 0;   ///< sample standard deviation (0 for n < 2)
  int n = 0;           ///< values aggregated
  std::string status;  ///< when n == 0: the failing status of the jobs (or empty: no job)
  bool best = false;
  std::string output_kind;  ///< "points", "mesh", "mixed" or "" (records' output_kind)
};

struct Table {
  std::string metric;
  bool higher_better = false;
  int better = -1;  ///< quantity_direction: -1 lower, +1 higher, 0 informational (no best)
  std::string row_title, col_title;
  std::vector<std::string> row_labels, col_labels;
  std::vector<std::vector<TableCell>> cells;  ///< [row][col]
  /// What one cell aggregates, e.g. "median ± std over 3 seeds (one value per job); sweep
  /// points separate".
  std::string aggregates;
  /// Said under the table: e.g. rows where mesh and point outputs are not comparable.
  std::string note;
};

/// Builds the table. Throws ParamError (one line, with a "did you mean" suggestion) for an
/// unknown row/column field, a param:<key> no record has, or a metric no record has.
Table build_table(const std::vector<Json>& records, const TableSpec& spec);
/// How a header names a quantity: the key, with its published evaluator's convention when it
/// follows one ("sd_cd_sph_x1e4 [ScoreDenoise convention]"); scanbench's own keys unmarked.
std::string metric_header(const std::string& quantity);
/// The default metric of a record set (see TableSpec::metric).
std::string default_metric(const std::vector<Json>& records);
/// Renders as "md", "csv" (long format: row,col,median,spread,n,best,status), "tex" or "html"
/// (a <table> element). Throws ParamError for another format.
std::string render_table(const Table& t, const std::string& format);
/// The value of a row/column field of a record ("dataset", "param:x", ...).
std::string field_value(const Json& record, const std::string& field);
/// Numbers in tables: 4 significant digits; integral values (counts) as integers, never in
/// scientific notation ("20630", not "2.063e+04").
std::string format_number(double v);
/// Escapes <, >, & and " for HTML text and attribute values.
std::string html_escape(const std::string& s);

/// Every quantity the records hold (metric keys, time.total, time.cpu, time.<phase>,
/// peak_rss_mb, sizes.<key>), sorted.
std::vector<std::string> record_quantities(const std::vector<Json>& records);
/// Throws ParamError "<where>: unknown quantity 'x' (did you mean 'y'?)" unless some record holds
/// `quantity`; a key a registered metric declares that no record holds is named as such.
void check_quantity(const std::vector<Json>& records, const std::string& quantity,
                    const std::string& where);
/// True when mesh and point outputs scored on `quantity` cannot be compared: a key declared both
/// by a metric scoring meshes and by one scoring points (metrics/registry.h).
bool mesh_points_incomparable(const std::string& quantity);
/// "mesh" when a record's metrics were scored on samples of a mesh output, else "points".
std::string scored_kind(const Json& record);

/// One variant's best sweep point in one row (best_points).
struct VariantBest {
  std::string row, variant;
  std::string point;  ///< the point's label ("h=0.04"), "" for an unswept variant
  int points = 1;     ///< sweep points of the variant in this row that have values
  double median = 0;  ///< median over the point's seeds (or timing samples)
  int n = 0;
  std::string output_kind;  ///< "points" or "mesh" ("" when unrecorded)
  /// "CLOP (h=0.04)" or "CLOP".
  std::string label() const { return point.empty() ? variant : variant + " (" + point + ")"; }
};

/// Per row (`rows` fields, e.g. "dataset+scanner") and variant, the sweep point with the best
/// median of `metric` (argmin or argmax in its direction; the first point for an informational
/// quantity), in first-seen order of rows then variants. Only ok records count.
std::vector<VariantBest> best_points(const std::vector<Json>& records, const std::string& metric,
                                     const std::string& rows);

}  // namespace scanbench::harness
