// The report's 3D viewer in a real browser (Debian's chromium, headless, WebGL through
// SwiftShader), on a tiny real experiment: the page loads offline and requests nothing outside
// its folder; the canvas draws pixels whose colours are viridis entries (diverging-map entries
// when coloured by the signed error); a scripted camera turn moves every view of a dataset alike;
// a picked point (by the hook, and by a pointer click at its pixel) reports the error the oracle
// computes from the output file and the ground truth; the ground-truth checkbox shows the truth
// in every panel. And without three.js the report is still written.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <OpenImageIO/imagebuf.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "cli_test_util.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/io.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"
#include "temp_dir.h"

namespace scanbench::test {
namespace {

namespace fs = std::filesystem;

/// One small run shared by the tests: the sphere, one scan, PCA normals (points with normals)
/// and WLOP (points without) at two sweep points, reported.
class Viewer : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir("viewer");
    write(*dir_ / "v.json", R"({
      "scanbench_experiment": 1, "name": "viewer", "seed": 3,
      "datasets": [{"name": "sphere"}],
      "scanners": [{"preset": "moderate", "params": {"views": 3, "resolution": 48}}],
      "variants": [
        {"label": "pca", "algorithm": "normals.pca"},
        {"label": "wlop", "algorithm": "resample.wlop", "params": {"iterations": 2},
         "sweep": {"resample.wlop.h": [0.05, 0.08]}}
      ],
      "metrics": ["accuracy.p2plane"]
    })");
    const auto r = sh(sb() + " run " + (*dir_ / "v.json").string() + " -o " + out().string() +
                      " -q && " + sb() + " report " + out().string());
    ok_ = r.code == 0;
    log_ = r.out;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path out() { return *dir_ / "out"; }

  /// Chromium on the report with `hash`, network off (every host name fails to resolve), WebGL
  /// through SwiftShader; `mode` is "--dump-dom" or "--screenshot=FILE". The window is tall
  /// enough to hold the viewer without scrolling (the screenshot shows the window's top).
  static std::string chromium(const std::string& hash, const std::string& mode) {
    const TempDir profile("viewer-chromium");
    return sh("timeout 120 /usr/bin/chromium --headless --no-sandbox --use-angle=swiftshader "
              "--enable-unsafe-swiftshader --disable-quic --no-first-run "
              "--disable-background-networking --disable-component-update --disable-sync "
              "--host-resolver-rules='MAP * ~NOTFOUND' --window-size=1400,4000 "
              "--hide-scrollbars --virtual-time-budget=5000 --user-data-dir=" +
                  profile.path.string() + " " + mode + " 'file://" +
                  fs::absolute(out() / "index.html").string() + "#" + hash + "' 2>/dev/null",
              false)
        .out;
  }

