// Issue 48, "No crash on any input" (docs/hardening.md): the checked JSON reader, sweep products
// capped before expansion, numbers parsed without std::stod, labels and names that cannot become
// paths outside the results folder, plugin files checked before dlopen.
#include <gtest/gtest.h>

#include <string>

#include "cli_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"

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

}  // namespace
}  // namespace scanbench::test
