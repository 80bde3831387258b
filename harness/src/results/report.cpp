#include "scanbench/harness/results/report.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include "config/json_checks.h"
#include "results/report_viewer.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/results/claims_render.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

const char* kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                          "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
const char* color(std::size_t i) {
  return kPalette[i % 10];
}

/// Viridis, 5 stops, linear in between.
std::string viridis(double t) {
  static const double stops[5][3] = {
      {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  int c[3];
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<int>(std::lround(stops[i][k] + f * (stops[i + 1][k] - stops[i][k])));
  return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
}

/// About 5 "nice" ticks covering [lo, hi].
std::vector<double> nice_ticks(double lo, double hi) {
  if (!(hi > lo)) {
    const double pad = lo == 0 ? 1.0 : std::abs(lo) * 0.1;
    lo -= pad;
    hi += pad;
  }
  const double raw = (hi - lo) / 5.0;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    step = m * mag;
    if (raw <= step) break;
  }
  std::vector<double> t;
  for (double v = std::ceil(lo / step) * step; v <= hi + step * 1e-9; v += step)
    t.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return t;
}

struct Series {
  std::string name;
  std::vector<std::pair<double, double>> pts;
};

constexpr int kW = 460, kH = 300, kL = 70, kR = 130, kT = 30, kB = 45;

std::string svg_open(const std::string& title, int w = kW, int h = kH) {
  return fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} "
      "{1}\" font-family=\"sans-serif\" font-size=\"11\"><title>{2}</title>"
      "<text x=\"{3}\" y=\"16\" text-anchor=\"middle\" font-size=\"12\" "
      "font-weight=\"bold\">{2}</text>",
      w, h, html_escape(title), w / 2);
}

/// Axes with ticks; returns the SVG and the mapping functions through the out parameters.
struct Axes {
  double x0, x1, y0, y1;
  double px(double x) const { return kL + (x - x0) / (x1 - x0) * (kW - kL - kR); }
  double py(double y) const { return kH - kB - (y - y0) / (y1 - y0) * (kH - kT - kB); }
};

std::string draw_axes(Axes& a, double xlo, double xhi, double ylo, double yhi,
                      const std::string& xlabel, const std::string& ylabel) {
  const auto xt = nice_ticks(xlo, xhi), yt = nice_ticks(ylo, yhi);
  a.x0 = std::min(xlo, xt.front());
  a.x1 = std::max(xhi, xt.back());
  a.y0 = std::min(ylo, yt.front());
  a.y1 = std::max(yhi, yt.back());
  if (!(a.x1 > a.x0)) a.x1 = a.x0 + 1;
  if (!(a.y1 > a.y0)) a.y1 = a.y0 + 1;
  std::string s;
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#444\"/>", kL, kT,
      kW - kL - kR, kH - kT - kB);
  for (double v : xt) {
    const double x = a.px(v);
    s += fmt::format(
        "<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#ddd\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>",
        x, kT, kH - kB, kH - kB + 14, html_escape(format_number(v)));
  }
  for (double v : yt) {
    const double y = a.py(v);
    s += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"#ddd\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>",
        kL, kW - kR, y, kL - 4, y + 4, html_escape(format_number(v)));
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>", (kL + kW - kR) / 2,
                   kH - 8, html_escape(xlabel));
  s += fmt::format(
      "<text x=\"14\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {0})\">{1}</text>",
      (kT + kH - kB) / 2, html_escape(ylabel));
  return s;
}

std::string legend(const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < 16; ++i) {
    const int y = kT + 8 + static_cast<int>(i) * 15;
    s += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{}\"/>"
        "<text x=\"{}\" y=\"{}\">{}</text>",
        kW - kR + 8, y - 8, color(i), kW - kR + 22, y + 1, html_escape(names[i]));
  }
  return s;
}

/// A horizontal reference line (an unswept variant on a sweep plot).
struct RefLine {
  std::string name;
  double y;
};

/// Lines of (x, y) markers, each marker with its values as a hover title. With `better` -1 or
/// +1 (quantity_direction), the best marker over all series (the least or greatest y; the first
/// on a tie) is ringed (class "best"), with its values in its title.
std::string line_plot(const std::string& title, const std::string& xlabel,
                      const std::string& ylabel, const std::vector<Series>& series,
                      const std::vector<RefLine>& refs = {}, int better = 0) {
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  for (const auto& s : series) {
    for (const auto& [x, y] : s.pts) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      xlo = std::min(xlo, x);
      xhi = std::max(xhi, x);
      ylo = std::min(ylo, y);
      yhi = std::max(yhi, y);
    }
  }
  if (!std::isfinite(xlo)) return "";
  for (const auto& r : refs) {
    if (!std::isfinite(r.y)) continue;
    ylo = std::min(ylo, r.y);
    yhi = std::max(yhi, r.y);
  }
  std::string svg = svg_open(title);
  Axes a{};
  svg += draw_axes(a, xlo, xhi, ylo, yhi, xlabel, ylabel);
  std::vector<std::string> names;
  auto values = [&](const std::string& name, double x, double y) {
    return html_escape(fmt::format("{}: {} = {}, {} = {}", name, xlabel, format_number(x), ylabel,
                                   format_number(y)));
  };
  std::size_t best_series = series.size(), best_point = 0;
  for (std::size_t i = 0; i < series.size(); ++i) {
    std::string path;
    for (std::size_t k = 0; k < series[i].pts.size(); ++k) {
      const auto [x, y] = series[i].pts[k];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      if (better != 0 && (best_series == series.size() ||
                          better * (y - series[best_series].pts[best_point].second) > 0)) {
        best_series = i;
        best_point = k;
      }
      path += fmt::format("{}{:.1f},{:.1f}", path.empty() ? "" : " ", a.px(x), a.py(y));
      svg += fmt::format(
          "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"><title>{}</title></circle>",
          a.px(x), a.py(y), color(i), values(series[i].name, x, y));
    }
    svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>",
                       path, color(i));
    names.push_back(series[i].name);
  }
  if (best_series < series.size()) {
    const auto [x, y] = series[best_series].pts[best_point];
    svg += fmt::format(
        "<circle class=\"best\" cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"6\" fill=\"none\" "
        "stroke=\"{}\" stroke-width=\"2\"><title>best ({} is better): {}</title></circle>",
        a.px(x), a.py(y), color(best_series), better < 0 ? "lower" : "higher",
        values(series[best_series].name, x, y));
  }
  svg += legend(names);
  // Reference lines: dashed grey shades, listed under the series in the legend.
  std::size_t shown_refs = 0;
  for (const auto& r : refs) {
    if (!std::isfinite(r.y) || names.size() + shown_refs >= 16) continue;
    const char* grey = shown_refs % 2 == 0 ? "#555" : "#999";
    const int ly = kT + 8 + static_cast<int>(names.size() + shown_refs) * 15;
    svg += fmt::format(
        "<line class=\"ref\" x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"{3}\" "
        "stroke-dasharray=\"5 3\"><title>{4}: {5}</title></line>"
        "<line x1=\"{6}\" x2=\"{7}\" y1=\"{8}\" y2=\"{8}\" stroke=\"{3}\" stroke-dasharray=\"5 "
        "3\"/>"
        "<text x=\"{9}\" y=\"{10}\">{4}</text>",
        kL, kW - kR, a.py(r.y), grey, html_escape(r.name), html_escape(format_number(r.y)),
        kW - kR + 6, kW - kR + 18, ly - 3, kW - kR + 22, ly + 1);
    ++shown_refs;
  }
  return svg + "</svg>";
}

