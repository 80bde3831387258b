#pragma once
// Internal to core: simd.cpp restricts Highway's dispatch (simd_targets.cpp) to the active ISA.
#include "scanbench/core/simd.h"

namespace scanbench::simd {

/// Makes the Highway kernels dispatch to the best target of `isa`'s width or narrower that this
/// CPU has.
void restrict_targets(Isa isa);

}  // namespace scanbench::simd
