#include "scanbench/harness/results/table.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::harness {

namespace {

std::vector<std::string> split_fields(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const auto plus = s.find('+', start);
    const std::string f =
        s.substr(start, plus == std::string::npos ? std::string::npos : plus - start);
    if (f.empty()) throw ParamError(fmt::format("table: empty field in '{}'", s));
    out.push_back(f);
    if (plus == std::string::npos) break;
    start = plus + 1;
  }
  return out;
}

std::string join_fields(const std::vector<std::string>& fields) {
  std::string out;
  for (const auto& f : fields)
    out += (out.empty() ? "" : "+") + f;
  return out;
}

/// The flat parameter keys of the records (for param:<key> suggestions).
std::vector<std::string> param_keys(const std::vector<Json>& records) {
  std::set<std::string> keys;
  for (const auto& r : records) {
    const Json p = r.value("params", Json::object());
    if (!p.is_object()) continue;
    for (const auto& item : p.items())
      keys.insert(item.key());
  }
  return {keys.begin(), keys.end()};
}

void check_field(const std::string& f, const std::vector<Json>& records, const char* option) {
  static const std::vector<std::string> known{"dataset", "scanner", "variant",
                                              "point",   "seed",    "status"};
  if (std::count(known.begin(), known.end(), f)) return;
  if (f.rfind("param:", 0) == 0) {
    const std::string key = f.substr(6);
    const std::vector<std::string> keys = param_keys(records);
    if (records.empty() || std::count(keys.begin(), keys.end(), key)) return;
    throw ParamError(fmt::format("table: {}: no record has the parameter '{}'{}", option, key,
                                 did_you_mean(key, keys)));
  }
  std::vector<std::string> candidates = known;
  candidates.push_back("param:<key>");
  throw ParamError(
      fmt::format("table: {}: unknown field '{}'{}", option, f, did_you_mean(f, candidates)));
}

/// How a record's output was scored: "mesh" (samples of its surface, output_mesh_samples) or
/// "points".
/// The label of a record on an axis: the fields' values joined with " / "; with `point_in_parens`
/// (a sweep point the table added) the point follows in parentheses: "CLOP (h=0.04)".
std::string label_of(const Json& r, const std::vector<std::string>& fields,
                     bool point_in_parens = false) {
  std::string out;
  for (const auto& f : fields) {
    const std::string v = field_value(r, f);
    if (v.empty()) continue;
    if (point_in_parens && f == "point" && !out.empty()) {
      out += " (" + v + ")";
    } else {
      out += (out.empty() ? "" : " / ") + v;
    }
  }
  return out.empty() ? "-" : out;
}

std::string tex_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '_' || c == '&' || c == '%' || c == '#' || c == '$') o += '\\';
    o += c;
  }
  return o;
}

}  // namespace

std::string scored_kind(const Json& r) {
  const Json m = r.value("metrics", Json::object());
  return m.is_object() && m.contains("output_mesh_samples") ? "mesh" : "points";
}

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '&':
        o += "&amp;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string format_number(double v) {
  if (std::isnan(v)) return "-";
  if (v == 0) return "0";
  const double a = std::abs(v);
  // Counts (and any integral value) as integers: 20630, not 2.063e+04.
  if (a >= 1 && a < 1e15 && v == std::round(v)) return fmt::format("{:.0f}", v);
  // Five digits and more without an exponent; the median of an even number of counts keeps
  // its half.
  if (a >= 1e4 && a < 1e15) {
    return 2 * v == std::round(2 * v) ? fmt::format("{:.1f}", v) : fmt::format("{:.0f}", v);
  }
  if (a >= 1e-3) return fmt::format("{:.4g}", v);
  return fmt::format("{:.3e}", v);
}

std::vector<std::string> record_quantities(const std::vector<Json>& records) {
  std::set<std::string> q;
  for (const auto& r : records) {
    const Json m = r.value("metrics", Json::object());
    if (m.is_object())
      for (const auto& [k, v] : m.items())
        if (v.is_number()) q.insert(k);
    const Json sizes = r.value("sizes", Json::object());
    if (sizes.is_object())
      for (const auto& [k, v] : sizes.items())
        if (v.is_number()) q.insert("sizes." + k);
    const Json timing = r.value("timing", Json::object());
    if (!timing.is_object()) continue;
    if (timing.contains("total_s")) q.insert("time.total");
    if (timing.contains("cpu_s")) q.insert("time.cpu");
    const Json phases = timing.value("phases", Json::object());
    if (phases.is_object())
      for (const auto& item : phases.items())
        q.insert("time." + item.key());
    if (r.contains("peak_rss_mb")) q.insert("peak_rss_mb");
  }
  return {q.begin(), q.end()};
}

