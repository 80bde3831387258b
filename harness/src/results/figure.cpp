#include "scanbench/harness/figure.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "results/report_viewer.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/harness/experiment.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/table.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

std::string known(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names)
    s += (s.empty() ? "" : ", ") + n;
  return s;
}

int view_index(const std::string& v) {
  if (v == "front") return 0;
  if (v == "side") return 1;
  if (v == "top") return 3;
  if (v == "iso") return metrics::kViewIso;
  throw InputError("--view " + v + ": not a view (known: front, iso, top, side)");
}

std::string rgb_hex(const Eigen::Vector3f& c) {
  return fmt::format("#{:02x}{:02x}{:02x}", std::lround(c[0] * 255), std::lround(c[1] * 255),
                     std::lround(c[2] * 255));
}

std::string svg(const std::vector<metrics::SplatImage>& cells, const FigureSummary& s,
                const std::string& title, const std::string& unit, int width, int height) {
  const metrics::FigureLayout l = metrics::figure_layout(
      width, height, static_cast<int>(s.rows.size()), static_cast<int>(s.cols.size()));
  const int y0 = l.top + 24;
  std::string o = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
      "xmlns:xlink=\"http://www.w3.org/1999/xlink\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"DejaVu Sans, sans-serif\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"#fff\"/>\n"
      "<text x=\"8\" y=\"24\" font-size=\"16\">{2}</text>\n",
      width, height, html_escape(title));
  for (std::size_t j = 0; j < s.cols.size(); ++j)
    o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"14\" text-anchor=\"middle\">{}</text>\n",
                     l.left + static_cast<int>(j) * l.cell_w + l.cell_w / 2, l.top + 18,
                     html_escape(s.cols[j]));
  for (std::size_t i = 0; i < s.rows.size(); ++i)
    o +=
        fmt::format("<text x=\"8\" y=\"{}\" font-size=\"14\">{}</text>\n",
                    y0 + static_cast<int>(i) * l.cell_h + l.cell_h / 2 + 5, html_escape(s.rows[i]));
  for (std::size_t i = 0; i < s.rows.size(); ++i)
    for (std::size_t j = 0; j < s.cols.size(); ++j) {
      const auto& c = cells[i * s.cols.size() + j];
      if (c.width == 0) continue;
      o += fmt::format(
          "<image x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" "
          "xlink:href=\"data:image/png;base64,{}\"/>\n",
          l.left + static_cast<int>(j) * l.cell_w, y0 + static_cast<int>(i) * l.cell_h, c.width,
          c.height, [&] {
            const std::string png = metrics::encode_png(c);
            return base64(png.data(), png.size());
          }());
    }
  // The colour bar: a vertical gradient through 17 viridis stops, t = 0 at the bottom.
  const int bx = l.bar_x + 12, by0 = y0 + 20, by1 = height - 30;
  o += "<defs><linearGradient id=\"viridis\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
  for (int k = 0; k <= 16; ++k)
    o += fmt::format("<stop offset=\"{:.4g}\" stop-color=\"{}\"/>", k / 16.0,
                     rgb_hex(metrics::viridis_color(std::min(1.0f, k / 16.0f))));
  o += "</linearGradient></defs>\n";
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"24\" height=\"{}\" fill=\"url(#viridis)\"/>\n",
                   bx, by0, by1 - by0);
  for (int k = 0; k <= 4; ++k) {
    const int y = by1 - static_cast<int>(k / 4.0 * (by1 - by0 - 1));
    o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\">{:.3g}</text>\n", bx + 28, y + 4,
                     k / 4.0 * s.saturation);
  }
  o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\">{}</text>\n", bx, by0 - 6,
                   html_escape(unit));
  o +=
      fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\">top: saturated</text>\n", bx, by1 + 16);
  return o + "</svg>\n";
}

}  // namespace

