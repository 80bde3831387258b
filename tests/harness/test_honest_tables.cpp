// Issue 49's honest tables, through the real binary where a user meets them: a table or report
// never pools sweep points silently and says what a cell aggregates; the winners table compares a
// swept variant at its best point, named with it; every name a user types into `table`,
// `compare` or a config's "report"/"compare" is checked, with a suggestion; `compare` says "not
// decidable" when its test cannot reach alpha with the repeats given; counts print as integers;
// mesh and point outputs are flagged where a key cannot compare them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "experiment_test_util.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/stats.h"
#include "scanbench/harness/results/table.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers
namespace h = scanbench::harness;

namespace {

/// One swept variant (test.subsample over stride, 2 seeds, 2 repeats) and one unswept on the
/// same data; ~17K scan points, so counts reach five digits. Run once for the suite.
class HonestTables : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = make_temp_dir("honest");
    write(dir_ / "sweep.json", R"({
      "scanbench_experiment": 1, "name": "sweep", "seeds": [1, 2], "repeats": 2,
      "save_outputs": false,
      "datasets": [{"name": "sphere"}],
      "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 200}}],
      "variants": [{"label": "sub", "algorithm": "test.subsample",
                    "sweep": {"test.subsample.stride": [1, 2, 3, 5]}},
                   {"label": "fixed", "algorithm": "test.subsample", "params": {"stride": 4}}],
      "metrics": ["accuracy.p2plane", "regularity.nn_dist"],
      "report": {"metrics": ["p2plane_mean_rel", "nn_dist_cv"]}
    })");
    const auto r = sh(sb() + " run " + (dir_ / "sweep.json").string() + " -o " + out().string() +
                      " -q --jobs 2");
    run_code_ = r.code;
    run_text_ = r.out;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  void SetUp() override { ASSERT_EQ(run_code_, 0) << run_text_; }

  static fs::path out() { return dir_ / "out"; }
  /// A copy of the results folder whose config.json has `patch` merged into its "config".
  static fs::path patched_copy(const std::string& name, const Json& patch) {
    const fs::path copy = dir_ / name;
    fs::remove_all(copy);
    fs::copy(out(), copy, fs::copy_options::recursive);
    Json cfg = Json::parse(slurp(copy / "config.json"));
    cfg["config"].merge_patch(patch);
    write(copy / "config.json", cfg.dump());
    return copy;
  }

  static fs::path dir_;
  static int run_code_;
  static std::string run_text_;
};

fs::path HonestTables::dir_;
int HonestTables::run_code_ = -1;
std::string HonestTables::run_text_;

/// The median of a metric per sweep point label of one variant, from the records.
std::map<std::string, double> point_medians(const std::vector<Json>& recs,
                                            const std::string& variant, const std::string& key) {
  std::map<std::string, std::vector<double>> by_point;
  for (const auto& r : recs)
    if (r["variant"]["label"] == variant && r["status"] == "ok")
      by_point[r["point_label"].get<std::string>()].push_back(r["metrics"][key].get<double>());
  std::map<std::string, double> out;
  for (auto& [p, v] : by_point) {
    std::sort(v.begin(), v.end());
    out[p] = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  }
  return out;
}

/// The one line a refused command prints (stderr merged): exactly one non-empty line.
void expect_one_line_refusal(const Result& r, const std::string& must_contain) {
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(must_contain), std::string::npos) << r.out;
  std::string trimmed = r.out;
  while (!trimmed.empty() && trimmed.back() == '\n')
    trimmed.pop_back();
  EXPECT_EQ(trimmed.find('\n'), std::string::npos) << r.out;
}

}  // namespace

TEST_F(HonestTables, TableKeepsSweepPointsApartUnlessAskedAndSaysWhatACellHolds) {
  const auto sep =
      sh(sb() + " table " + out().string() + " --rows dataset --cols variant --metric nn_dist_cv");
  ASSERT_EQ(sep.code, 0) << sep.out;
  // One column per sweep point, named with the point; the unswept variant as is.
  for (const char* col :
       {"sub (stride=1)", "sub (stride=2)", "sub (stride=3)", "sub (stride=5)", "| fixed |"})
    EXPECT_NE(sep.out.find(col), std::string::npos) << col << "\n" << sep.out;
  EXPECT_NE(sep.out.find("sweep points separate"), std::string::npos) << sep.out;
  EXPECT_NE(sep.out.find("2 seeds"), std::string::npos) << sep.out;

  const auto pooled = sh(sb() + " table " + out().string() +
                         " --rows dataset --cols variant --metric nn_dist_cv --pool-sweeps");
  ASSERT_EQ(pooled.code, 0) << pooled.out;
  EXPECT_EQ(pooled.out.find("stride="), std::string::npos) << pooled.out;
  EXPECT_NE(pooled.out.find("sweep points pooled (--pool-sweeps: up to 4 per cell)"),
            std::string::npos)
      << pooled.out;

  // Timing cells hold every timing sample: repeats x seeds.
  const auto time = sh(sb() + " table " + out().string() + " --metric time.total");
  ASSERT_EQ(time.code, 0) << time.out;
  EXPECT_NE(time.out.find("every timing sample (2 repeats x 2 seeds"), std::string::npos)
      << time.out;
}