  /// The viewer's status (JSON written by the page into #sb-viewer-status).
  static Json status(const std::string& hash) {
    const std::string dom = chromium(hash, "--dump-dom");
    const std::string open = "<pre id=\"sb-viewer-status\" style=\"display:none\">";
    const auto a = dom.find(open);
    if (a == std::string::npos) return Json();
    const auto b = dom.find("</pre>", a);
    std::string text = dom.substr(a + open.size(), b - a - open.size());
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}})
      for (auto p = text.find(from); p != std::string::npos; p = text.find(from, p + 1))
        text.replace(p, from.size(), to);
    return Json::parse(text, nullptr, false);
  }

  /// The screenshot of the report with `hash` (RGB, 8 bits), kept in $SCANBENCH_VIEWER_SHOTS
  /// as `name` when that is set.
  static OIIO::ImageBuf screenshot(const std::string& hash, const std::string& name) {
    const TempDir shots("viewer-shot");
    const fs::path png = shots / "viewer.png";
    chromium(hash, "--screenshot=" + png.string());
    OIIO::ImageBuf img(png.string());
    img.read(0, 0, true, OIIO::TypeDesc::UINT8);
    if (const char* keep = std::getenv("SCANBENCH_VIEWER_SHOTS"); keep && fs::exists(png)) {
      fs::create_directories(keep);
      fs::copy_file(png, fs::path(keep) / name, fs::copy_options::overwrite_existing);
    }
    return img;
  }

  /// The pixels of a view (its status "rect"), less its label (top 24 rows) and a 3-pixel margin.
  static OIIO::ROI view_roi(const Json& v) {
    const int x0 = static_cast<int>(v["rect"][0].get<double>()) + 3,
              y0 = static_cast<int>(v["rect"][1].get<double>()) + 24;
    return {x0, x0 + static_cast<int>(v["rect"][2].get<double>()) - 6, y0,
            static_cast<int>(v["rect"][1].get<double>() + v["rect"][3].get<double>()) - 3};
  }

  /// Drawn (non-white) pixels of a view and how many of them are no entry of `table` (each
  /// channel within 1.5 8-bit steps).
  static std::pair<int, int> off_map(const OIIO::ImageBuf& img, const Json& view,
                                     const float (&table)[256][3]) {
    const OIIO::ROI r = view_roi(view);
    int drawn = 0, off = 0;
    for (int y = r.ybegin; y < r.yend; ++y)
      for (int x = r.xbegin; x < r.xend; ++x) {
        float rgb[3];
        img.getpixel(x, y, rgb, 3);
        if (rgb[0] > 0.99f && rgb[1] > 0.99f && rgb[2] > 0.99f) continue;  // background
        ++drawn;
        float best = 1.0f;
        for (const auto& c : table)
          best = std::min(best, std::max({std::abs(rgb[0] - c[0]), std::abs(rgb[1] - c[1]),
                                          std::abs(rgb[2] - c[2])}));
        off += best > 1.5f / 255.0f;
      }
    return {drawn, off};
  }

  /// The oracle for a pick: the output file of the picked job, its point `index`'s
  /// point-to-plane error to the sphere's closest face, and the largest |E| of the file (the
  /// viewer stores errors as 16-bit multiples of max |E| / 32767).
  struct Oracle {
    double error = 0.0, max_abs = 0.0;
    Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  // the ground truth's frame plus its origin
    double diagonal = 0.0;
    Eigen::Index size = 0;
  };
  static Oracle oracle(const Json& pick) {
    Json rec;
    for (const auto& r : read_jsonl(out() / "runs.jsonl"))
      if (r["id"] == pick["job"]) rec = r;
    EXPECT_TRUE(rec.is_object()) << pick.dump();
    if (!rec.is_object()) return {};
    const TriangleMesh mesh =
        load_dataset("sphere", rec["dataset"].value("params", Json::object()));
    const metrics::GroundTruth gt(mesh, 0);
    PointCloud pts = read_point_cloud(out() / rec["artifacts"]["output"].get<std::string>());
    rebase(pts, mesh.origin);
    Oracle o;
    o.size = pts.size();
    o.diagonal = gt.diagonal();
    const auto i = pick["index"].get<Eigen::Index>();
    for (Eigen::Index j = 0; j < pts.size(); ++j) {
      const auto cp = gt.closest_point(pts.positions.col(j));
      const double ej = (pts.positions.col(j) - cp.point).dot(cp.normal);
      o.max_abs = std::max(o.max_abs, std::abs(ej));
      if (j == i) {
        o.error = ej;
        o.xyz = pts.positions.col(j).cast<double>() + mesh.origin.cast<double>();
      }
    }
    return o;
  }

  static TempDir* dir_;
  static bool ok_;
  static std::string log_;
};

TempDir* Viewer::dir_ = nullptr;
bool Viewer::ok_ = false;
std::string Viewer::log_;

