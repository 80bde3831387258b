#pragma once
// The one external-program runner is core's (scanbench/core/run_program.h: the scanner runs COLMAP
// too); the algorithms use it under their old names.
#include "scanbench/core/run_program.h"

namespace scanbench::algorithms::detail {
using programs::log_tail;
using programs::require_output;
using programs::run_program;
using programs::TempDir;
}  // namespace scanbench::algorithms::detail
