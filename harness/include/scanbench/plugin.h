#pragma once
// Plugins: a shared library that adds algorithms and metrics to scanbench without a fork
// (docs/plugins.md). Build it against the installed package (find_package(scanbench CONFIG),
// scanbench_add_plugin) and load it with `scanbench --plugin lib.so <command>`, with
// "plugins": ["lib.so"] in an experiment (relative to the config) or from SCANBENCH_PLUGIN_PATH.
//
//   #include "scanbench/plugin.h"
//   struct MyParams {
//     int k = 16;
//     static void declare(scanbench::ParamDeclarer<MyParams>& d) {
//       d.integer("k", &MyParams::k, {3, 256}, "", "neighbours per fit");
//     }
//   };
//   scanbench::PointCloud my_filter(const scanbench::PointCloud& in, const MyParams& p,
//                                   scanbench::RunContext& ctx);
//   SCANBENCH_PLUGIN(r) {
//     r.algorithm<MyParams>("filter.mine", "what it is, which paper and equations", my_filter);
//     r.metric<MyMetricParams>("accuracy.mine", "...", scanbench::metrics::Scores::Points,
//                              {{"mine_mean", scanbench::metrics::Better::Lower}}, my_metric);
//   }
//
// An entry is exactly a built-in one: its declared parameters are parsed, validated, swept and
// recorded; an algorithm declares what it consumes and produces and the chain is type-checked;
// a metric declares every key it emits and which way is better (tables, compare, claims read
// them). The loader calls the registration function once and adds all its entries or none:
// a name that is already registered, a key declared with another direction than a built-in
// metric's, or an exception thrown by the registration function refuses the whole plugin with a
// one-line error naming the file. So does a library built against another ABI version
// (scanbench/core/abi.h) or for another Eigen alignment (instruction set), or one without the
// symbols SCANBENCH_PLUGIN defines.
//
// Progress: a long step calls scanbench::report_progress(ctx, "what", fraction) now and then
// (where it is, and the fraction done when known); `scanbench algo` shows it (--progress, or on
// a terminal). The host hands its handler to the plugin through the optional symbol
// scanbench_plugin_set_progress (SCANBENCH_PLUGIN defines it): a plugin built before it existed
// loads as before, and a plugin's calls are no-ops where no handler is set (jobs, tests).
//
// Jobs run in child processes (the runner's isolation): a plugin that crashes or hangs inside a
// job fails that job only, with status "crash" or "timeout" in its record. Every record names each
// loaded plugin with its path and the SHA-256 of the file (context.plugins).
#include <functional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/abi.h"
#include "scanbench/metrics/registry.h"

namespace scanbench {

/// What a metric needs precomputed (metrics::MetricInput): the exact closest ground-truth point
/// of every output point (in.closest), or the exact oracle of a mesh output (in.output_oracle).
struct MetricNeeds {
  bool closest = false;
  bool output_oracle = false;
};

/// Handed to a plugin's registration function (SCANBENCH_PLUGIN). Entries are collected and
/// added to the registries after the function returns without throwing.
class PluginRegistrar {
 public:
  virtual ~PluginRegistrar() = default;

  /// An algorithm entry (algorithms::make_entry builds one; algorithm() below is shorter).
  virtual void add(algorithms::AlgorithmRegistry::Entry e) = 0;
  /// A metric entry (metric() below builds one).
  virtual void add(metrics::MetricRegistry::Entry e) = 0;

  /// An algorithm from a free function and its declared parameter struct P, as the built-in ones
  /// (algorithms::make_entry): `f(const PointCloud&, const P&, RunContext&)` returning a
  /// PointCloud, or `f(const StageData&, const P&, RunContext&)` returning a PointCloud or a
  /// StageData; `io` says what it consumes, produces and is scored on (default: points).
  template <class P, class F>
  void algorithm(std::string name, std::string doc, F f, algorithms::StageIo io = {}) {
    add(algorithms::make_entry<P>(std::move(name), std::move(doc), std::move(f), io));
  }

