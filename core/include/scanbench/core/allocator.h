#pragma once
// The process's allocator policy, set once at the start of every scanbench program (the CLI's
// main for every command, and the Google Benchmark mains), so that benchmarks measure what users
// run.
//
// glibc's defaults serve every allocation above 128 KiB (growing adaptively up to 32 MiB) with a
// fresh mmap and return it to the kernel on free, and trim the heap top above 128 KiB: a stage
// that allocates and frees its large buffers per tile, per view or per iteration then pays the
// first-touch page faults of fresh pages every time (measured: about 50 us per 4 KiB page on the
// 2-core VM; the scanner's 1K-triangle case ran at 0.29 of bare Embree without this policy).
// The policy keeps freed memory in the process: M_MMAP_THRESHOLD 32 MiB (buffers below are reused
// from the heap) and M_TRIM_THRESHOLD 1 GiB. The cost is a resident size that does not shrink
// after a peak; peak memory itself is unchanged.
#include <string_view>

namespace scanbench {

/// Applies the policy (idempotent; a no-op where the C library is not glibc).
void apply_allocator_policy();
/// One line describing the policy, for bench JSON and records.
std::string_view allocator_policy();

}  // namespace scanbench
