#include "scanbench/core/run_context.h"

#include <fmt/format.h>
#include <tbb/global_control.h>

#include "scanbench/core/errors.h"
#include "scanbench/core/timing.h"

namespace scanbench {

RunContext::RunContext(std::uint64_t seed, int threads) : seed_(seed), threads_(threads) {
  if (threads < 0) throw ParamError(fmt::format("threads: expected >= 0, got {}", threads));
  if (threads > 0) {
    control_ = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                     static_cast<std::size_t>(threads));
  }
}

RunContext::~RunContext() = default;

RunContext::PhaseTimer::PhaseTimer(RunContext& ctx, std::string name)
    : ctx_(ctx),
      name_(std::move(name)),
      start_(std::chrono::steady_clock::now()),
      cpu_start_(process_cpu_seconds()) {}

RunContext::PhaseTimer::~PhaseTimer() {
  const std::chrono::duration<double> d = std::chrono::steady_clock::now() - start_;
  ctx_.add_phase_time(name_, d.count());
  ctx_.phases_cpu_[name_] += process_cpu_seconds() - cpu_start_;
}

void RunContext::check_cancelled(std::string_view stage) const {
  if (cancelled()) throw Cancelled(fmt::format("{}: cancelled", stage));
}

}  // namespace scanbench
