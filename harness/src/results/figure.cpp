#include "scanbench/harness/results/figure.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "results/report_viewer.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"
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
                const std::string& title, const std::string& unit, int width, int height,
                metrics::ErrorScale scale) {
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
  // The colour bar: a vertical gradient through 17 stops of the map, t = 0 at the bottom.
  const int bx = l.bar_x + 12, by0 = y0 + 20, by1 = height - 30;
  o += "<defs><linearGradient id=\"viridis\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
  for (int k = 0; k <= 16; ++k)
    o += fmt::format("<stop offset=\"{:.4g}\" stop-color=\"{}\"/>", k / 16.0,
                     rgb_hex(metrics::map_color(std::min(1.0f, k / 16.0f), scale)));
  o += "</linearGradient></defs>\n";
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"24\" height=\"{}\" fill=\"url(#viridis)\"/>\n",
                   bx, by0, by1 - by0);
  for (int k = 0; k <= 4; ++k) {
    const int y = by1 - static_cast<int>(k / 4.0 * (by1 - by0 - 1));
    o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\">{:.3g}</text>\n", bx + 28, y + 4,
                     metrics::bar_value(k / 4.0, s.saturation, scale));
  }
  o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\">{}</text>\n", bx, by0 - 6,
                   html_escape(unit));
  o += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\">{}</text>\n", bx, by1 + 16,
                   scale == metrics::ErrorScale::Signed ? "ends: saturated" : "top: saturated");
  return o + "</svg>\n";
}

// A PDF figure, written here rather than by a library: none of the chosen dependencies writes
// PDF (OpenImageIO reads it at most; Chromium's print-to-PDF stamps the date, so two runs would
// differ, and needs a browser at figure time). The page is the SVG's layout in points (1 px =
// 1 pt): each cell an RGB image (8 bits, Flate-compressed by zlib, the PNG's pixels), the labels
// in the standard Helvetica (WinAnsi; labels left-aligned), the colour bar a 1 x 256 image of
// the map. No dates, no IDs: the same figure gives the same bytes.

/// UTF-8 text as a PDF literal string in WinAnsiEncoding (U+0020..U+007E and U+00A0..U+00FF,
/// where WinAnsi is Latin-1). Throws InputError naming `what` for any other character.
std::string pdf_string(const std::string& utf8, const std::string& what) {
  std::string out = "(";
  for (std::size_t i = 0; i < utf8.size();) {
    const auto c = static_cast<unsigned char>(utf8[i]);
    unsigned cp = 0x110000;
    std::size_t n = 1;
    if (c < 0x80) {
      cp = c;
    } else if ((c & 0xE0) == 0xC0 && i + 1 < utf8.size() &&
               (static_cast<unsigned char>(utf8[i + 1]) & 0xC0) == 0x80) {
      cp = ((c & 0x1Fu) << 6) | (static_cast<unsigned char>(utf8[i + 1]) & 0x3Fu);
      n = 2;
    }
    if (cp < 0x20 || (cp >= 0x7F && cp < 0xA0) || cp > 0xFF)
      throw InputError(what + ": '" + utf8 +
                       "' has a character a PDF figure's standard font cannot show (Latin-1 "
                       "only); write .svg or .png");
    if (cp == '(' || cp == ')' || cp == '\\') out += '\\';
    out += cp < 0x80 ? std::string(1, static_cast<char>(cp)) : fmt::format("\\{:03o}", cp);
    i += n;
  }
  return out + ")";
}

std::string deflate(const std::vector<unsigned char>& raw, const std::string& what) {
  uLongf n = compressBound(static_cast<uLong>(raw.size()));
  std::string out(n, '\0');
  if (compress2(reinterpret_cast<Bytef*>(out.data()), &n, raw.data(),
                static_cast<uLong>(raw.size()), 9) != Z_OK)
    throw IoError(what + ": zlib could not compress an image");
  out.resize(n);
  return out;
}

