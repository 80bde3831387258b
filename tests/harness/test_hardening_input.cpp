// Issue 48, "No crash on any input" (docs/hardening.md): the checked JSON reader, sweep products
// capped before expansion, numbers parsed without std::stod, labels and names that cannot become
// paths outside the results folder, plugin files checked before dlopen.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "cli_test_util.h"
#include "experiment_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/harness/config/claim_file.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/protocol.h"

namespace scanbench::test {
namespace {

std::string nested(std::size_t depth, const std::string& inner = "1") {
  return std::string(depth, '[') + inner + std::string(depth, ']');
}

/// The message of the scanbench error `f` throws ("" when it throws none).
template <class E, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "";
}

TEST(InputJsonText, ParsesValidTextWithCommentsWhenAsked) {
  const Json j = parse_json_text("{\"a\": [1, 2.5, \"x\"], // note\n \"b\": {\"c\": null}}",
                                 "t.json", {/*ignore_comments=*/true});
  EXPECT_EQ(j["a"][1].get<double>(), 2.5);
  EXPECT_TRUE(j["b"]["c"].is_null());
  // Key order is kept (ordered_json).
  EXPECT_EQ(j.begin().key(), "a");
  const std::string msg =
      error_of<IoError>([] { (void)parse_json_text("{\"a\": 1 // note\n}", "t.json"); });
  EXPECT_EQ(msg.rfind("t.json: not valid JSON: ", 0), 0u) << msg;
}

TEST(InputJsonText, MalformedTextNamesWhereAndPosition) {
  const std::string msg =
      error_of<IoError>([] { (void)parse_json_text("{\"a\": [1,\n 2,, 3]}", "cfg.json"); });
  EXPECT_EQ(msg.rfind("cfg.json: not valid JSON: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("line 2, column"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_NE(error_of<IoError>([] { (void)parse_json_text("", "empty.json"); }), "");
  EXPECT_NE(error_of<IoError>([] { (void)parse_json_text("[1] [2]", "two.json"); }), "");
}

TEST(InputJsonText, DepthLimitIsExact) {
  EXPECT_EQ(parse_json_text(nested(kJsonMaxDepth), "ok.json").dump(), nested(kJsonMaxDepth));
  EXPECT_EQ(
      error_of<IoError>([] { (void)parse_json_text(nested(kJsonMaxDepth + 1), "deep.json"); }),
      "deep.json: JSON nested deeper than 100 levels");
  JsonTextOptions shallow;
  shallow.max_depth = 2;
  EXPECT_NO_THROW((void)parse_json_text("{\"a\": [1]}", "x", shallow));
  EXPECT_EQ(error_of<IoError>([&] { (void)parse_json_text("{\"a\": [{}]}", "x", shallow); }),
            "x: JSON nested deeper than 2 levels");
}

// 200,000 levels: nlohmann builds such a value and then overflows the stack copying or dumping
// it (the crash of issue 48). The limit refuses it before a value is built, in objects as well as
// arrays, and even when the text is cut off after the opening brackets.
TEST(InputJsonText, RefusesDeepNestingBeforeBuildingAValue) {
  const std::string arrays = nested(200000);
  EXPECT_EQ(error_of<IoError>([&] { (void)parse_json_text(arrays, "a.json"); }),
            "a.json: JSON nested deeper than 100 levels");
  std::string objects;
  for (int i = 0; i < 200000; ++i)
    objects += "{\"k\":";
  EXPECT_EQ(error_of<IoError>([&] { (void)parse_json_text(objects, "o.json"); }),
            "o.json: JSON nested deeper than 100 levels");
}

// A command line's `--set key=value` (algo, scan, eval): a JSON array or object goes through the
// checked reader, a scalar is itself, any other text is a string.
TEST(InputJsonText, AssignedValuesGoThroughTheCheckedReader) {
  EXPECT_EQ(parse_assigned_value("3", "w"), Json(3));
  EXPECT_EQ(parse_assigned_value("true", "w"), Json(true));
  EXPECT_EQ(parse_assigned_value("\"a b\"", "w"), Json("a b"));
  EXPECT_EQ(parse_assigned_value("exact", "w"), Json("exact"));
  EXPECT_EQ(parse_assigned_value(" [1, 2]", "w"), Json::parse("[1, 2]"));
  EXPECT_EQ(parse_assigned_value("{\"a\": 1}", "w"), Json::parse("{\"a\": 1}"));
  EXPECT_EQ(error_of<IoError>([&] { (void)parse_assigned_value(nested(200000), "--set x"); }),
            "--set x: JSON nested deeper than 100 levels");
  EXPECT_NE(error_of<IoError>([&] {
              (void)parse_assigned_value("[1,", "--set x");
            }).find("--set x: not valid JSON"),
            std::string::npos);
  Json obj = Json::object();
  EXPECT_EQ(error_of<IoError>([&] { apply_assignment(obj, "a.b=" + nested(200000)); }),
            "--set a.b: JSON nested deeper than 100 levels");
  apply_assignment(obj, "a.b=[0.5]");
  EXPECT_EQ(obj, Json::parse(R"({"a": {"b": [0.5]}})"));
}

TEST(InputJsonText, DuplicateKeysNamedByJsonPointerWhenAsked) {
  const std::string text = R"({"a": [{"b": 1}, {"b": 1, "c/d": {"x": 1, "x": 2}}]})";
  EXPECT_NO_THROW((void)parse_json_text(text, "t.json"));
  JsonTextOptions strict;
  strict.reject_duplicate_keys = true;
  EXPECT_EQ(error_of<ParamError>([&] { (void)parse_json_text(text, "t.json", strict); }),
            "t.json: /a/1/c~1d/x: duplicate key (JSON keeps only one of them)");
  // The same key in sibling objects is not a duplicate.
  EXPECT_NO_THROW((void)parse_json_text(R"([{"b": 1}, {"b": 2}])", "t.json", strict));
}

TEST(InputJsonText, ParseJsonFileNamesTheFileAndTheReason) {
  const fs::path dir = make_temp_dir("json-text");
  const std::string msg =
      error_of<IoError>([&] { (void)parse_json_file(dir / "absent.json", "scanner preset"); });
  EXPECT_EQ(msg, (dir / "absent.json").string() +
                     ": cannot open scanner preset: No such file or directory");
  write(dir / "deep.json", nested(200000));
  EXPECT_EQ(error_of<IoError>([&] { (void)parse_json_file(dir / "deep.json", "config"); }),
            (dir / "deep.json").string() + ": JSON nested deeper than 100 levels");
  fs::remove_all(dir);
}

// --- Through the binary, under a memory limit ------------------------------------------------

/// `scanbench ARGS` run in `dir` under a 2 GiB address-space limit (a recursive copy of a deep
/// value or a 1e12-job expansion would crash or exhaust it), stderr merged.
Result sb_limited(const fs::path& dir, const std::string& args) {
  return sh("cd '" + dir.string() + "' && " + memory_limit(2048) + "SCANBENCH_TEST_ALGORITHMS=1 " +
            sb() + " " + args);
}

/// A one-line error: exit 2, exactly one line, starting "scanbench: " and containing `what`.
void expect_one_line(const Result& r, const std::string& what) {
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
}

/// The config of the CLI tests, with `extra` members (JSON text) inserted at the top level.
std::string config_with(const std::string& extra, bool with_seed = true,
                        const std::string& name = "t") {
  return "{\"scanbench_experiment\": 1, \"name\": " + Json(name).dump() + ", " +
         (with_seed ? "\"seed\": 1, " : "") +
         R"("save_outputs": false, "datasets": [{"name": "sphere"}],
             "scanners": [{"preset": "clean", "params": {"views": 1, "resolution": 16}}],
             "metrics": ["regularity.nn_dist"], )" +
         extra + "}";
}

const std::string kSubsample = R"("variants": [{"label": "s", "algorithm": "test.subsample"}])";

/// Every entry below `dir`, as paths relative to it (what a run may have written).
std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    out.push_back(fs::relative(e.path(), dir).string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(InputDeepJson, RefusedInOneLineWhereverItIs) {
  const fs::path dir = make_temp_dir("deep-json");
  const std::string deep = nested(200000, "");
  write(dir / "description.json", config_with("\"description\": " + deep + ", " + kSubsample));
  write(dir / "parameter.json",
        config_with(R"("variants": [{"label": "s", "algorithm": "test.subsample",
                                     "params": {"stride": )" +
                    deep + "}}]"));
  write(dir / "seeds.json", config_with("\"seeds\": " + deep + ", " + kSubsample, false));
  for (const char* f : {"description.json", "parameter.json", "seeds.json"}) {
    SCOPED_TRACE(f);
    expect_one_line(sb_limited(dir, std::string("run ") + f + " -q -o out"),
                    std::string(f) + ": JSON nested deeper than 100 levels");
  }
  // A scanner preset file (scan --preset FILE).
  write(dir / "preset.json", "{\"params\": {\"views\": " + deep + "}}");
  expect_one_line(
      sb_limited(dir, "scan --dataset sphere --preset preset.json -o scan.ply --seed 1"),
      "preset.json: JSON nested deeper than 100 levels");
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

TEST(InputSweepProduct, CappedBeforeExpansion) {
  const fs::path dir = make_temp_dir("sweep-cap");
  const std::string range = R"({"from": 1, "to": 1000, "count": 1000})";
  // 1e6 points: two swept parameters of one step; 1e12: four, over two steps.
  write(dir / "million.json",
        config_with(R"("variants": [{"label": "s", "chain": [{"algorithm": "test.subsample",
                      "label": "a"}], "sweep": {"a.stride": )" +
                    range + ", \"a.work_ms\": " + range + "}}]"));
  write(dir / "trillion.json",
        config_with(R"("variants": [{"label": "s", "chain": [
                         {"algorithm": "test.subsample", "label": "a"},
                         {"algorithm": "test.subsample", "label": "b"}], "sweep": {"a.stride": )" +
                    range + ", \"a.work_ms\": " + range + ", \"b.stride\": " + range +
                    ", \"b.work_ms\": " + range + "}}]"));
  expect_one_line(sb_limited(dir, "run million.json -q -o out"),
                  "million.json: /variants/0/sweep: 1000000 jobs");
  expect_one_line(sb_limited(dir, "run trillion.json -q -o out"),
                  "trillion.json: /variants/0/sweep: 1e+12 jobs");
  // Seeds multiply too: 1000 points x 101 seeds is over the cap, named at the variant's sweep.
  std::string seeds = "[1";
  for (int i = 2; i <= 101; ++i)
    seeds += "," + std::to_string(i);
  seeds += "]";
  write(dir / "seeds.json",
        config_with(R"("seeds": )" + seeds + R"(, "variants": [{"label": "s", "chain": [{
                      "algorithm": "test.subsample", "label": "a"}], "sweep": {"a.stride": )" +
                        range + "}}]",
                    false));
  expect_one_line(sb_limited(dir, "run seeds.json -q -o out"),
                  "seeds.json: /variants/0/sweep: 101000 jobs");
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

