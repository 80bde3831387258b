#pragma once
// What `scanbench list --json` prints: the registries with their declared parameters.
#include <string_view>

#include "scanbench/core/params.h"

namespace scanbench::harness {

/// {"algorithms": [...], "metrics": [...], "datasets": [...], "scanners": [...]}: each entry its
/// name, doc, declared parameters (defaults, ranges, units, docs) and what its kind adds (an
/// algorithm's data kinds and docs page, a plugin's file, a dataset's availability). `kind`
/// ("algorithms", "metrics", "datasets" or "scanners") keeps that array only; "" keeps all.
Json registries_json(std::string_view kind = "");

}  // namespace scanbench::harness