TEST_F(HonestTables, WinnersCompareEachVariantAtItsBestSweepPoint) {
  const std::vector<Json> recs = read_jsonl(out() / "runs.jsonl");
  const auto r = sh(sb() + " report " + out().string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = slurp(out() / "index.html");
  const auto w0 = html.find("<table id=\"winners\">");
  ASSERT_NE(w0, std::string::npos);
  const std::string winners = html.substr(w0, html.find("</table>", w0) - w0);
  EXPECT_NE(html.find("each swept variant at its best sweep point"), std::string::npos);
  EXPECT_NE(winners.find("sub (4 sweep points), fixed"), std::string::npos) << winners;
  for (const char* key : {"nn_dist_cv", "p2plane_mean_rel"}) {
    // The expected winner from the records: the swept variant at its argmin, against the fixed.
    const auto sub = point_medians(recs, "sub", key);
    const auto fixed = point_medians(recs, "fixed", key);
    ASSERT_EQ(sub.size(), 4u);
    ASSERT_EQ(fixed.size(), 1u);
    const auto best = std::min_element(
        sub.begin(), sub.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
    const double fixed_value = fixed.begin()->second;
    const std::string expected = best->second <= fixed_value
                                     ? "sub (" + best->first + ") " + h::format_number(best->second)
                                     : "fixed " + h::format_number(fixed_value);
    EXPECT_NE(winners.find(expected), std::string::npos) << key << ": " << expected << "\n"
                                                         << winners;
  }
  // Histograms per sweep point, labelled with the point; the unswept variant on its own.
  EXPECT_NE(html.find("p2plane histogram (sphere / clean): sub, per sweep point"),
            std::string::npos);
  EXPECT_NE(html.find("p2plane histogram (sphere / clean)</title>"), std::string::npos);
  // Sweep plots carry the unswept variant as a reference line.
  EXPECT_NE(html.find("<line class=\"ref\""), std::string::npos);
  // The setup: effective parameters with the swept values, the scan size as an integer.
  EXPECT_NE(html.find("stride=<b>{1, 2, 3, 5}</b>"), std::string::npos);
  const std::string scan_points =
      std::to_string(recs.front()["sizes"]["scan_points"].get<long long>());
  EXPECT_NE(html.find("<td>" + scan_points + "</td>", html.find("id=\"setup-scans\"")),
            std::string::npos);
}

/// The SVG of the report whose <title> is `title` ("" when none).
std::string svg_titled(const std::string& html, const std::string& title) {
  const auto t = html.find("<title>" + title + "</title>");
  if (t == std::string::npos) return "";
  const auto open = html.rfind("<svg", t);
  return html.substr(open, html.find("</svg>", t) - open);
}

/// The hover titles of the <circle>s of an SVG that carry `cls` (every circle when empty).
std::vector<std::string> circle_titles(const std::string& svg, const std::string& cls = "") {
  std::vector<std::string> out;
  for (auto c = svg.find("<circle"); c != std::string::npos; c = svg.find("<circle", c + 1)) {
    const auto end = svg.find("</circle>", c);
    const std::string el = svg.substr(c, end - c);
    if (!cls.empty() && el.find("class=\"" + cls + "\"") == std::string::npos) continue;
    const auto t = el.find("<title>");
    out.push_back(t == std::string::npos ? "" : el.substr(t + 7, el.find("</title>") - t - 7));
  }
  return out;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Plots a reader can query: each marker's values as its hover title; on a sweep plot the best
// point (from the records: the argmin of the per-point medians) ringed; a time-against-quality
// plot whose outlined front is exactly the non-dominated set of (median time, median value),
// recomputed here by brute force from the records.
TEST_F(HonestTables, PlotsRingTheBestPointAndOutlineTheParetoFront) {
  const std::vector<Json> recs = read_jsonl(out() / "runs.jsonl");
  const auto r = sh(sb() + " report " + out().string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = slurp(out() / "index.html");
  for (const std::string key : {"p2plane_mean_rel", "nn_dist_cv"}) {
    SCOPED_TRACE(key);
    const std::string sweep = svg_titled(html, "sub: " + key + " vs stride (sphere / clean)");
    ASSERT_FALSE(sweep.empty());
    for (const auto& t : circle_titles(sweep))
      EXPECT_NE(t.find(", " + key + " = "), std::string::npos) << t;
    const auto sub = point_medians(recs, "sub", key);
    const auto best = std::min_element(
        sub.begin(), sub.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
    const auto ringed = circle_titles(sweep, "best");
    ASSERT_EQ(ringed.size(), 1u) << sweep;
    EXPECT_EQ(ringed.front(), "best (lower is better): sub: test.subsample.stride = " +
                                  best->first.substr(best->first.find('=') + 1) + ", " + key +
                                  " = " + h::format_number(best->second));

    // The front from the records: per (variant, point) the median over seeds of each job's
    // median time and of the value; a point is on it when no other has at most its time and at
    // most its value with one of them strictly less.
    struct P {
      std::string label;
      double t, v;
    };
    std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> acc;
    for (const auto& rec : recs) {
      std::vector<double> samples = rec["timing"]["total_s"].get<std::vector<double>>();
      const std::string v = rec["variant"]["label"], pt = rec["point_label"];
      const std::string label = pt.empty() ? v : v + " (" + pt + ")";
      acc[label].first.push_back(median_of(samples));
      acc[label].second.push_back(rec["metrics"][key].get<double>());
    }
    std::vector<P> pts;
    for (const auto& [label, tv] : acc)
      pts.push_back({label, median_of(tv.first), median_of(tv.second)});
    std::set<std::string> expected;
    for (const P& p : pts) {
      const bool dominated = std::any_of(pts.begin(), pts.end(), [&](const P& q) {
        return q.t <= p.t && q.v <= p.v && (q.t < p.t || q.v < p.v);
      });
      if (!dominated) expected.insert(p.label);
    }
    const std::string pareto = svg_titled(html, key + " against time.total (sphere / clean)");
    ASSERT_FALSE(pareto.empty());
    EXPECT_EQ(circle_titles(pareto).size(), pts.size());
    std::set<std::string> front;
    for (const auto& t : circle_titles(pareto, "front")) {
      EXPECT_NE(t.find(" (on the front)"), std::string::npos) << t;
      front.insert(t.substr(0, t.find(": time.total = ")));
    }
    EXPECT_EQ(front, expected);
  }
}

TEST_F(HonestTables, UnknownNamesAreRefusedWithASuggestion) {
  const std::string dir = out().string();
  expect_one_line_refusal(sh(sb() + " table " + dir + " --metric nn_dist_c"),
                          "table: --metric: unknown quantity 'nn_dist_c' (did you mean "
                          "'nn_dist_cv'?)");
  // A registered key this run did not compute.
  expect_one_line_refusal(sh(sb() + " table " + dir + " --metric fscore"),
                          "no record has 'fscore'");
  expect_one_line_refusal(sh(sb() + " table " + dir + " --rows param:test.subsample.strid"),
                          "no record has the parameter 'test.subsample.strid' (did you mean "
                          "'test.subsample.stride'?)");
  expect_one_line_refusal(sh(sb() + " table " + dir + " --cols variantt"),
                          "unknown field 'variantt' (did you mean 'variant'?)");
  expect_one_line_refusal(sh(sb() + " compare " + dir + " " + dir + " --metric p2plane_mean_rell"),
                          "compare: --metric: unknown quantity 'p2plane_mean_rell' (did you mean "
                          "'p2plane_mean_rel'?)");
  // Names in a config's "report" and "compare" objects, checked where they are used.
  const fs::path rep =
      patched_copy("bad-report", Json::parse(R"({"report": {"metrics": ["nn_dist_cvv"]}})"));
  expect_one_line_refusal(sh(sb() + " report " + rep.string()),
                          "/config/report/metrics/0: unknown quantity 'nn_dist_cvv' (did you "
                          "mean 'nn_dist_cv'?)");
  const fs::path rx = patched_copy("bad-x", Json::parse(R"({"report": {"x": "strde"}})"));
  expect_one_line_refusal(sh(sb() + " report " + rx.string()),
                          "/config/report/x: 'strde' is no swept key of the records (did you mean "
                          "'test.subsample.stride'?)");
  const fs::path cmp =
      patched_copy("bad-compare",
                   Json::parse(R"({"compare": {"metrics": {"p2plane_mean_rell": {"rel": 0.1}}}})"));
  expect_one_line_refusal(sh(sb() + " compare " + dir + " " + cmp.string()),
                          "/compare/metrics/p2plane_mean_rell: unknown metric key (did you mean "
                          "'p2plane_mean_rel'?)");
  const fs::path ign =
      patched_copy("bad-ignore", Json::parse(R"({"compare": {"ignore": ["nn_dist_mea"]}})"));
  expect_one_line_refusal(sh(sb() + " compare " + dir + " " + ign.string()),
                          "/compare/ignore: unknown metric key 'nn_dist_mea' (did you mean");
  // Known names still pass.
  EXPECT_EQ(
      sh(sb() + " table " + dir + " --metric nn_dist_cv --rows param:test.subsample.stride").code,
      0);
}

TEST_F(HonestTables, CompareWithTwoRepeatsSaysNotDecidable) {
  const std::string dir = out().string();
  const fs::path json = dir_ / "compare.json";
  const auto r = sh(sb() + " compare " + dir + " " + dir + " --json " + json.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("timing comparisons are not decidable"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("it needs 4 repeats per side"), std::string::npos) << r.out;
  const Json res = Json::parse(slurp(json));
  EXPECT_EQ(res["repeats_needed"], 4);
  int time_total = 0;
  for (const auto& v : res["comparisons"]) {
    if (v["quantity"] != "time.total") continue;
    ++time_total;
    EXPECT_EQ(v["verdict"], "not decidable") << v.dump();
    EXPECT_NE(v["note"].get<std::string>().find("not decidable with 2 repeats"), std::string::npos)
        << v.dump();
  }
  EXPECT_EQ(time_total, 10);
  EXPECT_GE(res["undecidable"].get<int>(), time_total);  // time.total and every phase
}

TEST(HonestTablesStats, SmallestAttainablePAndRepeatsNeeded) {
  // Two fully separated samples: 2 / C(n1 + n2, n1) in the exact branch.
  EXPECT_NEAR(h::mann_whitney_min_p(2, 2), 2.0 / 6.0, 1e-12);
  EXPECT_NEAR(h::mann_whitney_min_p(3, 3), 2.0 / 20.0, 1e-12);
  EXPECT_NEAR(h::mann_whitney_min_p(4, 4), 2.0 / 70.0, 1e-12);
  EXPECT_NEAR(h::mann_whitney_min_p(2, 5), 2.0 / 21.0, 1e-12);
  EXPECT_DOUBLE_EQ(h::mann_whitney_min_p(1, 1), 1.0);
  EXPECT_DOUBLE_EQ(h::mann_whitney_min_p(0, 3), 1.0);
  EXPECT_EQ(h::mann_whitney_repeats_needed(0.05), 4);
  EXPECT_EQ(h::mann_whitney_repeats_needed(0.1), 4);  // 3 vs 3 reaches 0.1, not below it
  EXPECT_EQ(h::mann_whitney_repeats_needed(0.2), 3);
}

TEST(HonestTablesStats, CompareDecidesAtFourRepeatsAndNotAtTwo) {
  auto record = [](std::vector<double> times) {
    Json r = {{"key", "sphere|clean|v||seed=1"}, {"status", "ok"}, {"metrics", Json::object()}};
    r["timing"] = {{"total_s", times}, {"phases", Json::object()}};
    return r;
  };
  // 3x slower, fully separated samples.
  const auto two = h::compare_records({record({1.0, 1.1})}, {record({3.0, 3.1})}, {});
  ASSERT_EQ(two.verdicts.size(), 2u);
  EXPECT_EQ(two.verdicts[1].verdict, "not decidable");
  EXPECT_TRUE(two.verdicts[1].notable);  // a change that would count: listed without --all
  EXPECT_NE(two.table().find("not decidable with 2 repeats"), std::string::npos) << two.table();
  EXPECT_EQ(two.undecidable, 1);
  EXPECT_FALSE(two.regressed());
  const auto four =
      h::compare_records({record({1.0, 1.1, 1.05, 1.02})}, {record({3.0, 3.1, 3.05, 3.02})}, {});
  EXPECT_EQ(four.verdicts[1].verdict, "regression");
  EXPECT_EQ(four.undecidable, 0);
}

TEST_F(HonestTables, CountsPrintAsIntegers) {
  EXPECT_EQ(h::format_number(20630), "20630");
  EXPECT_EQ(h::format_number(20630.5), "20630.5");
  EXPECT_EQ(h::format_number(1234567), "1234567");
  EXPECT_EQ(h::format_number(0.001914), "0.001914");
  EXPECT_EQ(h::format_number(2.5e-8), "2.500e-08");
  const std::vector<Json> recs = read_jsonl(out() / "runs.jsonl");
  const double scan_points = recs.front()["sizes"]["scan_points"].get<double>();
  ASSERT_GE(scan_points, 1e4);  // five digits: 4 significant digits would show an exponent
  const std::string count = std::to_string(static_cast<long long>(scan_points));
  const auto t = sh(sb() + " table " + out().string() + " --metric sizes.scan_points");
  ASSERT_EQ(t.code, 0) << t.out;
  EXPECT_NE(t.out.find(count), std::string::npos) << t.out;
  EXPECT_EQ(t.out.find("e+0"), std::string::npos) << t.out;
  ASSERT_EQ(sh(sb() + " report " + out().string()).code, 0);
  const std::string html = slurp(out() / "index.html");
  const auto jobs = html.find("<table id=\"jobs\">");
  ASSERT_NE(jobs, std::string::npos);
  EXPECT_NE(html.find(count, jobs), std::string::npos);
  EXPECT_EQ(html.find("e+0", jobs), std::string::npos);
}

// A key that follows a published evaluator says whose convention in every table header, and
// `list metrics --json` marks every key's convention (docs/metrics.md "Conventions").
TEST(HonestTablesConventions, HeadersAndTheListNameEachKeysConvention) {
  const fs::path dir = make_temp_dir("honest-conventions");
  write(dir / "conv.json", R"({
    "scanbench_experiment": 1, "name": "conv", "seed": 3, "save_outputs": false,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "moderate", "params": {"views": 2, "resolution": 40}}],
    "variants": [{"label": "sub", "algorithm": "test.subsample", "params": {"stride": 2}}],
    "metrics": ["accuracy.chamfer", "convention.scoredenoise", "convention.tnt"]
  })");
  const fs::path out = dir / "out";
  const auto run =
      sh(sb() + " run " + (dir / "conv.json").string() + " -o " + out.string() + " -q");
  ASSERT_EQ(run.code, 0) << run.out;
  const auto sd = sh(sb() + " table " + out.string() + " --metric sd_cd_sph_x1e4");
  ASSERT_EQ(sd.code, 0) << sd.out;
  EXPECT_NE(sd.out.find("**sd_cd_sph_x1e4 [ScoreDenoise convention] (lower is better)**"),
            std::string::npos)
      << sd.out;
  const auto tnt = sh(sb() + " table " + out.string() + " --metric tnt_fscore --format tex");
  EXPECT_NE(tnt.out.find("% tnt_fscore [Tanks and Temples convention] (higher is better)"),
            std::string::npos)
      << tnt.out;
  const auto own = sh(sb() + " table " + out.string() + " --metric chamfer_rel");
  EXPECT_NE(own.out.find("**chamfer_rel (lower is better)**"), std::string::npos) << own.out;
  const auto list = sh(sb() + " list metrics --json");
  ASSERT_EQ(list.code, 0);
  const Json j = Json::parse(list.out);
  bool seen = false;
  for (const Json& m : j["metrics"]) {
    if (m["name"] != "convention.dtu") continue;
    seen = true;
    EXPECT_EQ(m["convention"]["title"], "DTU");
    EXPECT_NE(m["convention"]["source"].get<std::string>().find("DTUeval-python"),
              std::string::npos);
    EXPECT_EQ(m["key_conventions"]["dtu_overall_rel"], "dtu");
  }
  EXPECT_TRUE(seen) << list.out.substr(0, 400);
}

TEST(HonestTablesMesh, MeshAndPointOutputsFlaggedOnChamferKeys) {
  const fs::path dir = make_temp_dir("honest-mesh");
  write(dir / "mesh.json", R"({
    "scanbench_experiment": 1, "name": "mesh", "seed": 3, "save_outputs": false,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [
      {"label": "mesh", "algorithm": "test.sphere_mesh", "params": {"resolution": 8}},
      {"label": "points", "algorithm": "test.subsample", "params": {"stride": 2}}],
    "metrics": ["accuracy.chamfer", "surface.chamfer"],
    "report": {"metrics": ["fscore", "chamfer_rel"]}
  })");
  const fs::path out = dir / "out";
  const auto run =
      sh(sb() + " run " + (dir / "mesh.json").string() + " -o " + out.string() + " -q");
  ASSERT_EQ(run.code, 0) << run.out;
  const auto t = sh(sb() + " table " + out.string() + " --metric fscore");
  ASSERT_EQ(t.code, 0) << t.out;
  EXPECT_NE(t.out.find("Note: not comparable in 1 row"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("(mesh) |"), std::string::npos) << t.out;
  std::size_t bold = 0;
  for (auto at = t.out.find("**"); at != std::string::npos; at = t.out.find("**", at + 2))
    ++bold;
  EXPECT_EQ(bold, 2u) << "only the title is bold: no best in a mixed row\n" << t.out;
  // time.total compares them fine: no note.
  const auto tt = sh(sb() + " table " + out.string() + " --metric time.total");
  EXPECT_EQ(tt.out.find("not comparable"), std::string::npos) << tt.out;
  ASSERT_EQ(sh(sb() + " report " + out.string()).code, 0);
  const std::string html = slurp(out / "index.html");
  EXPECT_NE(html.find("mesh and point outputs not comparable on this key"), std::string::npos);
  EXPECT_NE(html.find("mesh outputs: mesh"), std::string::npos);
  EXPECT_NE(html.find("point outputs: points"), std::string::npos);
  // Time against quality: on a key that cannot compare them, mesh and point outputs each have
  // their own front (two joined lines, the mesh one dashed), and every marker names its kind.
  EXPECT_NE(html.find("each kind has its own front"), std::string::npos);
  for (const std::string key : {"fscore", "chamfer_rel"}) {
    SCOPED_TRACE(key);
    const std::string svg = svg_titled(html, key + " against time.total (sphere / clean)");
    ASSERT_FALSE(svg.empty());
    std::size_t lines = 0, dashed = 0;
    for (auto at = svg.find("<polyline"); at != std::string::npos;
         at = svg.find("<polyline", at + 1)) {
      ++lines;
      dashed +=
          svg.substr(at, svg.find('>', at) - at).find("stroke-dasharray") != std::string::npos;
    }
    EXPECT_EQ(lines, 2u);
    EXPECT_EQ(dashed, 1u);
    const auto titles = circle_titles(svg);
    ASSERT_EQ(titles.size(), 2u);
    // One point per kind: each is its kind's front, whatever the other kind scores.
    EXPECT_EQ(circle_titles(svg, "front").size(), 2u);
    EXPECT_NE(svg.find("mesh: time.total = "), std::string::npos);
    for (const auto& t : titles) {
      const bool mesh = t.rfind("mesh:", 0) == 0;
      EXPECT_NE(t.find(mesh ? " [mesh output] (on the front)" : " [points output] (on the front)"),
                std::string::npos)
          << t;
    }
  }
  fs::remove_all(dir);
}

namespace {

/// Issue 49, reproducible scoring: a job's record carries the seeds of its scoring, and
/// `eval --from-record` scores the job's saved output again to the same bits, for a points
/// output (a scan subsampled) and a mesh output (the ground truth Loop-subdivided).
class EvalFromRecord : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = make_temp_dir("fromrecord");
    write(dir_ / "points.json", R"({
      "scanbench_experiment": 1, "name": "p", "seeds": [3], "repeats": 1,
      "datasets": [{"name": "sphere"}],
      "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 120}}],
      "variants": [{"label": "sub", "algorithm": "test.subsample", "params": {"stride": 2}}]})");
    write(dir_ / "mesh.json", R"({
      "scanbench_experiment": 1, "name": "m", "seeds": [5], "repeats": 1,
      "datasets": [{"name": "sphere", "params": {"resolution": 12}}],
      "scanners": ["ground_truth"],
      "variants": [{"label": "loop", "algorithm": "subdivide.loop", "params": {"levels": 1}}]})");
    for (const char* c : {"points", "mesh"}) {
      const auto r = sh(sb() + " run " + (dir_ / (std::string(c) + ".json")).string() + " -o " +
                        (dir_ / c).string() + " -q");
      run_text_ += r.out;
      run_ok_ = run_ok_ && r.code == 0;
    }
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  void SetUp() override { ASSERT_TRUE(run_ok_) << run_text_; }

  static Json record(const char* name) { return read_jsonl(dir_ / name / "runs.jsonl").at(0); }
  static fs::path job_file(const char* name) {
    return dir_ / name / "jobs" / (record(name)["id"].get<std::string>() + ".json");
  }

  /// eval --from-record on `source` (extra args after), its exit code and output; the re-scored
  /// record is written to DIR/<tag>.json.
  static Result from_record(const fs::path& source, const std::string& tag,
                            const std::string& extra = "") {
    return sh(sb() + " eval --from-record " + source.string() + " " + extra + " -o " +
              (dir_ / (tag + ".json")).string());
  }

  /// Every metric key of the record equals the re-scored one exactly (as JSON values: the
  /// doubles round-trip bit for bit), and so do histograms, skipped and scoring.
  static void expect_same(const Json& rec, const Json& again) {
    for (const auto& [k, v] : rec["metrics"].items()) {
      ASSERT_TRUE(again.contains(k)) << k;
      EXPECT_EQ(again[k], v) << k;
    }
    for (const char* k : {"histograms", "skipped", "scoring", "metric_params"})
      EXPECT_EQ(again[k], rec[k]) << k;
  }

  static fs::path dir_;
  static bool run_ok_;
  static std::string run_text_;
};

fs::path EvalFromRecord::dir_;
bool EvalFromRecord::run_ok_ = true;
std::string EvalFromRecord::run_text_;

TEST_F(EvalFromRecord, RecordsCarryTheSeedsOfTheirScoring) {
  const Json p = record("points"), m = record("mesh");
  ASSERT_TRUE(p.contains("scoring")) << p.dump();
  EXPECT_TRUE(p["scoring"]["ground_truth_samples_seed"].is_number_unsigned());
  EXPECT_EQ(p["scoring"]["seed"], 3);
  EXPECT_FALSE(p["scoring"].contains("output_mesh_samples_seed"));  // points: nothing sampled
  EXPECT_TRUE(m["scoring"]["output_mesh_samples_seed"].is_number_unsigned());
  EXPECT_EQ(m["scoring"]["output_mesh_samples"], 100000);
  EXPECT_TRUE(m["scoring"]["output_oracle_seed"].is_number_unsigned());
}

TEST_F(EvalFromRecord, PointsOutputReproducedBitForBit) {
  const auto r = from_record(job_file("points"), "points_again");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("equal bit for bit"), std::string::npos) << r.out;
  expect_same(record("points"), Json::parse(slurp(dir_ / "points_again.json")));
}