TEST_F(Viewer, PageIsSelfContainedAndLoadsOffline) {
  ASSERT_TRUE(ok_) << log_;
  const std::string html = slurp(out() / "index.html");
  EXPECT_NE(html.find("Content-Security-Policy"), std::string::npos);
  EXPECT_NE(html.find("id=\"sb-viewer-data\""), std::string::npos);
  EXPECT_EQ(html.find("<script src"), std::string::npos);
  ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "chromium not installed (scripts/setup.sh)";
  const Json s = status("all=1&shade=0");
  ASSERT_TRUE(s.is_object()) << "no viewer status in the page";
  EXPECT_TRUE(s.value("ready", false)) << s.dump();
  EXPECT_TRUE(s["errors"].empty()) << s.dump();
  ASSERT_EQ(s["groups"].size(), 1u);
  // Three outputs: pca, and wlop's two sweep points sharing one panel (the slider's).
  const Json& views = s["groups"][0]["views"];
  ASSERT_EQ(views.size(), 3u);
  EXPECT_TRUE(views[0]["shown"].get<bool>() && views[1]["shown"].get<bool>());
  EXPECT_FALSE(views[2]["shown"].get<bool>());
  EXPECT_EQ(views[1]["rect"], views[2]["rect"]);
  const Json second = status("all=1&point=1");
  EXPECT_TRUE(second["groups"][0]["views"][2]["shown"].get<bool>()) << second.dump();
  EXPECT_FALSE(second["groups"][0]["views"][1]["shown"].get<bool>());
  // Everything the page loaded is inside the results folder (or the page's own blob: URLs).
  const std::string folder = "file://" + fs::absolute(out()).string() + "/";
  for (const auto& r : s["resources"]) {
    const std::string url = r.get<std::string>();
    EXPECT_TRUE(url.rfind(folder, 0) == 0 || url.rfind("blob:", 0) == 0 ||
                url.rfind("data:", 0) == 0)
        << url;
  }
}

TEST_F(Viewer, CanvasColoursLieOnViridis) {
  ASSERT_TRUE(ok_) << log_;
  const std::string hash = "all=1&shade=0";
  const Json s = status(hash);
  ASSERT_TRUE(s.is_object() && s.value("ready", false)) << s.dump();
  const OIIO::ImageBuf img = screenshot(hash, "viewer-unshaded.png");
  ASSERT_TRUE(img.initialized()) << "no screenshot";
  for (const auto& v : s["groups"][0]["views"]) {
    if (!v["shown"].get<bool>()) continue;
    const OIIO::ROI r = view_roi(v);
    ASSERT_GE(r.xbegin, 0);
    ASSERT_LE(r.yend, img.spec().height) << "the view is not inside the window";
    const auto [drawn, off] = off_map(img, v, metrics::viridis_table());
    EXPECT_GT(drawn, 500) << v.dump();
    EXPECT_EQ(off, 0) << v.dump() << ": of " << drawn << " drawn pixels";
  }
}

TEST_F(Viewer, SignedColoursLieOnTheDivergingMap) {
  ASSERT_TRUE(ok_) << log_;
  const std::string hash = "all=1&shade=0&colour=signed";
  const Json s = status(hash);
  ASSERT_TRUE(s.is_object() && s.value("ready", false)) << s.dump();
  EXPECT_EQ(s["groups"][0]["colour"], "signed");
  const OIIO::ImageBuf img = screenshot(hash, "viewer-signed.png");
  ASSERT_TRUE(img.initialized()) << "no screenshot";
  for (const auto& v : s["groups"][0]["views"]) {
    if (!v["shown"].get<bool>()) continue;
    const auto [drawn, off] = off_map(img, v, metrics::diverging_table());
    EXPECT_GT(drawn, 500) << v.dump();
    EXPECT_EQ(off, 0) << v.dump() << ": of " << drawn << " drawn pixels";
    // Not viridis any more: most drawn pixels are off that map.
    EXPECT_GT(off_map(img, v, metrics::viridis_table()).second, drawn / 2) << v.dump();
  }
}

