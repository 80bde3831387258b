// The declared parameter protocol (protocol.h): validation with one-line errors naming the field,
// the tuned choice (the best objective on the tuning data only; ties by range order), the config
// at the protocol's values and over its ranges, the sensitivity of a claim, and `scanbench claims`
// and `scanbench run` with a protocol end to end through the real binary.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/results/claims.h"
#include "scanbench/harness/results/tuning.h"

namespace fs = std::filesystem;
using scanbench::Json;
using scanbench::ParamError;
using namespace scanbench::harness;
using scanbench::test::make_temp_dir;
using scanbench::test::read_jsonl;
using scanbench::test::Result;
using scanbench::test::sh;
using scanbench::test::slurp;

namespace {

/// An experiment on the sphere: variants "sub" (test.subsample, stride tuned on the torus) and
/// "ref" (stride 3).
Json experiment_with_protocol() {
  setenv("SCANBENCH_TEST_ALGORITHMS", "1", 1);  // test.subsample in this process
  return {
      {"scanbench_experiment", 1},
      {"seed", 1},
      {"datasets", {{{"name", "sphere"}}}},
      {"scanners", {{{"preset", "clean"}, {"params", {{"views", 2}, {"resolution", 48}}}}}},
      {"metrics", {"regularity.nn_dist"}},
      {"variants",
       {{{"label", "sub"}, {"algorithm", "test.subsample"}},
        {{"label", "ref"}, {"algorithm", "test.subsample"}, {"params", {{"stride", 3}}}}}},
      {"protocol",
       {{"tuning", {{"datasets", {{{"name", "torus"}}}}}},
        {"objective", {{"quantity", "err"}, {"direction", "min"}}},
        {"variants",
         {{"sub", {{"test.subsample.stride", {{"source", "tuned"}, {"range", {2, 4, 8}}}}}}}}}}};
}

std::string param_error(const Json& config) {
  try {
    parse_experiment(config, "exp.json");
  } catch (const ParamError& e) {
    return e.what();
  }
  return "";
}

Json tuning_record(const std::string& dataset, const std::string& variant, Json point, double err,
                   const std::string& status = "ok") {
  return {{"key", dataset + "|" + variant + "|" + point.dump()},
          {"status", status},
          {"dataset", {{"label", dataset}}},
          {"variant", {{"label", variant}}},
          {"point", point},
          {"metrics", {{"err", err}}}};
}

/// err of the stride on a dataset: the torus is best at stride 2, the sphere at stride 8, so a
/// choice that looked at the sphere would differ from one made on the torus alone.
double synthetic_err(const std::string& dataset, int stride) {
  if (dataset == "torus") return stride == 2 ? 1.0 : (stride == 4 ? 2.0 : 3.0);
  return stride == 8 ? 1.0 : (stride == 4 ? 2.0 : 3.0);
}

/// Records for every job of a config, err from synthetic_err (the runner the protocol is given).
std::vector<Json> synthetic_records(const Json& config) {
  std::vector<Json> out;
  for (const auto& job : expand(parse_experiment(config, "synthetic")).jobs) {
    const int stride = job.chain[0]["params"]["stride"].get<int>();
    out.push_back(tuning_record(job.dataset_label, job.variant, job.point,
                                synthetic_err(job.dataset_label, stride)));
  }
  return out;
}

/// The claim "sub < ref" on the quantity err.
Claim sub_below_ref_claim() {
  Claim c;
  c.id = "c";
  ClaimRule r;
  r.what = "sub below ref";
  r.quantity = "err";
  r.a.variant = "sub";
  r.b.variant = "ref";
  r.has_b = true;
  r.op = "<";
  c.rules = {r};
  return c;
}

TEST(Protocol, BadProtocolIsOneLineNamingTheField) {
  EXPECT_EQ(param_error(experiment_with_protocol()), "");
  auto broken = [](auto edit) {
    Json c = experiment_with_protocol();
    edit(c["protocol"]);
    return param_error(c);
  };
  const std::string pv = "exp.json: /protocol/variants/sub/test.subsample.stride";
  EXPECT_EQ(broken([](Json& p) { p["variants"]["sub"]["test.subsample.stride"]["source"] = "x"; }),
            pv + "/source: expected one of paper, rule, tuned, got 'x'");
  EXPECT_EQ(broken([](Json& p) { p["variants"]["sub"]["test.subsample.stride"].erase("range"); }),
            pv + "/range: missing (the values to tune over, or a \"rule\")");
  EXPECT_EQ(broken([](Json& p) { p["variants"]["sub"]["test.subsample.stride"]["value"] = 2; }),
            pv + "/value: not used with source \"tuned\"");
  EXPECT_EQ(broken([](Json& p) {
              p["variants"]["sub"]["test.subsample.stride"]["range"] = Json::array({2});
            }),
            pv + "/range: expected at least two values to tune over");
  EXPECT_EQ(broken([](Json& p) { p.erase("objective"); }),
            pv + "/objective: missing (and the protocol has no default \"objective\")");
  EXPECT_EQ(broken([](Json& p) { p.erase("tuning"); }),
            "exp.json: /protocol/tuning: missing (the data tuned parameters use)");
  EXPECT_EQ(broken([](Json& p) { p["objective"]["direction"] = "down"; }),
            "exp.json: /protocol/objective/direction: expected one of min, max, got 'down'");
  EXPECT_EQ(broken([](Json& p) {
              p["variants"]["sub"]["test.subsample.stride"] = {{"source", "paper"}, {"value", 2}};
            }),
            pv + "/cite: expected a non-empty string");
  EXPECT_EQ(broken([](Json& p) { p["variants"]["nope"] = p["variants"]["sub"]; }),
            "exp.json: /protocol/variants/nope: no variant labelled 'nope'");
  EXPECT_EQ(broken([](Json& p) {
              p["variants"]["ref"] = {
                  {"test.subsample.stride", {{"source", "rule"}, {"rule", "r"}, {"value", 3}}}};
            }),
            "exp.json: /protocol/variants/ref/test.subsample.stride: also set in the step's params "
            "(give each parameter one source)");
  EXPECT_EQ(broken([](Json& p) {
              p["variants"]["sub"]["other.stride"] = {{"source", "tuned"}, {"range", {1, 2}}};
            }),
            "exp.json: /protocol/variants/sub/other.stride: the variant has no step 'other'");
  // A value the parameter's declaration rejects (stride in [1, 1000]).
  const std::string bad_value = broken([](Json& p) {
    p["variants"]["sub"]["test.subsample.stride"]["range"] = Json::array({2, 5000});
  });
  EXPECT_EQ(bad_value.rfind("exp.json: /protocol: a protocol value is not accepted: ", 0), 0u)
      << bad_value;
  // Tuning data that are the experiment's own data (same shape, scanner and seed).
  EXPECT_EQ(broken([](Json& p) {
              p["tuning"]["datasets"] = {{{"name", "sphere"}}};
            }),
            "exp.json: /protocol/tuning: the tuning data overlap the experiment's data (dataset "
            "sphere, scanner clean, seed 1): tune on another shape or another seed and noise draw");
  // The same shape with another seed is disjoint.
  EXPECT_EQ(broken([](Json& p) {
              p["tuning"]["datasets"] = {{{"name", "sphere"}}};
              p["tuning"]["seed"] = 2;
            }),
            "");
  for (const std::string& e : {bad_value, broken([](Json& p) { p["objective"] = 1; })})
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

TEST(Protocol, ChoosePointIsTheBestObjectiveWithTiesInRangeOrder) {
  const Protocol p = parse_protocol(experiment_with_protocol()["protocol"], "p");
  const auto tuned = p.tuned("sub");
  ASSERT_EQ(tuned.size(), 1u);
  const std::string k = "test.subsample.stride";
  std::vector<Json> recs = {
      tuning_record("a", "sub", {{k, 8}}, 3.0), tuning_record("a", "sub", {{k, 2}}, 2.0),
      tuning_record("a", "sub", {{k, 4}}, 1.0), tuning_record("b", "sub", {{k, 4}}, 5.0),
      tuning_record("b", "sub", {{k, 2}}, 2.0), tuning_record("b", "sub", {{k, 8}}, 3.0)};
  Json curve;
  // Medians over the datasets: 2 -> 2, 4 -> 3, 8 -> 3.
  EXPECT_EQ(choose_point(recs, tuned, {"err", "min", "median"}, curve), Json({{k, 2}}));
  EXPECT_DOUBLE_EQ(curve[k + "=4"].get<double>(), 3.0);
  EXPECT_EQ(choose_point(recs, tuned, {"err", "max", "median"}, curve), Json({{k, 4}}));  // tie
  EXPECT_EQ(choose_point(recs, tuned, {"err", "min", "min"}, curve), Json({{k, 4}}));
  // A failed job is no candidate.
  recs[1]["status"] = "error";
  recs[4]["status"] = "timeout";
  EXPECT_EQ(choose_point(recs, tuned, {"err", "min", "median"}, curve), Json({{k, 4}}));
  EXPECT_THROW(choose_point(recs, tuned, {"missing", "min", "median"}, curve), scanbench::Error);
}

TEST(Protocol, TuningSeesOnlyTheTuningDataAndItsChoiceIsUsedOnTheExperimentsData) {
  const Json config = experiment_with_protocol();
  const Protocol declared = parse_protocol(config["protocol"], "exp.json: /protocol");
  std::vector<Json> asked;
  std::vector<std::string> folders;
  const RecordsRunner run = [&](const Json& c, const fs::path& out) {
    asked.push_back(c);
    folders.push_back(out.filename().string());
    return synthetic_records(c);
  };
  const Protocol p = resolve_protocol(config, declared, "out", run);
  // Once per variant with tuned parameters, and once more for the extended range.
  EXPECT_EQ(folders, std::vector<std::string>({"tuning-sub", "tuning-sub.ext1"}));
  for (const auto& c : asked)
    for (const auto& job : expand(parse_experiment(c, "t")).jobs) {
      EXPECT_EQ(job.dataset, "torus");
      EXPECT_EQ(job.variant, "sub");
    }
  ASSERT_EQ(p.params.size(), 1u);
  EXPECT_EQ(p.params[0].value, 2);  // the torus's best
  // 2 is the lowest of the fixed range and 4 is worse: the range is extended by its own ratio
  // (1/2: stride 1, within 2x), where the curve rises again.
  EXPECT_EQ(p.params[0].range, std::vector<Json>({1, 2, 4, 8}));
  EXPECT_EQ(p.params[0].boundary["status"], "extended");
  EXPECT_EQ(p.params[0].boundary["text"],
            "test.subsample.stride tuned at the lower boundary 2, extended to 1: optimum 2");
  EXPECT_EQ(p.inconclusive(), "");
  // On the experiment's own data the best would have been 8: the data disagree, and the choice
  // did not look at them.
  const Json swept = protocol_config(config, p, true);
  Json curve;
  const std::vector<Json> verdict = synthetic_records(swept);
  EXPECT_EQ(choose_point(verdict, p.tuned("sub"), {"err", "min", "median"}, curve),
            Json({{"test.subsample.stride", 8}}));
  // The config to run sets the chosen value; swept, it covers the range one value per job.
  const Json plain = protocol_config(config, p, false);
  EXPECT_FALSE(plain.contains("protocol"));
  EXPECT_EQ(plain["variants"][0]["params"]["stride"], 2);
  EXPECT_EQ(swept["variants"][0]["sweep"],
            Json::parse(R"([{"test.subsample.stride": [2, 1, 4, 8]}])"));
  // The records at the protocol: "sub" at stride 2 only, "ref" untouched.
  const std::vector<Json> at = records_at_protocol(verdict, p);
  ASSERT_EQ(at.size(), 2u);
  EXPECT_EQ(at[0]["point"]["test.subsample.stride"], 2);
  EXPECT_EQ(at[1]["variant"]["label"], "ref");
  // The recorded protocol: source, chosen value, range, tuning data, objective and curve.
  const Json j = protocol_json(p)["sub"]["test.subsample.stride"];
  EXPECT_EQ(j["source"], "tuned");
  EXPECT_EQ(j["value"], 2);
  EXPECT_EQ(j["range"], Json({1, 2, 4, 8}));
  EXPECT_EQ(j["tuning_data"]["datasets"][0]["name"], "torus");
  EXPECT_EQ(j["objective"]["quantity"], "err");
  EXPECT_DOUBLE_EQ(j["tuning_curve"]["test.subsample.stride=8"].get<double>(), 3.0);
  EXPECT_NE(protocol_summary(protocol_json(p)).find("sub: test.subsample.stride tuned 2 (min err"),
            std::string::npos);
}

TEST(Protocol, SensitivityJudgesTheClaimAtEachValueOfTheRange) {
  const Json config = experiment_with_protocol();
  Protocol p = parse_protocol(config["protocol"], "p");
  p.params[0].value = 2;
  // err of "sub" at stride 2, 4, 8 against "ref" at 2.5: the claim sub < ref holds at 2 only.
  const std::string k = "test.subsample.stride";
  const std::vector<Json> recs = {tuning_record("sphere", "sub", {{k, 2}}, 1.0),
                                  tuning_record("sphere", "sub", {{k, 4}}, 3.0),
                                  tuning_record("sphere", "sub", {{k, 8}}, 4.0),
                                  tuning_record("sphere", "ref", Json::object(), 2.5)};
  Claim c = sub_below_ref_claim();
  const ClaimRule r = c.rules[0];
  EXPECT_EQ(judge_claim(c, records_at_protocol(recs, p)).verdict, "held");
  const Json s = claim_sensitivity(c, p, recs);
  EXPECT_EQ(s["params"][0]["verdicts"], Json({{"2", "held"}, {"4", "failed"}, {"8", "failed"}}));
  EXPECT_EQ(s["text"].get<std::string>().rfind(
                "sub test.subsample.stride (tuned): held at 2*; failed at 4, 8", 0),
            0u)
      << s["text"];
  EXPECT_EQ(claim_sensitivity(c, Protocol{}, recs)["text"], "no parameter ranges declared");
  // A second rule that holds everywhere: the failed values say how many rules held.
  ClaimRule below = r;
  below.what = "sub below 5";
  below.has_b = false;
  below.b = ClaimSelector{};
  below.value = 5.0;
  c.rules.push_back(below);
  const Json s2 = claim_sensitivity(c, p, recs);
  EXPECT_NE(s2["text"].get<std::string>().find(
                "held at 2*; failed at 4 (1/2 rules held), 8 (1/2 rules held)"),
            std::string::npos)
      << s2["text"];
  EXPECT_EQ(s2["params"][0]["rule_verdicts"]["4"], Json({"failed", "held"}));
}

// Scanner entries (issues 50, 52): the reading of "x% noise" declared once for every variant, the
// other readings as its sensitivity; one source per parameter.
TEST(ProtocolScanner, ScannerEntriesSetEveryScannerAndSweepEveryVariant) {
  Json config = experiment_with_protocol();
  config["scanners"][0]["params"]["noise_sigma"] = 0.004;
  config["protocol"]["tuning"]["scanners"] = Json::array({"clean"});
  config["protocol"]["scanner"] = {{"noise_family",
                                    {{"source", "rule"},
                                     {"value", "gaussian"},
                                     {"rule", "std along the ray"},
                                     {"sensitivity", {"laplace", "uniform"}}}}};
  EXPECT_EQ(param_error(config), "");
  Protocol p = parse_protocol(config["protocol"], "p");
  ASSERT_EQ(p.scanner.size(), 1u);
  EXPECT_EQ(p.scanner[0].key, "scanner.noise_family");
  EXPECT_EQ(p.scanner[0].variant, "");
  p.params[0].value = 4;  // the tuned stride, as resolve_protocol would choose it

  // Every scanner of the experiment and of the tuning data gets the value.
  const Json at_values = protocol_config(config, p, false);
  EXPECT_EQ(at_values["scanners"][0]["params"]["noise_family"], "gaussian");
  const Json tuning = tuning_config(config, p, "sub");
  EXPECT_EQ(tuning["scanners"][0],
            Json({{"preset", "clean"}, {"params", {{"noise_family", "gaussian"}}}}));

  // Sensitivity: each variant at the protocol point and at each other family, one at a time.
  const Plan plan = expand(parse_experiment(protocol_config(config, p, true), "exp.json"));
  std::multiset<std::string> points;
  for (const auto& j : plan.jobs) {
    points.insert(j.variant + " " + j.point_label);
    const std::string family = j.point.value("scanner.noise_family", std::string("gaussian"));
    EXPECT_EQ(j.scanner_params["noise_family"], family) << j.key;
  }
  EXPECT_EQ(points, (std::multiset<std::string>{
                        "ref noise_family=gaussian", "ref noise_family=laplace",
                        "ref noise_family=uniform", "sub stride=4", "sub stride=2", "sub stride=8",
                        "sub noise_family=laplace", "sub noise_family=uniform"}));

  // The verdict uses the protocol point only; the sensitivity re-judges every variant at each
  // family.
  std::vector<Json> recs;
  for (const auto& j : plan.jobs) {
    const std::string family = j.point.value("scanner.noise_family", std::string("gaussian"));
    double err = j.variant == "ref" ? 2.0 : (family == "laplace" ? 3.0 : 1.0);
    if (j.point.contains("test.subsample.stride") && j.point["test.subsample.stride"] != 4)
      err = 5.0;
    recs.push_back(tuning_record("sphere", j.variant, j.point, err));
  }
  const std::vector<Json> at = records_at_protocol(recs, p);
  ASSERT_EQ(at.size(), 2u);
  for (const auto& r : at)
    EXPECT_EQ(r["metrics"]["err"], r["variant"]["label"] == "ref" ? 2.0 : 1.0) << r.dump();
  const std::vector<Json> lap = records_at_protocol(recs, p, &p.scanner[0], "laplace");
  ASSERT_EQ(lap.size(), 2u);
  for (const auto& r : lap)
    EXPECT_EQ(r["point"]["scanner.noise_family"], "laplace") << r.dump();
  const Claim c = sub_below_ref_claim();
  const Json s = claim_sensitivity(c, p, recs);
  const Json& fam = s["params"][1];
  EXPECT_EQ(fam["key"], "scanner.noise_family");
  EXPECT_EQ(fam["verdicts"],
            Json({{"\"gaussian\"", "held"}, {"\"laplace\"", "failed"}, {"\"uniform\"", "held"}}));
  EXPECT_NE(s["text"].get<std::string>().find(
                "every variant scanner.noise_family (rule): held at \"gaussian\"*; failed at "
                "\"laplace\"; held at \"uniform\""),
            std::string::npos)
      << s["text"];
  EXPECT_EQ(protocol_json(p)["scanner"]["scanner.noise_family"]["sensitivity"],
            Json({"laplace", "uniform"}));

  // One source per parameter; declared, never tuned; a value the scanner rejects.
  auto broken = [&](auto edit) {
    Json b = config;
    edit(b);
    return param_error(b);
  };
  const std::string w = "exp.json: /protocol/scanner/noise_family";
  EXPECT_EQ(broken([](Json& b) { b["scanners"][0]["params"]["noise_family"] = "laplace"; }),
            w + ": also set in the params of the scanner at /scanners/0 (give each parameter one "
                "source)");
  EXPECT_EQ(broken([](Json& b) {
              b["variants"][1]["sweep"] = {{"scanner.noise_family", {"gaussian", "laplace"}}};
            }),
            w + ": also swept (scanner.noise_family; give each parameter one source)");
  EXPECT_EQ(broken([](Json& b) {
              b["protocol"]["scanner"]["noise_family"] = {{"source", "tuned"},
                                                          {"range", {"gaussian", "laplace"}}};
            }),
            w + "/source: a scanner reading is declared (paper or rule), never tuned");
  const std::string bad =
      broken([](Json& b) { b["protocol"]["scanner"]["noise_family"]["sensitivity"] = {"cauchy"}; });
  EXPECT_EQ(bad.rfind("exp.json: /protocol: a protocol value is not accepted: ", 0), 0u) << bad;
  EXPECT_NE(bad.find("noise_family"), std::string::npos) << bad;
}

// End to end through the real binary: the tuning runs on the torus only, the claim on the sphere
// at the chosen stride, claims.json keeps the protocol and the sensitivity; `scanbench run` uses
// the same protocol; a bad protocol exits 2 with one line naming the file and field.
TEST(ProtocolE2E, ClaimsAndRunTuneOnTheTuningDataOnly) {
  const fs::path dir = make_temp_dir("protocol");
  fs::create_directories(dir / "claims");
  Json exp = experiment_with_protocol();
  exp["protocol"]["objective"] = {{"quantity", "output_points"}, {"direction", "max"}};
  exp["protocol"]["scanner"] = {
      {"noise_direction",
       {{"source", "rule"}, {"value", "ray"}, {"rule", "r"}, {"sensitivity", {"normal"}}}}};
  const Json claim = {{"scanbench_claim", 1},
                      {"claim", "the tuned stride keeps more points than stride 3"},
                      {"source", "test"},
                      {"experiment", exp},
                      {"rules",
                       {{{"what", "more points"},
                         {"quantity", "output_points"},
                         {"a", {{"variant", "sub"}}},
                         {"op", ">"},
                         {"b", {{"variant", "ref"}}}}}}};
  std::ofstream(dir / "claims" / "tuned.json") << claim.dump(1);
  const std::string bin = SCANBENCH_BINARY;
  Result r = sh(bin + " claims --claims " + (dir / "claims").string() + " -o " +
                (dir / "out").string() + " --baseline " + (dir / "none.json").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const Json s = Json::parse(slurp(dir / "out" / "claims.json"));
  const Json& c = s["claims"][0];
  EXPECT_EQ(c["verdict"], "held") << c.dump(1);
  // Most points at the lowest stride: the range [2, 4, 8] is extended to stride 1, the end of
  // the parameter's own domain.
  EXPECT_EQ(c["protocol"]["sub"]["test.subsample.stride"]["value"], 1);
  EXPECT_EQ(c["protocol"]["sub"]["test.subsample.stride"]["boundary"]["status"], "limit");
  EXPECT_EQ(c["sensitivity"]["params"][0]["verdicts"],
            Json({{"1", "held"}, {"2", "held"}, {"4", "failed"}, {"8", "failed"}}));
  EXPECT_EQ(c["sensitivity"]["params"][1]["verdicts"],
            Json({{"\"ray\"", "held"}, {"\"normal\"", "held"}}));
  EXPECT_EQ(c["protocol"]["scanner"]["scanner.noise_direction"]["value"], "ray");
  // The scanner entry reached the scans: every record's scanner has the direction of its point.
  int normal_records = 0;
  for (const auto& rec : read_jsonl(dir / "out" / "tuned" / "runs.jsonl")) {
    const std::string want = rec["point"].value("scanner.noise_direction", std::string("ray"));
    EXPECT_EQ(rec["scanner"]["params"]["noise_direction"], want) << rec["key"];
    normal_records += want == "normal" ? 1 : 0;
  }
  EXPECT_EQ(normal_records, 2);  // sub and ref, once each
  std::set<std::string> tuning_datasets;
  for (const auto& rec : read_jsonl(dir / "out" / "tuned" / "tuning-sub" / "runs.jsonl")) {
    tuning_datasets.insert(rec["dataset"]["label"].get<std::string>());
    EXPECT_EQ(rec["scanner"]["params"]["noise_direction"], "ray");
  }
  EXPECT_EQ(tuning_datasets, std::set<std::string>{"torus"});
  EXPECT_TRUE(fs::exists(dir / "out" / "tuned" / "protocol.json"));
  const std::string md = slurp(dir / "out" / "claims.md");
  EXPECT_NE(
      md.find("sub: test.subsample.stride tuned 1 (max output_points over [1,2,4,8] on torus)"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("held at 1*, 2; failed at 4, 8"), std::string::npos) << md;

  // `scanbench run`: the chosen value in every record's chain.
  Json run_exp = exp;
  std::ofstream(dir / "exp.json") << run_exp.dump(1);
  r = sh(bin + " run " + (dir / "exp.json").string() + " -o " + (dir / "run").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(
      Json::parse(slurp(dir / "run" / "protocol.json"))["sub"]["test.subsample.stride"]["value"],
      1);
  int tuned_records = 0;
  for (const auto& rec : read_jsonl(dir / "run" / "runs.jsonl")) {
    if (rec["variant"]["label"] != "sub") continue;
    ++tuned_records;
    EXPECT_EQ(rec["variant"]["chain"][0]["params"]["stride"], 1);
  }
  EXPECT_EQ(tuned_records, 1);

  // Bad input: exit 2, one line naming the file and the field.
  run_exp["protocol"]["variants"]["sub"]["test.subsample.stride"]["source"] = "guessed";
  std::ofstream(dir / "bad.json") << run_exp.dump(1);
  r = sh(bin + " run " + (dir / "bad.json").string() + " -o " + (dir / "bad").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("bad.json: /protocol/variants/sub/test.subsample.stride/source"),
            std::string::npos)
      << r.out;
  fs::remove_all(dir);
}

}  // namespace

// "The same radius" (issue 50): each method's radius parameter for an equal data-term support, per
// method against the kernel table of docs/claims.md, and the outlier claim at those values.
TEST(ProtocolRadius, EqualSupportMapsToEachMethodsOwnParameter) {
  // GPF's data term sees the points within h/4 (h_GPF = h/2, data within h_GPF/2): at h 0.3 its
  // data ball is 0.075, WLOP's support at h 0.3 is 0.3 (the reading issue 50 corrected).
  EXPECT_DOUBLE_EQ(radius_param("filter.gpf", 0.075, "support"), 0.3);
  EXPECT_DOUBLE_EQ(radius_param("filter.gpf", 0.25, "support"), 1.0);
  for (const char* lop :
       {"resample.lop", "resample.wlop", "resample.clop", "normals.csw", "normals.bilateral"})
    EXPECT_DOUBLE_EQ(radius_param(lop, 0.25, "support"), 0.25) << lop;
  EXPECT_DOUBLE_EQ(radius_param("peer.cgal_wlop", 0.25, "support"), 0.5);  // neighbor_radius h/2
  // Equal kernel std: one kernel convention, so one h for every method.
  const double h = radius_param("resample.wlop", 0.01, "std");
  EXPECT_NEAR(h, 0.01 * 4 * std::sqrt(2.0), 1e-12);
  for (const auto& k : kernel_conventions())
    EXPECT_DOUBLE_EQ(radius_param(k.algorithm, 0.01, "std"), h) << k.algorithm;
  EXPECT_THROW(radius_param("normals.pca", 0.1, "support"), scanbench::ParamError);
  EXPECT_THROW(radius_param("filter.gpf", 0.1, "mean"), scanbench::ParamError);
  // The outlier claim says "the same radius": its h values are the mapping's at one support.
  const fs::path file = fs::path(SCANBENCH_TEST_DATA) / ".." / ".." / "configs" / "claims" /
                        "gpf-fig4-18-outliers.json";
  const Claim c = load_claim(file);
  const Json& v = c.experiment["protocol"]["variants"];
  const double support = 0.25;
  EXPECT_DOUBLE_EQ(v["gpf"]["filter.gpf.h"]["value"].get<double>(),
                   radius_param("filter.gpf", support, "support"));
  EXPECT_DOUBLE_EQ(v["wlop"]["resample.wlop.h"]["value"].get<double>(),
                   radius_param("resample.wlop", support, "support"));
}

// Tuning ranges of the verdict's own size (issue 50): an h0_multiples rule resolves from the
// tuning scans' point count, a boundary optimum with the curve still falling extends the range by
// the rule, and past the rule's limit the claim is judged inconclusive.
namespace {

/// "sub" with test.subsample.work_ms (a real parameter standing in for an h) as multiples of h0.
Json experiment_with_h0_rule(const Json& multiples) {
  Json c = experiment_with_protocol();
  c["protocol"]["variants"]["sub"] = {
      {"test.subsample.work_ms",
       {{"source", "tuned"}, {"rule", "h0_multiples"}, {"multiples", multiples}}}};
  return c;
}

/// A runner on synthetic records: the probe (variant "scan-size") sees scans of `n` points, the
/// tuning's err is |work_ms - target|. Keeps the folders it was asked to run into.
RecordsRunner h0_runner(double n, double target, std::vector<std::string>& folders) {
  return [n, target, &folders](const Json& c, const fs::path& out) {
    folders.push_back(out.filename().string());
    std::vector<Json> recs;
    for (const auto& job : expand(parse_experiment(c, "synthetic")).jobs) {
      const double w = job.chain[0]["params"].value("work_ms", 0.0);
      Json r = tuning_record(job.dataset_label, job.variant, job.point, std::abs(w - target));
      r["sizes"] = {{"scan_points", n}};
      recs.push_back(r);
    }
    return recs;
  };
}

}  // namespace

TEST(ProtocolRange, H0MultiplesResolveFromTheTuningScansSize) {
  const Json config = experiment_with_h0_rule({3, 6, 12});
  EXPECT_EQ(param_error(config), "");
  const Protocol declared = parse_protocol(config["protocol"], "p");
  std::vector<std::string> folders;
  // Quick scans (10,000 points): h0 = 0.01; full scans (40,000): h0 = 0.005, their own range.
  const Protocol quick = resolve_protocol(config, declared, "out", h0_runner(1e4, 0.06, folders));
  EXPECT_EQ(quick.params[0].range, std::vector<Json>({0.03, 0.06, 0.12}));
  EXPECT_DOUBLE_EQ(quick.params[0].value.get<double>(), 0.06);
  EXPECT_EQ(folders, std::vector<std::string>({"scan-sizes", "tuning-sub"}));
  const Protocol full = resolve_protocol(config, declared, "out", h0_runner(4e4, 0.03, folders));
  EXPECT_EQ(full.params[0].range, std::vector<Json>({0.015, 0.03, 0.06}));
  EXPECT_EQ(full.params[0].boundary["status"], "interior");
  const Json j = protocol_json(full)["sub"]["test.subsample.work_ms"];
  EXPECT_EQ(j["rule"], "h0_multiples");
  EXPECT_DOUBLE_EQ(j["scan_points"].get<double>(), 4e4);
  EXPECT_DOUBLE_EQ(j["h0"].get<double>(), 0.005);
  // Bad rules: one line naming the field.
  auto broken = [](auto edit) {
    Json c = experiment_with_h0_rule({3, 6, 12});
    edit(c["protocol"]["variants"]["sub"]["test.subsample.work_ms"]);
    return param_error(c);
  };
  const std::string w = "exp.json: /protocol/variants/sub/test.subsample.work_ms";
  EXPECT_EQ(broken([](Json& e) {
              e["multiples"] = {3, 3};
            }),
            w + "/multiples/1: expected positive multiples in ascending order");
  EXPECT_EQ(broken([](Json& e) {
              e["range"] = {1, 2};
            }),
            w + "/range: not used with \"rule\" (the rule gives the range)");
  EXPECT_EQ(broken([](Json& e) { e["rule"] = "h1"; }),
            w + "/rule: expected one of h0_multiples, got 'h1'");
  EXPECT_EQ(broken([](Json& e) { e["extend_limit"] = 0.5; }),
            w + "/extend_limit: expected a number >= 1");
  // No point count in the probe's records: an error, not a guess.
  const RecordsRunner none = [](const Json&, const fs::path&) { return std::vector<Json>{}; };
  EXPECT_THROW(resolve_protocol(config, declared, "out", none), scanbench::Error);
}

TEST(ProtocolRange, BoundaryOptimumExtendsTheRangeOrMakesTheVerdictInconclusive) {
  const Json config = experiment_with_h0_rule({3, 4.5, 6, 9, 12});
  const Protocol declared = parse_protocol(config["protocol"], "p");
  // h0 0.01: declared range 0.03 .. 0.12. The best is at 0.17: the curve still falls at 0.12, so
  // the range grows by the next multiples of ratio 12/9 within 2x (16, 21.33: 0.16, 0.2133).
  std::vector<std::string> folders;
  const Protocol ext = resolve_protocol(config, declared, "out", h0_runner(1e4, 0.17, folders));
  const ProtocolParam& q = ext.params[0];
  EXPECT_EQ(folders, std::vector<std::string>({"scan-sizes", "tuning-sub", "tuning-sub.ext1"}));
  EXPECT_EQ(q.declared_range, std::vector<Json>({0.03, 0.045, 0.06, 0.09, 0.12}));
  EXPECT_EQ(q.range, std::vector<Json>({0.03, 0.045, 0.06, 0.09, 0.12, 0.16, 0.2133}));
  EXPECT_DOUBLE_EQ(q.value.get<double>(), 0.16);
  EXPECT_EQ(q.boundary["status"], "extended");
  EXPECT_EQ(q.boundary["text"],
            "test.subsample.work_ms tuned at the upper boundary 0.12, "
            "extended to 0.2133: optimum 0.16");
  EXPECT_EQ(ext.inconclusive(), "");
  // The lower side: the best near 0.026 (ratio 3/4.5: 2 h0 = 0.02; 1.33 h0 is past 3/2 h0), the
  // curve falling at 0.03 (0.045 is worse), so 0.02 is tried and 0.03 stays the optimum.
  const Protocol low = resolve_protocol(config, declared, "out", h0_runner(1e4, 0.026, folders));
  EXPECT_EQ(low.params[0].range.front(), 0.02);
  EXPECT_EQ(low.params[0].boundary["status"], "extended");
  EXPECT_DOUBLE_EQ(low.params[0].value.get<double>(), 0.03);
  // Past the limit (the best at 0.5): still falling at 0.2133, the protocol is inconclusive and
  // so is a claim that held by its rules.
  const Protocol far = resolve_protocol(config, declared, "out", h0_runner(1e4, 0.5, folders));
  EXPECT_EQ(far.params[0].boundary["status"], "inconclusive");
  EXPECT_EQ(far.inconclusive(),
            "sub test.subsample.work_ms optimum on the upper boundary 0.2133 "
            "(the range extended up to 2x), still falling: inconclusive");
  Claim c;
  c.id = "c";
  ClaimRule r;
  r.what = "sub below 5";
  r.quantity = "err";
  r.a.variant = "sub";
  r.op = "<";
  r.value = 5.0;
  c.rules = {r};
  const std::vector<Json> recs = {
      tuning_record("sphere", "sub", {{"test.subsample.work_ms", 0.2133}}, 1.0)};
  EXPECT_EQ(judge_claim(c, records_at_protocol(recs, far)).verdict, "held");
  const ClaimOutcome o = judge_claim_at_protocol(c, records_at_protocol(recs, far), far);
  EXPECT_EQ(o.verdict, "inconclusive");
  EXPECT_NE(o.reason.find("tuning range not shown wide enough"), std::string::npos) << o.reason;
  const std::vector<Json> at_ext = {
      tuning_record("sphere", "sub", {{"test.subsample.work_ms", 0.16}}, 1.0)};
  EXPECT_EQ(judge_claim_at_protocol(c, records_at_protocol(at_ext, ext), ext).verdict, "held");
  // The sensitivity line says which.
  const std::string s = claim_sensitivity(c, far, recs)["text"].get<std::string>();
  EXPECT_NE(s.find("[test.subsample.work_ms optimum on the upper boundary 0.2133"),
            std::string::npos)
      << s;
}

// A fixed range (issue 50): a falling boundary is extended by the range's own ratio as far as the
// parameter's declaration allows; still falling past the limit is inconclusive, at the end of the
// parameter's own domain it is stated and the verdict stands.
TEST(ProtocolRange, FixedRangesExtendByTheirRatioWithinTheParametersDomain) {
  Json config = experiment_with_protocol();
  config["protocol"]["variants"]["sub"]["test.subsample.stride"]["range"] = {2, 4, 8};
  const Protocol declared = parse_protocol(config["protocol"], "p");
  std::vector<std::string> folders;
  // err = |stride - target| on every dataset.
  auto runner = [&folders](double target) -> RecordsRunner {
    return [target, &folders](const Json& c, const fs::path& out) {
      folders.push_back(out.filename().string());
      std::vector<Json> recs;
      for (const auto& job : expand(parse_experiment(c, "synthetic")).jobs) {
        const double stride = job.chain[0]["params"]["stride"].get<double>();
        recs.push_back(
            tuning_record(job.dataset_label, job.variant, job.point, std::abs(stride - target)));
      }
      return recs;
    };
  };
  // Upper side: ratio 2, limit 2 x 8: 16 is tried; the best at 30 still falls there.
  const Protocol up = resolve_protocol(config, declared, "out", runner(30));
  EXPECT_EQ(up.params[0].range, std::vector<Json>({2, 4, 8, 16}));
  EXPECT_EQ(up.params[0].value, 16);
  EXPECT_EQ(up.params[0].boundary["status"], "inconclusive");
  EXPECT_EQ(up.inconclusive(),
            "sub test.subsample.stride optimum on the upper boundary 16 (the range extended up to "
            "2x), still falling: inconclusive");
  // A wider limit reaches the optimum: 16, 32 within 4 x 8; the curve rises at 32.
  Json wide = config;
  wide["protocol"]["variants"]["sub"]["test.subsample.stride"]["extend_limit"] = 4;
  const Protocol reach =
      resolve_protocol(wide, parse_protocol(wide["protocol"], "p"), "out", runner(17));
  EXPECT_EQ(reach.params[0].range, std::vector<Json>({2, 4, 8, 16, 32}));
  EXPECT_EQ(reach.params[0].value, 16);
  EXPECT_EQ(reach.params[0].boundary["status"], "extended");
  // Lower side: stride 1 is tried (ratio 1/2), the best at 0 still falls there, but stride 1 is
  // the parameter's own minimum: stated, not inconclusive.
  const Protocol low = resolve_protocol(config, declared, "out", runner(0));
  EXPECT_EQ(low.params[0].range, std::vector<Json>({1, 2, 4, 8}));
  EXPECT_EQ(low.params[0].value, 1);
  EXPECT_EQ(low.params[0].boundary["status"], "limit");
  EXPECT_EQ(low.params[0].boundary["text"],
            "test.subsample.stride optimum at 1, the end of the parameter's own domain (still "
            "falling)");
  EXPECT_EQ(low.inconclusive(), "");
  // A ratio that overshoots the limit (3 -> 0.5 of 2 with limit 2: 1 by the limit itself).
  Json steep = config;
  steep["protocol"]["variants"]["sub"]["test.subsample.stride"]["range"] = {6, 36};
  const Protocol lim =
      resolve_protocol(steep, parse_protocol(steep["protocol"], "p"), "out", runner(0));
  EXPECT_EQ(lim.params[0].range, std::vector<Json>({3, 6, 36}));
  EXPECT_EQ(lim.params[0].boundary["status"], "inconclusive");
  // Bad limits are refused.
  Json bad = config;
  bad["protocol"]["variants"]["sub"]["test.subsample.stride"]["extend_limit"] = 0.5;
  EXPECT_EQ(param_error(bad),
            "exp.json: /protocol/variants/sub/test.subsample.stride/extend_limit: expected a "
            "number >= 1");
}

// Joint tuning: extending one parameter can move the optimum of another to its other side; each
// side is extended once, so the move is followed, not judged inconclusive.
TEST(ProtocolRange, EachSideOfARangeIsExtendedOnce) {
  Json config = experiment_with_protocol();
  config["protocol"]["variants"]["sub"] = {
      {"test.subsample.stride", {{"source", "tuned"}, {"range", {2, 4, 8}}}},
      {"test.subsample.work_ms", {{"source", "tuned"}, {"range", {1, 2, 4}}}}};
  const Protocol declared = parse_protocol(config["protocol"], "p");
  std::vector<std::string> folders;
  const RecordsRunner run = [&folders](const Json& c, const fs::path& out) {
    folders.push_back(out.filename().string());
    std::vector<Json> recs;
    for (const auto& job : expand(parse_experiment(c, "synthetic")).jobs) {
      const int stride = job.chain[0]["params"]["stride"].get<int>();
      const double w = job.chain[0]["params"]["work_ms"].get<double>();
      // First best at (8, 4), both on their upper boundaries; once work_ms reaches 8 the best is
      // (2, 8), stride's lower boundary, where 1 is worse.
      double err = 3.0;
      if (stride == 8 && w == 4) err = 1.0;
      if (stride == 2 && w == 8) err = 0.5;
      if (stride == 1 && w == 8) err = 0.7;
      recs.push_back(tuning_record(job.dataset_label, job.variant, job.point, err));
    }
    return recs;
  };
  const Protocol p = resolve_protocol(config, declared, "out", run);
  const ProtocolParam& stride = p.params[0];
  EXPECT_EQ(folders, std::vector<std::string>(
                         {"tuning-sub", "tuning-sub.ext1", "tuning-sub.ext2", "tuning-sub.ext3"}));
  EXPECT_EQ(stride.range, std::vector<Json>({1, 2, 4, 8, 16}));
  EXPECT_EQ(stride.value, 2);
  EXPECT_EQ(stride.boundary["status"], "extended");
  EXPECT_EQ(stride.boundary["text"],
            "test.subsample.stride tuned at the lower boundary 2, extended to 1; at the upper "
            "boundary 8, extended to 16: optimum 2");
  // work_ms still falls at 8, its upper side already extended once: inconclusive.
  EXPECT_EQ(p.params[1].value, 8);
  EXPECT_EQ(p.params[1].boundary["status"], "inconclusive");
}