std::vector<unsigned char> rgb_bytes(const metrics::SplatImage& c) {
  std::vector<unsigned char> b(c.rgb.size());
  for (std::size_t i = 0; i < b.size(); ++i)
    b[i] = static_cast<unsigned char>(std::lround(std::clamp(c.rgb[i], 0.0f, 1.0f) * 255.0f));
  return b;
}

std::string pdf(const std::vector<metrics::SplatImage>& cells, const FigureSummary& s,
                const std::string& title, const std::string& unit, int width, int height,
                metrics::ErrorScale scale, const std::string& what) {
  const metrics::FigureLayout l = metrics::figure_layout(
      width, height, static_cast<int>(s.rows.size()), static_cast<int>(s.cols.size()));
  const int y0 = l.top + 24;
  const auto text = [&](int x, int y, int size, const std::string& t, const std::string& field) {
    return fmt::format("BT /F1 {} Tf {} {} Td {} Tj ET\n", size, x, height - y,
                       pdf_string(t, field));
  };
  // Images: every drawn cell, then the colour bar (1 x 256, t = 1 in the top row).
  std::vector<std::string> images;
  std::string page = "1 g 0 0 " + fmt::format("{} {}", width, height) + " re f\n0 g\n";
  page += text(8, 24, 16, title, what + ": the title");
  for (std::size_t j = 0; j < s.cols.size(); ++j)
    page += text(l.left + static_cast<int>(j) * l.cell_w + 4, l.top + 18, 14, s.cols[j],
                 what + ": variant");
  for (std::size_t i = 0; i < s.rows.size(); ++i)
    page += text(8, y0 + static_cast<int>(i) * l.cell_h + l.cell_h / 2 + 5, 14, s.rows[i],
                 what + ": dataset");
  const auto image = [&](int w, int h, const std::vector<unsigned char>& raw) {
    images.push_back(
        fmt::format("<< /Type /XObject /Subtype /Image /Width {} /Height {} "
                    "/ColorSpace /DeviceRGB /BitsPerComponent 8 /Filter "
                    "/FlateDecode /Length ",
                    w, h));
    const std::string z = deflate(raw, what);
    images.back() += std::to_string(z.size()) + " >>\nstream\n" + z + "\nendstream";
    return images.size() - 1;
  };
  for (std::size_t i = 0; i < s.rows.size(); ++i)
    for (std::size_t j = 0; j < s.cols.size(); ++j) {
      const auto& c = cells[i * s.cols.size() + j];
      const int x = l.left + static_cast<int>(j) * l.cell_w,
                y = y0 + static_cast<int>(i) * l.cell_h;
      if (c.width > 0) {
        const std::size_t k = image(c.width, c.height, rgb_bytes(c));
        page += fmt::format("q {} 0 0 {} {} {} cm /Im{} Do Q\n", c.width, c.height, x,
                            height - y - c.height, k);
      }
      // The PNG's separators: grey lines left of and above every cell but the first.
      if (j > 0)
        page += fmt::format("0.6 g {} {} 1 {} re f 0 g\n", x, height - y - l.cell_h, l.cell_h);
      if (i > 0) page += fmt::format("0.6 g {} {} {} 1 re f 0 g\n", x, height - y - 1, l.cell_w);
    }
  const int bx = l.bar_x + 12, by0 = y0 + 20, by1 = height - 30;
  std::vector<unsigned char> bar;
  for (int r = 0; r < 256; ++r) {
    const Eigen::Vector3f c = metrics::map_color((255 - r) / 255.0f, scale);
    for (int ch = 0; ch < 3; ++ch)
      bar.push_back(static_cast<unsigned char>(std::lround(c[ch] * 255.0f)));
  }
  page += fmt::format("q 24 0 0 {} {} {} cm /Im{} Do Q\n", by1 - by0, bx, height - by1,
                      image(1, 256, bar));
  for (int k = 0; k <= 4; ++k) {
    const int y = by1 - static_cast<int>(k / 4.0 * (by1 - by0 - 1));
    page += text(bx + 28, y + 4, 11,
                 fmt::format("{:.3g}", metrics::bar_value(k / 4.0, s.saturation, scale)), what);
  }
  page += text(bx, by0 - 6, 11, unit, what);
  page += text(bx, by1 + 16, 10,
               scale == metrics::ErrorScale::Signed ? "ends: saturated" : "top: saturated", what);

  // Objects 1 catalog, 2 pages, 3 page, 4 contents, 5 font, 6.. images; then the xref table.
  std::vector<std::string> objs = {
      "<< /Type /Catalog /Pages 2 0 R >>", "<< /Type /Pages /Kids [3 0 R] /Count 1 >>", "",
      fmt::format("<< /Length {} >>\nstream\n{}endstream", page.size(), page),
      "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding >>"};
  std::string xobjects;
  for (std::size_t k = 0; k < images.size(); ++k)
    xobjects += fmt::format(" /Im{} {} 0 R", k, 6 + k);
  objs[2] = fmt::format(
      "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {} {}] /Contents 4 0 R /Resources << /Font "
      "<< /F1 5 0 R >> /XObject <<{} >> >> >>",
      width, height, xobjects);
  for (auto& im : images)
    objs.push_back(std::move(im));
  std::string out = "%PDF-1.4\n%\xe2\xe3\xcf\xd3\n";
  std::vector<std::size_t> offsets;
  for (std::size_t k = 0; k < objs.size(); ++k) {
    offsets.push_back(out.size());
    out += fmt::format("{} 0 obj\n{}\nendobj\n", k + 1, objs[k]);
  }
  const std::size_t xref = out.size();
  out += fmt::format("xref\n0 {}\n0000000000 65535 f \n", objs.size() + 1);
  for (std::size_t o : offsets)
    out += fmt::format("{:010d} 00000 n \n", o);
  out += fmt::format(
      "trailer\n<< /Size {} /Root 1 0 R /Info << /Producer (scanbench figure) >> >>\n"
      "startxref\n{}\n%%EOF\n",
      objs.size() + 1, xref);
  return out;
}

}  // namespace

