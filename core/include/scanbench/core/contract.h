#pragma once
// SCANBENCH_EXPECTS(condition, "what it guarantees"): a kernel's precondition (padding, room,
// alignment, lane counts) stated where it is relied on and checked where checks are on: the
// sanitizer tree (SCANBENCH_SANITIZE, build type Sanitize) and any build without NDEBUG. Release
// builds compile it out, so it costs the kernels nothing. A failed check prints one line (file,
// line, the condition and what it guarantees) and aborts: a broken contract is a bug, never input
// to recover from. (assert() would do the same check; this macro adds the sentence and stays on in
// the sanitizer tree whatever NDEBUG a dependency's flags bring.)
#include <cstdio>
#include <cstdlib>

#if defined(SCANBENCH_SANITIZE) || !defined(NDEBUG)
#define SCANBENCH_CHECK_CONTRACTS 1
#define SCANBENCH_EXPECTS(condition, what) \
  ((condition) ? (void)0 : ::scanbench::contract_failed(#condition, what, __FILE__, __LINE__))
#else
#define SCANBENCH_CHECK_CONTRACTS 0
#define SCANBENCH_EXPECTS(condition, what) ((void)0)
#endif

namespace scanbench {

[[noreturn]] inline void contract_failed(const char* condition, const char* what, const char* file,
                                         int line) {
  std::fprintf(stderr, "scanbench: %s:%d: contract broken: %s (%s)\n", file, line, condition, what);
  std::abort();
}

}  // namespace scanbench