std::string heatmap(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                    const std::vector<std::string>& xs, const std::vector<std::string>& ys,
                    const std::vector<std::vector<double>>& v) {
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& row : v)
    for (double x : row)
      if (std::isfinite(x)) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
  const int cw = std::max(28, 360 / std::max<int>(1, static_cast<int>(xs.size())));
  const int ch = 22;
  const int w = kL + cw * static_cast<int>(xs.size()) + 20;
  const int h = kT + ch * static_cast<int>(ys.size()) + 60;
  std::string svg = svg_open(title, std::max(w, 300), h);
  for (std::size_t r = 0; r < ys.size(); ++r) {
    const int y = kT + static_cast<int>(r) * ch;
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>", kL - 4, y + 15,
                       html_escape(ys[r]));
    for (std::size_t c = 0; c < xs.size(); ++c) {
      const double val = v[r][c];
      const double t = hi > lo ? (val - lo) / (hi - lo) : 0.5;
      const int x = kL + static_cast<int>(c) * cw;
      svg += fmt::format(
          "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" stroke=\"#fff\">"
          "<title>{}</title></rect>",
          x, y, cw, ch, std::isfinite(val) ? viridis(t) : "#eee", html_escape(format_number(val)));
      if (std::isfinite(val) && cw >= 40) {
        svg += fmt::format(
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"9\" "
            "fill=\"{}\">{}</text>",
            x + cw / 2, y + 15, t > 0.6 ? "#000" : "#fff", html_escape(format_number(val)));
      }
    }
  }
  const int yb = kT + static_cast<int>(ys.size()) * ch;
  for (std::size_t c = 0; c < xs.size(); ++c) {
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
                       kL + static_cast<int>(c) * cw + cw / 2, yb + 14, html_escape(xs[c]));
  }
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
                     kL + cw * static_cast<int>(xs.size()) / 2, yb + 30, html_escape(xlabel));
  svg += fmt::format("<text x=\"4\" y=\"{}\">{}</text>", kT - 4, html_escape(ylabel));
  svg += fmt::format("<text x=\"{}\" y=\"{}\">min {} (dark) .. max {} (yellow)</text>", kL, yb + 46,
                     html_escape(format_number(lo)), html_escape(format_number(hi)));
  return svg + "</svg>";
}

std::string stacked_bars(const std::string& title, const std::vector<std::string>& labels,
                         const std::vector<std::string>& parts,
                         const std::vector<std::vector<double>>& values) {
  const int bh = 16, left = 260, width = 300;
  double mx = 0;
  for (const auto& row : values) {
    double s = 0;
    for (double v : row)
      s += std::max(0.0, v);
    mx = std::max(mx, s);
  }
  if (mx <= 0) mx = 1;
  const int h = kT + static_cast<int>(labels.size()) * (bh + 4) + 40 +
                15 * static_cast<int>(std::min<std::size_t>(parts.size(), 12));
  const int w = left + width + 80;
  std::string svg = svg_open(title, w, h);
  for (std::size_t r = 0; r < labels.size(); ++r) {
    const int y = kT + static_cast<int>(r) * (bh + 4);
    std::string lab = labels[r];
    if (lab.size() > 42) lab = lab.substr(0, 40) + "..";
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>", left - 4, y + 12,
                       html_escape(lab));
    double x = left, total = 0;
    for (std::size_t p = 0; p < parts.size(); ++p) {
      const double v = std::max(0.0, values[r][p]);
      const double bw = v / mx * width;
      total += v;
      if (bw > 0) {
        svg += fmt::format(
            "<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"{}\" fill=\"{}\">"
            "<title>{}: {} s</title></rect>",
            x, y, bw, bh, color(p), html_escape(parts[p]), html_escape(format_number(v)));
      }
      x += bw;
    }
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\">{} s</text>", x + 4, y + 12,
                       html_escape(format_number(total)));
  }
  int y = kT + static_cast<int>(labels.size()) * (bh + 4) + 14;
  for (std::size_t p = 0; p < parts.size() && p < 12; ++p, y += 15) {
    svg += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{}\"/>"
        "<text x=\"{}\" y=\"{}\">{}</text>",
        left, y - 9, color(p), left + 14, y, html_escape(parts[p]));
  }
  return svg + "</svg>";
}

/// One series over commits (history.h HistoryPlot): every sample grey, the median per commit as
/// a line, the baseline's commit green, each change point a dashed red line before the first
/// commit after the step.
std::string history_svg(const HistoryPlot& p) {
  double ylo = INFINITY, yhi = -INFINITY;
  for (const auto& s : p.samples)
    for (double y : s)
      if (std::isfinite(y)) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
  if (!std::isfinite(ylo) || p.commits.size() < 2) return "";
  std::string svg = svg_open(p.title);
  Axes a{};
  svg += draw_axes(a, 0, static_cast<double>(p.commits.size() - 1), ylo, yhi,
                   fmt::format("commit {} .. {}", p.commits.front(), p.commits.back()), p.ylabel);
  if (p.baseline >= 0) {
    const double x = a.px(static_cast<double>(p.baseline));
    svg += fmt::format(
        "<line class=\"baseline\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" "
        "stroke=\"#2ca02c\" stroke-width=\"2\"/>",
        x, kT, kH - kB);
  }
  for (std::size_t c : p.changes) {
    const double x = a.px(static_cast<double>(c) - 0.5);
    svg += fmt::format(
        "<line class=\"change\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" "
        "stroke=\"#d62728\" stroke-dasharray=\"4 3\"><title>change point: {3}..{4}</title></line>",
        x, kT, kH - kB, html_escape(p.commits[c - 1]), html_escape(p.commits[c]));
  }
  std::string path;
  for (std::size_t i = 0; i < p.commits.size(); ++i) {
    const double x = a.px(static_cast<double>(i));
    for (double y : p.samples[i])
      if (std::isfinite(y)) {
        svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"1.5\" fill=\"#aaa\"/>", x,
                           a.py(y));
      }
    const double m = median(p.samples[i]);
    if (!std::isfinite(m)) continue;
    path += fmt::format("{}{:.1f},{:.1f}", path.empty() ? "" : " ", x, a.py(m));
    svg += fmt::format(
        "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"><title>{}: {}</title></circle>",
        x, a.py(m), color(0), html_escape(p.commits[i]), html_escape(format_number(m)));
  }
  svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>",
                     path, color(0));
  const char* keys[][2] = {
      {"median", "#1f77b4"}, {"change point", "#d62728"}, {"baseline", "#2ca02c"}};
  for (int i = 0; i < 3; ++i) {
    const int y = kT + 8 + i * 15;
    svg += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{}\"/>"
        "<text x=\"{}\" y=\"{}\">{}</text>",
        kW - kR + 8, y - 8, keys[i][1], kW - kR + 22, y + 1, keys[i][0]);
  }
  return svg + "</svg>";
}

/// The History section (history.h): plots over the commits of the database, the commit of
/// results/baseline/ marked.
std::string history_section(const fs::path& db, const std::vector<Json>& records,
                            const std::vector<std::string>& metrics) {
  std::string baseline;
  std::ifstream in(project_root() / "results" / "baseline" / "runs.jsonl");
  std::string line;
  std::string baseline_problem;
  if (std::getline(in, line)) {
    try {
      const Json r = parse_json_text(line, "results/baseline/runs.jsonl:1");
      check_record(r, "results/baseline/runs.jsonl:1");
      baseline = r.value("context", Json::object()).value("commit", std::string());
    } catch (const Error& e) {
      baseline_problem = e.what();  // the plots stand without the marker; the page says why
    }
  }
  std::string html;
  int shown = 0;
  for (const auto& p : history_plots(db, records, metrics, baseline)) {
    const std::string svg = history_svg(p);
    if (!svg.empty() && shown++ < 120) html += svg + "\n";
  }
  std::string out = fmt::format(
      "<h2>History</h2>\n<p>From <code>{}</code>: per dataset and variant (its first job) the "
      "headline metrics over the commits of every machine and time.total over this machine's; "
      "grey: every sample, line: median per commit, dashed red: change points (`scanbench history "
      "changes`), green: the baseline's commit{}.{}{}</p>\n",
      html_escape(db.string()), baseline.empty() ? "" : " " + html_escape(baseline),
      shown > 120 ? fmt::format(" The first 120 of {} plots are shown.", shown) : "",
      baseline_problem.empty()
          ? ""
          : " The baseline's commit is not marked: " + html_escape(baseline_problem) + ".");
  if (shown == 0) return out + "<p>No quantity has two commits in the database yet.</p>\n";
  return out + "<div class=\"plots\" id=\"history\">\n" + html + "</div>\n";
}

bool is_ok(const Json& r) {
  return r.value("status", std::string()) == "ok";
}

std::string group_of(const Json& r) {
  return field_value(r, "dataset") + " / " + field_value(r, "scanner");
}

/// The records of each dataset/scanner group (group_of), the groups in the order of their first
/// record.
std::vector<std::pair<std::string, std::vector<const Json*>>> records_by_group(
    const std::vector<const Json*>& ok) {
  std::vector<std::pair<std::string, std::vector<const Json*>>> out;
  std::map<std::string, std::size_t> at;
  for (const Json* r : ok) {
    const auto [it, fresh] = at.emplace(group_of(*r), out.size());
    if (fresh) out.push_back({it->first, {}});
    out[it->second].second.push_back(r);
  }
  return out;
}

