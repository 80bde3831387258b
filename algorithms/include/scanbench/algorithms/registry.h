#pragma once
// The algorithm registry: every algorithm variant by dotted name ("normals.pca", "resample.clop",
// "peer.cgal_wlop", ...), with its declared parameters and the stage data it consumes and produces
// (points, a Gaussian mixture, a triangle mesh, a covariance mesh; core/stage_data.h). A chain of
// steps is type-checked against these declarations when an experiment loads.
#include <functional>
#include <type_traits>

#include "scanbench/core/errors.h"
#include "scanbench/core/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// What a step reads and writes. `primary` is the kind a chain ending in this step is scored on
/// (and what `scanbench algo -o` writes); it is one of `produces`.
struct StageIo {
  DataKinds consumes = DataKind::Points;
  DataKinds produces = DataKind::Points;
  DataKind primary = DataKind::Points;
};

/// A registered algorithm. Calling it checks that the input holds what it consumes (InputError
/// naming the step and the missing kind otherwise), runs it, and returns its products with every
/// other kind carried over from the input (StageData::carry).
struct Algorithm {
  StageIo io;
  /// The step's output depends on heap addresses (CGAL meshers that order by handle address), so
  /// the same call can give another result after other work in the process: a job runs it in a
  /// fresh `scanbench algo` process (harness chain.h), where it repeats at any thread count.
  bool own_process = false;
  std::function<StageData(const StageData& input, const Json& params, RunContext& ctx)> run;

  StageData operator()(const StageData& input, const Json& params, RunContext& ctx) const {
    return run(input, params, ctx);
  }
  /// Adds "consumes", "produces" and "primary" to a `scanbench list --json` entry.
  void describe(Json& j) const {
    Json c = Json::array(), p = Json::array();
    for (DataKind k :
         {DataKind::Points, DataKind::Mixture, DataKind::Mesh, DataKind::CovarianceMesh}) {
      if (io.consumes.has(k)) c.push_back(kind_name(k));
      if (io.produces.has(k)) p.push_back(kind_name(k));
    }
    j["consumes"] = c;
    j["produces"] = p;
    j["primary"] = kind_name(io.primary);
    if (own_process) j["own_process"] = true;
  }
};

using AlgorithmFn = Algorithm;
using AlgorithmRegistry = Registry<Algorithm>;
/// The result of a step (kept as a name for readability at call sites).
using AlgorithmOutput = StageData;

/// Every registered algorithm, in one explicit list (algorithms/src/registry.cpp).
const AlgorithmRegistry& registry();
/// Adds a plugin's entry to registry() (the harness's plugin loader, scanbench/plugin.h), before
/// any step runs; not thread-safe. Throws Error on a duplicate name.
void add_plugin_entry(AlgorithmRegistry::Entry e);

/// Builds an entry from a free function and its declared parameter struct P. The function takes
/// `const PointCloud&` (the input's points) or `const StageData&` (everything), and returns a
/// `PointCloud` (the produced points) or a `StageData` holding what it produces.
template <class P, class F>
AlgorithmRegistry::Entry make_entry(std::string name, std::string doc, F f, StageIo io = {}) {
  Algorithm a;
  a.io = io;
  a.run = [f, name, io](const StageData& in, const Json& params, RunContext& ctx) -> StageData {
    const DataKinds have = in.kinds();
    if (!have.contains(io.consumes)) {
      throw InputError(name + ": consumes " + kinds_names(io.consumes) + ", but its input holds " +
                       kinds_names(have) + " (" + kinds_names(io.consumes - have) + " missing)");
    }
    P p = params_from_json<P>(params, name);
    StageData out;
    // StageData first: a PointCloud converts to StageData, so a StageData function would also be
    // invocable with the points alone (and lose the other kinds).
    if constexpr (std::is_invocable_v<F, const StageData&, const P&, RunContext&>) {
      auto r = f(in, p, ctx);
      if constexpr (std::is_same_v<decltype(r), PointCloud>) {
        out.points = std::move(r);
      } else {
        out = std::move(r);
      }
    } else {
      auto r = f(in.points, p, ctx);
      if constexpr (std::is_same_v<decltype(r), PointCloud>) {
        out.points = std::move(r);
      } else {
        out = std::move(r);
      }
    }
    if (!out.kinds().has(io.primary)) {
      throw Error(name + ": produced no " + std::string(kind_name(io.primary)));
    }
    return StageData::carry(std::move(out), in, io.produces);
  };
  return {std::move(name), std::move(doc), schema_of<P>(), std::move(a)};
}

}  // namespace scanbench::algorithms