TEST_F(EvalFromRecord, MeshOutputReproducedBitForBitFromRunsJsonl) {
  const Json rec = record("mesh");
  const auto r = from_record(dir_ / "mesh" / "runs.jsonl", "mesh_again",
                             "--id " + rec["id"].get<std::string>());
  ASSERT_EQ(r.code, 0) << r.out;
  expect_same(rec, Json::parse(slurp(dir_ / "mesh_again.json")));
}

TEST_F(EvalFromRecord, ADifferenceExitsOneAndIsNamed) {
  // A record whose ground-truth sample seed is not the one it was scored with: completeness and
  // recall come out different (the seed is used, not re-derived), and eval says so.
  const fs::path copy = dir_ / "tampered";
  fs::remove_all(copy);
  fs::copy(dir_ / "points", copy, fs::copy_options::recursive);
  Json rec = record("points");
  rec["scoring"]["ground_truth_samples_seed"] =
      rec["scoring"]["ground_truth_samples_seed"].get<std::uint64_t>() + 1;
  const fs::path job = copy / "jobs" / (rec["id"].get<std::string>() + ".json");
  write(job, rec.dump());
  const auto r = from_record(job, "tampered_again");
  EXPECT_EQ(r.code, 1) << r.out;
  for (const char* k : {"completeness ", "recall "}) {
    const auto at = r.out.find(std::string("  ") + k);
    ASSERT_NE(at, std::string::npos) << r.out;
    EXPECT_NE(r.out.find("DIFFERENT", at), std::string::npos) << r.out;
    EXPECT_LT(r.out.find("DIFFERENT", at), r.out.find('\n', at)) << k << r.out;
  }
}

