// `scanbench figure` (issue 53) on a tiny real experiment of 2 datasets x 2 variants, where the
// two variants are one algorithm under two labels: the PNG has the requested size; unshaded
// (--flat) every cell's covered pixel is a viridis table entry (with --signed, a diverging-map
// entry); one colour scale (the two labels give identical cells, shaded too); the SVG parses as
// XML and embeds rows x cols PNG images; the PDF's cross-reference table finds every object and
// its cell images inflate to the PNG's pixels; bad input exits 2 with one line naming the folder
// or option and writes nothing.
#include <gtest/gtest.h>

#include <OpenImageIO/imagebuf.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "scanbench/metrics/heatmap.h"
#include "temp_dir.h"

namespace scanbench::test {
namespace {

namespace fs = std::filesystem;

class Figure : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir("figure");
    write(*dir_ / "f.json", R"({
      "scanbench_experiment": 1, "name": "figure", "seed": 3,
      "datasets": [{"name": "sphere"}, {"name": "torus"}],
      "scanners": [{"preset": "moderate", "params": {"views": 3, "resolution": 48}}],
      "variants": [
        {"label": "pca", "algorithm": "normals.pca"},
        {"label": "pca-again", "algorithm": "normals.pca"}
      ],
      "metrics": ["accuracy.p2plane"]
    })");
    const auto r =
        sh(sb() + " run " + (*dir_ / "f.json").string() + " -o " + out().string() + " -q");
    ok_ = r.code == 0;
    log_ = r.out;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path out() { return *dir_ / "out"; }

  static OIIO::ImageBuf read_png(const fs::path& p) {
    OIIO::ImageBuf img(p.string());
    img.read(0, 0, true, OIIO::TypeDesc::UINT8);
    return img;
  }

  /// The pixels of cell (i, j) of a W x H figure, less its first row and column (separators).
  static OIIO::ROI cell_roi(int w, int h, int i, int j) {
    const auto l = metrics::figure_layout(w, h, 2, 2);
    const int x = l.left + j * l.cell_w, y = l.top + 24 + i * l.cell_h;
    return {x + 1, x + l.cell_w, y + 1, y + l.cell_h};
  }

  /// Covered (non-white) pixels of a region and how many of them are no entry of `table` (each
  /// channel within one 8-bit step).
  static std::pair<int, int> off_table(const OIIO::ImageBuf& img, const OIIO::ROI& roi,
                                       const float (&table)[256][3]) {
    int covered = 0, off = 0;
    for (int y = roi.ybegin; y < roi.yend; ++y)
      for (int x = roi.xbegin; x < roi.xend; ++x) {
        float p[3];
        img.getpixel(x, y, p, 3);
        if (p[0] == 1.0f && p[1] == 1.0f && p[2] == 1.0f) continue;  // background
        ++covered;
        bool on = false;
        for (const auto& c : table) {
          bool same = true;
          for (int k = 0; k < 3; ++k)
            same = same && std::abs(std::lround(p[k] * 255) - std::lround(c[k] * 255)) <= 1;
          if (same) {
            on = true;
            break;
          }
        }
        off += on ? 0 : 1;
      }
    return {covered, off};
  }

  static TempDir* dir_;
  static bool ok_;
  static std::string log_;
};

TempDir* Figure::dir_ = nullptr;
bool Figure::ok_ = false;
std::string Figure::log_;

TEST_F(Figure, FlatCellsAreViridisEntriesAtTheRequestedSize) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "flat.png";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + png.string() +
                    " --size 640x420 --flat --view front");
  ASSERT_EQ(r.code, 0) << r.out;
  const OIIO::ImageBuf img = read_png(png);
  ASSERT_EQ(img.spec().width, 640);
  ASSERT_EQ(img.spec().height, 420);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const auto [covered, off] =
          off_table(img, cell_roi(640, 420, i, j), metrics::viridis_table());
      EXPECT_GT(covered, 100) << "cell " << i << "," << j;
      EXPECT_EQ(off, 0) << "cell " << i << "," << j;
    }
}

TEST_F(Figure, SignedCellsAreDivergingEntriesWithTheBarFromMinusToPlusMax) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "signed.png";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + png.string() +
                    " --size 640x420 --flat --signed --max 0.004");
  ASSERT_EQ(r.code, 0) << r.out;
  const OIIO::ImageBuf img = read_png(png);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const auto [covered, off] =
          off_table(img, cell_roi(640, 420, i, j), metrics::diverging_table());
      EXPECT_GT(covered, 100) << "cell " << i << "," << j;
      EXPECT_EQ(off, 0) << "cell " << i << "," << j;
    }
  // The bar: its top row is the map's red end (+max), its bottom row the blue end (-max).
  const auto l = metrics::figure_layout(640, 420, 2, 2);
  const int bx = l.bar_x + 12 + 12, top = l.top + 24 + 20, bottom = 420 - 30 - 1;
  float p[3];
  img.getpixel(bx, top, p, 3);
  EXPECT_LT((Eigen::Vector3f(p[0], p[1], p[2]) - metrics::cool_warm(1.0)).cwiseAbs().maxCoeff(),
            1.5f / 255);
  img.getpixel(bx, bottom, p, 3);
  EXPECT_LT((Eigen::Vector3f(p[0], p[1], p[2]) - metrics::cool_warm(0.0)).cwiseAbs().maxCoeff(),
            1.5f / 255);
}

