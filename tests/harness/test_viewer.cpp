// The report's 3D viewer in a real browser (Debian's chromium, headless, WebGL through
// SwiftShader), on a tiny real experiment: the page loads offline and requests nothing outside
// its folder; the canvas draws pixels whose colours are viridis entries; a scripted camera turn
// moves every view of a dataset alike; a picked point reports the error the oracle computes from
// the output file and the ground truth. And without three.js the report is still written.
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
  const auto& table = metrics::viridis_table();
  for (const auto& v : s["groups"][0]["views"]) {
    if (!v["shown"].get<bool>()) continue;
    const OIIO::ROI r = view_roi(v);
    ASSERT_GE(r.xbegin, 0);
    ASSERT_LE(r.yend, img.spec().height) << "the view is not inside the window";
    int drawn = 0, off_map = 0;
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
        off_map += best > 1.5f / 255.0f;
      }
    EXPECT_GT(drawn, 500) << v.dump();
    EXPECT_EQ(off_map, 0) << v.dump() << ": of " << drawn << " drawn pixels";
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
  Json rec;
  for (const auto& r : read_jsonl(out() / "runs.jsonl"))
    if (r["id"] == pick["job"]) rec = r;
  ASSERT_TRUE(rec.is_object()) << pick.dump();
  const TriangleMesh mesh = load_dataset("sphere", rec["dataset"].value("params", Json::object()));
  const metrics::GroundTruth gt(mesh, 0);
  PointCloud pts = read_point_cloud(out() / rec["artifacts"]["output"].get<std::string>());
  rebase(pts, mesh.origin);
  const auto i = pick["index"].get<Eigen::Index>();
  ASSERT_LT(i, pts.size());
  EXPECT_EQ(i, 57);  // every point shown: the file index is k
  double max_e = 0.0, e = 0.0;
  for (Eigen::Index j = 0; j < pts.size(); ++j) {
    const auto cp = gt.closest_point(pts.positions.col(j));
    const double ej = (pts.positions.col(j) - cp.point).dot(cp.normal);
    max_e = std::max(max_e, std::abs(ej));
    if (j == i) e = ej;
  }
  // Errors are stored as 16-bit multiples of max |E| / 32767; positions as 16 bits of the cube.
  EXPECT_NEAR(pick["error"].get<double>(), e, max_e / 32767.0 + 1e-9) << pick.dump();
  EXPECT_GT(std::abs(e), 0.0);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(pick["xyz"][a].get<double>(), pts.positions(a, i) + mesh.origin[a],
                2e-5 * gt.diagonal())
        << a;
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
