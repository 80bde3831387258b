// `scanbench claims`: the verdict rules on synthetic records (each rule kind held, failed and
// inconclusive), claim-file validation, baseline regressions, and the command end to end on a
// tiny claim set run by the real binary.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "cli_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/results/claims.h"
#include "scanbench/harness/results/claims_render.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::harness;
using scanbench::test::make_temp_dir;
using scanbench::test::Result;
using scanbench::test::sh;
using scanbench::test::slurp;

namespace {

Json record(const std::string& dataset, const std::string& variant, Json metrics,
            Json point = Json::object(), std::vector<double> total_s = {1.0}) {
  return {{"key", dataset + "|s|" + variant + "|" + point.dump() + "|seed=1"},
          {"status", "ok"},
          {"dataset", {{"label", dataset}}},
          {"variant", {{"label", variant}}},
          {"point", point},
          {"metrics", metrics},
          {"timing", {{"total_s", total_s}}}};
}

ClaimRule compare_rule(const std::string& a, const std::string& op, const std::string& b,
                       const std::string& q = "err") {
  ClaimRule r;
  r.what = "test";
  r.quantity = q;
  r.a.variant = a;
  r.b.variant = b;
  r.has_b = true;
  r.op = op;
  return r;
}

TEST(ClaimRules, CompareHoldsOnEveryDatasetOrFailsNamingIt) {
  std::vector<Json> recs = {record("d1", "x", {{"err", 1.0}}), record("d1", "y", {{"err", 2.0}}),
                            record("d2", "x", {{"err", 3.0}}), record("d2", "y", {{"err", 4.0}})};
  RuleOutcome o = judge_rule(compare_rule("x", "<", "y"), recs);
  EXPECT_EQ(o.verdict, "held") << o.reason;
  EXPECT_NE(o.measured.find("d1: 1 vs 2 (ratio 0.5)"), std::string::npos) << o.measured;
  recs[2]["metrics"]["err"] = 5.0;  // x worse than y on d2 only
  o = judge_rule(compare_rule("x", "<", "y"), recs);
  EXPECT_EQ(o.verdict, "failed");
  EXPECT_NE(o.reason.find("d2"), std::string::npos) << o.reason;
  EXPECT_EQ(o.reason.find("d1"), std::string::npos) << o.reason;
  // Each operator, both ways.
  EXPECT_EQ(judge_rule(compare_rule("y", ">", "x"), recs).verdict, "failed");
  EXPECT_EQ(judge_rule(compare_rule("x", ">=", "x"), recs).verdict, "held");
  EXPECT_EQ(judge_rule(compare_rule("x", "<=", "x"), recs).verdict, "held");
  EXPECT_EQ(judge_rule(compare_rule("x", "<", "x"), recs).verdict, "failed");
}

TEST(ClaimRules, StatisticsOverAllDatasetsAndFactorAndConstant) {
  // per "all": the statistic runs over the records of every dataset.
  std::vector<Json> recs = {record("d1", "x", {{"err", 1.0}}), record("d2", "x", {{"err", 2.0}}),
                            record("d3", "x", {{"err", 9.0}}), record("d1", "y", {{"err", 2.5}})};
  ClaimRule r = compare_rule("x", "<", "y");
  r.per = "all";
  r.stat = "median";  // 2 < 2.5
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
  r.stat = "mean";  // 4 < 2.5 fails
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
  r.stat = "max";
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
  r.stat = "min";
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
  // A constant and a factor: median 2 < 0.5 x 5 holds, < 0.3 x 5 fails.
  r.stat = "median";
  r.has_b = false;
  r.value = 5.0;
  r.factor = 0.5;
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
  r.factor = 0.3;
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
}

TEST(ClaimRules, InconclusiveWhenJobFailedNoRecordMissingQuantityOrWithinMargin) {
  std::vector<Json> recs = {record("d1", "x", {{"err", 1.0}}), record("d1", "y", {{"err", 1.01}})};
  ClaimRule r = compare_rule("x", "<", "y");
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
  r.margin = 0.05;  // 1 vs 1.01: within 5%
  RuleOutcome o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("margin"), std::string::npos) << o.reason;
  r.margin = 0;
  recs[1]["status"] = "timeout";
  recs[1]["error"] = "killed after 5 s";
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("timeout: killed after 5 s"), std::string::npos) << o.reason;
  recs[1]["status"] = "ok";
  o = judge_rule(compare_rule("x", "<", "nosuch"), recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("no record matches b"), std::string::npos) << o.reason;
  o = judge_rule(compare_rule("x", "<", "y", "other"), recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("has no 'other'"), std::string::npos) << o.reason;
  EXPECT_EQ(judge_rule(r, {}).verdict, "inconclusive");
}

