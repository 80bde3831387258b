#pragma once
// The SIMD instruction set of the hot kernels: which packet width runs, chosen at run time.
//
// The build is compiled for one x86-64 level (CMake option SCANBENCH_SIMD, default: the widest
// level of the build machine; see README "SIMD width"). The kernels are written once over Eigen's
// packet type and instantiated for every width up to the compiled one: sse2 (4 floats, Eigen's
// Packet4f), avx2 (8 floats with FMA, Packet8f), avx512 (16 floats, Packet16f). The widest one the
// CPU has runs, unless the environment variable SCANBENCH_ISA=sse2|avx2|avx512 asks for a narrower
// one (to reproduce a result of a narrower machine). In a build compiled for avx2 or avx512 the
// sse2 path is the 4-float packet code compiled with that build's flags (VEX encoding, fused
// multiply-adds where Eigen uses them), so it matches a -DSCANBENCH_SIMD=sse2 build only within
// float rounding; results do not depend on the thread count on any path.
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

/// One line for --version and records: "avx2 (8 floats; compiled for avx2: -march=x86-64-v3)".
std::string describe();

}  // namespace scanbench::simd
