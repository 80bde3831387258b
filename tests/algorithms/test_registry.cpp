// Create-by-name tests: every registered algorithm runs by name with its default parameters on a
// small scan-like cloud and returns a valid, non-empty cloud. New entries are covered
// automatically because the test iterates the registry.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

// A noisy unit sphere seen by two sensors (above and below), like a tiny scan.
PointCloud small_scan() {
  Rng rng(77);
  const int n = 1500;
  PointCloud c;
  c.positions.resize(3, n);
  c.scan_ids.resize(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    d.normalize();
    c.positions.col(i) = d * (1.0f + static_cast<float>(rng.normal(0.0, 0.01)));
    c.scan_ids[i] = d.z() >= 0.0f ? 0 : 1;
  }
  c.sensor_origins.resize(3, 2);
  c.sensor_origins.col(0) = Eigen::Vector3f(0.2f, 0.1f, 4.0f);
  c.sensor_origins.col(1) = Eigen::Vector3f(-0.1f, 0.3f, -4.0f);
  return c;
}

TEST(AlgorithmRegistry, NamesAreDottedUniqueAndDocumented) {
  std::set<std::string> names;
  for (const auto& e : registry().entries()) {
    EXPECT_NE(e.name.find('.'), std::string::npos) << e.name;
    EXPECT_FALSE(e.doc.empty()) << e.name;
    EXPECT_TRUE(names.insert(e.name).second) << e.name;
    for (const auto& p : e.params.params())
      EXPECT_FALSE(p.doc.empty()) << e.name << "." << p.name;
  }
  EXPECT_THROW(registry().at("no.such_algorithm"), UnknownNameError);
}

TEST(AlgorithmRegistry, SchemasRejectUnknownKeys) {
  for (const auto& e : registry().entries()) {
    const Json defaults = e.params.defaults();
    EXPECT_EQ(e.params.validate(defaults, e.name), defaults) << e.name;
    EXPECT_THROW(e.params.validate(Json{{"no_such_key", 1}}, e.name), ParamError) << e.name;
  }
}

TEST(AlgorithmRegistry, EveryEntryRunsByNameOnASmallScan) {
  const PointCloud in = small_scan();
  ASSERT_FALSE(registry().entries().empty());
  for (const auto& e : registry().entries()) {
    SCOPED_TRACE(e.name);
    RunContext ctx(5);
    const Json params = e.params.validate(Json::object(), e.name);
    AlgorithmOutput out;
    ASSERT_NO_THROW(out = e.fn(in, params, ctx));
    EXPECT_GT(out.points.size(), 0);
    EXPECT_NO_THROW(out.points.validate(e.name));
    if (out.points.has_normals()) {
      for (Eigen::Index i = 0; i < out.points.size(); ++i)
        ASSERT_NEAR(out.points.normals.col(i).norm(), 1.0f, 1e-3f) << "normal " << i;
    }
    if (out.mixture) {
      EXPECT_NO_THROW(out.mixture->validate(e.name));
    }
  }
}

TEST(AlgorithmRegistry, EveryEntryRejectsAnEmptyCloud) {
  for (const auto& e : registry().entries()) {
    RunContext ctx(5);
    const Json params = e.params.validate(Json::object(), e.name);
    EXPECT_THROW(e.fn(PointCloud{}, params, ctx), Error) << e.name;
  }
}

}  // namespace
}  // namespace scanbench::algorithms