// std::stod threw out_of_range on a subnormal bound (exit 3 "internal error: stod").
TEST(InputNumbers, SubnormalSweepBoundRuns) {
  const fs::path dir = make_temp_dir("subnormal");
  write(dir / "tiny.json", config_with(kSubsample + R"(, "sweep": {"scanner.noise_sigma":
                                    {"from": 1e-308, "to": 1e-307, "count": 2}})"));
  const Result r = sb_limited(dir, "run tiny.json -q -o out");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
  const std::vector<Json> records = read_jsonl(dir / "out" / "runs.jsonl");
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0]["point"]["scanner.noise_sigma"].get<double>(), 1e-308);
  fs::remove_all(dir);
}

TEST(InputLabels, CheckLabelRules) {
  using harness::check_label;
  for (const std::string ok : {"clop", "resample.clop+normals.pca", "a b=1", "..x", "x..", "é"})
    EXPECT_NO_THROW(check_label(ok, "w")) << ok;
  const auto refused = [](const std::string& label) {
    return error_of<ParamError>([&] { check_label(label, "cfg.json: /variants/0/label"); });
  };
  EXPECT_EQ(refused("../x"),
            "cfg.json: /variants/0/label: \"../x\" contains '/' (labels and "
            "names become file names in the results folder)");
  EXPECT_NE(refused("a\\b").find("contains '\\'"), std::string::npos);
  EXPECT_NE(refused("..").find("is not a name"), std::string::npos);
  EXPECT_NE(refused(".").find("is not a name"), std::string::npos);
  EXPECT_NE(refused("").find("is empty"), std::string::npos);
  EXPECT_EQ(refused("a\nb"), "cfg.json: /variants/0/label: \"a\\nb\" contains a control character");
  EXPECT_NE(refused(std::string(1, '\x7f')).find("control character"), std::string::npos);
  EXPECT_NO_THROW(check_label(std::string(harness::kMaxLabelLength, 'a'), "w"));
  const std::string too_long = refused(std::string(harness::kMaxLabelLength + 1, 'a'));
  EXPECT_NE(too_long.find("is longer than 100 bytes (101)"), std::string::npos) << too_long;
  EXPECT_LT(too_long.size(), 200u) << too_long;
}