TEST(ClaimRules, ARuleNamingADatasetIsJudgedOnThatDatasetOnly) {
  const std::vector<Json> recs = {
      record("d1", "x", {{"err", 1.0}}), record("d1", "y", {{"err", 2.0}}),
      record("d2", "x", {{"err", 5.0}}), record("d2", "y", {{"err", 4.0}})};
  ClaimRule r = compare_rule("x", "<", "y");
  r.a.dataset = r.b.dataset = "d1";
  RuleOutcome o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "held") << o.reason;  // d2 (where x loses) is not this rule's dataset
  EXPECT_EQ(o.groups.size(), 1u);
  EXPECT_EQ(o.measured.find("d2"), std::string::npos) << o.measured;
  r.a.dataset = r.b.dataset = "d2";
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
  r.a.dataset = r.b.dataset = "d3";  // named, but no record: nothing judged
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("no records"), std::string::npos) << o.reason;
}

TEST(ClaimRules, TimingSamplesMustNotOverlap) {
  std::vector<Json> recs = {record("d1", "fast", {}, Json::object(), {1.0, 1.1, 1.2}),
                            record("d1", "slow", {}, Json::object(), {2.0, 2.1, 2.2})};
  EXPECT_EQ(judge_rule(compare_rule("fast", "<", "slow", "time.total"), recs).verdict, "held");
  EXPECT_EQ(judge_rule(compare_rule("slow", "<", "fast", "time.total"), recs).verdict, "failed");
  recs[0]["timing"]["total_s"] = {1.0, 1.1, 2.05};  // median still below, ranges overlap
  const RuleOutcome o = judge_rule(compare_rule("fast", "<", "slow", "time.total"), recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("overlap"), std::string::npos) << o.reason;
}

TEST(ClaimRules, EqualityWithinTolerance) {
  std::vector<Json> recs = {record("d1", "x", {{"v", 1.0}}),
                            record("d1", "y", {{"v", 1.0 + 1e-9}})};
  ClaimRule r = compare_rule("x", "==", "y", "v");
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
  recs[1]["metrics"]["v"] = 1.001;
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
  r.tolerance = 0.01;
  EXPECT_EQ(judge_rule(r, recs).verdict, "held");
}

TEST(ClaimRules, ArgminOfASweepParameter) {
  std::vector<Json> recs;
  const double errs[] = {3.0, 2.0, 2.5, 4.0};
  const double alphas[] = {1.5, 2.0, 2.5, 3.0};
  for (int i = 0; i < 4; ++i)
    recs.push_back(record("d1", "clop", {{"err", errs[i]}}, {{"clop.alpha", alphas[i]}}));
  ClaimRule r;
  r.what = "min near 2";
  r.kind = "argmin";
  r.quantity = "err";
  r.a.variant = "clop";
  r.param = "clop.alpha";
  r.lo = 1.75;
  r.hi = 2.25;
  RuleOutcome o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "held") << o.reason;
  EXPECT_NE(o.measured.find("argmin 2"), std::string::npos) << o.measured;
  recs[3]["metrics"]["err"] = 1.0;  // now lowest at 3
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "failed");
  EXPECT_NE(o.reason.find("clop.alpha=3"), std::string::npos) << o.reason;
  // Point selectors pick one sweep value.
  ClaimRule c = compare_rule("clop", ">", "clop");
  c.a.point = {{"clop.alpha", 2.5}};
  c.b.point = {{"clop.alpha", 2}};
  EXPECT_EQ(judge_rule(c, recs).verdict, "held");
  c.op = "<";
  EXPECT_EQ(judge_rule(c, recs).verdict, "failed");
}

