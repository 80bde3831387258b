#pragma once
// Writing a file whole: a reader (another job, a merge, a crashed run's resume) sees the old file
// or the new one, never a part of either.
#include <filesystem>
#include <string>

#include "scanbench/core/params.h"

namespace scanbench {

/// Writes `text` to `path` atomically: a temp file in the same folder, fsync, rename. Throws
/// IoError.
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

/// The one JSON-to-file writer: `j` dumped with `indent` spaces (-1: on one line) and a newline,
/// written by write_file_atomic after creating the parent folders. Throws IoError.
void write_json_file(const std::filesystem::path& path, const Json& j, int indent = 1);

}  // namespace scanbench