TEST(InputLabels, EveryLabelAndNameOfAConfigIsChecked) {
  const auto cfg = [](const Json& over) {
    Json c = Json::parse(R"({"scanbench_experiment": 1, "datasets": [{"name": "sphere"}],
      "scanners": ["moderate"], "variants": [{"algorithm": "resample.wlop"}]})");
    c.merge_patch(over);
    return c;
  };
  const auto error = [&](const std::string& over) {
    return experiment_load_error(cfg(Json::parse(over)));
  };
  EXPECT_EQ(error("{}"), "");
  EXPECT_NE(error(R"({"name": "../up"})").find("cfg.json: /name: \"../up\""), std::string::npos);
  EXPECT_NE(error(R"({"datasets": [{"name": "sphere", "label": ".."}]})")
                .find("cfg.json: /datasets/0/label: \"..\" is not a name"),
            std::string::npos);
  EXPECT_NE(error(R"({"datasets": [{"name": "meshes/../.."}]})").find("cfg.json: /datasets/0/name"),
            std::string::npos);
  EXPECT_NE(error(R"({"scanners": [{"preset": "moderate", "label": "a/b"}]})")
                .find("cfg.json: /scanners/0/label"),
            std::string::npos);
  EXPECT_NE(error(R"({"variants": [{"label": "v\u0001", "algorithm": "resample.wlop"}]})")
                .find("cfg.json: /variants/0/label"),
            std::string::npos);
  EXPECT_NE(error(R"({"variants": [{"chain": [{"algorithm": "resample.wlop", "label": "a/b"}]}]})")
                .find("cfg.json: /variants/0/chain/0/label"),
            std::string::npos);
  // A derived variant label (the step labels joined by '+') is held to the same length limit.
  Json long_chain = Json::array();
  for (int i = 0; i < 5; ++i)
    long_chain.push_back(
        {{"algorithm", "resample.wlop"}, {"label", std::string(30, 'a' + static_cast<char>(i))}});
  EXPECT_NE(experiment_load_error(cfg({{"variants", {{{"chain", long_chain}}}}}))
                .find("cfg.json: /variants/0: the label made of the step labels is longer"),
            std::string::npos);
  // A sweep's string values end up in table cells: no control characters.
  EXPECT_NE(error(R"({"variants": [{"algorithm": "resample.wlop",
                       "sweep": {"resample.wlop.h": ["a\nb"]}}]})")
                .find("cfg.json: /variants/0/sweep/resample.wlop.h/0"),
            std::string::npos);
}