TEST_F(Figure, PdfObjectsResolveAndItsCellsAreThePngsPixels) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "same.png", pdf = *dir_ / "same.pdf", again = *dir_ / "again.pdf";
  const std::string args = " --size 640x420 --view front";
  ASSERT_EQ(sh(sb() + " figure " + out().string() + " -o " + png.string() + args).code, 0);
  const auto r = sh(sb() + " figure " + out().string() + " -o " + pdf.string() + args);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(sh(sb() + " figure " + out().string() + " -o " + again.string() + args).code, 0);
  const std::string doc = slurp(pdf);
  EXPECT_EQ(doc, slurp(again)) << "the same figure twice gives different bytes";
  ASSERT_EQ(doc.rfind("%PDF-1.4\n", 0), 0u);
  // The cross-reference table: startxref points at it, every entry at its "k 0 obj".
  const auto sx = doc.rfind("startxref\n");
  ASSERT_NE(sx, std::string::npos);
  const std::size_t xref = std::stoul(doc.substr(sx + 10));
  ASSERT_EQ(doc.compare(xref, 5, "xref\n"), 0);
  std::size_t at = doc.find('\n', xref + 5) + 1;
  const int count = std::stoi(doc.substr(xref + 7));
  ASSERT_GT(count, 6);
  at += 20;  // entry 0, the free list's head
  for (int k = 1; k < count; ++k, at += 20) {
    const std::size_t off = std::stoul(doc.substr(at, 10));
    const std::string head = std::to_string(k) + " 0 obj\n";
    EXPECT_EQ(doc.compare(off, head.size(), head), 0) << "object " << k << " at " << off;
  }
  EXPECT_NE(doc.find("/MediaBox [0 0 640 420]"), std::string::npos);
  for (const char* label : {"(sphere) Tj", "(torus) Tj", "(pca) Tj", "(pca-again) Tj"})
    EXPECT_NE(doc.find(label), std::string::npos) << label;
  // The images, in page order: the four cells (row-major), then the colour bar (1 x 256). Each
  // cell inflates to the PNG's pixels of that cell (less the separators the PNG draws over its
  // first row and column).
  const OIIO::ImageBuf img = read_png(png);
  const std::regex image_dict(
      R"(/Subtype /Image /Width (\d+) /Height (\d+) /ColorSpace /DeviceRGB /BitsPerComponent 8 /Filter /FlateDecode /Length (\d+) >>\nstream\n)");
  std::vector<std::vector<unsigned char>> images;
  std::vector<std::pair<int, int>> sizes;
  for (std::sregex_iterator it(doc.begin(), doc.end(), image_dict), end; it != end; ++it) {
    const int w = std::stoi((*it)[1]), h = std::stoi((*it)[2]);
    const std::size_t len = std::stoul((*it)[3]);
    const std::size_t start = static_cast<std::size_t>(it->position(0) + it->length(0));
    std::vector<unsigned char> raw(static_cast<std::size_t>(w) * h * 3);
    uLongf n = raw.size();
    ASSERT_EQ(uncompress(raw.data(), &n, reinterpret_cast<const Bytef*>(doc.data() + start), len),
              Z_OK);
    ASSERT_EQ(n, raw.size());
    EXPECT_EQ(doc.compare(start + len, 10, "\nendstream"), 0);
    images.push_back(std::move(raw));
    sizes.emplace_back(w, h);
  }
  ASSERT_EQ(images.size(), 5u);
  EXPECT_EQ(sizes[4], std::make_pair(1, 256));
  const auto l = metrics::figure_layout(640, 420, 2, 2);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const auto& raw = images[static_cast<std::size_t>(2 * i + j)];
      const auto [w, h] = sizes[static_cast<std::size_t>(2 * i + j)];
      EXPECT_EQ(w, l.cell_w);
      EXPECT_EQ(h, l.cell_h);
      const OIIO::ROI roi = cell_roi(640, 420, i, j);
      const int x0 = l.left + j * l.cell_w, y0 = l.top + 24 + i * l.cell_h;
      int differ = 0, covered = 0;
      for (int y = roi.ybegin; y < roi.yend && y - y0 < h; ++y)
        for (int x = roi.xbegin; x < roi.xend && x - x0 < w; ++x) {
          float p[3];
          img.getpixel(x, y, p, 3);
          const std::size_t k = 3 * (static_cast<std::size_t>(y - y0) * w + (x - x0));
          bool same = true;
          for (int c = 0; c < 3; ++c)
            same = same && std::lround(p[c] * 255) == raw[k + c];
          differ += same ? 0 : 1;
          covered += raw[k] != 255 || raw[k + 1] != 255 || raw[k + 2] != 255;
        }
      EXPECT_GT(covered, 100) << "cell " << i << "," << j;
      EXPECT_EQ(differ, 0) << "cell " << i << "," << j;
    }
}