TEST_F(EvalFromRecord, UnknownIdRefusedWithSuggestion) {
  const std::string id = record("points")["id"].get<std::string>();
  const auto r = sh(sb() + " eval --from-record " + (dir_ / "points" / "runs.jsonl").string() +
                    " --id " + id.substr(0, id.size() - 1) + "x");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("did you mean '" + id + "'"), std::string::npos) << r.out;
}

}  // namespace

namespace {

/// Issue 49: every name a config's "report" and "compare" sections hold is checked when the
/// config loads, with a suggestion, so a typo fails before any job runs.
Json names_config() {
  return Json::parse(R"({
    "scanbench_experiment": 1, "name": "n", "seeds": [1],
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 64}}],
    "variants": [{"label": "sub", "algorithm": "test.subsample",
                  "sweep": {"test.subsample.stride": [1, 2]}}],
    "metrics": ["accuracy.p2plane"],
    "report": {"metrics": ["p2plane_mean_rel", "time.total"], "x": "test.subsample.stride",
               "cost": {"exclude_steps": ["test.subsample"]}},
    "compare": {"metrics": {"p2plane_mean_rel": {"rel": 0.1}}, "ignore": ["nn_dist_cv"]}})");
}

std::string load_error_with(const std::string& pointer, const Json& value) {
  Json cfg = names_config();
  cfg[Json::json_pointer(pointer)] = value;
  setenv("SCANBENCH_TEST_ALGORITHMS", "1", 1);
  return experiment_load_error(cfg);
}

