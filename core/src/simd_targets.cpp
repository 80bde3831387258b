// The Highway side of scanbench/core/simd.h: which targets the kernels were compiled for, which one
// they dispatch to, and the restriction of that choice to the active ISA. Compiled once per target
// by hwy/foreach_target.h, like every kernel translation unit, with the same target list
// (cmake/Simd.cmake), so what this file reports is what the kernels do.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "simd_targets.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "simd_targets.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::simd::HWY_NAMESPACE {

const char* TargetNameHere() {
  return hwy::TargetName(HWY_TARGET);
}

}  // namespace scanbench::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

#include <fmt/format.h>

#include "scanbench/core/errors.h"

namespace scanbench::simd {

HWY_EXPORT(TargetNameHere);

namespace {

// The targets an ISA admits: its own width and every narrower one (Highway picks the best of
// them the CPU has). The scalar targets are admitted by every ISA: Highway's fallback.
std::int64_t admitted(Isa isa) {
  std::int64_t t = HWY_SCALAR | HWY_EMU128 | HWY_SSSE3 | HWY_SSE4;
  if (isa == Isa::avx2 || isa == Isa::avx512) t |= HWY_AVX2;
  if (isa == Isa::avx512) t |= HWY_AVX3 | HWY_AVX3_DL;
  return t;
}

// What the CPU supports, before any restriction of ours.
std::int64_t cpu_targets() {
  static const std::int64_t t = [] {
    hwy::SetSupportedTargetsForTest(0);
    return hwy::SupportedTargets();
  }();
  return t;
}

std::int64_t target_of_name(std::string_view name) {
  for (std::int64_t t = HWY_TARGETS; t != 0; t &= t - 1) {
    const std::int64_t one = t & -t;
    if (name == hwy::TargetName(one)) return one;
  }
  throw ParamError(fmt::format("no Highway target '{}' is compiled into this binary", name));
}

}  // namespace

// Highway 1.0.3 chooses a target at the first dispatched call and keeps it: DisableTargets()
// does not make it choose again (measured), SetSupportedTargetsForTest() does. So the set the
// CPU supports, intersected with what the ISA admits, is set through the latter (never a target
// the CPU lacks).
void restrict_targets(Isa isa) {
  hwy::SetSupportedTargetsForTest(cpu_targets() & admitted(isa));
}

std::vector<std::string> compiled_targets() {
  std::vector<std::string> out;
  for (std::int64_t t = HWY_TARGETS; t != 0; t &= t - 1)
    out.emplace_back(hwy::TargetName(t & -t));
  return out;
}

std::vector<std::string> runnable_targets() {
  std::vector<std::string> out;
  for (std::int64_t t = HWY_TARGETS & cpu_targets(); t != 0; t &= t - 1)
    out.emplace_back(hwy::TargetName(t & -t));
  return out;
}

std::string scalar_target() {
  const std::int64_t t = HWY_TARGETS & (HWY_SCALAR | HWY_EMU128);
  return t == 0 ? std::string() : std::string(hwy::TargetName(t & -t));
}

std::string chosen_target() {
  (void)active();
  return HWY_DYNAMIC_DISPATCH(TargetNameHere)();
}

ScopedTarget::ScopedTarget(std::string_view name) {
  const std::int64_t t = target_of_name(name);
  if ((t & cpu_targets()) == 0)
    throw ParamError(fmt::format("this CPU does not run the Highway target {}", name));
  (void)active();
  hwy::SetSupportedTargetsForTest(t);
}

ScopedTarget::~ScopedTarget() {
  restrict_targets(active());
}

}  // namespace scanbench::simd

#endif  // HWY_ONCE
