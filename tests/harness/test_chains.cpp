// Chains are type-checked when a config loads: a step that consumes a kind the steps before it do
// not provide fails with the file, the JSON path of the step and its name; the chains of the
// reconstruction and CSW configs load.
#include <gtest/gtest.h>

#include <string>

#include "experiment_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/experiment.h"

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

}  // namespace
}  // namespace scanbench::harness