// The rules as a vector: a Json built from a one-element braced list ({rule}) is a copy of the
// rule under clang but an array under GCC (nlohmann/json's single-element brace initialisation),
// so the list is made an array explicitly.
Json claim_json(const std::vector<Json>& rule_list) {
  const Json rules(rule_list);
  return {{"scanbench_claim", 1},
          {"claim", "x is better than y"},
          {"source", "a paper, Fig. 1"},
          {"experiment",
           {{"scanbench_experiment", 1},
            {"datasets", {{{"name", "sphere"}}}},
            {"scanners", {"clean"}},
            {"variants",
             {{{"label", "x"}, {"algorithm", "normals.pca"}},
              {{"label", "y"}, {"algorithm", "resample.wlop"}}}}}},
          {"quick", {{"scanners", {{{"preset", "clean"}, {"params", {{"resolution", 16}}}}}}}},
          {"rules", rules}};
}

Json good_rule() {
  return {{"what", "x below y"},
          {"quantity", "err"},
          {"a", {{"variant", "x"}}},
          {"op", "<"},
          {"b", {{"variant", "y"}}}};
}

/// A record of a trade-off sweep: error, a time per repeat with a shared "clop" step, a size.
Json tradeoff_record(const std::string& variant, const std::string& key, double x, double err,
                     std::vector<double> total_s, double clop_s, double bytes) {
  Json r = record("d1", variant, {{"err", err}, {"mesh_bytes", bytes}}, {{key, x}}, total_s);
  r["timing"]["phases"]["clop"] = std::vector<double>(total_s.size(), clop_s);
  r["sizes"] = {{"covmesh_bytes", bytes}};
  return r;
}

TEST(ClaimRules, ParetoFrontsOfTwoSweeps) {
  // b = y (depth sweep): times 2, 4, 8 for errors 4, 2, 1; a dominated point (time 5, error 3) is
  // not on b's front. a = x (sigma sweep): errors 3.5, 1.8 at times 1.5, 3.5: as accurate as b's 4
  // and 2 for less time, and nothing reaches b's 1.
  std::vector<Json> recs;
  const double bt[] = {2, 4, 8, 5}, be[] = {4, 2, 1, 3};
  for (int i = 0; i < 4; ++i)
    recs.push_back(tradeoff_record("y", "depth", i, be[i], {bt[i] + 10, bt[i] + 10.1}, 10, 0));
  recs.push_back(tradeoff_record("x", "sigma", 1, 3.5, {11.5, 11.6}, 10, 0));
  recs.push_back(tradeoff_record("x", "sigma", 2, 1.8, {13.5, 13.6}, 10, 0));
  const Json rule = {{"what", "a faster at equal error"},
                     {"kind", "front"},
                     {"quantity", "err"},
                     {"cost", "time.total"},
                     {"exclude_steps", {"clop"}},
                     {"a", {{"variant", "x"}}},
                     {"b", {{"variant", "y"}}}};
  const ClaimRule r = parse_claim(claim_json({rule}), "c.json", "c").rules[0];
  RuleOutcome o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "held") << o.reason;
  ASSERT_EQ(o.groups[0]["pairs"].size(), 2u);  // b's points at errors 4 and 2; not 1, not 3
  EXPECT_NEAR(o.groups[0]["pairs"][0]["b_cost"].get<double>(), 2.05, 1e-9);  // clop left out
  // a slower than b where it is as accurate: failed, naming the point.
  recs[5]["timing"]["total_s"] = {15.0, 15.1};
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "failed") << o.reason;
  EXPECT_NE(o.reason.find("depth=1"), std::string::npos) << o.reason;
  // Overlapping repeats decide nothing.
  recs[5]["timing"]["total_s"] = {13.9, 14.2};
  EXPECT_EQ(judge_rule(r, recs).verdict, "inconclusive");
  // No a point as accurate as any b point: inconclusive, not held.
  for (int i : {4, 5})
    recs[static_cast<std::size_t>(i)]["metrics"]["err"] = 9.0;
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("no a point reaches"), std::string::npos) << o.reason;
  // A time cost without the excluded step's seconds has no value.
  recs[0]["timing"].erase("phases");
  EXPECT_EQ(judge_rule(r, recs).verdict, "inconclusive");
}

