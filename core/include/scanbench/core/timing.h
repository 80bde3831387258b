#pragma once
// Small timing helpers shared by the phase timers and the benchmark commands.
#include <vector>

namespace scanbench {

/// CPU seconds (user + system, every thread) this process has used so far.
double process_cpu_seconds();

/// Median of the values, NaNs ignored (NaN when none is left).
double median(std::vector<double> v);

}  // namespace scanbench
