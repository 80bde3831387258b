#pragma once
// Steps that run in a fresh process (algorithms::Algorithm::own_process): the chain hands such a
// step to `scanbench algo` in a child process, so that its output does not depend on the heap's
// history in the job (see own_process.cpp).
#include <optional>
#include <string>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::harness {

/// The scanbench binary that runs own-process steps: $SCANBENCH_EXE when set, else this process's
/// own executable when it is `scanbench`; empty otherwise (a test binary that links the harness
/// runs such steps in its own process, and says so in the test).
std::optional<std::string> own_process_exe();

/// Runs `entry` on `input` (origin zero, as every chain step sees it) through `exe algo` in a
/// fresh process with ctx's seed and thread count: the consumed kinds are written to a private
/// directory, the primary output read back and the other kinds carried over from `input`. The
/// child's phase seconds are added to ctx; its peak memory is noted as a program's. Throws what
/// run_program throws, with the child's one-line error.
StageData run_in_own_process(const std::string& exe,
                             const algorithms::AlgorithmRegistry::Entry& entry, const Json& params,
                             const StageData& input, RunContext& ctx);

}  // namespace scanbench::harness