/// Numeric sweep keys of a record set, in the order of the first record's point.
std::vector<std::string> numeric_point_keys(const std::vector<const Json*>& rs) {
  std::vector<std::string> keys;
  if (rs.empty()) return keys;
  const Json first = rs.front()->value("point", Json::object());
  for (const auto& [k, v] : first.items()) {
    bool numeric = true;
    std::set<double> distinct;
    for (const Json* r : rs) {
      const Json p = r->value("point", Json::object());
      if (!p.contains(k) || !p[k].is_number()) {
        numeric = false;
        break;
      }
      distinct.insert(p[k].get<double>());
    }
    if (numeric && distinct.size() > 1) keys.push_back(k);
  }
  return keys;
}

std::string short_key(const std::string& k) {
  const auto dot = k.rfind('.');
  return dot == std::string::npos ? k : k.substr(dot + 1);
}

double point_num(const Json& r, const std::string& k) {
  const Json p = r.value("point", Json::object());
  return p.contains(k) && p[k].is_number() ? p[k].get<double>() : NAN;
}

std::string series_label(const Json& r, const std::vector<std::string>& keys) {
  std::string s;
  const Json p = r.value("point", Json::object());
  for (const auto& k : keys) {
    if (!p.contains(k)) continue;
    const Json& v = p[k];
    s += (s.empty() ? "" : " ") + short_key(k) + "=" +
         (v.is_number_float() ? fmt::format("{:g}", v.get<double>()) : v.dump());
  }
  return s.empty() ? "all" : s;
}

/// Median over records (e.g. seeds) sharing (series, x).
std::vector<Series> build_series(const std::vector<const Json*>& rs, const std::string& xkey,
                                 const std::vector<std::string>& skeys, const std::string& metric,
                                 bool x_is_compression) {
  std::map<std::string, std::map<double, std::vector<double>>> acc;
  std::vector<std::string> order;
  for (const Json* r : rs) {
    double x;
    if (x_is_compression) {
      const double n = record_value(*r, "sizes.scan_points");
      const double k = record_value(*r, "sizes.mixture_components");
      x = k > 0 ? n / k : NAN;
    } else {
      x = point_num(*r, xkey);
    }
    const double y = record_value(*r, metric);
    if (!std::isfinite(x) || !std::isfinite(y)) continue;
    const std::string s = series_label(*r, skeys);
    if (!acc.count(s)) order.push_back(s);
    acc[s][x].push_back(y);
  }
  std::vector<Series> out;
  for (const auto& s : order) {
    Series ser{s, {}};
    for (const auto& [x, ys] : acc[s])
      ser.pts.push_back({x, median(ys)});
    out.push_back(std::move(ser));
  }
  return out;
}

/// The output's size in the jobs table: points, or "V vertices, F faces" for a mesh output.
std::string output_size(const Json& r) {
  const double v = record_value(r, "sizes.mesh_vertices");
  if (!std::isnan(v)) {
    return format_number(v) + " vertices, " + format_number(record_value(r, "sizes.mesh_faces")) +
           " faces";
  }
  return format_number(record_value(r, "sizes.output_points"));
}

std::string link(const fs::path& dir, const std::string& rel, const std::string& text) {
  if (rel.empty() || !fs::exists(dir / rel)) return "";
  return fmt::format("<a href=\"{}\">{}</a>", html_escape(rel), html_escape(text));
}

}  // namespace

namespace {

// The first screen: per dataset, which variants ran and, for each headline quantity that has a
// direction, the winner: each variant at its best sweep point (best_points, table.h), then the
// best of those. Mesh and point outputs on a key that scores them differently get a winner each,
// marked not comparable.
std::string winners_section(const std::vector<Json>& records,
                            const std::vector<std::string>& metrics) {
  struct Column {
    std::string metric;
    int better;
    std::vector<VariantBest> bests;
  };
  std::vector<Column> cols;
  for (const std::string& m : metrics) {
    const int better = quantity_direction(m);
    if (better == 0) continue;
    auto bests = best_points(records, m, "dataset+scanner");
    if (!bests.empty()) cols.push_back({m, better, std::move(bests)});
  }
  if (cols.empty()) return "";
  // Rows and the variants compared in each (with their number of sweep points), first seen.
  std::vector<std::string> rows;
  std::map<std::string, std::vector<std::pair<std::string, int>>> compared;
  bool any_swept = false, any_incomparable = false;
  for (const Column& c : cols) {
    for (const VariantBest& b : c.bests) {
      if (std::find(rows.begin(), rows.end(), b.row) == rows.end()) rows.push_back(b.row);
      auto& list = compared[b.row];
      auto it = std::find_if(list.begin(), list.end(),
                             [&](const auto& e) { return e.first == b.variant; });
      if (it == list.end()) {
        list.push_back({b.variant, b.points});
      } else {
        it->second = std::max(it->second, b.points);
      }
      any_swept = any_swept || !b.point.empty();
    }
  }
  std::string body;
  for (const std::string& row : rows) {
    std::string list;
    for (const auto& [v, n] : compared[row]) {
      list += (list.empty() ? "" : ", ") + html_escape(v) +
              (n > 1 ? fmt::format(" ({} sweep points)", n) : "");
    }
    std::string cells;
    for (const Column& c : cols) {
      // The winners per scored kind (one kind unless the key cannot compare mesh and points).
      std::map<std::string, std::vector<const VariantBest*>> by_kind;
      for (const VariantBest& b : c.bests)
        if (b.row == row)
          by_kind[mesh_points_incomparable(c.metric) ? b.output_kind : ""].push_back(&b);
      std::string cell;
      for (const auto& [kind, bs] : by_kind) {
        double best = c.better > 0 ? -INFINITY : INFINITY;
        for (const VariantBest* b : bs)
          best = c.better > 0 ? std::max(best, b->median) : std::min(best, b->median);
        std::string names;
        for (const VariantBest* b : bs) {
          if (b->median != best) continue;
          names += fmt::format("{}{} {}", names.empty() ? "" : ", ", html_escape(b->label()),
                               format_number(b->median));
        }
        if (by_kind.size() > 1)
          names = (kind == "mesh" ? "mesh" : "point") + std::string(" outputs: ") + names;
        cell += (cell.empty() ? "" : "<br>") + names;
      }
      if (by_kind.size() > 1) {
        any_incomparable = true;
        cell += "<br><i>mesh and point outputs not comparable on this key</i>";
      }
      cells += "<td style=\"text-align:left\">" + (cell.empty() ? "-" : cell) + "</td>";
    }
    body += fmt::format(
        "<tr><td style=\"text-align:left\">{}</td><td style=\"text-align:left\">{}"
        "</td>{}</tr>\n",
        html_escape(row), list, cells);
  }
  std::string h =
      "<h2>What was compared and what won</h2>\n<p class=\"aggregates\">Each value: the median "
      "over "
      "the seeds of one variant and sweep point (one value per job; time.* over every timing "
      "sample)";
  if (any_swept) {
    h += "; each swept variant at its best sweep point (the argmin, or the argmax where higher is "
         "better, over its points, named with the point's value), then the best variant";
  }
  h += ".";
  if (any_incomparable) {
    h += " Mesh outputs are scored on samples of their surface and point outputs on their own "
         "points: on the keys marked, each kind has its own winner.";
  }
  h += "</p>\n<table id=\"winners\"><tr><th>dataset</th><th>compared</th>";
  for (const Column& c : cols)
    h += fmt::format("<th>{} ({})</th>", html_escape(metric_header(c.metric)),
                     c.better > 0 ? "higher" : "lower");
  h += "</tr>\n" + body;
  return h + "</table>\n";
}

}  // namespace

namespace {

/// The quantities the report shows: "report": {"metrics": [...]} of the config, else the main
/// ones present among the ok records (point outputs, then the surface metrics of mesh outputs:
/// surface.h, mesh_facts.h), else the records' default metric unless it is time.total.
/// A configured name no record holds (a typo would plot nothing) is a ParamError naming `where`
/// (the config's "report" object) with a suggestion; so is an "x" that is no swept key.
std::vector<std::string> report_metrics(const Json& report_cfg, const std::vector<Json>& records,
                                        const std::vector<const Json*>& ok,
                                        const std::string& where) {
  std::vector<std::string> metrics;
  if (report_cfg.contains("x") && report_cfg["x"].is_string() && !ok.empty()) {
    const std::string x = report_cfg["x"].get<std::string>();
    std::set<std::string> swept;
    for (const Json* r : ok) {
      const Json point = r->value("point", Json::object());
      for (const auto& item : point.items())
        swept.insert(item.key());
    }
    if (!swept.count(x)) {
      throw ParamError(fmt::format("{}/x: '{}' is no swept key of the records{}", where, x,
                                   did_you_mean(x, {swept.begin(), swept.end()})));
    }
  }
  if (report_cfg.contains("metrics") && report_cfg["metrics"].is_array()) {
    const Json& list = report_cfg["metrics"];
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (!list[i].is_string()) {
        throw ParamError(
            fmt::format("{}/metrics/{}: expected a metric key, got {}", where, i, list[i].dump()));
      }
      const std::string m = list[i].get<std::string>();
      if (!ok.empty()) check_quantity(records, m, fmt::format("{}/metrics/{}", where, i));
      metrics.push_back(m);
    }
    return metrics;
  }
  for (const char* m : {"p2plane_mean_rel", "nn_dist_cv", "chamfer_rel", "fscore",
                        "normal_angle_mean_deg", "outlier_residue", "input_distance_rms_rel",
                        "volume_iou", "mesh_boundary_edges", "mesh_bytes"}) {
    for (const Json* r : ok) {
      if (!std::isnan(record_value(*r, m))) {
        metrics.push_back(m);
        break;
      }
    }
  }
  if (metrics.empty() && !records.empty()) {
    const std::string d = default_metric(records);
    if (d != "time.total") metrics.push_back(d);
  }
  return metrics;
}