// Issue 48: an experiment name with "../" wrote outside results/ (no -o), a variant label with
// "../" its tuning records outside -o. Both are refused when the config is read: nothing written.
TEST(InputLabels, NothingWrittenOutsideTheFolder) {
  const fs::path dir = make_temp_dir("labels");
  fs::create_directories(dir / "work" / "here");
  write(dir / "work" / "here" / "name.json", config_with(kSubsample, true, "../../outside"));
  write(dir / "work" / "here" / "label.json",
        config_with(R"("variants": [{"label": "../../escape", "algorithm": "test.subsample",
                                      "params": {"stride": 2}}])"));
  const std::vector<std::string> before = listing(dir);
  expect_one_line(sb_limited(dir / "work" / "here", "run name.json -q"),
                  "name.json: /name: \"../../outside\" contains '/'");
  expect_one_line(sb_limited(dir / "work" / "here", "run label.json -q -o out"),
                  "label.json: /variants/0/label: \"../../escape\" contains '/'");
  EXPECT_EQ(listing(dir), before);
  fs::remove_all(dir);
}

TEST(InputLabels, ClaimIdIsALabel) {
  const fs::path dir = make_temp_dir("claim-id");
  write(dir / "c.json", R"({"scanbench_claim": 1, "id": "../../x", "claim": "c", "source": "s",
    "experiment": {"scanbench_experiment": 1, "datasets": ["sphere"], "scanners": ["moderate"],
                   "variants": [{"algorithm": "resample.wlop"}]},
    "rules": [{"kind": "threshold"}]})");
  const std::string msg = error_of<ParamError>([&] { (void)harness::load_claim(dir / "c.json"); });
  EXPECT_NE(msg.find("c.json: /id: \"../../x\" contains '/'"), std::string::npos) << msg;
  fs::remove_all(dir);
}

