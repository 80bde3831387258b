// Unit tests of the harness: Mann-Whitney U against exhaustive enumeration and scipy values,
// compare verdicts on synthetic records, config validation messages, sweep expansion, tables.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/stats.h"
#include "scanbench/harness/results/table.h"

using namespace scanbench;
using namespace scanbench::harness;

namespace {

/// Exact two-sided p by enumerating every split of the pooled sample (the oracle).
double brute_force_p(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> pooled = a;
  pooled.insert(pooled.end(), b.begin(), b.end());
  const int n = static_cast<int>(pooled.size()), n1 = static_cast<int>(a.size());
  auto u_of = [&](const std::vector<bool>& in1) {
    double u = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (in1[i] && !in1[j]) u += pooled[i] > pooled[j] ? 1 : 0;
    return u;
  };
  std::vector<bool> obs(n, false);
  std::fill(obs.begin(), obs.begin() + n1, true);
  const double u_obs = u_of(obs);
  const double mu = n1 * (n - n1) / 2.0;
  std::vector<bool> sel(n, false);
  std::fill(sel.end() - n1, sel.end(), true);
  double extreme = 0, total = 0;
  do {
    const double u = u_of(sel);
    total += 1;
    if (std::abs(u - mu) >= std::abs(u_obs - mu) - 1e-9) extreme += 1;
  } while (std::next_permutation(sel.begin(), sel.end()));
  return std::min(1.0, extreme / total);
}

Json make_record(const std::string& key, const std::string& variant, double err,
                 const std::vector<double>& times) {
  Json r = Json::object();
  r["id"] = key;
  r["key"] = key;
  r["status"] = "ok";
  r["dataset"] = {{"label", "sphere"}};
  r["scanner"] = {{"label", "clean"}};
  r["variant"] = {{"label", variant}, {"chain", Json::array()}};
  r["point_label"] = "";
  r["seed"] = 1;
  r["metrics"] = {{"p2plane_mean_rel", err}, {"fscore", 0.9}, {"output_points", 1000}};
  r["timing"] = {{"total_s", times}, {"phases", {{"step:work", times}}}};
  return r;
}

std::vector<double> noisy(double center, double rel_noise, int n, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<double> v;
  for (int i = 0; i < n; ++i)
    v.push_back(center * (1.0 + rel_noise * rng.normal()));
  return v;
}

}  // namespace

TEST(MannWhitney, MatchesExhaustiveEnumeration) {
  Rng rng(7);
  for (int trial = 0; trial < 30; ++trial) {
    const int n1 = 2 + static_cast<int>(rng.below(5)), n2 = 2 + static_cast<int>(rng.below(5));
    std::vector<double> a, b;
    for (int i = 0; i < n1; ++i)
      a.push_back(rng.uniform());
    for (int i = 0; i < n2; ++i)
      b.push_back(rng.uniform() + 0.3 * (trial % 3));
    const auto r = mann_whitney_u(a, b);
    EXPECT_TRUE(r.exact);
    EXPECT_NEAR(r.p, brute_force_p(a, b), 1e-12) << "trial " << trial;
  }
}

TEST(MannWhitney, ScipyReferenceValues) {
  // scipy.stats.mannwhitneyu(x, y, method="exact"): U1 = 17, two-sided p = 0.1111...
  const std::vector<double> x{19, 22, 16, 29, 24}, y{20, 11, 17, 12};
  const auto r = mann_whitney_u(x, y);
  EXPECT_DOUBLE_EQ(r.u, 17.0);
  EXPECT_NEAR(r.p, 1.0 / 9.0, 1e-12);
  // Complete separation of 5 vs 5: p = 2 / C(10, 5) = 2 / 252.
  const auto s = mann_whitney_u({1, 2, 3, 4, 5}, {6, 7, 8, 9, 10});
  EXPECT_NEAR(s.p, 2.0 / 252.0, 1e-12);
  // Ties use the normal approximation with tie and continuity correction:
  // scipy.stats.mannwhitneyu([1,2,2,3,4,5,6,7,8,9], [2,4,6,8,10,12,14,16,18,20]) -> U=18.5,
  // p = 0.007...; recomputed here from the formula.
  const std::vector<double> a{1, 2, 2, 3, 4, 5, 6, 7, 8, 9}, b{2, 4, 6, 8, 10, 12, 14, 16, 18, 20};
  const auto t = mann_whitney_u(a, b);
  EXPECT_FALSE(t.exact);
  EXPECT_DOUBLE_EQ(t.u, 18.5);
  // Tie groups: {2,2,2} (t=3), {4,4}, {6,6}, {8,8} (t=2 each).
  const double tie = (27 - 3) + 3 * (8 - 2);
  const double sd = std::sqrt(100.0 / 12.0 * (21.0 - tie / (20.0 * 19.0)));
  const double z = (100.0 - 18.5 - 50.0 - 0.5) / sd;
  EXPECT_NEAR(t.p, std::erfc(z / std::sqrt(2.0)), 1e-12);
  EXPECT_DOUBLE_EQ(mann_whitney_u({}, {1.0}).p, 1.0);
}

