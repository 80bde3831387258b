#pragma once
// Private to scanner-sim: the photogrammetric scanner (kind "photo"; documented in scanner.h).
#include "scanbench/scanner/scanner.h"

namespace scanbench::scanner::detail {

/// Renders, runs COLMAP, reads the model back (scanner.h, "The photogrammetric scanner").
/// Throws InputError / ParamError as scan(), Error("scan: colmap ...") when COLMAP fails or a
/// dense kind is asked of a COLMAP without CUDA.
Scan photo_scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx);

}  // namespace scanbench::scanner::detail
