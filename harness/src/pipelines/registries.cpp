#include "scanbench/harness/pipelines/registries.h"

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/scanner/registry.h"

namespace scanbench::harness {

namespace {

template <class R>
Json entries_json(const R& reg, std::string_view kind = "") {
  Json a = Json::array();
  for (const auto& e : reg.entries()) {
    a.push_back(e.to_json());
    if (!kind.empty()) mark_source(a.back(), kind);
  }
  return a;
}

Json datasets_json() {
  Json a = Json::array();
  for (const auto& e : datasets().entries()) {
    Json j = e.to_json();
    j["procedural"] = e.fn.file.empty();
    j["file"] = e.fn.file.empty() ? Json(nullptr) : Json(e.fn.file.string());
    j["available"] = e.fn.available();
    a.push_back(std::move(j));
  }
  return a;
}

}  // namespace

Json registries_json(std::string_view kind) {
  Json all = Json::object();
  auto want = [&](std::string_view k) { return kind.empty() || kind == k; };
  if (want("algorithms")) all["algorithms"] = entries_json(algorithms::registry(), "algorithm");
  if (want("metrics")) all["metrics"] = entries_json(metrics::registry(), "metric");
  if (want("datasets")) all["datasets"] = datasets_json();
  if (want("scanners")) all["scanners"] = entries_json(scanner::presets());
  return all;
}

}  // namespace scanbench::harness
