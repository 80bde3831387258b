#include "scanbench/core/allocator.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace scanbench {

void apply_allocator_policy() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

std::string_view allocator_policy() {
#if defined(__GLIBC__)
  return "glibc mallopt M_MMAP_THRESHOLD 32 MiB, M_TRIM_THRESHOLD 1 GiB (every command)";
#else
  return "C library defaults";
#endif
}

}  // namespace scanbench
