#include "scanbench/metrics/heatmap.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <system_error>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"

namespace scanbench::metrics {

namespace {

namespace IBA = OIIO::ImageBufAlgo;

constexpr int kTitleRows = 40;
constexpr int kBarColumns = 110;

std::string font() {
  const char* path = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  return std::filesystem::exists(path) ? path : "DejaVuSans";
}

void text(OIIO::ImageBuf& img, int x, int y, const std::string& s, int size,
          OIIO::ImageBufAlgo::TextAlignX ax = OIIO::ImageBufAlgo::TextAlignX::Left) {
  const float black[3] = {0.0f, 0.0f, 0.0f};
  if (!IBA::render_text(img, x, y, s, size, font(), black, ax))
    throw IoError("heatmap: cannot render text with font DejaVuSans (install fonts-dejavu-core): " +
                  img.geterror());
}

/// Encodes the PNG in memory (OIIO's IO proxy) and writes it with write_file_atomic: OIIO's PNG
/// writer does not report a failed write to a full disk (a 0-byte and a truncated PNG were left
/// with success), write_file_atomic checks every write and names the reason.
void write_png(OIIO::ImageBuf& img, const std::filesystem::path& png) {
  if (png.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(png.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the folder: {}", png.parent_path().string(),
                                ec.message()));
    }
  }
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("png");
  OIIO::ImageSpec spec = img.spec();
  spec.set_format(OIIO::TypeDesc::UINT8);
  if (!out || !out->set_ioproxy(&proxy) || !out->open(png.string(), spec) ||
      !img.write(out.get()) || !out->close() || bytes.empty()) {
    throw IoError(png.string() +
                  ": cannot encode PNG: " + (out ? out->geterror() : OIIO::geterror()));
  }
  write_file_atomic(png,
                    std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

// Camera of view v: (u, v, depth) of a point relative to the frame centre; smaller depth is
// nearer to the camera.
Eigen::Vector3f view_coords(int view, const Eigen::Vector3f& d) {
  switch (view) {
    case 0:
      return {d.x(), d.y(), -d.z()};  // front, camera on +z
    case 1:
      return {-d.z(), d.y(), -d.x()};  // right, camera on +x
    case 2:
      return {-d.x(), d.y(), d.z()};  // back, camera on -z
    default:
      return {d.x(), -d.z(), -d.y()};  // top, camera on +y
  }
}

}  // namespace

Eigen::Vector2i heatmap_size(const HeatmapParams& p) {
  return {4 * p.width + kBarColumns, p.height + kTitleRows};
}

Eigen::Vector3f turbo_color(float t) {
  OIIO::ImageBuf v(OIIO::ImageSpec(1, 1, 1, OIIO::TypeDesc::FLOAT));
  const float tv = std::clamp(t, 0.0f, 1.0f);
  v.setpixel(0, 0, &tv);
  const OIIO::ImageBuf c = IBA::color_map(v, 0, "turbo");
  float rgb[3];
  c.getpixel(0, 0, rgb, 3);
  return {rgb[0], rgb[1], rgb[2]};
}

void write_heatmap(const PointCloud& points, const Eigen::VectorXf& errors,
                   const BoundingBox& frame, float diagonal, const HeatmapParams& p,
                   const std::filesystem::path& png, const std::string& title) {
  if (errors.size() != points.size())
    throw InputError("heatmap: " + std::to_string(errors.size()) + " errors for " +
                     std::to_string(points.size()) + " points");
  if (!errors.allFinite()) throw InputError("heatmap: an error value is not finite");
  if (frame.empty() || !(diagonal > 0.0f)) throw InputError("heatmap: empty frame");
  const Eigen::Vector2i size = heatmap_size(p);
  const int w = p.width, h = p.height;
  const float scale = 0.95f * static_cast<float>(std::min(w, h)) / frame.diagonal();
  const float range = static_cast<float>(p.range) * diagonal;
  const Eigen::Vector3f centre = frame.center();

  // Value image (t in [0, 1]) of all views, plus a coverage mask.
  OIIO::ImageBuf values(OIIO::ImageSpec(4 * w, h, 1, OIIO::TypeDesc::FLOAT));
  IBA::zero(values);
  std::vector<std::uint8_t> covered(static_cast<std::size_t>(4 * w * h), 0);
  std::vector<float> t_of(static_cast<std::size_t>(4 * w * h), 0.0f);
  const int r = p.splat_radius;
  for (int view = 0; view < 4; ++view) {
    std::vector<float> depth(static_cast<std::size_t>(w * h),
                             std::numeric_limits<float>::infinity());
    for (Eigen::Index i = 0; i < points.size(); ++i) {
      const Eigen::Vector3f c = view_coords(view, points.positions.col(i) - centre);
      const int px = static_cast<int>(std::floor(0.5f * w + c.x() * scale));
      const int py = static_cast<int>(std::floor(0.5f * h - c.y() * scale));
      const float t = std::min(std::abs(errors[i]) / range, 1.0f);
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          if (dx * dx + dy * dy > r * r) continue;
          const int x = px + dx, y = py + dy;
          if (x < 0 || y < 0 || x >= w || y >= h) continue;
          const std::size_t k = static_cast<std::size_t>(y * w + x);
          if (c.z() < depth[k]) {  // strict: ties keep the earlier (lower index) point
            depth[k] = c.z();
            const std::size_t g = static_cast<std::size_t>(y * 4 * w + view * w + x);
            covered[g] = 1;
            t_of[g] = t;
          }
        }
    }
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 4 * w; ++x)
      values.setpixel(x, y, &t_of[static_cast<std::size_t>(y * 4 * w + x)]);
  OIIO::ImageBuf coloured = IBA::color_map(values, 0, "turbo");
  const float white[3] = {1.0f, 1.0f, 1.0f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 4 * w; ++x)
      if (!covered[static_cast<std::size_t>(y * 4 * w + x)]) coloured.setpixel(x, y, white, 3);