TEST(InputLabels, ProtocolVariantLabelIsALabel) {
  const Json protocol = Json::parse(R"({"variants": {"../../x": {"resample.wlop.h": {}}}})");
  const std::string msg =
      error_of<ParamError>([&] { (void)harness::parse_protocol(protocol, "cfg.json: /protocol"); });
  EXPECT_EQ(msg.rfind("cfg.json: /protocol/variants: \"../../x\" contains '/'", 0), 0u) << msg;
}

// Every shipped config and claim still loads under the label, depth and job-count checks.
TEST(InputLabels, ShippedConfigsAndClaimsLoad) {
  const fs::path configs = fs::path(SCANBENCH_TEST_DATA).parent_path().parent_path() / "configs";
  int n = 0;
  for (const auto& e : fs::directory_iterator(configs)) {
    if (e.path().extension() != ".json") continue;
    EXPECT_NO_THROW((void)harness::load_experiment(e.path())) << e.path();
    ++n;
  }
  EXPECT_GE(n, 5);
  EXPECT_GE(harness::load_claims(configs / "claims", "").size(), 10u);
}

// --- Plugins --------------------------------------------------------------------------------

/// A real shared library of this build: a test plugin when the plugin tests were built, else
/// the core library the binary itself loads (a truncated copy of either makes dlopen SIGBUS).
fs::path real_shared_library() {
  const fs::path build = fs::path(SCANBENCH_BINARY).parent_path().parent_path();
  const fs::path plugin = build / "tests" / "libtest_plugin_throwing.so";
  if (fs::exists(plugin)) return plugin;
  return fs::canonical(build / "core" / "libscanbench_core.so");
}

TEST(InputPlugins, TruncatedSharedLibraryRefusedBeforeDlopen) {
  const fs::path dir = make_temp_dir("plugin-elf");
  const fs::path lib = real_shared_library();
  const std::string bytes = slurp(lib);
  ASSERT_GT(bytes.size(), 4096u) << lib;
  for (const std::size_t keep : {bytes.size() / 2, bytes.size() / 10, std::size_t{100}}) {
    SCOPED_TRACE(keep);
    write(dir / "cut.so", bytes.substr(0, keep));
    const Result r = sb_limited(dir, "--plugin cut.so list metrics");
    expect_one_line(r, "not a complete shared library");
    EXPECT_NE(r.out.find(fmt::format("beyond the file's {} bytes", keep)), std::string::npos)
        << r.out;
  }
  write(dir / "text.so", "not an ELF file at all");
  expect_one_line(sb_limited(dir, "--plugin text.so list metrics"),
                  "text.so: not a shared library (no ELF header)");
  // A complete library passes the check (and fails later, or loads, for its own reasons).
  write(dir / "whole.so", bytes);
  const Result whole = sb_limited(dir, "--plugin whole.so list metrics");
  EXPECT_EQ(whole.out.find("not a complete shared library"), std::string::npos) << whole.out;
  EXPECT_NE(whole.code, -1) << whole.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scanbench::test
