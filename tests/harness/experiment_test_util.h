#pragma once
// Config-loader helper shared by the harness tests that check experiment validation.
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/harness/config/experiment.h"

namespace scanbench::test {

/// The ParamError message parse_experiment gives for `cfg` (as if read from "cfg.json"), or ""
/// when the config loads.
inline std::string experiment_load_error(const Json& cfg) {
  try {
    harness::parse_experiment(cfg, "cfg.json");
  } catch (const ParamError& e) {
    return e.what();
  }
  return "";
}

}  // namespace scanbench::test
