#include "scanbench/scanner/registry.h"

#include <fmt/format.h>

#include "scanbench/core/json_text.h"
#include "scanbench/core/paths.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::scanner {

namespace {

Json read_json(const std::filesystem::path& file) {
  JsonTextOptions options;
  options.reject_duplicate_keys = true;
  Json j = parse_json_file(file, "scanner preset", options);
  if (!j.is_object()) throw IoError(fmt::format("{}: expected a JSON object", file.string()));
  return j;
}

/// {"doc", "params"} or a bare parameter object -> (doc, validated values).
std::pair<std::string, Json> parse_preset(const std::filesystem::path& file) {
  const Json j = read_json(file);
  std::string doc;
  Json params = j;
  if (j.contains("params")) {
    for (const auto& [key, value] : j.items()) {
      if (key != "doc" && key != "params") {
        throw ParamError(
            fmt::format("{}: {}: unknown key (expected doc, params)", file.string(), key));
      }
    }
    if (j.contains("doc")) {
      if (!j["doc"].is_string()) {
        throw ParamError(fmt::format("{}: doc: expected a string", file.string()));
      }
      doc = j["doc"].get<std::string>();
    }
    params = j["params"];
  }
  const std::string where = file.string() + ": params";
  Json values = schema_of<ScannerParams>().validate(params, where);
  validate(params_from_json<ScannerParams>(values, where), where);
  return {doc, values};
}

}  // namespace

Json load_preset_file(const std::filesystem::path& file) {
  return parse_preset(file).second;
}

const ScannerRegistry& presets() {
  static const ScannerRegistry r = [] {
    ScannerRegistry reg("scanner preset");
    // One explicit list; values live in configs/scanners/<name>.json.
    for (const char* name : {"clean", "moderate", "scut_low", "scut_medium", "scut_high",
                             "outliers_heavy", "photo_default", "photo_noisy", "photo_dense"}) {
      const auto file = config_root() / "scanners" / (std::string(name) + ".json");
      auto [doc, values] = parse_preset(file);
      std::vector<ParamInfo> infos = schema_of<ScannerParams>().params();
      for (auto& info : infos)
        info.default_value = values.at(info.name);
      reg.add({name, doc, ParamSchema(std::move(infos)), ScannerPreset{values}});
    }
    return reg;
  }();
  return r;
}

Json preset_values(std::string_view name_or_path) {
  const ScannerRegistry& reg = presets();
  if (const auto* e = reg.find(name_or_path)) return e->fn.values;
  const std::filesystem::path file{std::string(name_or_path)};
  if (std::filesystem::is_regular_file(file)) return load_preset_file(file);
  reg.at(name_or_path);  // throws UnknownNameError listing the presets
  return {};
}

}  // namespace scanbench::scanner