  /// A metric scoring `scores` from `f(const metrics::MetricInput&, const P&)` (or with a third
  /// RunContext& argument) returning a JSON object of the declared `keys` (numbers). A key the
  /// metric emits but did not declare makes evaluate() fail the job (as for built-in metrics).
  template <class P, class F>
  void metric(std::string name, std::string doc, metrics::Scores scores,
              std::vector<metrics::MetricKey> keys, F f, MetricNeeds needs = {}) {
    metrics::MetricRegistry::Entry e;
    e.name = name;
    e.doc = std::move(doc);
    e.params = schema_of<P>();
    e.fn.scores = scores;
    e.fn.keys = std::move(keys);
    e.fn.needs_closest = needs.closest;
    e.fn.needs_output_oracle = needs.output_oracle;
    e.fn.run = [f, name](const metrics::MetricInput& in, const Json& params, RunContext& ctx) {
      const P p = params_from_json<P>(params, "metric " + name);
      if constexpr (std::is_invocable_v<F, const metrics::MetricInput&, const P&, RunContext&>) {
        return Json(f(in, p, ctx));
      } else {
        return Json(f(in, p));
      }
    };
    add(std::move(e));
  }
};

/// Where a long step is: `what` (its phase, e.g. "iteration 3/10") and `fraction` done in [0, 1]
/// (negative: not known). Called from any thread of the step; the handler copies what it needs.
using ProgressFn = void (*)(const RunContext& ctx, const char* what, double fraction);

namespace detail {
/// This library's progress handler (one per plugin and one in the host; null: no handler).
inline ProgressFn& progress_fn() {
  static ProgressFn f = nullptr;
  return f;
}
}  // namespace detail

/// Reports the progress of the step running with `ctx` (see ProgressFn). Cheap when nobody
/// listens; call it at natural boundaries (an iteration, a batch), not per point.
inline void report_progress(const RunContext& ctx, const std::string& what,
                            double fraction = -1.0) {
  if (const ProgressFn f = detail::progress_fn()) f(ctx, what.c_str(), fraction);
}

/// Host side (harness, config/plugins.cpp): while a ProgressListener for `ctx` lives, every
/// report_progress(ctx, ...) of the host and of every loaded plugin calls `on` (under a mutex,
/// from the reporting thread). One listener per context.
class ProgressListener {
 public:
  ProgressListener(const RunContext& ctx,
                   std::function<void(const std::string& what, double fraction)> on);
  ~ProgressListener();
  ProgressListener(const ProgressListener&) = delete;
  ProgressListener& operator=(const ProgressListener&) = delete;

 private:
  const RunContext* ctx_;
};

/// The symbols a plugin exports (SCANBENCH_PLUGIN defines them; the progress one is optional
/// for the loader, so plugins built before it load unchanged).
inline constexpr const char* kPluginAbiSymbol = "scanbench_plugin_abi_version";
inline constexpr const char* kPluginRegisterSymbol = "scanbench_plugin_register";
inline constexpr const char* kPluginAlignSymbol = "scanbench_plugin_eigen_max_align_bytes";
inline constexpr const char* kPluginProgressSymbol = "scanbench_plugin_set_progress";
using PluginAbiFn = int (*)();
using PluginSetProgressFn = void (*)(ProgressFn);
using PluginRegisterFn = void (*)(PluginRegistrar&);

}  // namespace scanbench

/// Defines a plugin's exported functions: the ABI version it was compiled against, its Eigen
/// alignment (EIGEN_MAX_ALIGN_BYTES, set by the instruction set, -march, which scanbench::core's
/// usage requirements give a plugin: memory allocated on one side is freed on the other), the
/// setter of its progress handler and its registration function, whose body follows the macro: SCANBENCH_PLUGIN(r) { r.algorithm...; }
#define SCANBENCH_PLUGIN(registrar)                                                                \
  extern "C" __attribute__((visibility("default"))) int scanbench_plugin_abi_version() {           \
    return SCANBENCH_ABI_VERSION;                                                                  \
  }                                                                                                \
  extern "C" __attribute__((visibility("default"))) int scanbench_plugin_eigen_max_align_bytes() { \
    return EIGEN_MAX_ALIGN_BYTES;                                                                  \
  }                                                                                                \
  extern "C" __attribute__((visibility("default"))) void scanbench_plugin_set_progress(            \
      ::scanbench::ProgressFn f) {                                                                 \
    ::scanbench::detail::progress_fn() = f;                                                        \
  }                                                                                                \
  extern "C" __attribute__((visibility("default"))) void scanbench_plugin_register(                \
      ::scanbench::PluginRegistrar& registrar)