void check_quantity(const std::vector<Json>& records, const std::string& quantity,
                    const std::string& where) {
  const std::vector<std::string> present = record_quantities(records);
  if (std::count(present.begin(), present.end(), quantity)) return;
  if (metrics::key_direction(quantity)) {
    throw ParamError(fmt::format("{}: no record has '{}' (no job computed it){}", where, quantity,
                                 did_you_mean(quantity, present)));
  }
  throw ParamError(
      fmt::format("{}: unknown quantity '{}'{}", where, quantity, did_you_mean(quantity, present)));
}

bool mesh_points_incomparable(const std::string& quantity) {
  bool by_mesh = false, by_points = false;
  for (const auto& e : metrics::registry().entries()) {
    if (!e.fn.find_key(quantity)) continue;
    (metrics::scores_mesh(e.fn.scores) ? by_mesh : by_points) = true;
  }
  return by_mesh && by_points;
}

std::string field_value(const Json& r, const std::string& f) {
  auto label = [&](const char* k) {
    if (!r.contains(k)) return std::string();
    const Json& x = r[k];
    return x.is_object() ? x.value("label", std::string()) : std::string();
  };
  if (f == "dataset" || f == "scanner" || f == "variant") return label(f.c_str());
  if (f == "point") return r.value("point_label", std::string());
  if (f == "seed") return r.contains("seed") ? r["seed"].dump() : "";
  if (f == "status") return r.value("status", std::string());
  if (f.rfind("param:", 0) == 0) {
    const std::string key = f.substr(6);
    const Json p = r.value("params", Json::object());
    if (!p.contains(key)) return "";
    const Json& v = p[key];
    if (v.is_string()) return v.get<std::string>();
    if (v.is_number_float()) return fmt::format("{:g}", v.get<double>());
    return v.dump();
  }
  return "";
}

std::string metric_header(const std::string& quantity) {
  const auto c = metrics::key_convention(quantity);
  if (!c || *c == "scanbench") return quantity;
  return fmt::format("{} [{} convention]", quantity, metrics::convention(*c).title);
}

std::string default_metric(const std::vector<Json>& records) {
  std::string first;
  for (const auto& r : records) {
    const Json m = r.value("metrics", Json::object());
    if (m.contains("p2plane_mean_rel")) return "p2plane_mean_rel";
    if (m.contains("chamfer_rel")) return "chamfer_rel";  // mesh outputs (surface.chamfer)
    for (const auto& [k, v] : m.items()) {
      if (first.empty() && v.is_number()) first = k;
    }
  }
  return first.empty() ? "time.total" : first;
}

