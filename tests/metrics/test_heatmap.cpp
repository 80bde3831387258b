// Heatmap and histogram images: size, colours following the errors, depth test.
#include <gtest/gtest.h>

#include <OpenImageIO/imagebuf.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/metrics/heatmap.h"
#include "temp_dir.h"

namespace scanbench::metrics {
namespace {

namespace fs = std::filesystem;

Eigen::Vector3f pixel(const OIIO::ImageBuf& img, int x, int y) {
  float rgb[3];
  img.getpixel(x, y, rgb, 3);
  return {rgb[0], rgb[1], rgb[2]};
}

TEST(Heatmap, SizeColoursAndDepthTest) {
  // A unit square in z = 0, left half error 0, right half error range/2, and a strip at
  // y in [0.1, 0.2] with error 3 x range (saturated).
  const int n = 200;
  PointCloud pts;
  pts.positions.resize(3, n * n + 2);
  Eigen::VectorXf err(n * n + 2);
  BoundingBox frame;
  frame.extend({0, 0, -0.5f});
  frame.extend({1, 1, 0.5f});
  const float diag = frame.diagonal();
  HeatmapParams p;
  const float range = static_cast<float>(p.range) * diag;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float x = (i + 0.5f) / n, y = (j + 0.5f) / n;
      pts.positions.col(j * n + i) = Eigen::Vector3f(x, y, 0);
      err[j * n + i] = y > 0.1f && y < 0.2f ? 3 * range : (x < 0.5f ? 0.0f : -0.5f * range);
    }
  // Depth test: at (0.5, 0.9) a point in front (z = 0.3, t = 1) hides one behind.
  pts.positions.col(n * n) = Eigen::Vector3f(0.5f, 0.9f, 0.3f);
  err[n * n] = range;
  pts.positions.col(n * n + 1) = Eigen::Vector3f(0.5f, 0.9f, -0.3f);
  err[n * n + 1] = 0.0f;

  const test::TempDir dir("heatmap");
  const fs::path png = dir / "heatmap.png";
  write_heatmap(pts, err, frame, diag, p, png, "test heatmap");
  ASSERT_TRUE(fs::exists(png));
  OIIO::ImageBuf img(png.string());
  ASSERT_TRUE(img.read(0, 0, true, OIIO::TypeDesc::FLOAT));
  const Eigen::Vector2i size = heatmap_size(p);
  EXPECT_EQ(img.spec().width, size.x());
  EXPECT_EQ(img.spec().height, size.y());
  EXPECT_EQ(size, Eigen::Vector2i(4 * 400 + 110, 440));

