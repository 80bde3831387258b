// compare/nightly name a baseline that ran another SIMD path (records' context.isa) and still judge
// accuracy by the tolerances.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "scanbench/harness/results/compare.h"

namespace scanbench::harness {
namespace {

Json record(const std::string& isa, double p2plane) {
  Json r = Json::object();
  r["key"] = "camel|scan|clop|0|1";
  r["status"] = "ok";
  r["metrics"] = {{"p2plane_mean", p2plane}};
  r["context"] = {{"isa", isa}};
  return r;
}

TEST(CompareIsa, NamesADifferentBaselineIsaAndKeepsTolerances) {
  const std::vector<Json> base{record("sse2", 1.0e-3)};
  // Within the default 5% tolerance: the same, not a regression, on another ISA.
  const std::vector<Json> now{record("avx2", 1.0e-3 * (1.0 + 1e-6))};
  const CompareResult r = compare_records(base, now, CompareOptions{});
  EXPECT_FALSE(r.regressed()) << r.table(true);
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("sse2"), std::string::npos) << r.notes[0];
  EXPECT_NE(r.notes[0].find("avx2"), std::string::npos) << r.notes[0];
  EXPECT_NE(r.table().find("Note: "), std::string::npos);
  EXPECT_EQ(r.to_json()["isa"]["base"][0], "sse2");
  EXPECT_EQ(r.to_json()["isa"]["new"][0], "avx2");
  // A real change beyond the tolerance is still a regression.
  const CompareResult worse = compare_records(base, {record("avx2", 2.0e-3)}, CompareOptions{});
  EXPECT_TRUE(worse.regressed());
}

TEST(CompareIsa, SameIsaAndUnrecordedBaselines) {
  const CompareResult same =
      compare_records({record("avx2", 1e-3)}, {record("avx2", 1e-3)}, CompareOptions{});
  EXPECT_TRUE(same.notes.empty());
  Json old = record("sse2", 1e-3);
  old.erase("context");  // written before the ISA was recorded
  const CompareResult r = compare_records({old}, {record("avx2", 1e-3)}, CompareOptions{});
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("unrecorded"), std::string::npos) << r.notes[0];
}

}  // namespace
}  // namespace scanbench::harness
