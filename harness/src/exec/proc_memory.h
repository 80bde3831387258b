#pragma once
// The process's resident memory from /proc/self (Linux): the current and peak RSS, and a reset of
// the peak so that the peak of one stretch of work can be read (`scanbench bench resample`, the
// per-step working memory of a job's chain).
#include <cstdlib>
#include <fstream>
#include <string>

namespace scanbench::harness {

/// kB value of a /proc/self/status field ("VmRSS", "VmHWM"), or -1 when unavailable.
inline long status_kb(const std::string& field) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind(field + ":", 0) == 0) {
      return std::strtol(line.c_str() + field.size() + 1, nullptr, 10);  // never throws
    }
  }
  return -1;
}

/// Resets the peak RSS (VmHWM) to the current RSS (Linux >= 4.0); false when not possible.
inline bool reset_peak_rss() {
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

}  // namespace scanbench::harness