/// The page's head and first lines: the title, the config's description, the run context and
/// the status counts with links to the records.
std::string head_section(const std::string& name, const Json& cfg,
                         const std::vector<Json>& records) {
  std::string h;
  h += std::string("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">") +
       "<meta http-equiv=\"Content-Security-Policy\" content=\"" + kReportCsp + "\">" +
       "<title>scanbench: " + html_escape(name) +
       "</title>\n<style>\n"
       "body{font-family:sans-serif;margin:1.5em;max-width:1400px;color:#222}"
       "table{border-collapse:collapse;margin:0.6em 0}td,th{border:1px solid #ccc;padding:2px 6px;"
       "font-size:13px}td{text-align:right}caption{text-align:left;font-size:13px;padding:3px}"
       "td.best{background:#e6f4e6}td.fail{background:#fbe3e3;color:#900}"
       ".plots{display:flex;flex-wrap:wrap;gap:10px}.plots svg{border:1px solid #eee}"
       "h2{border-bottom:1px solid #ccc;margin-top:1.5em}code{font-size:12px}"
       ".regression{color:#b00;font-weight:bold}\n</style></head><body>\n";
  h += "<h1>scanbench report: " + html_escape(name) + "</h1>\n";
  if (cfg.contains("description")) {
    h += "<p>" + html_escape(cfg["description"].get<std::string>()) + "</p>\n";
  }
  if (!records.empty() && records.front().contains("context")) {
    const Json& c = records.front()["context"];
    h += fmt::format(
        "<p id=\"context\">commit <code>{}</code>, {}, {} build; host {} ({}, {} hardware "
        "threads); {} threads per job; first job {}</p>\n",
        html_escape(c.value("commit", "")), html_escape(c.value("compiler", "")),
        html_escape(c.value("build", "")), html_escape(c.value("host", "")),
        html_escape(c.value("cpu", "")), c.value("hardware_threads", 0), c.value("threads", 0),
        html_escape(c.value("date", "")));
  }
  std::map<std::string, int> status_counts;
  for (const auto& r : records)
    ++status_counts[r.value("status", std::string("?"))];
  std::string counts;
  for (const auto& [s, n] : status_counts)
    counts += fmt::format("{}{} {}", counts.empty() ? "" : ", ", n, s);
  h += fmt::format(
      "<p id=\"summary\">{} jobs: {}. Records: <a href=\"runs.jsonl\">runs.jsonl</a>, "
      "<a href=\"runs.csv\">runs.csv</a>, <a href=\"config.json\">config.json</a>.</p>\n",
      records.size(), html_escape(counts));
  return h;
}

/// The nightly verdicts of DIR/compare.json (regressions and improvements); empty without it.
std::string baseline_section(const fs::path& dir) {
  if (!fs::exists(dir / "compare.json")) return "";
  const Json cmp = read_json_file(dir / "compare.json");
  std::string h =
      fmt::format("<h2>Comparison with the baseline: <span class=\"{}\">{}</span></h2>\n",
                  cmp.value("regressions", 0) > 0 ? "regression" : "",
                  html_escape(cmp.value("verdict", std::string("?"))));
  h += "<table id=\"verdicts\"><tr><th>job</th><th>quantity</th><th>base</th><th>new</th>"
       "<th>change</th><th>p</th><th>verdict</th></tr>\n";
  for (const auto& v : cmp.value("comparisons", Json::array())) {
    const std::string verdict = v.value("verdict", std::string());
    const bool undecided_notable = verdict == "not decidable" && v.value("notable", false);
    if (verdict != "regression" && verdict != "improvement" && !undecided_notable) continue;
    auto num = [&](const char* k) {
      return v.contains(k) && v[k].is_number() ? format_number(v[k].get<double>()) : "";
    };
    h += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "<td class=\"{}\">{}</td></tr>\n",
        html_escape(v.value("key", "")), html_escape(v.value("quantity", "")), num("base"),
        num("new"), num("change"), num("p"), verdict == "regression" ? "regression" : "",
        html_escape(undecided_notable ? v.value("note", verdict) : verdict));
  }
  h += "</table>\n";
  if (cmp.value("undecidable", 0) > 0) {
    h += fmt::format(
        "<p>{} timing comparisons are not decidable: too few repeats for the U test to reach its "
        "threshold (it needs {} per side); those whose change would count are listed above.</p>\n",
        cmp.value("undecidable", 0), cmp.value("repeats_needed", 0));
  }
  return h;
}

/// The jobs that failed, with their reasons and logs; empty when none did.
std::string failures_section(const fs::path& dir, const std::vector<Json>& records) {
  std::string h;
  bool any_failed = false;
  for (const auto& r : records) {
    if (is_ok(r)) continue;
    if (!any_failed) {
      h += "<h2>Failed jobs</h2>\n<table id=\"failures\"><tr><th>job</th><th>status</th>"
           "<th>reason</th><th>log</th></tr>\n";
      any_failed = true;
    }
    const Json art = r.value("artifacts", Json::object());
    h += fmt::format(
        "<tr class=\"failed\"><td>{}</td><td>{}</td><td style=\"text-align:left\">{}"
        "</td><td>{}</td></tr>\n",
        html_escape(r.value("key", "")), html_escape(r.value("status", "")),
        html_escape(r.value("error", "")), link(dir, art.value("log", ""), "log"));
  }
  if (any_failed) h += "</table>\n";
  return h;
}

/// One comparison table (table.h) per shown quantity, time.total and peak_rss_mb.
std::string tables_section(const std::vector<Json>& records,
                           const std::vector<std::string>& metrics) {
  std::string h = "<h2>Tables</h2>\n";
  std::vector<std::string> table_quantities = metrics;
  // The two the report adds of its own accord, where the records have them (records merged from
  // other tools, or a job that never ran a step, may not): names a user typed are checked.
  const std::vector<std::string> held = record_quantities(records);
  for (const char* q : {"time.total", "peak_rss_mb"})
    if (std::find(held.begin(), held.end(), q) != held.end()) table_quantities.push_back(q);
  for (const auto& q : table_quantities) {
    TableSpec spec;
    spec.metric = q;
    h += render_table(build_table(records, spec), "html");
  }
  return h;
}

/// The ok records of one variant on one dataset/scanner group and one set of swept keys.
struct SweepGroup {
  std::string variant, group;
  std::vector<const Json*> records;
  std::vector<std::string> keys;  ///< numeric swept keys, the plotted x first (report "x")
};

/// The ok records by variant (in record order), then dataset/scanner group and swept keys:
/// records of different sweeps (e.g. alpha x levels, then h alone) are plotted separately.
std::vector<SweepGroup> sweep_groups(const std::vector<const Json*>& ok, const Json& report_cfg) {
  std::map<std::string, std::map<std::string, std::vector<const Json*>>> by_variant;
  std::vector<std::string> variant_order;
  for (const Json* r : ok) {
    const std::string v = field_value(*r, "variant");
    if (!by_variant.count(v)) variant_order.push_back(v);
    std::string swept;
    const Json point = r->value("point", Json::object());
    for (const auto& [k, val] : point.items())
      swept += "," + k;
    by_variant[v][group_of(*r) + "\x1f" + swept].push_back(r);
  }
  std::vector<SweepGroup> groups;
  for (const auto& v : variant_order) {
    for (const auto& [group_key, rs] : by_variant[v]) {
      SweepGroup g{v, group_key.substr(0, group_key.find('\x1f')), rs, numeric_point_keys(rs)};
      if (report_cfg.contains("x") && report_cfg["x"].is_string()) {
        const std::string x = report_cfg["x"].get<std::string>();
        auto it = std::find(g.keys.begin(), g.keys.end(), x);
        if (it != g.keys.end()) std::rotate(g.keys.begin(), it, it + 1);
      }
      groups.push_back(std::move(g));
    }
  }
  return groups;
}