FigureSummary write_figure(const FigureOptions& opts) {
  if (opts.metric != "p2plane" && opts.metric != "accuracy.p2plane")
    throw InputError("--metric " + opts.metric +
                     ": figures colour by the per-point error of p2plane only");
  const int view = view_index(opts.view);
  if (opts.out.empty()) throw InputError("-o: the figure file is required");
  const std::string ext = opts.out.extension().string();
  if (ext != ".png" && ext != ".svg")
    throw InputError("-o " + opts.out.string() + ": the figure file must end in .png or .svg");
  if (!(opts.max >= 0.0) || !std::isfinite(opts.max))
    throw InputError(fmt::format("--max {}: not a non-negative number", opts.max));
  if (!fs::is_directory(opts.dir)) throw InputError(opts.dir.string() + ": not a results folder");
  const std::vector<Json> records = load_records(opts.dir);

  // Candidate records: ok, with an output, at the requested sweep point.
  std::vector<const Json*> ok;
  std::vector<std::string> points;
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") continue;
    const Json art = r.value("artifacts", Json::object());
    if (!art.contains("output") && !art.contains("mesh") && !art.contains("covariance_mesh"))
      continue;
    const std::string pt = field_value(r, "point");
    if (std::find(points.begin(), points.end(), pt) == points.end()) points.push_back(pt);
    if (!opts.point.empty() && pt != opts.point) continue;
    ok.push_back(&r);
  }
  if (!opts.point.empty() && ok.empty())
    throw InputError("--point " + opts.point + ": no ok record of " + opts.dir.string() +
                     " has this sweep point (known: " + known(points) + ")");
  if (ok.empty()) throw InputError(opts.dir.string() + ": no ok record with an output file");

  std::vector<std::string> all_rows, all_cols;
  for (const Json* r : ok) {
    const std::string d = field_value(*r, "dataset"), v = field_value(*r, "variant");
    if (std::find(all_rows.begin(), all_rows.end(), d) == all_rows.end()) all_rows.push_back(d);
    if (std::find(all_cols.begin(), all_cols.end(), v) == all_cols.end()) all_cols.push_back(v);
  }
  FigureSummary s;
  s.rows = opts.datasets.empty() ? all_rows : opts.datasets;
  s.cols = opts.variants.empty() ? all_cols : opts.variants;
  for (const auto& d : s.rows)
    if (std::find(all_rows.begin(), all_rows.end(), d) == all_rows.end())
      throw InputError("--datasets: " + opts.dir.string() + " has no ok output of dataset '" + d +
                       "' (known: " + known(all_rows) + ")");
  for (const auto& v : s.cols)
    if (std::find(all_cols.begin(), all_cols.end(), v) == all_cols.end())
      throw InputError("--variants: " + opts.dir.string() + " has no ok output of variant '" + v +
                       "' (known: " + known(all_cols) + ")");
  const metrics::FigureLayout layout = metrics::figure_layout(
      opts.width, opts.height, static_cast<int>(s.rows.size()), static_cast<int>(s.cols.size()));

  // The first record (first seed, first or the chosen sweep point) of each cell, its errors
  // relative to the dataset's diagonal.
  struct Cell {
    std::optional<OutputCloud> cloud;
    BoundingBox frame;
  };
  std::vector<Cell> cells(s.rows.size() * s.cols.size());
  s.jobs.assign(cells.size(), "");
  std::vector<float> all;
  for (std::size_t i = 0; i < s.rows.size(); ++i) {
    const Json* first = nullptr;
    for (const Json* r : ok)
      if (field_value(*r, "dataset") == s.rows[i]) {
        first = r;
        break;
      }
    const Json dataset = first->value("dataset", Json::object());
    const Json params = dataset.value("params", Json::object());
    if (params.contains("gt_points"))
      throw InputError("--datasets: dataset '" + s.rows[i] +
                       "' has a point-cloud ground truth; figures need a mesh");
    const bool from_points =
        first->value("scanner", Json::object()).value("preset", std::string()) == kPointsInput;
    const TriangleMesh gt_mesh =
        load_dataset(dataset.value("name", std::string()), from_points ? Json::object() : params);
    const metrics::GroundTruth gt(gt_mesh, 0);
    const float diag = gt.diagonal();
    for (std::size_t j = 0; j < s.cols.size(); ++j) {
      for (const Json* r : ok) {
        if (field_value(*r, "dataset") != s.rows[i] || field_value(*r, "variant") != s.cols[j])
          continue;
        Cell& c = cells[i * s.cols.size() + j];
        c.cloud = output_cloud(opts.dir, *r, gt_mesh, gt, opts.budget);
        c.frame = gt.bbox();
        if (c.cloud) {
          c.cloud->errors /= diag;
          s.jobs[i * s.cols.size() + j] = c.cloud->job;
          for (Eigen::Index k = 0; k < c.cloud->errors.size(); ++k)
            all.push_back(std::abs(c.cloud->errors[k]));
        }
        break;
      }
    }
  }
  s.percentile = opts.max <= 0.0;
  if (s.percentile && !all.empty()) {
    const std::size_t k = std::min(all.size() - 1, static_cast<std::size_t>(0.95 * all.size()));
    std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(k), all.end());
    s.saturation = all[k];
  } else {
    s.saturation = opts.max;
  }
  if (!(s.saturation > 0.0)) s.saturation = 1e-9;

  std::vector<metrics::SplatImage> images(cells.size());
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const auto& c = cells[k].cloud;
    if (!c) continue;
    images[k] = metrics::render_splats(c->positions, c->normals, c->errors, cells[k].frame, view,
                                       layout.cell_w, layout.cell_h, opts.splat_radius,
                                       static_cast<float>(s.saturation), !opts.flat);
  }
  const std::string title =
      fmt::format("|E| point-to-plane, view {}{}; colour saturates at {:.3g} x diagonal ({})",
                  opts.view, opts.point.empty() ? "" : ", sweep point " + opts.point, s.saturation,
                  s.percentile ? "95th percentile of all cells" : "--max");
  const std::string unit = "|E| / diagonal";
  if (ext == ".svg") {
    write_file_atomic(opts.out, svg(images, s, title, unit, opts.width, opts.height));
  } else {
    metrics::write_figure_png(images, s.rows, s.cols, title, s.saturation, unit, opts.width,
                              opts.height, opts.out);
  }
  return s;
}

}  // namespace scanbench::harness
