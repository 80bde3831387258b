#pragma once
// The plugin loader (scanbench/plugin.h, docs/plugins.md). Plugins come from three places, all
// loaded before a command runs: `scanbench --plugin FILE` (repeatable, any command), the
// colon-separated SCANBENCH_PLUGIN_PATH (files, or folders whose *.so files load in name order),
// and an experiment's "plugins" list (paths relative to the config's folder). A file loads once
// per process however often it is named.
//
// Every failure is a one-line Error naming the file, and the plugin's entries are added all or
// none: a library dlopen() refuses (missing file, unresolved symbol), no
// scanbench_plugin_abi_version or scanbench_plugin_register symbol, another ABI version
// (scanbench/core/abi.h), a registration that throws, an empty or already registered name, a
// metric key declared with another direction than the registered metrics give it.
//
// Jobs run in child processes (`scanbench job`): the runner puts plugins_json() in each job's
// spec and the child loads the same files, refusing one whose SHA-256 changed since the run
// started. Records carry plugins_json() as context.plugins.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct LoadedPlugin {
  std::filesystem::path path;  ///< absolute and normalised, as loaded
  std::string sha256;          ///< SHA-256 of the file (lowercase hex)
  std::string origin;          ///< "--plugin", "SCANBENCH_PLUGIN_PATH", the config, "job spec"
  std::vector<std::string> algorithms;  ///< names it registered, in its order
  std::vector<std::string> metrics;
  /// {"path", "sha256", "algorithms", "metrics"}
  Json to_json() const;
};

/// Loads one plugin (see above for what it refuses; nothing is added then). Returns the loaded
/// plugin (the earlier one when this file was loaded before).
const LoadedPlugin& load_plugin(const std::filesystem::path& file, const std::string& origin);
/// Every plugin named by SCANBENCH_PLUGIN_PATH (nothing when unset or empty).
void load_plugins_from_env();
/// The "plugins" list of an experiment config `config` read from `config_file` (paths relative
/// to its folder). A list that is not one of strings is a ParamError naming the config.
void load_config_plugins(const Json& config, const std::filesystem::path& config_file);
/// A job spec's "plugins" (plugins_json() of the run): loads each and checks its hash.
void load_spec_plugins(const Json& plugins);

/// Every plugin loaded in this process, in load order.
const std::vector<LoadedPlugin>& loaded_plugins();
/// Array of LoadedPlugin::to_json(), in load order (empty array when none).
Json plugins_json();
/// The plugin that registered an algorithm (`kind` "algorithm") or metric ("metric") of that
/// name; null for a built-in entry.
const LoadedPlugin* plugin_of(std::string_view kind, std::string_view name);
/// Adds "source" ("builtin" or "plugin") and, for a plugin, "plugin" {path, sha256} to a
/// `scanbench list --json` entry of that kind.
void mark_source(Json& entry, std::string_view kind);

/// SHA-256 of a file's bytes, lowercase hex (OpenSSL's EVP digest). Throws IoError.
std::string file_sha256(const std::filesystem::path& file);

}  // namespace scanbench::harness