/// Each shown quantity and time.total against the group's first swept key, one line per value
/// of the other swept keys.
std::string sweep_plots(const SweepGroup& g, const std::vector<std::string>& metrics,
                        const std::vector<const SweepGroup*>& unswept) {
  std::string html;
  const std::string& xkey = g.keys.front();
  std::vector<std::string> skeys;
  const Json first = g.records.front()->value("point", Json::object());
  for (const auto& [k, val] : first.items())
    if (k != xkey) skeys.push_back(k);
  std::vector<std::string> plot_metrics = metrics;
  plot_metrics.push_back("time.total");
  for (const auto& m : plot_metrics) {
    auto series = build_series(g.records, xkey, skeys, m, false);
    if (series.size() == 1 && skeys.empty()) series.front().name = g.variant;
    std::vector<RefLine> refs;
    for (const SweepGroup* u : unswept) {
      std::vector<double> ys;
      for (const Json* r : u->records)
        if (const double y = record_value(*r, m); std::isfinite(y)) ys.push_back(y);
      if (!ys.empty()) refs.push_back({u->variant, median(ys)});
    }
    const std::string svg =
        line_plot(fmt::format("{}: {} vs {} ({})", g.variant, m, short_key(xkey), g.group), xkey, m,
                  series, refs, quantity_direction(m));
    if (!svg.empty()) html += svg + "\n";
  }
  return html;
}

/// A group swept over exactly two keys: a heatmap of each shown quantity over them (median over
/// seeds).
std::string sweep_heatmaps(const SweepGroup& g, const std::vector<std::string>& metrics) {
  std::string html;
  const std::vector<std::string>& keys = g.keys;
  std::set<double> xs_set, ys_set;
  for (const Json* r : g.records) {
    xs_set.insert(point_num(*r, keys[0]));
    ys_set.insert(point_num(*r, keys[1]));
  }
  const std::vector<double> xs(xs_set.begin(), xs_set.end()), ys(ys_set.begin(), ys_set.end());
  for (const auto& m : metrics) {
    std::vector<std::vector<std::vector<double>>> acc(ys.size(),
                                                      std::vector<std::vector<double>>(xs.size()));
    for (const Json* r : g.records) {
      const auto xi = std::lower_bound(xs.begin(), xs.end(), point_num(*r, keys[0])) - xs.begin();
      const auto yi = std::lower_bound(ys.begin(), ys.end(), point_num(*r, keys[1])) - ys.begin();
      acc[yi][xi].push_back(record_value(*r, m));
    }
    std::vector<std::vector<double>> vals(ys.size(), std::vector<double>(xs.size(), NAN));
    for (std::size_t a = 0; a < ys.size(); ++a)
      for (std::size_t b = 0; b < xs.size(); ++b)
        vals[a][b] = median(acc[a][b]);
    std::vector<std::string> xl, yl;
    for (double x : xs)
      xl.push_back(format_number(x));
    for (double y : ys)
      yl.push_back(format_number(y));
    html += heatmap(fmt::format("{}: {} over {} x {} ({})", g.variant, m, short_key(keys[0]),
                                short_key(keys[1]), g.group),
                    keys[0], keys[1], xl, yl, vals) +
            "\n";
  }
  return html;
}

/// Error against compression (CLOP paper Fig. 13) when the group's variant makes a mixture;
/// empty otherwise, and for a single point (no curve).
std::string compression_plot(const SweepGroup& g, const std::vector<std::string>& metrics) {
  bool has_mixture = false;
  for (const Json* r : g.records)
    has_mixture = has_mixture || !std::isnan(record_value(*r, "sizes.mixture_components"));
  if (!has_mixture || metrics.empty()) return "";
  std::vector<std::string> skeys;
  if (g.keys.size() > 1) skeys.assign(g.keys.begin() + 1, g.keys.end());
  const auto series = build_series(g.records, "", skeys, metrics.front(), true);
  std::size_t points = 0;
  for (const auto& ser : series)
    points += ser.pts.size();
  if (points < 2) return "";
  const std::string svg =
      line_plot(fmt::format("{}: {} vs compression ({})", g.variant, metrics.front(), g.group),
                "compression = scan points / Gaussians", metrics.front(), series);
  return svg.empty() ? "" : svg + "\n";
}

/// Sweep plots, error against compression and heatmaps, per variant and dataset/scanner group.
std::string sweep_sections(const std::vector<const Json*>& ok, const Json& report_cfg,
                           const std::vector<std::string>& metrics) {
  std::string sweep_html, heat_html, comp_html;
  const std::vector<SweepGroup> groups = sweep_groups(ok, report_cfg);
  for (const SweepGroup& g : groups) {
    if (!g.keys.empty()) {
      // The variants run without a sweep on the same data: reference lines.
      std::vector<const SweepGroup*> unswept;
      for (const SweepGroup& u : groups) {
        if (u.group != g.group || u.variant == g.variant) continue;
        const bool no_point = std::all_of(u.records.begin(), u.records.end(), [](const Json* r) {
          return r->value("point", Json::object()).empty();
        });
        if (no_point) unswept.push_back(&u);
      }
      sweep_html += sweep_plots(g, metrics, unswept);
      if (g.keys.size() == 2 && !metrics.empty()) heat_html += sweep_heatmaps(g, metrics);
    }
    comp_html += compression_plot(g, metrics);
  }
  std::string h;
  if (!sweep_html.empty()) {
    h += "<h2>Sweeps</h2>\n<p class=\"aggregates\">Each marker: the median over the seeds of one "
         "sweep point (time.total: of each job's median over its repeats); ringed: the best point "
         "of the plot in the quantity's direction; dashed lines: the variants run without a sweep "
         "on "
         "the same dataset and scanner (median over their seeds). Hover a marker for its "
         "values.</p>\n"
         "<div class=\"plots\" id=\"sweeps\">\n" +
         sweep_html + "</div>\n";
  }
  if (!comp_html.empty()) {
    h += "<h2>Error against compression</h2>\n<div class=\"plots\">\n" + comp_html + "</div>\n";
  }
  if (!heat_html.empty()) {
    h += "<h2>Heatmaps</h2>\n<p class=\"aggregates\">Each cell: one sweep point, the median over "
         "its seeds.</p>\n<div class=\"plots\" id=\"heatmaps\">\n" +
         heat_html + "</div>\n";
  }
  return h;
}

/// One marker of a time-against-quality plot: a variant at one sweep point on one group.
struct ParetoPoint {
  std::string variant, point;
  double seconds, value;
  std::string kind;  ///< scored_kind: "mesh" or "points"; a front per kind where they cannot meet
  bool front = false;
};

/// The points no other point beats: none has at most its seconds and at least as good a value
/// (in direction `better`) with one of the two strictly better. With `per_kind`, a point is
/// beaten only by points of its own kind (mesh and point outputs on a key that cannot compare
/// them). Brute force, O(n^2): a group holds tens of sweep points.
void mark_front(std::vector<ParetoPoint>& pts, int better, bool per_kind) {
  for (auto& p : pts) {
    p.front = std::none_of(pts.begin(), pts.end(), [&](const ParetoPoint& q) {
      if (per_kind && q.kind != p.kind) return false;
      const double gain = better * (q.value - p.value);
      return q.seconds <= p.seconds && gain >= 0 && (q.seconds < p.seconds || gain > 0);
    });
  }
}

