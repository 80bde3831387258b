#pragma once
// Scanner presets by name (configs/scanners/<name>.json, found through config_root()): each
// entry's schema is the scanner's declared parameters with the preset's values as defaults, and
// entry.fn.values holds the complete, validated parameters.
//
// Preset file format: {"doc": "one paragraph", "params": {<ScannerParams keys>}}; a file given by
// path may also be a bare object of ScannerParams keys. Unknown keys, wrong types and out-of-range
// values throw ParamError naming the file and key; a missing or malformed file throws IoError.
#include <filesystem>
#include <string_view>

#include "scanbench/core/registry.h"

namespace scanbench::scanner {

struct ScannerPreset {
  Json values;  ///< complete, validated scanner parameters of the preset
};
using ScannerRegistry = Registry<ScannerPreset>;

/// Every scanner preset, in one explicit list: clean, moderate, scut_low, scut_medium, scut_high,
/// outliers_heavy, and the photogrammetric photo_default, photo_noisy, photo_dense (scanner.h).
/// Throws (IoError / ParamError) when a preset file is missing or invalid.
const ScannerRegistry& presets();

/// The complete, validated parameters in a preset file (see the format above).
Json load_preset_file(const std::filesystem::path& file);

/// A registered preset's values by name, or else a preset file by path. Throws UnknownNameError
/// when `name_or_path` is neither a preset name nor an existing file.
Json preset_values(std::string_view name_or_path);

}  // namespace scanbench::scanner