TEST(ConfigNames, ValidNamesLoad) {
  EXPECT_EQ(load_error_with("/name", "n"), "");
}

TEST(ConfigNames, ReportMetricTypoRefusedWithSuggestion) {
  const std::string e = load_error_with("/report/metrics/0", "p2plane_mean_rl");
  EXPECT_NE(e.find("cfg.json: /report/metrics/0: unknown metric key 'p2plane_mean_rl' (did you "
                   "mean 'p2plane_mean_rel'?)"),
            std::string::npos)
      << e;
}

TEST(ConfigNames, ReportXNotSweptRefusedWithSuggestion) {
  const std::string e = load_error_with("/report/x", "test.subsample.strid");
  EXPECT_NE(e.find("/report/x: 'test.subsample.strid' is no swept key of this config (did you "
                   "mean 'test.subsample.stride'?)"),
            std::string::npos)
      << e;
}

TEST(ConfigNames, ReportUnknownKeyAndCostStepRefused) {
  EXPECT_NE(load_error_with("/report/metric", Json::array()).find("/report"), std::string::npos);
  const std::string e = load_error_with("/report/cost/exclude_steps/0", "test.subsampl");
  EXPECT_NE(e.find("/report/cost/exclude_steps/0: 'test.subsampl' is no step of the variants "
                   "(did you mean 'test.subsample'?)"),
            std::string::npos)
      << e;
}

