#pragma once
// Scanner presets by name (configs/scanners/*.json): each entry's schema is the scanner's declared
// parameters with the preset's values as defaults.
#include "scanbench/core/registry.h"

namespace scanbench::scanner {

struct ScannerPreset {
  Json values;  ///< complete, validated scanner parameters of the preset
};
using ScannerRegistry = Registry<ScannerPreset>;

/// Every scanner preset, in one explicit list.
const ScannerRegistry& presets();

}  // namespace scanbench::scanner