Table build_table(const std::vector<Json>& records, const TableSpec& spec) {
  auto rf = split_fields(spec.rows);
  auto cf = split_fields(spec.cols);
  for (const auto& f : rf)
    check_field(f, records, "--rows");
  for (const auto& f : cf)
    check_field(f, records, "--cols");
  Table t;
  t.metric = spec.metric.empty() ? default_metric(records) : spec.metric;
  // A metric the user named must be one the records hold (a typo would give an empty table).
  const bool any_ok = std::any_of(records.begin(), records.end(), [](const Json& r) {
    return r.value("status", std::string()) == "ok";
  });
  if (!spec.metric.empty() && any_ok) check_quantity(records, t.metric, "table: --metric");
  t.better = quantity_direction(t.metric);
  t.higher_better = t.better > 0;
  const bool names_point =
      std::count(rf.begin(), rf.end(), "point") + std::count(cf.begin(), cf.end(), "point") > 0;
  // Sweep points join the variant's axis when a cell would otherwise mix them.
  bool point_added = false;
  if (!names_point && !spec.pool_sweeps) {
    std::map<std::pair<std::string, std::string>, std::set<std::string>> points;
    for (const auto& r : records)
      points[{label_of(r, rf), label_of(r, cf)}].insert(field_value(r, "point"));
    const bool mixed = std::any_of(points.begin(), points.end(),
                                   [](const auto& kv) { return kv.second.size() > 1; });
    if (mixed) {
      const bool variant_in_rows = std::count(rf.begin(), rf.end(), "variant") > 0 &&
                                   std::count(cf.begin(), cf.end(), "variant") == 0;
      (variant_in_rows ? rf : cf).push_back("point");
      point_added = true;
    }
  }
  t.row_title = join_fields(rf);
  t.col_title = join_fields(cf);
  std::map<std::string, std::size_t> ri, ci;
  struct Acc {
    std::vector<double> values;
    std::string status;
    std::set<std::string> seeds, points, datasets, scanners, kinds;
    std::size_t max_repeats = 0;
  };
  std::map<std::pair<std::size_t, std::size_t>, Acc> acc;
  for (const auto& r : records) {
    const std::string rl = label_of(r, rf, point_added), cl = label_of(r, cf, point_added);
    if (!ri.count(rl)) {
      ri[rl] = t.row_labels.size();
      t.row_labels.push_back(rl);
    }
    if (!ci.count(cl)) {
      ci[cl] = t.col_labels.size();
      t.col_labels.push_back(cl);
    }
    Acc& a = acc[{ri[rl], ci[cl]}];
    const std::string status = r.value("status", std::string());
    if (status != "ok") {
      a.status = status;
      continue;
    }
    const std::vector<double> samples = record_samples(r, t.metric);
    if (samples.empty()) continue;
    for (double v : samples)
      a.values.push_back(v);
    a.seeds.insert(field_value(r, "seed"));
    a.points.insert(field_value(r, "point"));
    a.datasets.insert(field_value(r, "dataset"));
    a.scanners.insert(field_value(r, "scanner"));
    a.kinds.insert(scored_kind(r));
    a.max_repeats = std::max(a.max_repeats, samples.size());
  }
  t.cells.assign(t.row_labels.size(), std::vector<TableCell>(t.col_labels.size()));
  std::size_t max_seeds = 0, max_points = 0, max_datasets = 0, max_scanners = 0, max_repeats = 0;
  for (auto& [rc, a] : acc) {
    TableCell& c = t.cells[rc.first][rc.second];
    c.n = static_cast<int>(a.values.size());
    c.status = a.status;
    if (c.n == 0) continue;
    c.output_kind = a.kinds.size() > 1 ? "mixed" : *a.kinds.begin();
    max_seeds = std::max(max_seeds, a.seeds.size());
    max_points = std::max(max_points, a.points.size());
    max_datasets = std::max(max_datasets, a.datasets.size());
    max_scanners = std::max(max_scanners, a.scanners.size());
    max_repeats = std::max(max_repeats, a.max_repeats);
    c.median = median(a.values);
    if (c.n > 1) {
      double mean = 0;
      for (double v : a.values)
        mean += v;
      mean /= c.n;
      double ss = 0;
      for (double v : a.values)
        ss += (v - mean) * (v - mean);
      c.spread = std::sqrt(ss / (c.n - 1));
    }
  }
  // What a cell aggregates.
  const bool timing = t.metric.rfind("time.", 0) == 0;
  std::string what;
  if (timing) {
    what = fmt::format("median ± std of every timing sample ({} {} x {} {} per cell at most)",
                       max_repeats, max_repeats == 1 ? "repeat" : "repeats", max_seeds,
                       max_seeds == 1 ? "seed" : "seeds");
  } else if (max_seeds > 1 || max_points > 1 || max_datasets > 1 || max_scanners > 1) {
    what = fmt::format("median ± std over jobs (one value per job; {} {} per cell at most)",
                       max_seeds, max_seeds == 1 ? "seed" : "seeds");
  } else {
    what = "one job per cell (one value, no spread)";
  }
  if (max_points > 1) {
    what += fmt::format("; sweep points pooled (--pool-sweeps: up to {} per cell)", max_points);
  } else if (names_point || point_added) {
    what += "; sweep points separate";
  }
  if (max_datasets > 1) what += fmt::format("; datasets pooled (up to {})", max_datasets);
  if (max_scanners > 1) what += fmt::format("; scanners pooled (up to {})", max_scanners);
  t.aggregates = what;

  // Mesh and point outputs on a key that scores them differently: no best in such a row.
  const bool incomparable_key = mesh_points_incomparable(t.metric);
  std::vector<std::string> mixed_rows;
  for (std::size_t r = 0; r < t.cells.size(); ++r) {
    auto& row = t.cells[r];
    if (incomparable_key) {
      std::set<std::string> kinds;
      for (const auto& c : row)
        if (c.n > 0) kinds.insert(c.output_kind);
      if (kinds.count("mixed") || (kinds.count("mesh") && kinds.count("points"))) {
        mixed_rows.push_back(t.row_labels[r]);
        continue;
      }
    }
    if (t.better == 0) continue;  // informational: no best
    double best = t.higher_better ? -INFINITY : INFINITY;
    for (const auto& c : row) {
      if (c.n == 0 || std::isnan(c.median)) continue;
      best = t.higher_better ? std::max(best, c.median) : std::min(best, c.median);
    }
    int with_values = 0;
    for (const auto& c : row)
      with_values += c.n > 0;
    if (with_values < 2) continue;  // nothing to compare in this row
    for (auto& c : row)
      c.best = c.n > 0 && c.median == best;
  }
  if (!mixed_rows.empty()) {
    t.note = fmt::format(
        "not comparable in {} row{} ({}): mesh outputs are scored on samples of their surface, "
        "point outputs on their own points, so {} differs by construction; no best is marked there "
        "(cells of mesh outputs are marked \"mesh\")",
        mixed_rows.size(), mixed_rows.size() == 1 ? "" : "s",
        fmt::format(
            "{}{}",
            fmt::join(mixed_rows.begin(),
                      mixed_rows.begin() + std::min<std::ptrdiff_t>(
                                               3, static_cast<std::ptrdiff_t>(mixed_rows.size())),
                      ", "),
            mixed_rows.size() > 3 ? ", ..." : ""),
        t.metric);
  }
  return t;
}

