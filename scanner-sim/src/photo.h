#pragma once
// Private to scanner-sim: the photogrammetric scanner (kind "photo"; documented in scanner.h).
#include "scanbench/scanner/scanner.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace scanbench::scanner::detail {

/// Parses the `poses` text "x y z; x y z" (commas allowed between numbers) into diag-unit offsets;
/// ParamError("<where>.poses: ...") when malformed (shared by both scanners).
std::vector<Eigen::Vector3d> parse_poses(const std::string& text, const std::string& where);

/// Renders, runs COLMAP, reads the model back (scanner.h, "The photogrammetric scanner").
/// Throws InputError / ParamError as scan(), Error("scan: colmap ...") when COLMAP fails or a
/// dense kind is asked of a COLMAP without CUDA.
Scan photo_scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx);

}  // namespace scanbench::scanner::detail
