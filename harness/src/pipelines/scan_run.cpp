#include "scanbench/harness/pipelines/scan_run.h"

#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/scanner/registry.h"

namespace scanbench::harness {

scanner::Scan run_scan(const ScanRequest& r) {
  if (r.dataset.empty() == r.mesh.empty()) {
    throw ParamError("scan: give exactly one of --dataset NAME or --mesh FILE");
  }
  const TriangleMesh mesh = r.mesh.empty() ? load_dataset(r.dataset) : read_mesh(r.mesh);
  Json values = r.preset.empty() ? schema_of<scanner::ScannerParams>().defaults()
                                 : scanner::preset_values(r.preset);
  for (const auto& s : r.sets)
    apply_assignment(values, s);
  if (!r.values.is_object()) throw ParamError("scan: the parameter values must be an object");
  for (const auto& [k, v] : r.values.items())
    values[k] = v;
  const auto p = params_from_json<scanner::ScannerParams>(values, "scanner");
  RunContext ctx(r.seed, r.threads);
  scanner::Scan s = scanner::scan(mesh, p, ctx);
  Json input = Json::object();
  input["dataset"] = r.dataset.empty() ? Json(nullptr) : Json(r.dataset);
  input["mesh"] = r.mesh.empty() ? Json(nullptr) : Json(r.mesh);
  input["preset"] = r.preset.empty() ? Json(nullptr) : Json(r.preset);
  s.record["input"] = input;
  return s;
}

}  // namespace scanbench::harness