/// Time against each shown quantity per dataset/scanner group: one marker per variant and sweep
/// point (the medians over its seeds of each job's median time.total and of the quantity), the
/// Pareto front joined by a line and ringed (class "front"), every marker's values as its hover
/// title. Quantities without a direction are left out; at most 60 plots.
std::string pareto_section(const std::vector<const Json*>& ok,
                           const std::vector<std::string>& metrics) {
  const auto groups = records_by_group(ok);
  std::string html;
  int shown = 0;
  bool split = false;  // some plot has a front per output kind
  for (const std::string& m : metrics) {
    const int better = quantity_direction(m);
    if (better == 0 || m.rfind("time.", 0) == 0) continue;
    for (const auto& [g, rs] : groups) {
      // (variant, point) in record order, with the samples of its seeds.
      std::vector<std::pair<std::string, std::string>> order;
      std::map<std::pair<std::string, std::string>, std::string> kind;
      std::map<std::pair<std::string, std::string>,
               std::pair<std::vector<double>, std::vector<double>>>
          acc;
      for (const Json* r : rs) {
        const double t = record_value(*r, "time.total"), v = record_value(*r, m);
        if (!std::isfinite(t) || !std::isfinite(v)) continue;
        const auto key = std::make_pair(field_value(*r, "variant"), field_value(*r, "point"));
        if (!acc.count(key)) order.push_back(key);
        const std::string k = scored_kind(*r);
        kind[key] = kind.count(key) && kind[key] != k ? "mesh+points" : k;
        acc[key].first.push_back(t);
        acc[key].second.push_back(v);
      }
      if (order.size() < 2 || shown >= 60) continue;
      std::vector<ParetoPoint> pts;
      std::vector<std::string> variants;
      for (const auto& key : order) {
        pts.push_back(
            {key.first, key.second, median(acc[key].first), median(acc[key].second), kind[key]});
        if (std::find(variants.begin(), variants.end(), key.first) == variants.end())
          variants.push_back(key.first);
      }
      const bool per_kind =
          mesh_points_incomparable(m) &&
          std::any_of(pts.begin(), pts.end(), [&](const auto& p) { return p.kind != pts[0].kind; });
      split = split || per_kind;
      mark_front(pts, better, per_kind);
      double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
      for (const auto& p : pts) {
        xlo = std::min(xlo, p.seconds);
        xhi = std::max(xhi, p.seconds);
        ylo = std::min(ylo, p.value);
        yhi = std::max(yhi, p.value);
      }
      std::string svg = svg_open(fmt::format("{} against time.total ({})", m, g));
      Axes a{};
      svg += draw_axes(a, xlo, xhi, ylo, yhi, "time.total [s]", m);
      std::set<std::string> kinds;
      for (const auto& p : pts)
        kinds.insert(per_kind ? p.kind : "");
      for (const std::string& k : kinds) {  // one joined front per kind when split
        std::vector<const ParetoPoint*> front;
        for (const auto& p : pts)
          if (p.front && (k.empty() || p.kind == k)) front.push_back(&p);
        std::sort(front.begin(), front.end(), [](const ParetoPoint* x, const ParetoPoint* y) {
          return x->seconds < y->seconds;
        });
        std::string path;
        for (const ParetoPoint* p : front)
          path += fmt::format("{}{:.1f},{:.1f}", path.empty() ? "" : " ", a.px(p->seconds),
                              a.py(p->value));
        svg += fmt::format(
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#888\" stroke-width=\"1\"{}/>", path,
            k.empty() || k == "points" ? "" : " stroke-dasharray=\"4 2\"");
      }
      for (const auto& p : pts) {
        const std::size_t c = static_cast<std::size_t>(
            std::find(variants.begin(), variants.end(), p.variant) - variants.begin());
        const std::string label = p.point.empty() ? p.variant : p.variant + " (" + p.point + ")";
        svg += fmt::format(
            "<circle{} cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{}\" fill=\"{}\"{}><title>{}</title>"
            "</circle>",
            p.front ? " class=\"front\"" : "", a.px(p.seconds), a.py(p.value),
            p.front ? "4.5" : "3", color(c), p.front ? " stroke=\"#000\" stroke-width=\"1.5\"" : "",
            html_escape(fmt::format("{}: time.total = {} s, {} = {}{}{}", label,
                                    format_number(p.seconds), m, format_number(p.value),
                                    per_kind ? " [" + p.kind + " output]" : "",
                                    p.front ? " (on the front)" : "")));
      }
      svg += legend(variants);
      html += svg + "</svg>\n";
      ++shown;
    }
  }
  if (html.empty()) return "";
  return "<h2>Time against quality</h2>\n<p class=\"aggregates\">Each marker: one variant at one "
         "sweep point, the medians over its seeds of each job's median time.total and of the "
         "quantity. Outlined and joined: the Pareto front, the points no other point beats in "
         "both time and quality. Hover a marker for its values." +
         std::string(split ? " Where mesh and point outputs meet on a key that cannot compare "
                             "them (mesh outputs are scored on samples of their surface), each "
                             "kind has its own front (the mesh front dashed) and the titles name "
                             "the kind."
                           : "") +
         "</p>\n<div class=\"plots\" id=\"pareto\">\n" + html + "</div>\n";
}

/// Per-job error heatmaps (PNG images written next to the outputs), inline; at most 40.
std::string error_heatmaps_section(const fs::path& dir, const std::vector<const Json*>& ok) {
  std::string imgs;
  int shown = 0;
  for (const Json* r : ok) {
    const Json art = r->value("artifacts", Json::object());
    const std::string rel = art.value("heatmap", std::string());
    if (rel.empty() || !fs::exists(dir / rel)) continue;
    if (++shown > 40) break;
    imgs += fmt::format(
        "<figure><a href=\"{0}\"><img src=\"{0}\" width=\"560\" alt=\"{1}\">"
        "</a><figcaption>{1}</figcaption></figure>\n",
        html_escape(rel), html_escape(r->value("key", std::string())));
  }
  if (imgs.empty()) return "";
  return "<h2>Error heatmaps (four views: |point-to-plane error| of output points; for mesh "
         "outputs the distance to the ground truth of samples of the output surface)</h2>\n"
         "<div class=\"plots\" "
         "id=\"error-heatmaps\">\n" +
         imgs + "</div>\n";
}

/// Time per phase: medians of the repeat samples, sub-phases of each step stacked (the rest of
/// a step's time as "<step>:other" when over 2 %); at most 60 jobs.
std::string phases_section(const std::vector<const Json*>& ok) {
  std::vector<std::string> labels, parts;
  std::map<std::string, std::size_t> part_index;
  std::vector<std::map<std::string, double>> rows;
  for (const Json* r : ok) {
    if (rows.size() >= 60) break;
    const Json phases = (*r)["timing"].value("phases", Json::object());
    std::map<std::string, double> row;
    for (const auto& step : (*r)["variant"]["chain"]) {
      const std::string label = step.value("label", std::string());
      double sub = 0;
      for (const auto& [k, v] : phases.items()) {
        if (k.rfind(label + ":", 0) != 0) continue;
        const double m = record_value(*r, "time." + k);
        row[k] += m;
        sub += m;
      }
      const double total = record_value(*r, "time." + label);
      if (std::isfinite(total) && total - sub > 0.02 * total) row[label + ":other"] += total - sub;
    }
    for (const auto& [k, v] : row)
      if (!part_index.count(k)) {
        part_index[k] = parts.size();
        parts.push_back(k);
      }
    labels.push_back(field_value(*r, "dataset") + " " + field_value(*r, "variant") + " " +
                     field_value(*r, "point"));
    rows.push_back(std::move(row));
  }
  if (rows.empty()) return "";
  std::vector<std::vector<double>> vals(rows.size(), std::vector<double>(parts.size(), 0.0));
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (const auto& [k, v] : rows[i])
      vals[i][part_index[k]] = v;
  return "<h2>Time per phase</h2>\n<div class=\"plots\" id=\"phases\">\n" +
         stacked_bars("median wall seconds per phase", labels, parts, vals) + "\n</div>\n";
}

/// A histogram record {"counts", "min", "max", "count"} as fractions of the points at the bin
/// centres.
Series histogram_series(const std::string& name, const Json& hj) {
  const double lo = hj.value("min", 0.0), hi = hj.value("max", 1.0);
  const auto& counts = hj["counts"];
  const double n = std::max(1.0, hj.value("count", 1.0));
  Series s{name, {}};
  const double w = (hi - lo) / static_cast<double>(std::max<std::size_t>(1, counts.size()));
  for (std::size_t b = 0; b < counts.size(); ++b)
    s.pts.push_back({lo + (static_cast<double>(b) + 0.5) * w, counts[b].get<double>() / n});
  return s;
}

/// Reconstruction cost per job (report "cost"): seconds and working memory without the excluded
/// steps, and the size of the representation.
struct CostMeasure {
  std::set<std::string> excluded;  ///< steps left out of seconds and memory

  /// The summed median wall seconds of the steps not excluded (timing.phases); NaN when none.
  double seconds(const Json& r) const {
    double sum = 0.0;
    bool any = false;
    const Json timing = r.value("timing", Json::object());
    const Json phases = timing.value("phases", Json::object());
    for (const auto& [k, v] : phases.items()) {
      if (k.find(':') != std::string::npos || excluded.count(k)) continue;
      std::vector<double> xs;
      for (const auto& x : v)
        if (x.is_number()) xs.push_back(x.get<double>());
      if (xs.empty()) continue;
      sum += median(xs);
      any = true;
    }
    return any ? sum : NAN;
  }
  /// The largest working memory of the steps not excluded (timing.step_work_mb); NaN when none.
  double build_mb(const Json& r) const {
    double mb = NAN;
    const Json timing = r.value("timing", Json::object());
    const Json work = timing.value("step_work_mb", Json::object());
    for (const auto& [k, v] : work.items()) {
      if (excluded.count(k) || !v.is_number()) continue;
      mb = std::isnan(mb) ? v.get<double>() : std::max(mb, v.get<double>());
    }
    return mb;
  }
  /// vertices, faces or bytes of the control covariance mesh when the chain made one, else of
  /// the output mesh.
  static double size_of(const Json& r, const char* what) {
    const double c = record_value(r, std::string("sizes.covmesh_") + what);
    if (!std::isnan(c)) return c;
    return std::string(what) == "bytes" ? record_value(r, "mesh_bytes")
                                        : record_value(r, std::string("sizes.mesh_") + what);
  }
};