TEST_F(Figure, OneColourScaleGivesIdenticalCellsForIdenticalOutputs) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "shaded.png";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + png.string() + " --size 800x500");
  ASSERT_EQ(r.code, 0) << r.out;
  const OIIO::ImageBuf img = read_png(png);
  ASSERT_EQ(img.spec().width, 800);
  for (int i = 0; i < 2; ++i) {
    const OIIO::ROI a = cell_roi(800, 500, i, 0), b = cell_roi(800, 500, i, 1);
    int differ = 0, covered = 0;
    for (int y = a.ybegin; y < a.yend; ++y)
      for (int x = 0; x < a.width() && x < b.width(); ++x) {
        float p[3], q[3];
        img.getpixel(a.xbegin + x, y, p, 3);
        img.getpixel(b.xbegin + x, y, q, 3);
        differ += (p[0] != q[0] || p[1] != q[1] || p[2] != q[2]) ? 1 : 0;
        covered += (p[0] != 1.0f || p[1] != 1.0f || p[2] != 1.0f) ? 1 : 0;
      }
    EXPECT_GT(covered, 100) << "row " << i;
    EXPECT_EQ(differ, 0) << "row " << i;
  }
  if (const char* keep = std::getenv("SCANBENCH_FIGURE_SHOTS"); keep) {
    fs::create_directories(keep);
    fs::copy_file(png, fs::path(keep) / "figure.png", fs::copy_options::overwrite_existing);
  }
}

TEST_F(Figure, MaxSetsTheOneScaleOfEveryCell) {
  // With a saturation far above every error each covered pixel of every cell is viridis entry 0:
  // the scale is the figure's, not a per-cell normalisation.
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "max.png";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + png.string() +
                    " --size 640x420 --flat --max 1000");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("saturation 1000 x diagonal (--max)"), std::string::npos) << r.out;
  const OIIO::ImageBuf img = read_png(png);
  const auto& c0 = metrics::viridis_table()[0];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const OIIO::ROI roi = cell_roi(640, 420, i, j);
      int covered = 0, other = 0;
      for (int y = roi.ybegin; y < roi.yend; ++y)
        for (int x = roi.xbegin; x < roi.xend; ++x) {
          float p[3];
          img.getpixel(x, y, p, 3);
          if (p[0] == 1.0f && p[1] == 1.0f && p[2] == 1.0f) continue;
          ++covered;
          for (int k = 0; k < 3; ++k)
            if (std::lround(p[k] * 255) != std::lround(c0[k] * 255)) {
              ++other;
              break;
            }
        }
      EXPECT_GT(covered, 100) << "cell " << i << "," << j;
      EXPECT_EQ(other, 0) << "cell " << i << "," << j;
    }
}

TEST_F(Figure, SvgParsesAndEmbedsEveryCell) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path svg = *dir_ / "f.svg";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + svg.string() + " --size 640x420");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto py =
      sh("python3 -c 'import sys, xml.dom.minidom as m; d = m.parse(sys.argv[1]); "
         "print(len(d.getElementsByTagName(\"image\")))' " +
         svg.string());
  ASSERT_EQ(py.code, 0) << py.out;
  EXPECT_EQ(py.out, "4\n");
  EXPECT_NE(slurp(svg).find("data:image/png;base64,iVBOR"), std::string::npos);
}

TEST_F(Figure, BadInputExitsTwoWithOneLineAndWritesNothing) {
  ASSERT_TRUE(ok_) << log_;
  const fs::path png = *dir_ / "bad.png";
  struct Case {
    std::string args, names;
  };
  const Case cases[] = {
      {(*dir_ / "missing").string(), (*dir_ / "missing").string()},
      {out().string() + " --datasets sphere,nosuch", "--datasets"},
      {out().string() + " --variants nosuch", "--variants"},
      {out().string() + " --view diagonal", "--view"},
      {out().string() + " --point h=9", "--point"},
      {out().string() + " --size 12by3", "--size"},
      {out().string() + " --metric chamfer", "--metric"},
  };
  for (const auto& c : cases) {
    const auto r = sh(sb() + " figure " + c.args + " -o " + png.string());
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.names), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_FALSE(fs::exists(png)) << c.args;
  }
  const fs::path eps = *dir_ / "bad.eps";
  const auto r = sh(sb() + " figure " + out().string() + " -o " + eps.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(".png, .svg or .pdf"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(eps));
}

}  // namespace
}  // namespace scanbench::test
