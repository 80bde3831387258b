#pragma once
// Fixtures of the tests that loop over every registered algorithm (test_registry,
// test_thread_identity, test_local_origin_algorithms): one input holding every kind of stage
// data, and the parameters an entry cannot run without.
#include <string>
#include <utility>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms::fixtures {

/// Stage data holding every kind an entry may consume: `scan` with its PCA normals
/// (reconstruct.poisson needs oriented normals), their HEM mixture, `mesh`, and `mesh` with
/// isotropic covariances 0.01 I as a covariance mesh.
inline StageData every_kind(PointCloud scan, const TriangleMesh& mesh) {
  RunContext ctx(3, 1);
  const auto& pca = registry().at("normals.pca");
  StageData d =
      pca.fn(StageData{std::move(scan)}, pca.params.validate(Json::object(), "test"), ctx);
  const auto& hem = registry().at("mixture.hem");
  d.mixture = hem.fn(d, hem.params.validate(Json::object(), "test"), ctx).mixture;
  d.mesh = mesh;
  CovarianceMesh cm;
  cm.resize(mesh.num_vertices());
  cm.means = mesh.vertices.cast<double>();
  for (Eigen::Index i = 0; i < cm.num_vertices(); ++i)
    cm.set_covariance(i, 0.01 * Eigen::Matrix3d::Identity());
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    const int t[3] = {mesh.faces(0, f), mesh.faces(1, f), mesh.faces(2, f)};
    cm.faces.add(t);
  }
  d.covariance_mesh = std::move(cm);
  return d;
}

/// Parameters an entry cannot run without (external.*: the command to run).
inline Json required_params(const std::string& name) {
  if (name == "external.points") return Json{{"command", "cp {in} {out}"}};
  if (name == "external.mesh") {
    return Json{{"command", "printf 'OFF\\n3 1 0\\n0 0 0\\n1 0 0\\n0 1 0\\n3 0 1 2\\n' > {out}"},
                {"extension", ".off"}};
  }
  return Json::object();
}

}  // namespace scanbench::algorithms::fixtures