std::vector<VariantBest> best_points(const std::vector<Json>& records, const std::string& metric,
                                     const std::string& rows) {
  const auto rf = split_fields(rows);
  const int better = quantity_direction(metric);
  // row -> variant -> point -> values, in first-seen order.
  struct PointAcc {
    std::vector<double> values;
    std::string kind;
  };
  struct VariantAcc {
    std::vector<std::string> order;
    std::map<std::string, PointAcc> points;
  };
  std::vector<std::pair<std::string, std::vector<std::string>>> order;
  std::map<std::string, std::map<std::string, VariantAcc>> acc;
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") continue;
    const std::vector<double> samples = record_samples(r, metric);
    if (samples.empty()) continue;
    const std::string row = label_of(r, rf), v = field_value(r, "variant"),
                      p = field_value(r, "point");
    auto it =
        std::find_if(order.begin(), order.end(), [&](const auto& o) { return o.first == row; });
    if (it == order.end()) {
      order.push_back({row, {}});
      it = order.end() - 1;
    }
    if (std::find(it->second.begin(), it->second.end(), v) == it->second.end())
      it->second.push_back(v);
    VariantAcc& va = acc[row][v];
    if (!va.points.count(p)) va.order.push_back(p);
    PointAcc& pa = va.points[p];
    pa.values.insert(pa.values.end(), samples.begin(), samples.end());
    pa.kind = scored_kind(r);
  }
  std::vector<VariantBest> out;
  for (const auto& [row, variants] : order) {
    for (const auto& v : variants) {
      const VariantAcc& va = acc[row][v];
      VariantBest b;
      b.row = row;
      b.variant = v;
      b.points = static_cast<int>(va.order.size());
      bool first = true;
      for (const auto& p : va.order) {
        const PointAcc& pa = va.points.at(p);
        const double m = median(pa.values);
        const bool better_here =
            first || (better < 0 && m < b.median) || (better > 0 && m > b.median);
        if (!better_here) continue;
        b.point = p;
        b.median = m;
        b.n = static_cast<int>(pa.values.size());
        b.output_kind = pa.kind;
        first = false;
      }
      out.push_back(std::move(b));
    }
  }
  return out;
}