  // Front view pixel of world point (x, y): same mapping as the writer.
  const float scale = 0.95f * 400 / diag;
  auto front = [&](float x, float y) {
    return Eigen::Vector2i(static_cast<int>(std::floor(200 + (x - 0.5f) * scale)),
                           40 + static_cast<int>(std::floor(200 - (y - 0.5f) * scale)));
  };
  // Oracle: viridis' published 8-bit colours (matplotlib, d3): #440154 at 0, #21918c at 0.5,
  // #fde725 at 1, independent of the writer's table.
  const auto hex = [](int r, int g, int b) -> Eigen::Vector3f {
    return Eigen::Vector3f(r, g, b) / 255.0f;
  };
  const std::map<float, Eigen::Vector3f> published = {
      {0.0f, hex(0x44, 0x01, 0x54)}, {0.5f, hex(0x21, 0x91, 0x8c)}, {1.0f, hex(0xfd, 0xe7, 0x25)}};
  const float tol = 2.5f / 255.0f;
  auto expect_colour = [&](Eigen::Vector2i px, float t) {
    const Eigen::Vector3f got = pixel(img, px.x(), px.y());
    const Eigen::Vector3f want = published.at(t);
    EXPECT_LT((got - want).cwiseAbs().maxCoeff(), tol)
        << "pixel " << px.transpose() << " got " << got.transpose() << " want " << want.transpose();
  };
  expect_colour(front(0.25f, 0.6f), 0.0f);
  expect_colour(front(0.75f, 0.6f), 0.5f);
  expect_colour(front(0.25f, 0.15f), 1.0f);  // saturated
  expect_colour(front(0.5f, 0.9f), 1.0f);    // the nearer point wins
  // Back view (camera on -z, x mirrored): the point at z = -0.3 is nearer there.
  const Eigen::Vector2i b = front(0.5f, 0.9f) + Eigen::Vector2i(2 * 400, 0);
  expect_colour(b, 0.0f);
  // The map itself: the published colours, clamping, and lightness rising monotonically
  // (sequential: a larger error is always lighter; Rec. 709 luma as the proxy).
  for (const auto& [t, rgb] : published)
    EXPECT_LT((viridis_color(t) - rgb).cwiseAbs().maxCoeff(), tol) << t;
  EXPECT_EQ(viridis_color(-1.0f), viridis_color(0.0f));
  EXPECT_EQ(viridis_color(7.0f), viridis_color(1.0f));
  const Eigen::Vector3f luma(0.2126f, 0.7152f, 0.0722f);
  for (int i = 1; i < 256; ++i) {
    const Eigen::Vector3f a(viridis_table()[i - 1]), b(viridis_table()[i]);
    EXPECT_GT(b.dot(luma), a.dot(luma)) << "entry " << i;
  }
  // The colour bar's top and bottom rows are the map's ends; the background is white.
  const int bx = 4 * 400 + 12 + 12;
  EXPECT_LT((pixel(img, bx, 40 + 20) - published.at(1.0f)).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((pixel(img, bx, 40 + 400 - 21) - published.at(0.0f)).cwiseAbs().maxCoeff(), tol);
  EXPECT_EQ(pixel(img, 3, size.y() - 3), Eigen::Vector3f(1, 1, 1));
  fs::remove(png);

  EXPECT_THROW(write_heatmap(pts, Eigen::VectorXf(3), frame, diag, p, png, "x"), InputError);
}

TEST(Heatmap, HistogramImage) {
  Json h = {{"unit", "diag"},         {"min", 0.0},    {"max", 0.01}, {"bins", 4},
            {"counts", {1, 5, 2, 0}}, {"overflow", 3}, {"count", 11}};
  const test::TempDir dir("hist");
  const fs::path png = dir / "hist.png";
  write_histogram_image(h, png, "p2plane |E|", 500, 300);
  OIIO::ImageBuf img(png.string());
  ASSERT_TRUE(img.read(0, 0, true, OIIO::TypeDesc::FLOAT));
  EXPECT_EQ(img.spec().width, 500);
  EXPECT_EQ(img.spec().height, 300);
  // The tallest bar (bin 1) reaches the top of the plot area; bin 3 is empty.
  const int x0 = 60, x1 = 480, y0 = 40, y1 = 250;
  const double bw = (x1 - x0) / 4.0;
  EXPECT_NE(pixel(img, x0 + static_cast<int>(1.5 * bw), y0 + 1), Eigen::Vector3f(1, 1, 1));
  EXPECT_EQ(pixel(img, x0 + static_cast<int>(3.5 * bw), y1 - 2), Eigen::Vector3f(1, 1, 1));
  fs::remove(png);
  EXPECT_THROW(write_histogram_image(Json::object(), png, "x"), InputError);
}

TEST(Heatmap, CoolWarmIsMorelandsPublishedDivergingMap) {
  // Oracle: Moreland's own table (kennethmoreland.com/color-maps, CoolWarmFloat33.csv), 33
  // entries computed by his code, independent of the Msh interpolation here. Every ninth entry
  // and the ends; agreement to 5e-4 (his conversion constants differ in the fourth digit).
  const std::vector<std::array<double, 4>> published = {
      {0.0, 0.2298057, 0.298717966, 0.753683153},
      {0.125, 0.38301334, 0.50941904, 0.917387822},
      {0.25, 0.552953156, 0.688929332, 0.995375608},
      {0.375, 0.722193294, 0.813952739, 0.976574709},
      {0.5, 0.865395197, 0.86541021, 0.865395561},
      {0.625, 0.958852946, 0.769767752, 0.678007945},
      {0.75, 0.958003065, 0.602842431, 0.481775914},
      {0.875, 0.869186849, 0.378313092, 0.300267182},
      {0.96875, 0.752534934, 0.157246067, 0.184115123},
      {1.0, 0.705673158, 0.01555616, 0.150232812}};
  for (const auto& [t, r, g, b] : published) {
    const Eigen::Vector3f got = cool_warm(t);
    EXPECT_LT((got - Eigen::Vector3f(r, g, b)).cwiseAbs().maxCoeff(), 5e-4f)
        << "t " << t << " got " << got.transpose();
  }
  // The table the viewer and figures use: row i is cool_warm(i / 255), looked up by floor(256 t);
  // clamped ends; NaN is the middle (a zero error).
  for (int i = 0; i < 256; ++i)
    EXPECT_EQ(Eigen::Vector3f(diverging_table()[i]), cool_warm(i / 255.0)) << i;
  EXPECT_EQ(diverging_color(-3.0f), cool_warm(0.0));
  EXPECT_EQ(diverging_color(3.0f), cool_warm(1.0));
  EXPECT_EQ(diverging_color(std::nanf("")), diverging_color(0.5f));
  // Symmetric lightness: CIELAB L* (from the sRGB bytes: linearised, Y of Rec. 709 primaries)
  // rises to the middle and falls after it, and t and 1 - t are equally light within one L*
  // unit; a signed error of either sign reads alike.
  const auto lstar = [](const float* rgb) {
    double y = 0.0;
    const double w[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; ++c) {
      const double v = rgb[c];
      y += w[c] * (v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
    }
    return y > 0.008856 ? 116.0 * std::cbrt(y) - 16.0 : 903.3 * y;
  };
  for (int i = 1; i < 256; ++i) {
    const double a = lstar(diverging_table()[i - 1]), b = lstar(diverging_table()[i]);
    if (i <= 127) {
      EXPECT_GT(b, a) << "entry " << i;
    } else if (i >= 129) {
      EXPECT_LT(b, a) << "entry " << i;
    }
  }
  for (int i = 0; i < 128; ++i)
    EXPECT_NEAR(lstar(diverging_table()[i]), lstar(diverging_table()[255 - i]), 1.0) << i;
  // error_color: magnitude through viridis (the sign ignored), signed through the diverging map.
  EXPECT_EQ(error_color(-0.3f, 1.0f, ErrorScale::Magnitude), viridis_color(0.3f));
  EXPECT_EQ(error_color(0.3f, 1.0f, ErrorScale::Magnitude), viridis_color(0.3f));
  EXPECT_EQ(error_color(-2.0f, 1.0f, ErrorScale::Signed), cool_warm(0.0));
  EXPECT_EQ(error_color(2.0f, 1.0f, ErrorScale::Signed), cool_warm(1.0));
  EXPECT_EQ(error_color(0.5f, 1.0f, ErrorScale::Signed), diverging_color(0.75f));
}

}  // namespace
}  // namespace scanbench::metrics
