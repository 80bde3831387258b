#include <gtest/gtest.h>

#include "scanbench/core/params.h"

namespace scanbench {
namespace {

struct DemoParams {
  double h = 0.04;
  int iterations = 10;
  bool flag = false;
  std::string mode = "fast";
  static void declare(ParamDeclarer<DemoParams>& d) {
    d.real("h", &DemoParams::h, Range::above(0.0), "diag", "kernel support");
    d.integer("iterations", &DemoParams::iterations, Range::closed(1, 100), "", "iterations");
    d.flag("flag", &DemoParams::flag, "a switch");
    d.choice("mode", &DemoParams::mode, {"fast", "exact"}, "mode");
  }
};

std::string error_of(const Json& j) {
  try {
    params_from_json<DemoParams>(j, "cfg.json: /p");
  } catch (const ParamError& e) {
    return e.what();
  }
  return "";
}

TEST(Params, DefaultsAndSchema) {
  const auto& s = schema_of<DemoParams>();
  ASSERT_EQ(s.params().size(), 4u);
  EXPECT_EQ(s.params()[0].name, "h");
  EXPECT_EQ(s.params()[0].default_value.get<double>(), 0.04);
  EXPECT_EQ(s.params()[1].range.max, 100);
  const Json j = s.to_json();
  EXPECT_TRUE(j[0]["max"].is_null());
  EXPECT_EQ(j[1]["min"].dump(), "1");  // integer bounds print as integers
  EXPECT_EQ(j[3]["choices"].size(), 2u);
}

TEST(Params, ParsesAndRoundTrips) {
  const auto p = params_from_json<DemoParams>(
      Json::parse(R"({"h": 0.1, "iterations": 3, "flag": true, "mode": "exact"})"), "x");
  EXPECT_EQ(p.h, 0.1);
  EXPECT_EQ(p.iterations, 3);
  EXPECT_TRUE(p.flag);
  EXPECT_EQ(p.mode, "exact");
  const Json back = params_to_json(p);
  EXPECT_EQ(back.dump(), R"({"h":0.1,"iterations":3,"flag":true,"mode":"exact"})");
  // An integer literal is a valid real.
  EXPECT_EQ(params_from_json<DemoParams>(Json::parse(R"({"h": 1})"), "x").h, 1.0);
}

TEST(Params, RejectsUnknownKeysWrongTypesAndRanges) {
  EXPECT_NE(error_of(Json::parse(R"({"hh": 0.1})")).find("cfg.json: /p.hh: unknown parameter"),
            std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"({"h": "0.1"})")).find("/p.h: expected a number"),
            std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"({"h": 0})")).find("/p.h: expected a number in (0, inf)"),
            std::string::npos);
  EXPECT_NE(
      error_of(Json::parse(R"({"iterations": 2.5})")).find("/p.iterations: expected an integer"),
      std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"({"iterations": 101})")).find("[1, 100]"), std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"({"flag": 1})")).find("/p.flag: expected a boolean"),
            std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"({"mode": "slow"})")).find("expected one of fast|exact"),
            std::string::npos);
  EXPECT_NE(error_of(Json::parse(R"([1, 2])")).find("expected an object"), std::string::npos);
}

TEST(Params, Assignments) {
  Json j = Json::object();
  apply_assignment(j, "h=0.5");
  apply_assignment(j, "mode=exact");
  apply_assignment(j, "scanner.noise=0.01");
  apply_assignment(j, "flag=true");
  EXPECT_EQ(j["h"].get<double>(), 0.5);
  EXPECT_EQ(j["mode"].get<std::string>(), "exact");
  EXPECT_EQ(j["scanner"]["noise"].get<double>(), 0.01);
  EXPECT_TRUE(j["flag"].get<bool>());
  EXPECT_THROW(apply_assignment(j, "novalue"), ParamError);
  EXPECT_THROW(apply_assignment(j, "=3"), ParamError);
}

TEST(Params, RangeText) {
  EXPECT_EQ(Range::half_open(0, 0.5).to_string(), "[0, 0.5)");
  EXPECT_FALSE(Range::half_open(0, 0.5).contains(0.5));
  EXPECT_FALSE(Range::closed(0, 1).contains(std::nan("")));
}

}  // namespace
}  // namespace scanbench