TEST(Compare, FlagsSlowdownAndAccuracyLossButNotNoise) {
  const int n = 8;
  std::vector<Json> base, slow, worse, noise;
  base.push_back(make_record("a", "v", 0.010, noisy(1.0, 0.02, n, 1)));
  slow.push_back(make_record("a", "v", 0.010, noisy(1.3, 0.02, n, 2)));    // 30% slower
  worse.push_back(make_record("a", "v", 0.012, noisy(1.0, 0.02, n, 3)));   // 20% worse error
  noise.push_back(make_record("a", "v", 0.0101, noisy(1.0, 0.02, n, 4)));  // 1%, timing noise
  const CompareOptions o;
  const auto rs = compare_records(base, slow, o);
  EXPECT_TRUE(rs.regressed());
  bool total_flagged = false;
  for (const auto& v : rs.verdicts) {
    if (v.quantity == "time.total") {
      total_flagged = v.verdict == "regression";
      EXPECT_LT(v.p, 0.05);
    }
    if (v.kind == "accuracy") {
      EXPECT_NE(v.verdict, "regression") << v.quantity;
    }
  }
  EXPECT_TRUE(total_flagged);

  const auto rw = compare_records(base, worse, o);
  EXPECT_TRUE(rw.regressed());
  int acc_regressions = 0;
  for (const auto& v : rw.verdicts) {
    if (v.verdict == "regression") {
      EXPECT_EQ(v.quantity, "p2plane_mean_rel");
      ++acc_regressions;
    }
  }
  EXPECT_EQ(acc_regressions, 1);

  const auto rn = compare_records(base, noise, o);
  EXPECT_FALSE(rn.regressed()) << rn.table(true);
  EXPECT_EQ(compare_records(base, base, o).regressions, 0);

  // Faster and more accurate is an improvement, never a regression.
  std::vector<Json> better{make_record("a", "v", 0.005, noisy(0.5, 0.02, n, 5))};
  const auto rb = compare_records(base, better, o);
  EXPECT_FALSE(rb.regressed());
  EXPECT_GE(rb.improvements, 2);
}

TEST(Compare, HigherIsBetterAndStatusAndTooFewRepeats) {
  std::vector<Json> base{make_record("a", "v", 0.01, {1.0})};
  std::vector<Json> now{make_record("a", "v", 0.01, {5.0})};
  now[0]["metrics"]["fscore"] = 0.5;  // lower F-score is worse
  auto r = compare_records(base, now, CompareOptions{});
  bool fscore_reg = false, time_na = false;
  for (const auto& v : r.verdicts) {
    if (v.quantity == "fscore") fscore_reg = v.verdict == "regression";
    if (v.quantity == "time.total") time_na = v.verdict == "not decidable";
    if (v.quantity == "output_points") {
      EXPECT_NE(v.verdict, "regression");
    }
  }
  EXPECT_TRUE(fscore_reg);
  EXPECT_TRUE(time_na);  // one sample per side: no U test, no timing verdict

  now[0] = make_record("a", "v", 0.01, {1.0});
  now[0]["status"] = "crash";
  EXPECT_TRUE(compare_records(base, now, CompareOptions{}).regressed());
  EXPECT_TRUE(compare_records(base, {}, CompareOptions{}).regressed());  // job missing

  // Declared tolerances: a 20% loss within rel 0.25 is not a regression.
  const CompareOptions loose = CompareOptions::from_json(
      Json::parse(R"({"metrics": {"p2plane_mean_rel": {"rel": 0.25}}})"), "cfg");
  std::vector<Json> worse{make_record("a", "v", 0.012, {1.0})};
  EXPECT_FALSE(compare_records(base, worse, loose).regressed());
  EXPECT_THROW(CompareOptions::from_json(Json::parse(R"({"alpah": 0.1})"), "cfg"), ParamError);
  EXPECT_THROW(
      CompareOptions::from_json(Json::parse(R"({"metrics": {"x": {"better": "up"}}})"), "cfg"),
      ParamError);
}