TEST_F(Viewer, ScriptedCameraTurnMovesEveryViewAlike) {
  ASSERT_TRUE(ok_) << log_;
  const Json before = status("all=1&shade=0");
  const Json after = status("all=1&shade=0&cam=120,40,2.5");
  ASSERT_TRUE(before.value("ready", false) && after.value("ready", false)) << after.dump();
  const auto& views = after["groups"][0]["views"];
  // Every view has the camera the hash asked for: at azimuth 120 and elevation 40 degrees
  // around the ground truth's centre, 2.5 diagonals away (matrixWorld: column 3 = position).
  const TriangleMesh sphere = load_dataset("sphere");
  const BoundingBox box = bounding_box(sphere.vertices);
  const double az = 120 * M_PI / 180, el = 40 * M_PI / 180, d = 2.5 * box.diagonal();
  const Eigen::Vector3d want =
      box.center().cast<double>() +
      d * Eigen::Vector3d(std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az));
  for (std::size_t i = 0; i < views.size(); ++i) {
    EXPECT_EQ(views[i]["camera"], views[0]["camera"]) << "view " << i;
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(views[i]["camera"][12 + a].get<double>(), want[a], 1e-4 * d) << a;
    EXPECT_NE(views[i]["camera"], before["groups"][0]["views"][i]["camera"]) << "view " << i;
  }
  // And the pictures follow: every shown view's pixels change with the turn.
  const OIIO::ImageBuf a = screenshot("all=1&shade=0", "viewer-before-turn.png"),
                       b = screenshot("all=1&shade=0&cam=120,40,2.5", "viewer-after-turn.png");
  ASSERT_TRUE(a.initialized() && b.initialized());
  for (const auto& v : views) {
    if (!v["shown"].get<bool>()) continue;
    const OIIO::ROI r = view_roi(v);
    int changed = 0;
    for (int y = r.ybegin; y < r.yend; ++y)
      for (int x = r.xbegin; x < r.xend; ++x) {
        float pa[3], pb[3];
        a.getpixel(x, y, pa, 3);
        b.getpixel(x, y, pb, 3);
        changed += pa[0] != pb[0] || pa[1] != pb[1] || pa[2] != pb[2];
      }
    EXPECT_GT(changed, 500) << v.dump();
  }
}

TEST_F(Viewer, PickedPointReportsTheOraclesError) {
  ASSERT_TRUE(ok_) << log_;
  // View 1, shown point 57: its file index, error and coordinates against the oracle: the
  // point-to-plane error to the sphere's closest face, from the output file.
  const Json s = status("pick=0,1,57");
  ASSERT_TRUE(s.value("ready", false)) << s.dump();
  const Json& pick = s["pick"];
  ASSERT_TRUE(pick.is_object()) << s.dump();
  const Oracle o = oracle(pick);
  ASSERT_LT(pick["index"].get<Eigen::Index>(), o.size);
  EXPECT_EQ(pick["index"].get<Eigen::Index>(), 57);  // every point shown: the file index is k
  // Errors are stored as 16-bit multiples of max |E| / 32767; positions as 16 bits of the cube.
  EXPECT_NEAR(pick["error"].get<double>(), o.error, o.max_abs / 32767.0 + 1e-9) << pick.dump();
  EXPECT_GT(std::abs(o.error), 0.0);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(pick["xyz"][a].get<double>(), o.xyz[a], 2e-5 * o.diagonal) << a;
}

