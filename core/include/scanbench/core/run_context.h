#pragma once
// RunContext: what one run of a stage needs besides its data and parameters: the seed (with an
// independent random stream per named stage), the thread count, named phase timers and
// cooperative cancellation. Algorithms take it by reference; nothing in it is global except the
// TBB thread limit, which it holds for its lifetime.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include <tbb/global_control.h>

#include "scanbench/core/rng.h"

namespace scanbench {

class RunContext {
 public:
  /// threads = 0 uses every hardware thread; otherwise TBB is limited to `threads` while this
  /// context lives (and while no more restrictive limit is active).
  explicit RunContext(std::uint64_t seed = 0, int threads = 0);
  ~RunContext();
  RunContext(const RunContext&) = delete;
  RunContext& operator=(const RunContext&) = delete;

  std::uint64_t seed() const { return seed_; }
  int threads() const { return threads_; }

  /// Seed of the named stream (e.g. "scan", "hem", "particles"): independent streams per stage,
  /// so adding random draws to one stage never changes another's numbers.
  std::uint64_t stream_seed(std::string_view stream) const { return derive_seed(seed_, stream); }
  /// A generator on the named stream.
  Rng rng(std::string_view stream) const { return Rng(stream_seed(stream)); }

  /// RAII timer: adds the wall seconds (and the process CPU seconds, all threads) between
  /// construction and destruction to phase `name`.
  class PhaseTimer {
   public:
    PhaseTimer(RunContext& ctx, std::string name);
    ~PhaseTimer();
    PhaseTimer(const PhaseTimer&) = delete;
    PhaseTimer& operator=(const PhaseTimer&) = delete;

   private:
    RunContext& ctx_;
    std::string name_;
    std::chrono::steady_clock::time_point start_;
    double cpu_start_ = 0.0;
  };
  PhaseTimer phase(std::string name) { return PhaseTimer(*this, std::move(name)); }
  /// Adds seconds to a phase by hand.
  void add_phase_time(const std::string& name, double seconds) { phases_[name] += seconds; }
  /// Accumulated wall seconds per phase, in name order.
  const std::map<std::string, double>& phase_seconds() const { return phases_; }
  /// Accumulated process CPU seconds (all threads) per phase timed with phase(): on a shared
  /// machine this is steadier than wall time.
  const std::map<std::string, double>& phase_cpu_seconds() const { return phases_cpu_; }
  void clear_phases() {
    phases_.clear();
    phases_cpu_.clear();
  }

  /// Peak resident memory (kB) of the external programs a step ran (reconstruct.poisson's colmap),
  /// each measured alone, not counting this process (algorithms' run_program); -1 when no program
  /// ran since the last reset. The harness resets it before each step of a chain.
  void note_program_peak_rss_kb(long kb) {
    if (kb > program_peak_rss_kb_) program_peak_rss_kb_ = kb;
  }
  long program_peak_rss_kb() const { return program_peak_rss_kb_; }
  void reset_program_peak_rss() { program_peak_rss_kb_ = -1; }

  /// Requests cancellation (thread-safe; e.g. from a signal handler thread or a watchdog).
  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  /// Throws Cancelled("<stage>: cancelled") once cancel() was called. Call between iterations.
  void check_cancelled(std::string_view stage) const;

 private:
  std::uint64_t seed_;
  int threads_;
  std::unique_ptr<tbb::global_control> control_;
  std::map<std::string, double> phases_;
  std::map<std::string, double> phases_cpu_;
  std::atomic<bool> cancelled_{false};
  long program_peak_rss_kb_ = -1;
};

}  // namespace scanbench