FigureSummary write_figure(const FigureOptions& opts) {
  if (opts.metric != "p2plane" && opts.metric != "accuracy.p2plane")
    throw InputError("--metric " + opts.metric +
                     ": figures colour by the per-point error of p2plane only");
  const int view = view_index(opts.view);
  if (opts.out.empty()) throw InputError("-o: the figure file is required");
  const std::string ext = opts.out.extension().string();
  if (ext != ".png" && ext != ".svg" && ext != ".pdf")
    throw InputError("-o " + opts.out.string() +
                     ": the figure file must end in .png, .svg or .pdf");
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

  const metrics::ErrorScale scale =
      opts.signed_errors ? metrics::ErrorScale::Signed : metrics::ErrorScale::Magnitude;
  std::vector<metrics::SplatImage> images(cells.size());
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const auto& c = cells[k].cloud;
    if (!c) continue;
    images[k] = metrics::render_splats(c->positions, c->normals, c->errors, cells[k].frame, view,
                                       layout.cell_w, layout.cell_h, opts.splat_radius,
                                       static_cast<float>(s.saturation), !opts.flat, scale);
  }
  const std::string title = fmt::format(
      "{} point-to-plane, view {}{}; colour saturates at {}{:.3g} x diagonal ({})",
      opts.signed_errors ? "Signed E (- inside, + outside)" : "|E|", opts.view,
      opts.point.empty() ? "" : ", sweep point " + opts.point, opts.signed_errors ? "+/-" : "",
      s.saturation, s.percentile ? "95th percentile of all cells' |E|" : "--max");
  const std::string unit = opts.signed_errors ? "E / diagonal" : "|E| / diagonal";
  if (ext == ".svg") {
    write_file_atomic(opts.out, svg(images, s, title, unit, opts.width, opts.height, scale));
  } else if (ext == ".pdf") {
    write_file_atomic(
        opts.out, pdf(images, s, title, unit, opts.width, opts.height, scale, opts.out.string()));
  } else {
    metrics::write_figure_png(images, s.rows, s.cols, title, s.saturation, unit, opts.width,
                              opts.height, opts.out, scale);
  }
  return s;
}

}  // namespace scanbench::harness
