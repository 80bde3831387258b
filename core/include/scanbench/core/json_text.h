#pragma once
// The one checked JSON reader: every JSON text scanbench reads (experiment configs, claim files,
// protocols, scanner presets, job specs and records, runs.jsonl lines, plugin and child outputs)
// goes through parse_json_text, so no input can crash the process or exhaust its stack.
//
// nlohmann::json parses iteratively, but copying, comparing and dumping a value recurse once per
// nesting level: a value nested 200,000 deep ("[[[[...") parses and then overflows the stack when
// it is first copied. parse_json_text therefore makes two passes over the text: a SAX pass
// (nlohmann's own lexer and grammar, no value built) that counts the nesting depth, checks for
// duplicate keys when asked and stops at the first error, and only then the DOM pass that builds
// the value.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "scanbench/core/params.h"

namespace scanbench {

/// The deepest nesting (objects and arrays, the outermost counting 1) parse_json_text accepts
/// by default. Real configs and records nest fewer than 10 levels; 100 levels keep every
/// recursive walk of a value (copy, dump, compare) far inside an 8 MiB stack.
inline constexpr std::size_t kJsonMaxDepth = 100;

struct JsonTextOptions {
  /// Accept // and /* */ comments (configs written by hand; records never have them).
  bool ignore_comments = false;
  /// Refuse an object with the same key twice (JSON, RFC 8259 sec. 4, leaves duplicate names
  /// undefined and nlohmann::json silently keeps one of them, so a config with two "seed" keys
  /// would run with a seed its author did not read).
  bool reject_duplicate_keys = false;
  /// Nesting limit, >= 1.
  std::size_t max_depth = kJsonMaxDepth;
};

/// Parses `text` as one JSON value. `where` starts every message (a file name, "runs.jsonl:12").
/// Throws IoError "<where>: not valid JSON: <nlohmann's message with line and column>" for
/// malformed text, IoError "<where>: JSON nested deeper than <max_depth> levels" before any
/// value is built, and ParamError "<where>: /a/0/b: duplicate key (JSON keeps only one of them)"
/// with reject_duplicate_keys (the JSON pointer of the second occurrence).
Json parse_json_text(std::string_view text, const std::string& where,
                     const JsonTextOptions& options = {});

/// The value of a command line's `key=value` (`--set`): a text starting with `[` or `{` is JSON,
/// read by parse_json_text (so a malformed or 200,000-deep value is refused, naming `where`);
/// any other text that is a JSON scalar (a number, true, false, null, a quoted string) is that
/// scalar; anything else is the text itself as a string (a choice such as `exact`).
Json parse_assigned_value(std::string_view text, const std::string& where);

/// Reads the whole of `file` and parses it with parse_json_text (`where` = the path as given).
/// Throws IoError "<file>: cannot open <what>: <reason>" when it cannot be read (`what` names the
/// kind of file: "experiment config", "scanner preset").
Json parse_json_file(const std::filesystem::path& file, std::string_view what,
                     const JsonTextOptions& options = {});

}  // namespace scanbench