  OIIO::ImageBuf img(OIIO::ImageSpec(size.x(), size.y(), 3, OIIO::TypeDesc::FLOAT));
  IBA::fill(img, white);
  IBA::paste(img, 0, kTitleRows, 0, 0, coloured);
  const char* names[4] = {"front (+z)", "right (+x)", "back (-z)", "top (+y)"};
  for (int view = 0; view < 4; ++view) {
    text(img, view * w + 6, kTitleRows + 16, names[view], 13);
    if (view > 0) {  // thin separators between views
      const float grey[3] = {0.6f, 0.6f, 0.6f};
      IBA::fill(img, grey, OIIO::ROI(view * w, view * w + 1, kTitleRows, kTitleRows + h));
    }
  }
  text(img, 8, 27, title, 18);

  // Colour bar: 24 columns wide, from t = 0 at the bottom to t = 1 at the top.
  const int bx = 4 * w + 12, by0 = kTitleRows + 20, by1 = kTitleRows + h - 20;
  OIIO::ImageBuf ramp(OIIO::ImageSpec(24, by1 - by0, 1, OIIO::TypeDesc::FLOAT));
  for (int y = 0; y < by1 - by0; ++y) {
    const float t = 1.0f - static_cast<float>(y) / static_cast<float>(by1 - by0 - 1);
    for (int x = 0; x < 24; ++x)
      ramp.setpixel(x, y, &t);
  }
  IBA::paste(img, bx, by0, 0, 0, IBA::color_map(ramp, 0, "turbo"));
  for (int k = 0; k <= 4; ++k) {
    const double frac = k / 4.0;
    const int y = by1 - static_cast<int>(frac * (by1 - by0 - 1));
    text(img, bx + 28, y + 4, fmt::format("{:.4g}", frac * p.range), 12);
  }
  text(img, bx, by0 - 6, "|E| / diag", 12);
  text(img, bx, by1 + 16, fmt::format(">= {:.3g} sat.", p.range), 11);
  write_png(img, png);
}

void write_histogram_image(const Json& hist, const std::filesystem::path& png,
                           const std::string& title, int width, int height) {
  if (!hist.is_object() || !hist.contains("counts") || !hist["counts"].is_array())
    throw InputError("histogram image: not a histogram record");
  const auto counts = hist["counts"].get<std::vector<std::int64_t>>();
  if (counts.empty()) throw InputError("histogram image: no bins");
  const std::int64_t top =
      std::max<std::int64_t>(1, *std::max_element(counts.begin(), counts.end()));
  OIIO::ImageBuf img(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::FLOAT));
  const float white[3] = {1.0f, 1.0f, 1.0f};
  const float bar[3] = {0.2f, 0.35f, 0.7f};
  const float axis[3] = {0.0f, 0.0f, 0.0f};
  IBA::fill(img, white);
  const int x0 = 60, x1 = width - 20, y0 = 40, y1 = height - 50;
  const double bw = static_cast<double>(x1 - x0) / static_cast<double>(counts.size());
  for (std::size_t b = 0; b < counts.size(); ++b) {
    const int bh = static_cast<int>(std::lround(static_cast<double>(counts[b]) / top * (y1 - y0)));
    if (bh <= 0) continue;
    const int xa = x0 + static_cast<int>(b * bw),
              xb = std::max(xa + 1, x0 + static_cast<int>((b + 1) * bw) - 1);
    IBA::fill(img, bar, OIIO::ROI(xa, xb, y1 - bh, y1));
  }
  IBA::fill(img, axis, OIIO::ROI(x0 - 1, x1, y1, y1 + 1));
  IBA::fill(img, axis, OIIO::ROI(x0 - 1, x0, y0, y1));
  const std::string unit = hist.value("unit", std::string());
  text(img, 8, 26, title, 16);
  text(img, x0, y1 + 18, fmt::format("{:.4g}", hist.value("min", 0.0)), 12);
  text(img, x1, y1 + 18, fmt::format("{:.4g}", hist.value("max", 0.0)), 12,
       OIIO::ImageBufAlgo::TextAlignX::Right);
  text(img, (x0 + x1) / 2, y1 + 18, unit, 12, OIIO::ImageBufAlgo::TextAlignX::Center);
  text(img, x0, y1 + 38,
       fmt::format("count {}  overflow {}  peak bin {}", hist.value("count", std::int64_t{0}),
                   hist.value("overflow", std::int64_t{0}), top),
       12);
  write_png(img, png);
}

}  // namespace scanbench::metrics