/// The cost table of one dataset/scanner group and its three plots (RMSE against seconds and
/// against working memory, the input-distance histograms).
std::pair<std::string, std::string> cost_group(const std::string& group,
                                               const std::vector<const Json*>& rs,
                                               const CostMeasure& cost) {
  const std::vector<std::pair<const char*, const char*>> cols = {
      {"input_distance_rms_rel", "input RMSE"}, {"input_distance_mean_rel", "input mean"},
      {"input_distance_max_rel", "input max"},  {"chamfer_rel", "Chamfer"},
      {"hausdorff_rel", "Hausdorff"},           {"fscore", "F-score"}};
  std::string html = "<table class=\"cost\"><caption>" + html_escape(group) +
                     ": lengths relative to the bbox diagonal; sec and build MB without " +
                     html_escape(fmt::format("{}", fmt::join(cost.excluded, ", "))) +
                     "</caption>\n<tr><th>job</th><th>sec</th><th>build MB</th><th>vertices</th>"
                     "<th>faces</th><th>bytes</th>";
  for (const auto& c : cols)
    html += std::string("<th>") + c.second + "</th>";
  html += "</tr>\n";
  std::map<std::string, Series> vs_sec, vs_mb;
  std::vector<Series> hists;
  for (const Json* r : rs) {
    const std::string name =
        field_value(*r, "variant") + (r->value("point_label", std::string()).empty()
                                          ? ""
                                          : " " + r->value("point_label", std::string()));
    const double sec = cost.seconds(*r), mb = cost.build_mb(*r);
    html += "<tr><td style=\"text-align:left\">" + html_escape(name) + "</td><td>" +
            format_number(sec) + "</td><td>" + format_number(mb) + "</td><td>" +
            format_number(CostMeasure::size_of(*r, "vertices")) + "</td><td>" +
            format_number(CostMeasure::size_of(*r, "faces")) + "</td><td>" +
            format_number(CostMeasure::size_of(*r, "bytes")) + "</td>";
    for (const auto& c : cols)
      html += "<td>" + format_number(record_value(*r, c.first)) + "</td>";
    html += "</tr>\n";
    const double rmse = record_value(*r, "input_distance_rms_rel");
    const std::string v = field_value(*r, "variant");
    vs_sec[v].name = v;
    vs_sec[v].pts.push_back({sec, rmse});
    vs_mb[v].name = v;
    vs_mb[v].pts.push_back({mb, rmse});
    const Json all_hists = r->value("histograms", Json::object());
    const Json hj = all_hists.value("input_distance", Json::object());
    if (hj.contains("counts") && hj["counts"].is_array() && !hj["counts"].empty()) {
      hists.push_back(histogram_series(name, hj));
    }
  }
  html += "</table>\n";
  auto sorted = [](std::map<std::string, Series>& m) {
    std::vector<Series> out;
    for (auto& [k, ser] : m) {
      std::sort(ser.pts.begin(), ser.pts.end());
      out.push_back(ser);
    }
    return out;
  };
  std::string plots;
  plots += line_plot(fmt::format("input RMSE vs seconds ({})", group), "sec",
                     "input_distance_rms_rel", sorted(vs_sec)) +
           "\n";
  plots += line_plot(fmt::format("input RMSE vs working memory ({})", group), "build MB",
                     "input_distance_rms_rel", sorted(vs_mb)) +
           "\n";
  plots += line_plot(fmt::format("input distance histogram ({})", group), "input_distance",
                     "fraction of points", hists) +
           "\n";
  return {html, plots};
}

// Reconstruction cost (GPS paper sec. 7.2): the table of Fig. 13c and the trade-off plots of
// Fig. 14, per dataset/scanner group, when the config asks for it with
//   "report": {"cost": {"exclude_steps": ["clop"]}}
// (steps left out of seconds and memory: preprocessing both methods share). Per job: sec = the
// summed median wall seconds of the other steps (timing.phases), build MB = the largest of their
// working memories (timing.step_work_mb), vertices, faces and bytes of the representation (the
// control covariance mesh, sizes.covmesh_*, when the chain made one: 6 more floats per vertex;
// else the output mesh), the error of the input points to the surface and the ground-truth
// surface metrics; the input-distance histograms of every job; RMSE against sec and build MB.
std::string cost_section(const std::vector<const Json*>& ok, const Json& report_cfg) {
  if (!report_cfg.contains("cost") || !report_cfg["cost"].is_object()) return "";
  CostMeasure cost;
  for (const auto& e : report_cfg["cost"].value("exclude_steps", Json::array()))
    if (e.is_string()) cost.excluded.insert(e.get<std::string>());
  std::map<std::string, std::vector<const Json*>> by_group;
  for (const Json* r : ok)
    by_group[group_of(*r)].push_back(r);
  std::string cost_html, plots;
  for (const auto& [group, rs] : by_group) {
    auto [table, group_plots] = cost_group(group, rs, cost);
    cost_html += table;
    plots += group_plots;
  }
  if (cost_html.empty()) return "";
  return "<h2>Reconstruction cost (GPS paper Fig. 13c, 14)</h2>\n<div id=\"cost\">\n" + cost_html +
         "</div>\n<div class=\"plots\" id=\"cost-plots\">\n" + plots + "</div>\n";
}

/// Error histograms per dataset/scanner group (the first seed of each job, normalised to
/// fractions of the points): one plot of the unswept variants (a line each), and per swept
/// variant plots of its sweep points (a line per point, labelled with it; at most 10 a plot).
std::string histograms_section(const std::vector<const Json*>& ok) {
  struct Entry {
    std::string variant, point;
    const Json* record;
  };
  std::vector<std::string> hist_names;
  std::map<std::string, std::map<std::string, std::vector<Entry>>> entries;  // name, group
  for (const Json* r : ok) {
    const Json hists = r->value("histograms", Json::object());
    for (const auto& [hn, hv] : hists.items()) {
      if (!hv.is_object() || !hv.contains("counts") || !hv["counts"].is_array()) continue;
      if (std::find(hist_names.begin(), hist_names.end(), hn) == hist_names.end()) {
        hist_names.push_back(hn);
      }
      auto& list = entries[hn][group_of(*r)];
      const std::string v = field_value(*r, "variant"), p = field_value(*r, "point");
      const bool seen = std::any_of(list.begin(), list.end(),
                                    [&](const Entry& e) { return e.variant == v && e.point == p; });
      if (!seen) list.push_back({v, p, r});
    }
  }
  std::string hist_html;
  auto plot = [&](const std::string& title, const std::string& hn,
                  const std::vector<std::pair<std::string, const Json*>>& lines) {
    std::vector<Series> series;
    std::string unit;
    for (const auto& [name, r] : lines) {
      const Json& hj = (*r)["histograms"][hn];
      unit = hj.value("unit", std::string());
      series.push_back(histogram_series(name, hj));
    }
    const std::string svg = line_plot(title, hn + (unit.empty() ? "" : " [" + unit + "]"),
                                      "fraction of points", series);
    if (!svg.empty()) hist_html += svg + "\n";
  };
  constexpr std::size_t kPerPlot = 10;
  for (const auto& hn : hist_names) {
    for (const auto& [group, list] : entries[hn]) {
      std::vector<std::pair<std::string, const Json*>> unswept;
      std::vector<std::string> swept_order;
      std::map<std::string, std::vector<std::pair<std::string, const Json*>>> swept;
      for (const Entry& e : list) {
        if (e.point.empty()) {
          unswept.push_back({e.variant, e.record});
          continue;
        }
        if (!swept.count(e.variant)) swept_order.push_back(e.variant);
        swept[e.variant].push_back({e.point, e.record});
      }
      if (!unswept.empty()) plot(fmt::format("{} histogram ({})", hn, group), hn, unswept);
      for (const auto& v : swept_order) {
        const auto& pts = swept[v];
        for (std::size_t from = 0; from < pts.size(); from += kPerPlot) {
          const std::size_t to = std::min(pts.size(), from + kPerPlot);
          const std::string which = pts.size() <= kPerPlot ? "per sweep point"
                                                           : fmt::format("sweep points {}-{} of {}",
                                                                         from + 1, to, pts.size());
          plot(fmt::format("{} histogram ({}): {}, {}", hn, group, v, which), hn,
               {pts.begin() + static_cast<std::ptrdiff_t>(from),
                pts.begin() + static_cast<std::ptrdiff_t>(to)});
        }
      }
    }
  }
  if (hist_html.empty()) return "";
  return "<h2>Error histograms</h2>\n<p class=\"aggregates\">Each line: one job (its first "
         "seed); a swept variant has a line per sweep point, labelled with the point.</p>\n"
         "<div class=\"plots\" id=\"histograms\">\n" +
         hist_html + "</div>\n";
}