TEST(Table, BestPerRowAndSpreadAndFormats) {
  std::vector<Json> rs;
  rs.push_back(make_record("k1", "A", 0.02, {1.0, 1.2, 1.1}));
  rs.push_back(make_record("k2", "B", 0.01, {2.0, 2.1, 2.2}));
  rs.push_back(make_record("k3", "C", 0.03, {0.5}));
  rs.back()["status"] = "timeout";
  TableSpec spec;
  spec.metric = "p2plane_mean_rel";
  const Table t = build_table(rs, spec);
  ASSERT_EQ(t.row_labels.size(), 1u);
  ASSERT_EQ(t.col_labels.size(), 3u);
  EXPECT_FALSE(t.cells[0][0].best);
  EXPECT_TRUE(t.cells[0][1].best);
  EXPECT_EQ(t.cells[0][2].status, "timeout");
  const std::string csv = render_table(t, "csv");
  EXPECT_NE(csv.find("sphere / clean,B,p2plane_mean_rel,0.01,0,1,1,ok"), std::string::npos) << csv;
  EXPECT_NE(csv.find("timeout"), std::string::npos);
  EXPECT_NE(render_table(t, "md").find("**0.01**"), std::string::npos);
  EXPECT_NE(render_table(t, "tex").find("\\textbf{0.01}"), std::string::npos);
  EXPECT_NE(render_table(t, "html").find("class=\"best\""), std::string::npos);
  EXPECT_THROW(render_table(t, "xls"), ParamError);

  spec.metric = "time.total";
  const Table tt = build_table(rs, spec);
  EXPECT_TRUE(tt.cells[0][0].best);
  EXPECT_EQ(tt.cells[0][0].n, 3);
  EXPECT_NEAR(tt.cells[0][0].median, 1.1, 1e-12);
  EXPECT_NEAR(tt.cells[0][0].spread, 0.1, 1e-12);
  spec.rows = "dataset+nonsense";
  EXPECT_THROW(build_table(rs, spec), ParamError);

  spec = TableSpec{};
  spec.metric = "fscore";  // higher is better: ties mark both
  const Table tf = build_table(rs, spec);
  EXPECT_TRUE(tf.higher_better);
  EXPECT_TRUE(tf.cells[0][0].best && tf.cells[0][1].best);
}

TEST(Records, CsvHasEveryKeyOnce) {
  std::vector<Json> rs{make_record("k1", "A", 0.02, {1.0}), make_record("k2", "B", 0.01, {2.0})};
  rs[1]["metrics"]["extra"] = 3;
  const std::string csv = records_csv(rs);
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_NE(header.find("metrics.p2plane_mean_rel"), std::string::npos);
  EXPECT_NE(header.find("metrics.extra"), std::string::npos);
  EXPECT_NE(header.find("time.step:work_median_s"), std::string::npos);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
  EXPECT_DOUBLE_EQ(median({3, 1, 2, 10}), 2.5);
  EXPECT_TRUE(std::isnan(median({})));
}

// ---- config validation and expansion (needs the registries: procedural datasets, presets) ----

namespace {

Json base_config() {
  return Json::parse(R"({
    "scanbench_experiment": 1,
    "name": "t",
    "seed": 3,
    "datasets": [{"name": "sphere"}],
    "scanners": ["clean"],
    "variants": [{"label": "lop", "algorithm": "resample.lop"}]
  })");
}