TEST(ClaimRules, MatchedJudgesEveryPointInTheBudgetBandAndNoOther) {
  // Band: [bytes of depth 7, a third of depth 8's] = [100, 200].
  std::vector<Json> recs = {tradeoff_record("y", "depth", 7, 2.0, {1}, 0, 100),
                            tradeoff_record("y", "depth", 8, 1.0, {1}, 0, 600),
                            tradeoff_record("x", "sigma", 1, 5.0, {1}, 0, 50),
                            tradeoff_record("x", "sigma", 2, 1.5, {1}, 0, 150),
                            tradeoff_record("x", "sigma", 3, 0.5, {1}, 0, 400)};
  const Json d7 = {{"variant", "y"}, {"point", {{"depth", 7}}}};
  const Json rule = {{"what", "g below depth 7 in the band"},
                     {"kind", "matched"},
                     {"quantity", "err"},
                     {"a", {{"variant", "x"}}},
                     {"op", "<"},
                     {"b", d7},
                     {"match",
                      {{"quantity", "sizes.covmesh_bytes"},
                       {"ref", "mesh_bytes"},
                       {"lo", d7},
                       {"hi", {{"variant", "y"}, {"point", {{"depth", 8}}}}},
                       {"hi_factor", 1.0 / 3.0}}}};
  const ClaimRule r = parse_claim(claim_json({rule}), "c.json", "c").rules[0];
  RuleOutcome o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "held") << o.reason;  // sigma 2 only: 1.5 < 2 (sigma 1's 5.0 is outside)
  recs[3]["metrics"]["err"] = 2.5;
  EXPECT_EQ(judge_rule(r, recs).verdict, "failed");
  recs[3]["sizes"]["covmesh_bytes"] = 250.0;  // now nothing in the band
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("no a record in the band [100, 200]"), std::string::npos) << o.reason;
  recs[1]["metrics"]["mesh_bytes"] = 150.0;  // a third of depth 8's (50) below depth 7's (100)
  o = judge_rule(r, recs);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("empty"), std::string::npos) << o.reason;
}

