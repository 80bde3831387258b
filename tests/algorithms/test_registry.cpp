// Create-by-name tests: every registered algorithm runs by name with its default parameters on a
// small scan-like cloud and returns a valid, non-empty cloud. New entries are covered
// automatically because the test iterates the registry.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "registry_fixtures.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

// A noisy unit sphere seen by two sensors (above and below), like a tiny scan, with unit radial
// normals (for the stages that consume normals: normals.bilateral, filter.gpf, peer.cgal_ear).
PointCloud small_scan() {
  Rng rng(77);
  const int n = 1500;
  PointCloud c;
  c.positions.resize(3, n);
  c.scan_ids.resize(n);
  c.normals.resize(3, n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    d.normalize();
    c.positions.col(i) = d * (1.0f + static_cast<float>(rng.normal(0.0, 0.01)));
    c.normals.col(i) = d;
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

StageData every_kind() {
  SphereParams sp;
  sp.resolution = 4;
  return fixtures::every_kind(small_scan(), make_sphere(sp));
}

TEST(AlgorithmRegistry, EveryEntryRunsByNameOnASmallScan) {
  const StageData all = every_kind();
  ASSERT_FALSE(registry().entries().empty());
  for (const auto& e : registry().entries()) {
    SCOPED_TRACE(e.name);
    RunContext ctx(5);
    const Json params = e.params.validate(fixtures::required_params(e.name), e.name);
    EXPECT_TRUE(e.fn.io.produces.has(e.fn.io.primary));
    // The entry gets exactly what it consumes, nothing else.
    StageData in;
    if (e.fn.io.consumes.has(DataKind::Points)) in.points = all.points;
    if (e.fn.io.consumes.has(DataKind::Mixture)) in.mixture = all.mixture;
    if (e.fn.io.consumes.has(DataKind::Mesh)) in.mesh = all.mesh;
    if (e.fn.io.consumes.has(DataKind::CovarianceMesh)) in.covariance_mesh = all.covariance_mesh;
    StageData out;
    ASSERT_NO_THROW(out = e.fn(in, params, ctx));
    EXPECT_TRUE(out.kinds().contains(e.fn.io.produces)) << kinds_names(out.kinds());
    if (e.fn.io.produces.has(DataKind::Points)) {
      EXPECT_GT(out.points.size(), 0);
      EXPECT_NO_THROW(out.points.validate(e.name));
    }
    if (out.points.has_normals()) {
      for (Eigen::Index i = 0; i < out.points.size(); ++i)
        ASSERT_NEAR(out.points.normals.col(i).norm(), 1.0f, 1e-3f) << "normal " << i;
    }
    if (out.mixture) {
      EXPECT_NO_THROW(out.mixture->validate(e.name));
    }
    if (out.mesh) {
      EXPECT_NO_THROW(out.mesh->validate(e.name));
    }
    if (out.covariance_mesh) {
      EXPECT_NO_THROW(out.covariance_mesh->validate(e.name));
    }
  }
}

TEST(AlgorithmRegistry, EveryEntryRefusesInputWithoutWhatItConsumes) {
  for (const auto& e : registry().entries()) {
    RunContext ctx(5);
    const Json params = e.params.validate(Json::object(), e.name);
    try {
      (void)e.fn(StageData{}, params, ctx);
      ADD_FAILURE() << e.name << " ran on empty stage data";
    } catch (const InputError& err) {
      EXPECT_NE(std::string(err.what()).find(e.name + ": consumes"), std::string::npos)
          << err.what();
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