std::string error_of(const Json& cfg) {
  try {
    parse_experiment(cfg, "cfg.json");
  } catch (const ParamError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Experiment, ErrorsNameFilePathAndExpectation) {
  ASSERT_EQ(error_of(base_config()), "");
  Json c = base_config();
  c["varients"] = Json::array();
  EXPECT_NE(error_of(c).find("cfg.json: /varients: unknown key"), std::string::npos) << error_of(c);

  c = base_config();
  c["repeats"] = "3";
  EXPECT_NE(error_of(c).find("cfg.json: /repeats: expected an integer"), std::string::npos);

  c = base_config();
  c["variants"][0]["params"] = {{"h", "big"}};
  const std::string e1 = error_of(c);
  EXPECT_NE(e1.find("cfg.json: /variants/0/params.h: expected a number"), std::string::npos) << e1;

  c = base_config();
  c["variants"][0]["params"] = {{"hh", 0.1}};
  EXPECT_NE(error_of(c).find("unknown parameter"), std::string::npos);

  c = base_config();
  c["variants"][0]["algorithm"] = "resample.nope";
  EXPECT_NE(error_of(c).find("cfg.json: /variants/0: unknown algorithm 'resample.nope'"),
            std::string::npos)
      << error_of(c);

  c = base_config();
  c["datasets"][0]["name"] = "spheer";
  EXPECT_NE(error_of(c).find("unknown dataset 'spheer'"), std::string::npos);

  c = base_config();
  c["scanners"][0] = {{"preset", "clean"}, {"params", {{"views", -1}}}};
  EXPECT_NE(error_of(c).find("cfg.json: /scanners/0/params.views"), std::string::npos)
      << error_of(c);

  c = base_config();
  c["variants"][0]["sweep"] = {{"resample.lop.h", {{"from", 0.1}, {"to", 0.05}, {"step", 0.01}}}};
  EXPECT_NE(error_of(c).find("/variants/0/sweep/resample.lop.h/step"), std::string::npos)
      << error_of(c);

  c = base_config();
  c["scanbench_experiment"] = 2;
  EXPECT_NE(error_of(c).find("expected version 1"), std::string::npos);

  c = base_config();
  c["test.crash"] = 1;
  EXPECT_NE(error_of(c).find("unknown key"), std::string::npos);
}

TEST(Experiment, SweepsExpandToCartesianProductsWithStableIds) {
  Json c = base_config();
  c["seeds"] = {1, 2};
  c.erase("seed");
  c["variants"][0]["sweep"] = Json::parse(R"([
      {"resample.lop.h": {"from": 0.02, "to": 0.05, "step": 0.01}, "scanner.views": [4, 6]},
      {"resample.lop.h": [0.03], "scanner.views": [4]}])");
  const Experiment e = parse_experiment(c, "cfg.json");
  const Plan p = expand(e);
  // 4 h values x 2 view counts (the second sweep duplicates a point) x 2 seeds.
  ASSERT_EQ(p.jobs.size(), 16u);
  std::set<std::string> ids, keys;
  for (const auto& j : p.jobs) {
    ids.insert(j.id);
    keys.insert(j.key);
    EXPECT_EQ(j.scanner_params["views"], j.point["scanner.views"]);
    EXPECT_EQ(j.chain[0]["params"]["h"], j.point["resample.lop.h"]);
  }
  EXPECT_EQ(ids.size(), 16u);
  EXPECT_EQ(keys.size(), 16u);
  // Range values are exact decimals, not accumulated floats.
  EXPECT_EQ(p.jobs[2 * 2 * 1].chain[0]["params"]["h"].get<double>(), 0.03);
  EXPECT_EQ(p.jobs[0].point_label, "h=0.02 views=4");
  // Same config, same ids; a changed parameter changes the id.
  EXPECT_EQ(expand(parse_experiment(c, "cfg.json")).jobs[5].id, p.jobs[5].id);
  c["variants"][0]["params"] = {{"iterations", 3}};
  EXPECT_NE(expand(parse_experiment(c, "cfg.json")).jobs[5].id, p.jobs[5].id);
  // Job specs round-trip.
  const Job back = Job::from_json(p.jobs[3].to_json());
  EXPECT_EQ(back.to_json(), p.jobs[3].to_json());

  // Sweep values are validated against the declaration.
  c["variants"][0]["sweep"] = {{"resample.lop.iterations", {1, 0}}};
  EXPECT_THROW(expand(parse_experiment(c, "cfg.json")), ParamError);
  c["variants"][0]["sweep"] = {{"resample.nope.h", {0.1}}};
  EXPECT_THROW(expand(parse_experiment(c, "cfg.json")), ParamError);
  // count ranges: ends included.
  c["variants"][0]["sweep"] = {{"resample.lop.h", {{"from", 0.02}, {"to", 0.04}, {"count", 3}}}};
  const Plan p3 = expand(parse_experiment(c, "cfg.json"));
  ASSERT_EQ(p3.jobs.size(), 6u);
  EXPECT_EQ(p3.jobs[4].chain[0]["params"]["h"].get<double>(), 0.04);
}

TEST(Experiment, AbsentFileDatasetsAreSkippedWithANote) {
  Json c = base_config();
  c["datasets"].push_back({{"name", "/nonexistent/mesh.off"}, {"optional", true}});
  const Plan p = expand(parse_experiment(c, "cfg.json"));
  EXPECT_EQ(p.jobs.size(), 1u);
  ASSERT_EQ(p.notes.size(), 1u);
  EXPECT_NE(p.notes[0].find("skipped"), std::string::npos);
  c["datasets"][1]["optional"] = false;
  EXPECT_THROW(expand(parse_experiment(c, "cfg.json")), IoError);
}