/// A JSON value as a setup table shows it: strings bare, floats as %g, the rest as JSON.
std::string setup_value(const Json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) return fmt::format("{:g}", v.get<double>());
  return v.dump();
}

/// What ran: per variant its chain with the effective parameters (of its first ok job; swept
/// keys with every value they took), per dataset and scanner the scanner's settings and the scan
/// size (median over the seeds, and the range).
std::string setup_section(const std::vector<const Json*>& ok) {
  if (ok.empty()) return "";
  std::vector<std::string> variants;
  std::map<std::string, std::vector<const Json*>> by_variant;
  for (const Json* r : ok) {
    const std::string v = field_value(*r, "variant");
    if (!by_variant.count(v)) variants.push_back(v);
    by_variant[v].push_back(r);
  }
  std::string h =
      "<h2>Setup</h2>\n<table id=\"setup-variants\"><caption>Each variant's chain and effective "
      "parameters (defaults filled in); swept parameters with every value they took</caption>"
      "<tr><th>variant</th><th>step</th><th>parameters</th></tr>\n";
  for (const auto& v : variants) {
    const auto& rs = by_variant[v];
    // Swept values per step parameter (the chain's params of each job differ only there).
    std::map<std::string, std::vector<std::string>> values;  // "<step>/<param>" -> values
    for (const Json* r : rs) {
      const Json chain = (*r)["variant"].value("chain", Json::array());
      for (std::size_t i = 0; i < chain.size(); ++i) {
        const Json params = chain[i].value("params", Json::object());
        for (const auto& [k, val] : params.items()) {
          auto& vs = values[fmt::format("{}/{}", i, k)];  // in the order the jobs ran
          if (std::find(vs.begin(), vs.end(), setup_value(val)) == vs.end())
            vs.push_back(setup_value(val));
        }
      }
    }
    const Json chain = (*rs.front())["variant"].value("chain", Json::array());
    for (std::size_t i = 0; i < chain.size(); ++i) {
      std::string params;
      const Json ps = chain[i].value("params", Json::object());
      for (const auto& [k, val] : ps.items()) {
        const auto& vs = values[fmt::format("{}/{}", i, k)];
        const std::string shown =
            vs.size() > 1
                ? fmt::format("<b>{{{}}}</b>", html_escape(fmt::format("{}", fmt::join(vs, ", "))))
                : html_escape(setup_value(val));
        params += (params.empty() ? "" : ", ") + html_escape(k) + "=" + shown;
      }
      h += fmt::format(
          "<tr><td style=\"text-align:left\">{}</td><td style=\"text-align:left\">{}</td>"
          "<td style=\"text-align:left;font-size:11px\">{}</td></tr>\n",
          i == 0 ? html_escape(v) : "", html_escape(chain[i].value("algorithm", std::string())),
          params);
    }
  }
  h += "</table>\n";
  // Datasets and scanners.
  h += "<table id=\"setup-scans\"><caption>Each dataset and scanner: the scanner's settings and "
       "the scan size (median over the seeds, and the range)</caption><tr><th>dataset / "
       "scanner</th><th>preset</th><th>settings</th><th>scan points</th><th>outliers</th></tr>\n";
  for (const auto& group : records_by_group(ok)) {
    const std::string& g = group.first;
    const std::vector<const Json*>& rs = group.second;  // captured below (not a binding)
    auto stat = [&rs](const char* q) {
      std::vector<double> xs;
      for (const Json* r : rs)
        if (const double x = record_value(*r, q); std::isfinite(x)) xs.push_back(x);
      if (xs.empty()) return std::string("-");
      const auto [lo, hi] = std::minmax_element(xs.begin(), xs.end());
      return *lo == *hi ? format_number(*lo)
                        : fmt::format("{} ({} .. {})", format_number(median(xs)),
                                      format_number(*lo), format_number(*hi));
    };
    const Json scanner = (*rs.front()).value("scanner", Json::object());
    std::string settings;
    const Json scanner_params = scanner.value("params", Json::object());
    for (const auto& [k, val] : scanner_params.items())
      settings +=
          (settings.empty() ? "" : ", ") + html_escape(k) + "=" + html_escape(setup_value(val));
    h += fmt::format(
        "<tr><td style=\"text-align:left\">{}</td><td>{}</td><td style=\"text-align:left;"
        "font-size:11px\">{}</td><td>{}</td><td>{}</td></tr>\n",
        html_escape(g), html_escape(scanner.value("preset", std::string())), settings,
        stat("sizes.scan_points"), stat("sizes.scan_outliers"));
  }
  return h + "</table>\n";
}

/// Every job with its status, sizes and links to its files (artifacts, and any .vdb, .png or
/// .exr next to its outputs).
std::string jobs_section(const fs::path& dir, const std::vector<Json>& records) {
  std::string h =
      "<h2>Jobs and files</h2>\n<table id=\"jobs\"><tr><th>job</th><th>status</th>"
      "<th>points in / output</th><th>files</th></tr>\n";
  for (const auto& r : records) {
    const Json art = r.value("artifacts", Json::object());
    std::string files;
    for (const auto& [k, v] : art.items()) {
      if (!v.is_string()) continue;
      const std::string l = link(dir, v.get<std::string>(), k);
      if (!l.empty()) files += l + " ";
    }
    const std::string id = r.value("id", std::string());
    if (fs::is_directory(dir / "outputs")) {
      for (const auto& e : fs::directory_iterator(dir / "outputs")) {
        const std::string fn = e.path().filename().string();
        const std::string ext = e.path().extension().string();
        if (fn.rfind(id, 0) == 0 && (ext == ".vdb" || ext == ".png" || ext == ".exr")) {
          files += link(dir, "outputs/" + fn, fn) + " ";
        }
      }
    }
    h += fmt::format(
        "<tr><td style=\"text-align:left\">{}</td><td>{}</td><td>{} / {}</td>"
        "<td style=\"text-align:left\">{}</td></tr>\n",
        html_escape(r.value("key", "")), html_escape(r.value("status", "")),
        format_number(record_value(r, "sizes.scan_points")), output_size(r), files);
  }
  return h + "</table>\n";
}

}  // namespace

fs::path write_report(const fs::path& dir, const fs::path& out_arg, const fs::path& history_db) {
  const std::vector<Json> records = load_records(dir);
  const fs::path out = out_arg.empty() ? dir / "index.html" : out_arg;
  Json config = Json::object();
  if (fs::exists(dir / "config.json")) config = read_json_file(dir / "config.json");
  const Json cfg = config.value("config", Json::object());
  const Json report_cfg = cfg.value("report", Json::object());
  const std::string name = cfg.value("name", dir.filename().string());
  std::vector<const Json*> ok;
  for (const auto& r : records)
    if (is_ok(r)) ok.push_back(&r);
  const std::vector<std::string> metrics =
      report_metrics(report_cfg, records, ok, (dir / "config.json").string() + ": /config/report");

  std::string h = head_section(name, cfg, records);
  h += winners_section(records, metrics);
  h += baseline_section(dir);
  // The papers' claims (`scanbench claims`, or nightly's quick set).
  if (fs::exists(dir / "claims.json"))
    h += claims_html_section(read_json_file(dir / "claims.json"));
  h += failures_section(dir, records);
  h += tables_section(records, metrics);
  h += sweep_sections(ok, report_cfg, metrics);
  h += pareto_section(ok, metrics);
  h += error_heatmaps_section(dir, ok);
  h += viewer_section(dir, ok);
  h += phases_section(ok);
  h += cost_section(ok, report_cfg);
  h += histograms_section(ok);
  if (!history_db.empty()) h += history_section(history_db, records, metrics);
  h += setup_section(ok);
  h += jobs_section(dir, records);
  h += "<p>Generated by <code>scanbench report</code>.</p>\n</body></html>\n";
  write_file_atomic(out, h);
  return out;
}

}  // namespace scanbench::harness