// Fair chains (issue 50): two compared variants whose steps after their methods differ are refused
// at load with the file, the variants and the step; the same with the difference declared loads,
// and claims.json and the table show the declaration.
TEST(ClaimFiles, ComparedChainsDifferOnlyInTheirMethodsOrDeclareIt) {
  auto with_chains = [](Json x_chain, Json y_chain, Json chains) {
    Json c = claim_json({good_rule()});
    c["experiment"]["variants"] =
        Json::array({{{"label", "x"}, {"chain", x_chain}}, {{"label", "y"}, {"chain", y_chain}}});
    if (!chains.is_null()) c["chains"] = chains;
    return c;
  };
  const Json x = Json::array(
      {{{"algorithm", "resample.wlop"}}, {{"algorithm", "normals.pca"}, {"params", {{"k", 10}}}}});
  const Json y_same = Json::array(
      {{{"algorithm", "resample.clop"}}, {{"algorithm", "normals.pca"}, {"params", {{"k", 10}}}}});
  Json y_other = y_same;
  y_other[1]["params"]["k"] = 20;
  const Json y_none = Json::array({{{"algorithm", "resample.clop"}}});
  const Json methods = {{"x", {"resample.wlop"}}, {"y", {"resample.clop"}}};
  auto refused = [](const Json& c, const std::string& want) {
    try {
      parse_claim(c, "c.json", "c");
      ADD_FAILURE() << "accepted: " << c["chains"].dump();
    } catch (const scanbench::ParamError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
  EXPECT_NO_THROW(parse_claim(with_chains(x, y_same, {{"methods", methods}}), "c.json", "c"));
  refused(with_chains(x, y_other, {{"methods", methods}}),
          "c.json: /chains: variants 'x' and 'y' differ outside their methods: downstream step 1 "
          "('normals.pca' with params {\"k\":10} vs {\"k\":20})");
  // The method's own normals going downstream: y has no normals step after its method.
  refused(with_chains(x, y_none, {{"methods", methods}}),
          "downstream step 1 ('normals.pca' vs none)");
  refused(with_chains(x, y_same, Json()), "c.json: /chains/methods/x: missing");
  refused(with_chains(x, y_same, {{"methods", {{"x", {"normals.pca", "resample.wlop"}}}}}),
          "/chains/methods/x: 'resample.wlop' is not the next step");
  const Json declared = {{"methods", methods},
                         {"downstream_differs", {{"y", {{"reason", "its own normals"}}}}}};
  const Claim c = parse_claim(with_chains(x, y_none, declared), "c.json", "c");
  ClaimOutcome o;
  o.verdict = "held";
  const Json j = claim_result_json(c, o);
  EXPECT_EQ(j["chains"]["downstream_differs"]["y"]["reason"], "its own normals");
  const std::string md = claims_markdown({{"claims", Json::array({j})}});
  EXPECT_NE(md.find("declared: y: chain differs outside its method (its own normals)"),
            std::string::npos)
      << md;
}

TEST(ClaimFiles, TradeoffRulesRejectBadFields) {
  Json front = {{"what", "w"},          {"kind", "front"},         {"quantity", "err"},
                {"cost", "mesh_bytes"}, {"a", {{"variant", "x"}}}, {"b", {{"variant", "y"}}}};
  EXPECT_NO_THROW(parse_claim(claim_json({front}), "c.json", "c"));
  for (const auto& [key, value] : std::vector<std::pair<std::string, Json>>{
           {"exclude_steps", Json::array({"clop"})},  // a byte cost has no steps' seconds
           {"op", ">"},
           {"factor", -1},
           {"margin", 0.1}}) {
    Json bad = front;
    bad[key] = value;
    try {
      parse_claim(claim_json({bad}), "c.json", "c");
      ADD_FAILURE() << key << " accepted";
    } catch (const scanbench::ParamError& e) {
      EXPECT_NE(std::string(e.what()).find("c.json: /rules/0/" + key), std::string::npos)
          << e.what();
    }
  }
  Json matched = {
      {"what", "w"},
      {"kind", "matched"},
      {"quantity", "err"},
      {"a", {{"variant", "x"}}},
      {"b", {{"variant", "y"}}},
      {"match", {{"quantity", "q"}, {"lo", {{"variant", "y"}}}, {"hi", {{"variant", "nope"}}}}}};
  try {
    parse_claim(claim_json({matched}), "c.json", "c");
    ADD_FAILURE() << "a band selector naming no variant accepted";
  } catch (const scanbench::ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("/rules/0/match/hi/variant"), std::string::npos)
        << e.what();
  }
}

TEST(ClaimFiles, ValidatedWithPathsAndQuickPatchApplied) {
  const Claim c = parse_claim(claim_json({good_rule()}), "c.json", "c");
  EXPECT_EQ(c.id, "c");
  EXPECT_EQ(c.experiment_config(true)["scanners"][0]["params"]["resolution"], 16);
  EXPECT_FALSE(c.experiment_config(false)["scanners"][0].is_object());
  auto error_of = [](const Json& j) {
    try {
      parse_claim(j, "c.json", "c");
    } catch (const scanbench::ParamError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  Json r = good_rule();
  r["b"]["variant"] = "z";
  EXPECT_EQ(error_of(claim_json({r})), "c.json: /rules/0/b/variant: no variant labelled 'z'");
  r = good_rule();
  r["opp"] = "<";
  EXPECT_NE(error_of(claim_json({r})).find("c.json: /rules/0/opp: unknown key"), std::string::npos);
  r = good_rule();
  r["op"] = "=<";
  EXPECT_NE(error_of(claim_json({r})).find("/rules/0/op: expected one of"), std::string::npos);
  r = good_rule();
  r["value"] = 1.0;
  EXPECT_NE(error_of(claim_json({r})).find("exactly one of"), std::string::npos);
  EXPECT_NE(error_of(claim_json({})).find("/rules: expected a non-empty list"), std::string::npos);
  Json bad = claim_json({good_rule()});
  bad["experiment"]["variants"][0]["params"] = {{"k", -3}};
  EXPECT_NE(error_of(bad).find("c.json: /experiment: /variants/0/params"), std::string::npos)
      << error_of(bad);
}

TEST(ClaimVerdicts, CombinationAndBaselineRegressions) {
  Claim c = parse_claim(claim_json({good_rule(), good_rule()}), "c.json", "c");
  c.rules[1].b.variant = "x";  // x < x: fails
  std::vector<Json> recs = {record("sphere", "x", {{"err", 1.0}}),
                            record("sphere", "y", {{"err", 2.0}})};
  ClaimOutcome o = judge_claim(c, recs);
  EXPECT_EQ(o.verdict, "failed");
  EXPECT_EQ(o.reason.rfind("x below y: ", 0), 0u) << o.reason;
  c.rules[1].margin = 1.0;  // x vs x within the margin: inconclusive beats held
  EXPECT_EQ(judge_claim(c, recs).verdict, "inconclusive");
  c.rules.pop_back();
  EXPECT_EQ(judge_claim(c, recs).verdict, "held");

  const Json base = {{"claims",
                      {{{"id", "a"}, {"verdict", "held"}},
                       {{"id", "b"}, {"verdict", "inconclusive"}},
                       {{"id", "c"}, {"verdict", "failed"}},
                       {{"id", "d"}, {"verdict", "held"}}}}};
  const Json now = {{"claims",
                     {{{"id", "a"}, {"verdict", "failed"}},
                      {{"id", "b"}, {"verdict", "failed"}},
                      {{"id", "c"}, {"verdict", "failed"}},
                      {{"id", "d"}, {"verdict", "inconclusive"}},
                      {{"id", "e"}, {"verdict", "failed"}}}}};
  EXPECT_EQ(claim_regressions(base, now), std::vector<std::string>{"a"});
}

// End to end: two claims on the test subsampler, through the real binary.
TEST(ClaimsE2E, RunsJudgesWritesAndExitsOneOnARegression) {
  const fs::path dir = make_temp_dir("claims");
  fs::create_directories(dir / "claims");
  auto write_claim = [&](const std::string& id, const std::string& op) {
    const Json c = {
        {"scanbench_claim", 1},
        {"claim", "stride 2 keeps more points than stride 4"},
        {"source", "test"},
        {"paper", "2x"},
        {"experiment",
         {{"scanbench_experiment", 1},
          {"datasets", {{{"name", "sphere"}}, {{"name", "torus"}}}},
          {"scanners", {{{"preset", "clean"}, {"params", {{"views", 2}, {"resolution", 48}}}}}},
          {"metrics", {"regularity.nn_dist"}},
          {"variants",
           {{{"label", "sub2"}, {"algorithm", "test.subsample"}, {"params", {{"stride", 2}}}},
            {{"label", "sub4"}, {"algorithm", "test.subsample"}, {"params", {{"stride", 4}}}}}}}},
        {"quick", {{"datasets", {{{"name", "sphere"}}}}}},
        {"rules",
         {{{"what", "more points"},
           {"quantity", "output_points"},
           {"a", {{"variant", "sub2"}}},
           {"op", op},
           {"factor", 1.5},
           {"b", {{"variant", "sub4"}}}}}}};
    std::ofstream(dir / "claims" / (id + ".json")) << c.dump(1);
  };
  write_claim("holds", ">");
  write_claim("fails", "<");
  const std::string bin = SCANBENCH_BINARY;
  // Baseline where both held: "fails" regressed -> exit 1.
  const fs::path base = dir / "base.json";
  std::ofstream(base) << Json{{"claims",
                               {{{"id", "holds"}, {"verdict", "held"}},
                                {{"id", "fails"}, {"verdict", "held"}}}}}
                             .dump();
  Result r = sh(bin + " claims --quick --claims " + (dir / "claims").string() + " -o " +
                (dir / "out").string() + " --baseline " + base.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("REGRESSION"), std::string::npos) << r.out;
  const Json s = Json::parse(slurp(dir / "out" / "claims.json"));
  ASSERT_EQ(s["claims"].size(), 2u);
  EXPECT_EQ(s["claims"][0]["id"], "fails");
  EXPECT_EQ(s["claims"][0]["verdict"], "failed");
  EXPECT_EQ(s["claims"][1]["verdict"], "held");
  EXPECT_TRUE(s["quick"].get<bool>());
  EXPECT_EQ(s["claims"][1]["jobs"], 2);  // quick: the sphere only
  EXPECT_EQ(s["regressions"], Json::array({"fails"}));
  // One scan cache for both claims.
  EXPECT_TRUE(fs::is_symlink(dir / "out" / "holds" / "scans"));
  int scans = 0;
  for (const auto& e : fs::directory_iterator(dir / "out" / "scans"))
    scans += e.path().extension() == ".ply" ? 1 : 0;
  EXPECT_EQ(scans, 1);
  EXPECT_NE(slurp(dir / "out" / "claims.md").find("| holds | test | 2x |"), std::string::npos);
  EXPECT_NE(slurp(dir / "out" / "index.html").find("id=\"claims\""), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "out" / "holds" / "index.html"));

  // Filter, full set, and a baseline in which "fails" already failed: exit 0.
  std::ofstream(base) << Json{{"claims", {{{"id", "fails"}, {"verdict", "failed"}}}}}.dump();
  r = sh(bin + " claims --claims " + (dir / "claims").string() + " -o " + (dir / "out2").string() +
         " --baseline " + base.string() + " --filter '^fai'");
  EXPECT_EQ(r.code, 0) << r.out;
  const Json s2 = Json::parse(slurp(dir / "out2" / "claims.json"));
  ASSERT_EQ(s2["claims"].size(), 1u);
  EXPECT_EQ(s2["claims"][0]["jobs"], 4);
  // The report of a folder holding claims.json shows the section.
  fs::copy_file(dir / "out2" / "claims.json", dir / "out2" / "fails" / "claims.json");
  r = sh(bin + " report " + (dir / "out2" / "fails").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(slurp(dir / "out2" / "fails" / "index.html").find("Claims of the source papers"),
            std::string::npos);
  // Bad input: exit 2 with one line naming the file.
  write_claim("broken", "=<");
  r = sh(bin + " claims --claims " + (dir / "claims").string() + " -o " + (dir / "out3").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("broken.json: /rules/0/op"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

}  // namespace
