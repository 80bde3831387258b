// Chains are type-checked when a config loads: a step that consumes a kind the steps before it do
// not provide fails with the file, the JSON path of the step and its name; the chains of the
// reconstruction and CSW configs load.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "experiment_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/config/experiment.h"

namespace scanbench::harness {
namespace {

Json config_with(const Json& variant) {
  Json c = Json::parse(R"({
    "scanbench_experiment": 1,
    "name": "t",
    "seed": 3,
    "datasets": [{"name": "sphere"}],
    "scanners": ["clean"]
  })");
  c["variants"] = Json::array({variant});
  return c;
}

TEST(Chains, AStepMissingTheMixtureFailsAtLoadNamingTheStep) {
  // normals.csw consumes the mixture of mixture.hem; normals.pca provides only points.
  const std::string e =
      test::experiment_load_error(config_with(Json::parse(R"({"label": "csw", "chain": [
      {"algorithm": "normals.pca"}, {"algorithm": "normals.csw"}]})")));
  EXPECT_NE(e.find("cfg.json: /variants/0/chain/1"), std::string::npos) << e;
  EXPECT_NE(e.find("(normals.csw) consumes points and mixture"), std::string::npos) << e;
  EXPECT_NE(e.find("(mixture missing)"), std::string::npos) << e;
  // The one-step form too.
  const std::string e1 = test::experiment_load_error(
      config_with(Json::parse(R"({"label": "csw", "algorithm": "normals.csw"})")));
  EXPECT_NE(e1.find("cfg.json: /variants/0"), std::string::npos) << e1;
  EXPECT_NE(e1.find("mixture missing"), std::string::npos) << e1;
}

TEST(Chains, ReconstructionAndCswChainsLoad) {
  for (const char* v : {
           R"({"label": "csw", "chain": [{"algorithm": "mixture.hem"},
                                        {"algorithm": "normals.csw"}]})",
           R"({"label": "poisson", "chain": [{"algorithm": "normals.pca"},
                                            {"algorithm": "reconstruct.poisson"}]})",
           R"({"label": "af", "algorithm": "peer.cgal_advancing_front"})",
           R"({"label": "ext", "algorithm": "external.mesh",
               "params": {"command": "cp {in} {out}"}})"}) {
    EXPECT_EQ(test::experiment_load_error(config_with(Json::parse(v))), "") << v;
  }
}

// A variant's "datasets" restricts it to those dataset labels: its jobs exist only there, and a
// label that names no dataset fails at load with the JSON path.
TEST(Chains, VariantDatasetsRestrictTheJobs) {
  Json c = config_with(Json::parse(R"({"label": "a", "algorithm": "resample.wlop"})"));
  c["datasets"] = Json::parse(R"([{"name": "sphere"}, {"name": "torus"}])");
  c["variants"].push_back(
      Json::parse(R"({"label": "b", "algorithm": "resample.lop", "datasets": ["torus"]})"));
  const Plan plan = expand(parse_experiment(c, "cfg.json"));
  std::multiset<std::string> keys;
  for (const Job& j : plan.jobs)
    keys.insert(j.dataset_label + "/" + j.variant);
  EXPECT_EQ(keys, (std::multiset<std::string>{"sphere/a", "torus/a", "torus/b"}));
  c["variants"][1]["datasets"] = Json::array({"torus", "cube"});
  const std::string e = test::experiment_load_error(c);
  EXPECT_NE(e.find("cfg.json: /variants/1/datasets/1"), std::string::npos) << e;
  EXPECT_NE(e.find("no dataset labelled 'cube'"), std::string::npos) << e;
  c["variants"][1]["datasets"] = Json::array();
  EXPECT_NE(test::experiment_load_error(c).find("/variants/1/datasets"), std::string::npos);
}

}  // namespace
}  // namespace scanbench::harness
