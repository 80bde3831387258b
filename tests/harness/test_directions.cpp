// compare, table and report take each metric's direction from its registry entry
// (metrics/registry.h): a gain in normal quality or volume IoU is an improvement and the best
// cell, a change in a vertex count is informational.
#include <gtest/gtest.h>

#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/table.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::harness {
namespace {

Json record(const std::string& variant, const Json& metrics) {
  Json r = Json::object();
  r["id"] = r["key"] = "sphere|clean|" + variant;
  r["status"] = "ok";
  r["dataset"] = {{"label", "sphere"}};
  r["scanner"] = {{"label", "clean"}};
  r["variant"] = {{"label", variant}, {"chain", Json::array()}};
  r["point_label"] = "";
  r["seed"] = 1;
  r["metrics"] = metrics;
  r["timing"] = {{"total_s", {1.0}}};
  return r;
}

TEST(Directions, QuantityDirectionFollowsTheRegistry) {
  // Every key of every registered metric maps to its declared direction.
  for (const auto& e : metrics::registry().entries())
    for (const auto& k : e.fn.keys) {
      const int want = k.better == metrics::Better::Lower    ? -1
                       : k.better == metrics::Better::Higher ? 1
                                                             : 0;
      EXPECT_EQ(quantity_direction(k.key), want) << k.key;
      EXPECT_EQ(CompareOptions{}.tolerance(k.key).better, want) << k.key;
    }
  EXPECT_EQ(quantity_direction("normal_pgp5"), 1);
  EXPECT_EQ(quantity_direction("normal_pgp10"), 1);
  EXPECT_EQ(quantity_direction("volume_iou"), 1);
  EXPECT_EQ(quantity_direction("mesh_vertices"), 0);
  EXPECT_EQ(quantity_direction("time.total"), -1);
  EXPECT_EQ(quantity_direction("peak_rss_mb"), -1);
  EXPECT_EQ(quantity_direction("sizes.mesh_faces"), 0);
  EXPECT_EQ(quantity_direction("undeclared_thing"), 0);
}

TEST(Directions, CompareCallsHigherNormalQualityAnImprovement) {
  const std::vector<Json> base{record("v", {{"normal_pgp5", 0.5},
                                            {"normal_pgp10", 0.6},
                                            {"volume_iou", 0.8},
                                            {"normal_angle_mean_deg", 10.0},
                                            {"mesh_vertices", 100}})};
  const std::vector<Json> now{record("v", {{"normal_pgp5", 0.9},
                                           {"normal_pgp10", 0.95},
                                           {"volume_iou", 0.9},
                                           {"normal_angle_mean_deg", 5.0},
                                           {"mesh_vertices", 200}})};
  const CompareResult r = compare_records(base, now, CompareOptions{});
  EXPECT_FALSE(r.regressed()) << r.table(true);
  std::map<std::string, std::string> v;
  for (const auto& x : r.verdicts)
    v[x.quantity] = x.verdict;
  EXPECT_EQ(v["normal_pgp5"], "improvement");
  EXPECT_EQ(v["normal_pgp10"], "improvement");
  EXPECT_EQ(v["volume_iou"], "improvement");
  EXPECT_EQ(v["normal_angle_mean_deg"], "improvement");
  EXPECT_EQ(v["mesh_vertices"], "changed");
  // The other way round, each quality loss is a regression.
  const CompareResult back = compare_records(now, base, CompareOptions{});
  EXPECT_EQ(back.regressions, 4) << back.table(true);
}

TEST(Directions, TableMarksTheHighestIouBestAndCountsNone) {
  const std::vector<Json> rs{record("a", {{"volume_iou", 0.7}, {"mesh_faces", 10}}),
                             record("b", {{"volume_iou", 0.9}, {"mesh_faces", 20}})};
  TableSpec spec;
  spec.metric = "volume_iou";
  const Table t = build_table(rs, spec);
  EXPECT_TRUE(t.higher_better);
  EXPECT_FALSE(t.cells[0][0].best);
  EXPECT_TRUE(t.cells[0][1].best);
  EXPECT_NE(render_table(t, "md").find("higher is better"), std::string::npos);
  spec.metric = "mesh_faces";
  const Table f = build_table(rs, spec);
  EXPECT_EQ(f.better, 0);
  EXPECT_FALSE(f.cells[0][0].best || f.cells[0][1].best);
  EXPECT_NE(render_table(f, "md").find("informational"), std::string::npos);
}

}  // namespace
}  // namespace scanbench::harness