TEST(ConfigNames, CompareMetricsAndIgnoreTyposRefused) {
  const std::string m = load_error_with("/compare/metrics", Json{{"chamfer_rell", Json::object()}});
  EXPECT_NE(m.find("/compare/metrics/chamfer_rell: unknown metric key 'chamfer_rell' (did you "
                   "mean 'chamfer_rel'?)"),
            std::string::npos)
      << m;
  const std::string i = load_error_with("/compare/ignore/0", "fscor");
  EXPECT_NE(i.find("/compare/ignore/0: unknown metric key 'fscor' (did you mean 'fscore'?)"),
            std::string::npos)
      << i;
  EXPECT_NE(load_error_with("/compare/alpah", 0.1).find("alpah"), std::string::npos);
}

TEST(ConfigNames, ATypoFailsTheRunBeforeAnyJob) {
  const fs::path dir = make_temp_dir("names");
  Json cfg = names_config();
  cfg["report"]["metrics"][0] = "p2plane_mean_rl";
  write(dir / "cfg.json", cfg.dump());
  const auto r =
      sh(sb() + " run " + (dir / "cfg.json").string() + " -o " + (dir / "out").string() + " -q");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("did you mean 'p2plane_mean_rel'"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "out" / "jobs")) << r.out;  // no job ran
  fs::remove_all(dir);
}