std::string render_table(const Table& t, const std::string& format) {
  // In a table whose rows mix mesh and point outputs on an incomparable key, mesh cells say so.
  auto kind_mark = [&t](const TableCell& c) -> std::string {
    if (t.note.empty() || c.n == 0 || c.output_kind == "points") return "";
    return c.output_kind == "mesh" ? " (mesh)" : " (mesh+points)";
  };
  auto cell_text = [&kind_mark](const TableCell& c) {
    if (c.n == 0) return c.status.empty() ? std::string("") : c.status;
    std::string s = format_number(c.median);
    if (c.n > 1) s += " ± " + format_number(c.spread);
    return s + kind_mark(c);
  };
  const std::string title = t.better == 0
                                ? fmt::format("{} (informational)", metric_header(t.metric))
                                : fmt::format("{} ({} is better)", metric_header(t.metric),
                                              t.higher_better ? "higher" : "lower");
  const std::string bold = t.better == 0 ? "" : "; best per row in bold";
  std::string out;
  if (format == "md") {
    out = fmt::format("**{}**; {}{}\n\n", title, t.aggregates, bold);
    out += "| " + t.row_title + " \\ " + t.col_title + " |";
    for (const auto& c : t.col_labels)
      out += " " + c + " |";
    out += "\n|---|";
    for (std::size_t i = 0; i < t.col_labels.size(); ++i)
      out += "---:|";
    out += "\n";
    for (std::size_t r = 0; r < t.row_labels.size(); ++r) {
      out += "| " + t.row_labels[r] + " |";
      for (const auto& c : t.cells[r]) {
        const std::string s = cell_text(c);
        out += " " + (c.best ? "**" + s + "**" : s) + " |";
      }
      out += "\n";
    }
    if (!t.note.empty()) out += "\nNote: " + t.note + "\n";
  } else if (format == "csv") {
    out = "row,col,metric,median,spread,n,best,status,aggregates,note\n";
    for (std::size_t r = 0; r < t.row_labels.size(); ++r) {
      for (std::size_t k = 0; k < t.col_labels.size(); ++k) {
        const TableCell& c = t.cells[r][k];
        if (c.n == 0 && c.status.empty()) continue;
        const std::string mark = kind_mark(c);
        out += fmt::format(
            "{},{},{},{},{},{},{},{},{},{}\n", csv_field(t.row_labels[r]),
            csv_field(t.col_labels[k]), csv_field(t.metric),
            c.n ? fmt::format("{:.9g}", c.median) : "", c.n ? fmt::format("{:.9g}", c.spread) : "",
            c.n, c.best ? 1 : 0, c.n ? "ok" : c.status, csv_field(t.aggregates),
            csv_field(mark.empty() ? ""
                                   : mark.substr(2, mark.size() - 3) +
                                         " output: not comparable with point outputs"));
      }
    }
  } else if (format == "tex") {
    std::string agg = t.aggregates;
    for (std::size_t pos; (pos = agg.find("±")) != std::string::npos;)
      agg.replace(pos, std::string("±").size(), "+-");
    out = "% " + title + "; " + agg + bold + "\n";
    out += "\\begin{tabular}{l" + std::string(t.col_labels.size(), 'r') + "}\n\\hline\n";
    out += tex_escape(t.row_title);
    for (const auto& c : t.col_labels)
      out += " & " + tex_escape(c);
    out += " \\\\\n\\hline\n";
    for (std::size_t r = 0; r < t.row_labels.size(); ++r) {
      out += tex_escape(t.row_labels[r]);
      for (const auto& c : t.cells[r]) {
        std::string s = c.n == 0 ? c.status : format_number(c.median);
        if (c.n > 1) s += " $\\pm$ " + format_number(c.spread);
        s += kind_mark(c);
        out += " & " + (c.best ? "\\textbf{" + s + "}" : s);
      }
      out += " \\\\\n";
    }
    out += "\\hline\n\\end{tabular}\n";
    if (!t.note.empty()) out += "% Note: " + t.note + "\n";
  } else if (format == "html") {
    out = "<table class=\"cmp\">\n<caption>" + html_escape(title) + "; " +
          html_escape(t.aggregates) + bold +
          (t.note.empty() ? "" : "<br><b>Note:</b> " + html_escape(t.note)) +
          "</caption>\n<tr><th>" + html_escape(t.row_title + " \\ " + t.col_title) + "</th>";
    for (const auto& c : t.col_labels)
      out += "<th>" + html_escape(c) + "</th>";
    out += "</tr>\n";
    for (std::size_t r = 0; r < t.row_labels.size(); ++r) {
      out += "<tr><th>" + html_escape(t.row_labels[r]) + "</th>";
      for (const auto& c : t.cells[r]) {
        const std::string s = html_escape(cell_text(c));
        const std::string cls =
            c.best ? " class=\"best\"" : (c.n == 0 && !c.status.empty() ? " class=\"fail\"" : "");
        out += "<td" + cls + ">" + (c.best ? "<b>" + s + "</b>" : s) + "</td>";
      }
      out += "</tr>\n";
    }
    out += "</table>\n";
  } else {
    throw ParamError(fmt::format("table: --format: expected md|csv|tex|html, got '{}'", format));
  }
  return out;
}

}  // namespace scanbench::harness
