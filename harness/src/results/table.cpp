#include "scanbench/harness/table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "scanbench/core/errors.h"
#include "scanbench/harness/compare.h"
#include "scanbench/harness/records.h"

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

void check_field(const std::string& f) {
  static const std::set<std::string> known{"dataset", "scanner", "variant",
                                           "point",   "seed",    "status"};
  if (known.count(f) || f.rfind("param:", 0) == 0) return;
  throw ParamError(fmt::format(
      "table: unknown field '{}' (expected dataset, scanner, variant, point, seed, status or "
      "param:<key>)",
      f));
}

std::string label_of(const Json& r, const std::vector<std::string>& fields) {
  std::string out;
  for (const auto& f : fields) {
    const std::string v = field_value(r, f);
    if (v.empty()) continue;
    out += (out.empty() ? "" : " / ") + v;
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
  if (a >= 1e-3 && a < 1e5) return fmt::format("{:.4g}", v);
  return fmt::format("{:.3e}", v);
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
  const auto rf = split_fields(spec.rows);
  const auto cf = split_fields(spec.cols);
  for (const auto& f : rf)
    check_field(f);
  for (const auto& f : cf)
    check_field(f);
  Table t;
  t.metric = spec.metric.empty() ? default_metric(records) : spec.metric;
  t.better = quantity_direction(t.metric);
  t.higher_better = t.better > 0;
  t.row_title = spec.rows;
  t.col_title = spec.cols;
  std::map<std::string, std::size_t> ri, ci;
  struct Acc {
    std::vector<double> values;
    std::string status;
  };
  std::map<std::pair<std::size_t, std::size_t>, Acc> acc;
  for (const auto& r : records) {
    const std::string rl = label_of(r, rf), cl = label_of(r, cf);
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
    for (double v : record_samples(r, t.metric))
      a.values.push_back(v);
  }
  t.cells.assign(t.row_labels.size(), std::vector<TableCell>(t.col_labels.size()));
  for (auto& [rc, a] : acc) {
    TableCell& c = t.cells[rc.first][rc.second];
    c.n = static_cast<int>(a.values.size());
    c.status = a.status;
    if (c.n == 0) continue;
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
  for (auto& row : t.cells) {
    if (t.better == 0) break;  // informational: no best
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
  return t;
}

std::string render_table(const Table& t, const std::string& format) {
  auto cell_text = [](const TableCell& c) {
    if (c.n == 0) return c.status.empty() ? std::string("") : c.status;
    std::string s = format_number(c.median);
    if (c.n > 1) s += " ± " + format_number(c.spread);
    return s;
  };
  const std::string title = t.better == 0 ? fmt::format("{} (informational)", t.metric)
                                          : fmt::format("{} ({} is better)", t.metric,
                                                        t.higher_better ? "higher" : "lower");
  std::string out;
  if (format == "md") {
    out = fmt::format("**{}**; median ± std over repeats, best per row in bold\n\n", title);
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
  } else if (format == "csv") {
    out = "row,col,metric,median,spread,n,best,status\n";
    for (std::size_t r = 0; r < t.row_labels.size(); ++r) {
      for (std::size_t k = 0; k < t.col_labels.size(); ++k) {
        const TableCell& c = t.cells[r][k];
        if (c.n == 0 && c.status.empty()) continue;
        out += fmt::format(
            "{},{},{},{},{},{},{},{}\n", csv_field(t.row_labels[r]), csv_field(t.col_labels[k]),
            csv_field(t.metric), c.n ? fmt::format("{:.9g}", c.median) : "",
            c.n ? fmt::format("{:.9g}", c.spread) : "", c.n, c.best ? 1 : 0, c.n ? "ok" : c.status);
      }
    }
  } else if (format == "tex") {
    out = "% " + title + "; median $\\pm$ std over repeats, best per row in bold\n";
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
        out += " & " + (c.best ? "\\textbf{" + s + "}" : s);
      }
      out += " \\\\\n";
    }
    out += "\\hline\n\\end{tabular}\n";
  } else if (format == "html") {
    out = "<table class=\"cmp\">\n<caption>" + html_escape(title) +
          "; median &plusmn; std over repeats, best per row in bold</caption>\n<tr><th>" +
          html_escape(t.row_title + " \\ " + t.col_title) + "</th>";
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