TEST_F(Viewer, APointerClickPicksThePointUnderIt) {
  ASSERT_TRUE(ok_) << log_;
  // Where point 57 of view 1 is drawn (the hook reports its canvas pixel), then a pointer down
  // and up there through the canvas's own listeners: the pick is a point drawn within the 8-px
  // radius of the click, and its error is the oracle's for the file index it names.
  const Json hooked = status("pick=0,1,57");
  ASSERT_TRUE(hooked["pick"].is_object()) << hooked.dump();
  const double x = std::round(hooked["pick"]["screen"][0].get<double>()),
               y = std::round(hooked["pick"]["screen"][1].get<double>());
  const Json s = status(fmt::format("click=0,{},{}", x, y));
  ASSERT_TRUE(s.value("ready", false)) << s.dump();
  EXPECT_TRUE(s["errors"].empty()) << s.dump();
  const Json& pick = s["clicked"];
  ASSERT_TRUE(pick.is_object()) << "the click picked nothing: " << s.dump();
  EXPECT_EQ(pick["view"], 1) << pick.dump();
  EXPECT_LE(std::hypot(pick["screen"][0].get<double>() - x, pick["screen"][1].get<double>() - y),
            8.0)
      << pick.dump();
  const Oracle o = oracle(pick);
  EXPECT_NEAR(pick["error"].get<double>(), o.error, o.max_abs / 32767.0 + 1e-9) << pick.dump();
  // The page says so too.
  const std::string dom = chromium(fmt::format("click=0,{},{}", x, y), "--dump-dom");
  EXPECT_NE(dom.find(fmt::format(", point {} of ", pick["index"].get<long>())), std::string::npos);
}

TEST_F(Viewer, TheGroundTruthCheckboxShowsItInEveryPanel) {
  ASSERT_TRUE(ok_) << log_;
  // Clicking the checkbox (its change listener, as a user's click) turns the ground truth on in
  // every panel; under shade=0 it is drawn in its flat grey, rgb(200, 200, 200), no colour-map
  // entry, which the views show only then.
  const Json before = status("all=1&shade=0"), after = status("all=1&shade=0&toggle=truth");
  ASSERT_TRUE(before.value("ready", false) && after.value("ready", false)) << after.dump();
  for (const bool shown : before["groups"][0]["extras"]["truth"])
    EXPECT_FALSE(shown) << before.dump();
  ASSERT_FALSE(after["groups"][0]["extras"]["truth"].empty()) << after.dump();
  for (const bool shown : after["groups"][0]["extras"]["truth"])
    EXPECT_TRUE(shown) << after.dump();
  const OIIO::ImageBuf a = screenshot("all=1&shade=0", "viewer-no-truth.png"),
                       b = screenshot("all=1&shade=0&toggle=truth", "viewer-truth.png");
  ASSERT_TRUE(a.initialized() && b.initialized());
  const auto grey = [](const OIIO::ImageBuf& img, const Json& v) {
    const OIIO::ROI r = view_roi(v);
    int n = 0;
    for (int y = r.ybegin; y < r.yend; ++y)
      for (int x = r.xbegin; x < r.xend; ++x) {
        float p[3];
        img.getpixel(x, y, p, 3);
        n += std::lround(p[0] * 255) == 200 && std::lround(p[1] * 255) == 200 &&
             std::lround(p[2] * 255) == 200;
      }
    return n;
  };
  for (const auto& v : after["groups"][0]["views"]) {
    if (!v["shown"].get<bool>()) continue;
    EXPECT_EQ(grey(a, v), 0) << v.dump();
    EXPECT_GT(grey(b, v), 500) << v.dump();
  }
}

TEST(ViewerMissingThree, ReportStillWrittenWithTheInstallLine) {
  const TempDir dir("viewer-no-three");
  write(dir / "v.json", R"({
    "scanbench_experiment": 1, "name": "nothree", "seed": 3,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 32}}],
    "variants": [{"label": "pca", "algorithm": "normals.pca"}],
    "metrics": ["accuracy.p2plane"]
  })");
  const fs::path out = dir / "out";
  ASSERT_EQ(sh(sb() + " run " + (dir / "v.json").string() + " -o " + out.string() + " -q").code, 0);
  const auto r = sh("SCANBENCH_REPORT_ASSETS=" + (dir / "nowhere").string() + " " + sb() +
                    " report " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = slurp(out / "index.html");
  EXPECT_NE(html.find("id=\"viewer-missing\""), std::string::npos);
  EXPECT_NE(html.find("bash scripts/setup.sh"), std::string::npos);
  EXPECT_EQ(html.find("sb-viewer-data"), std::string::npos);
  EXPECT_NE(html.find("id=\"jobs\""), std::string::npos);  // the rest of the report is there
}

}  // namespace
}  // namespace scanbench::test
