#include "scanbench/core/simd.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>

#include "scanbench/core/errors.h"
#include "simd_targets.h"

#ifndef SCANBENCH_SIMD_FLAGS
#define SCANBENCH_SIMD_FLAGS "(default flags)"
#endif

namespace scanbench::simd {

namespace {

constexpr Isa kCompiled =
#if defined(__AVX512F__) && defined(__AVX512VL__) && defined(__AVX512BW__) && defined(__AVX512DQ__)
    Isa::avx512;
#elif defined(__AVX2__) && defined(__FMA__)
    Isa::avx2;
#else
    Isa::sse2;
#endif

// -1 until the first active() or select(); then the ISA's number.
std::atomic<int> g_active{-1};
std::mutex g_init;

bool cpu_has_impl(Isa isa) {
#if defined(__x86_64__) || defined(__i386__)
  // Needed before libgcc's own initialiser has run (check_cpu below runs first of all).
  __builtin_cpu_init();
  switch (isa) {
    case Isa::sse2:
      return true;
#if defined(__clang__)
    // clang 14 knows no x86-64-vN level names here: the features that define the levels.
    case Isa::avx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
             __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
    case Isa::avx512:
      return cpu_has_impl(Isa::avx2) && __builtin_cpu_supports("avx512f") &&
             __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd");
#else
    case Isa::avx2:
      return __builtin_cpu_supports("x86-64-v3") != 0;
    case Isa::avx512:
      return __builtin_cpu_supports("x86-64-v4") != 0;
#endif
  }
  return false;
#else
  return isa == Isa::sse2;
#endif
}

// Runs before every other static initialiser (which are compiled for the build's ISA and may
// already use its instructions): a CPU without it gets one line instead of an illegal
// instruction. Kept trivial so that it uses no wide instructions itself.
__attribute__((constructor(101))) void check_cpu() {
  if (!cpu_has_impl(kCompiled)) {
    std::fprintf(stderr,
                 "scanbench: this binary was compiled for %s (%s) and this CPU lacks it; "
                 "rebuild with -DSCANBENCH_SIMD=sse2 (or native on this machine)\n",
                 kCompiled == Isa::avx512 ? "avx512" : "avx2", SCANBENCH_SIMD_FLAGS);
    std::_Exit(2);
  }
}

std::string why_unavailable(Isa isa) {
  if (static_cast<int>(isa) > static_cast<int>(kCompiled))
    return fmt::format("this binary was compiled for {} ({}); rebuild with -DSCANBENCH_SIMD={}",
                       name(kCompiled), SCANBENCH_SIMD_FLAGS, name(isa));
  return fmt::format("this CPU does not have {}", name(isa));
}

}  // namespace

std::string_view name(Isa isa) {
  switch (isa) {
    case Isa::sse2:
      return "sse2";
    case Isa::avx2:
      return "avx2";
    case Isa::avx512:
      return "avx512";
  }
  return "?";
}

int lanes(Isa isa) {
  return 4 << static_cast<int>(isa);
}

Isa parse(std::string_view text, std::string_view where) {
  for (Isa isa : {Isa::sse2, Isa::avx2, Isa::avx512})
    if (text == name(isa)) return isa;
  throw ParamError(fmt::format("{}: expected sse2, avx2 or avx512, got '{}'", where, text));
}

Isa compiled() {
  return kCompiled;
}

std::string_view compile_flags() {
  return SCANBENCH_SIMD_FLAGS;
}

bool cpu_has(Isa isa) {
  return cpu_has_impl(isa);
}

std::vector<Isa> available() {
  std::vector<Isa> out;
  for (Isa isa : {Isa::sse2, Isa::avx2, Isa::avx512})
    if (static_cast<int>(isa) <= static_cast<int>(kCompiled) && cpu_has(isa)) out.push_back(isa);
  return out;
}

void select(Isa isa) {
  if (static_cast<int>(isa) > static_cast<int>(kCompiled) || !cpu_has(isa))
    throw ParamError(fmt::format("SCANBENCH_ISA={}: {}", name(isa), why_unavailable(isa)));
  restrict_targets(isa);
  g_active.store(static_cast<int>(isa), std::memory_order_relaxed);
}

Isa active() {
  const int a = g_active.load(std::memory_order_relaxed);
  if (a >= 0) return static_cast<Isa>(a);
  std::lock_guard lock(g_init);
  if (g_active.load(std::memory_order_relaxed) < 0) {
    const char* env = std::getenv("SCANBENCH_ISA");
    if (env != nullptr && *env != '\0') {
      select(parse(env, "SCANBENCH_ISA"));
    } else {
      select(available().back());
    }
  }
  return static_cast<Isa>(g_active.load(std::memory_order_relaxed));
}

std::string describe() {
  const Isa a = active();
  return fmt::format("{} ({} floats; compiled for {}: {}); Highway target {} of {}", name(a),
                     lanes(a), name(kCompiled), SCANBENCH_SIMD_FLAGS, chosen_target(),
                     fmt::join(compiled_targets(), " "));
}

}  // namespace scanbench::simd
