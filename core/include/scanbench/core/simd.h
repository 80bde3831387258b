#pragma once
// The SIMD instruction set of the hot kernels: which packet width runs, chosen at run time.
//
// Two kinds of kernel share this choice while the kernels move to Google Highway (issue 51):
// - Highway kernels (the `HWY_NAMESPACE` code of a hwy/foreach_target.h translation unit, called
//   through SCANBENCH_DISPATCH below) are compiled for every target of cmake/Simd.cmake: SCALAR
//   (Highway's one-lane reference of the same source; EMU128 with clang), SSE4 (4 floats), AVX2
//   (8) and AVX3
//   (AVX-512, 16). They run the best target of the active ISA's width or narrower that the CPU
//   has: sse2 -> SSE4, avx2 -> AVX2, avx512 -> AVX3.
// - The kernels not yet moved are written over Eigen's packet type and instantiated for every
//   width up to the compiled one (scanbench/core/simd_dispatch.h): sse2 (Packet4f), avx2
//   (Packet8f), avx512 (Packet16f).
//
// The build is compiled for one x86-64 level (CMake option SCANBENCH_SIMD, default: the widest
// level of the build machine; see README "SIMD width"). The widest ISA the CPU has runs, unless the
// environment variable SCANBENCH_ISA=sse2|avx2|avx512 asks for a narrower one (to reproduce a
// result of a narrower machine). In a build compiled for avx2 or avx512 the sse2 path is 4-float
// code compiled with that build's flags (VEX encoding, fused multiply-adds where the compiler
// fuses), so it matches a -DSCANBENCH_SIMD=sse2 build only within float rounding; results do not
// depend on the thread count on any path.
#include <string>
#include <string_view>
#include <vector>

namespace scanbench::simd {

enum class Isa { sse2 = 0, avx2 = 1, avx512 = 2 };

/// "sse2", "avx2", "avx512".
std::string_view name(Isa isa);
/// Float lanes of the packet: 4, 8, 16.
int lanes(Isa isa);
/// Parses a name; throws ParamError naming `where` for anything else.
Isa parse(std::string_view text, std::string_view where);
/// The widest ISA this binary was compiled for.
Isa compiled();
/// The compiler flags of that ISA (e.g. "-march=x86-64-v3").
std::string_view compile_flags();
/// Whether this CPU (and its operating system) runs the ISA.
bool cpu_has(Isa isa);
/// The ISAs this binary can run here: compiled for and supported by the CPU, narrowest first.
std::vector<Isa> available();

/// The ISA the kernels use now: the one chosen with select(), else SCANBENCH_ISA (read at the
/// first call; an invalid or unavailable value throws ParamError with a one-line message), else
/// the widest available.
Isa active();
/// Makes the kernels use `isa` from now on (process-wide; call between runs, not during one).
/// Throws ParamError when the ISA is not available here (the message says why).
void select(Isa isa);

/// select() for a scope (tests): restores the previous choice.
class ScopedIsa {
 public:
  explicit ScopedIsa(Isa isa) : previous_(active()) { select(isa); }
  ~ScopedIsa() { select(previous_); }
  ScopedIsa(const ScopedIsa&) = delete;
  ScopedIsa& operator=(const ScopedIsa&) = delete;

 private:
  Isa previous_;
};

/// One line for --version: "avx2 (8 floats; compiled for avx2: -march=x86-64-v3); Highway target
/// AVX2 of AVX3 AVX2 SSE4 SCALAR".
std::string describe();

/// The Highway targets the kernels are compiled for, best first ("AVX3", "AVX2", "SSE4",
/// "SCALAR"): the same list in every kernel translation unit (cmake/Simd.cmake).
std::vector<std::string> compiled_targets();
/// Those this CPU runs, best first.
std::vector<std::string> runnable_targets();
/// The target the Highway kernels dispatch to now (follows active()).
std::string chosen_target();
/// The compiled reference target without SIMD instructions: "SCALAR" (one lane; GCC builds, where
/// Highway 1.0.3 marks EMU128 broken) or "EMU128" (four lanes emulated in plain C++; clang builds,
/// the sanitizer tree).
std::string scalar_target();

/// For tests: the Highway kernels run on one target (a name of runnable_targets()) for a scope,
/// whatever the active ISA; then they follow active() again. Throws ParamError for a target not
/// compiled or not runnable here.
class ScopedTarget {
 public:
  explicit ScopedTarget(std::string_view name);
  ~ScopedTarget();
  ScopedTarget(const ScopedTarget&) = delete;
  ScopedTarget& operator=(const ScopedTarget&) = delete;
};

}  // namespace scanbench::simd

/// Calls a Highway kernel exported with HWY_EXPORT(fn) on the target of the active ISA:
///   SCANBENCH_DISPATCH(RayDirections)(args...);
/// (active() first applies SCANBENCH_ISA, read at its first call, to Highway's choice.)
#define SCANBENCH_DISPATCH(fn) ((void)::scanbench::simd::active(), HWY_DYNAMIC_DISPATCH(fn))
