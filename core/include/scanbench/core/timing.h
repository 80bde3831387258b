#pragma once
// Small timing helpers shared by the phase timers and the benchmark commands.
#include <vector>

namespace scanbench {

/// Seconds on the monotonic clock (std::chrono::steady_clock) since an arbitrary epoch: subtract
/// two readings for a wall time.
double wall_seconds();

/// CPU seconds (user + system, every thread) this process has used so far.
double process_cpu_seconds();

/// Median of the values, NaNs ignored (NaN when none is left).
double median(std::vector<double> v);

}  // namespace scanbench
