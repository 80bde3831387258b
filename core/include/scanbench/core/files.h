#pragma once
// Writing a file whole: a reader (another job, a merge, a crashed run's resume) sees the old file
// or the new one, never a part of either. Every artifact of scanbench (records, fields, images,
// point clouds, meshes, caches) is written by one of the two writers here:
//
//  - write_file_atomic: the bytes are in memory (JSON, text, a PLY or VDB encoded into a string);
//    every write(2) is checked, so a failure carries the kernel's reason.
//  - write_via_temp: a library that can only write to a path (OpenImageIO without an IO proxy,
//    a third-party writer) writes a temp beside the final path; the temp is checked and renamed.
//
// Both: the temp is ".<name>.tmp.<pid>.<counter>" in the final folder, created with
// O_CREAT|O_EXCL|O_NOFOLLOW (never a file or link that was already there), fsync'ed, renamed over
// the final name (a symlink there is replaced, never written through), and the folder fsync'ed.
// On any failure the temp is removed and the final name keeps what it had.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/core/params.h"

namespace scanbench {

/// Writes `text` to `path` atomically (see above). The parent folder must exist. Throws IoError
/// "<path>: cannot write: <reason>" with the reason from errno ("No space left on device",
/// "Read-only file system", "File name too long", "Permission denied", ...).
void write_file_atomic(const std::filesystem::path& path, std::string_view text);

/// Runs `write(tmp)` on a fresh temp path beside `path`, then checks that the writer left a
/// regular, non-empty file there, fsyncs it and renames it to `path`. `write` should throw on any
/// failure it can see (a library's error flag, a read-back check): the temp is then removed and
/// the exception propagates; an IoError's message has the temp's name replaced by `path`. The temp
/// exists (empty, made by this process) when `write` is called, so the writer opens it with
/// truncation. Throws IoError as write_file_atomic.
void write_via_temp(const std::filesystem::path& path,
                    const std::function<void(const std::filesystem::path& tmp)>& write);

/// The one JSON-to-file writer: `j` dumped with `indent` spaces (-1: on one line) and a newline,
/// written by write_file_atomic after creating the parent folders. Throws IoError.
void write_json_file(const std::filesystem::path& path, const Json& j, int indent = 1);

/// The IoError for a failed system call on `path`: "<path>: <what>: <strerror(err)>".
IoError io_error(const std::filesystem::path& path, std::string_view what, int err);

/// True for a name the writers above give their temps (".<name>.tmp.<pid>[.<counter>]"), so a
/// later run can remove what a killed process left behind.
bool is_temp_name(std::string_view filename);

}  // namespace scanbench