TEST(ConfigNames, ShippedConfigsLoad) {
  for (const auto& f :
       fs::directory_iterator(fs::path(SCANBENCH_TEST_DATA) / ".." / ".." / "configs")) {
    if (f.path().extension() != ".json") continue;
    EXPECT_NO_THROW(scanbench::harness::load_experiment(f.path())) << f.path();
  }
}

}  // namespace

namespace {

/// Issue 49: progress of a long single step. The test plugin's algorithm reports three phases
/// through the plugin API (report_progress); `algo --progress` prints them, and without it (stderr
/// not a terminal) nothing is printed. --progress-interval 0 prints one line per reported phase
/// and no timed lines, so the output does not depend on the machine's speed.
struct AlgoProgress : ::testing::Test {
  void SetUp() override {
    dir_ = make_temp_dir("progress");
    plugin_ = fs::path(sb()).parent_path().parent_path() / "tests" / "libtest_plugin_progress.so";
    ASSERT_TRUE(fs::exists(plugin_)) << plugin_;
    write(dir_ / "in.xyz", "0 0 0\n1 0 0\n0 1 0\n");
  }
  void TearDown() override { fs::remove_all(dir_); }
  Result algo(const std::string& extra) {
    return sh(sb() + " --plugin " + plugin_.string() + " algo test_plugin.progress -i " +
              (dir_ / "in.xyz").string() + " -o " + (dir_ / "out.ply").string() + " " + extra);
  }
  fs::path dir_, plugin_;
};

TEST_F(AlgoProgress, ReportedPhasesPrintedWhenAsked) {
  const auto r = algo("--progress --progress-interval 0");
  ASSERT_EQ(r.code, 0) << r.out;
  std::size_t at = 0;
  for (const char* line : {"stage 1/3 (33%)", "stage 2/3 (67%)", "stage 3/3 (100%)"}) {
    const auto pos = r.out.find(line, at);
    ASSERT_NE(pos, std::string::npos) << line << " in order in\n" << r.out;
    EXPECT_EQ(r.out.rfind("algo test_plugin.progress: ", pos) != std::string::npos, true);
    at = pos;
  }
}

TEST_F(AlgoProgress, SilentWithoutProgressOffATerminal) {
  const auto r = algo("");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("stage"), std::string::npos) << r.out;
}

}  // namespace
