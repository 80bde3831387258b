// Helpers for the end-to-end tests that drive the real `scanbench` binary through a shell:
// temporary folders, files, a shell runner and the JSON-lines records. One copy for every
// end-to-end test (harness, mesh, Slurm).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::test {

namespace fs = std::filesystem;

/// A fresh folder under the system temp dir, named scanbench-TAG-XXXXXX.
inline fs::path make_temp_dir(const std::string& tag) {
  std::string tmpl = (fs::temp_directory_path() / ("scanbench-" + tag + "-XXXXXX")).string();
  if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed for " + tmpl);
  return tmpl;
}

/// The whole content of a file ("" when it cannot be read).
inline std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void write(const fs::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

struct Result {
  int code;
  std::string out;
};

/// Runs a shell command with the test-only algorithms enabled; its exit code (-1 when it did not
/// exit normally) and its stdout, with stderr merged unless `merge_stderr` is false.
inline Result sh(const std::string& cmd, bool merge_stderr = true) {
  const std::string full =
      "SCANBENCH_TEST_ALGORITHMS=1 " + cmd + (merge_stderr ? " 2>&1" : " 2>/dev/null");
  FILE* p = popen(full.c_str(), "r");
  std::string out;
  char buf[4096];
  while (p && fgets(buf, sizeof(buf), p))
    out += buf;
  const int status = p ? pclose(p) : -1;
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

/// A shell prefix that bounds the memory of the command written after it: an address-space limit
/// (`ulimit -v`); in the sanitizer tree, where AddressSanitizer reserves terabytes of address
/// space and cannot start under such a limit, AddressSanitizer's own limit on the resident set.
inline std::string memory_limit(int mb) {
#ifdef SCANBENCH_SANITIZE
  return "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}hard_rss_limit_mb=" + std::to_string(mb) +
         "\" ";
#else
  return "ulimit -v " + std::to_string(mb * 1024) + " && ";
#endif
}

/// The scanbench binary under test (SCANBENCH_BINARY is set by tests/CMakeLists.txt).
inline std::string sb() {
  return std::string(SCANBENCH_BINARY);
}

/// The records of a runs.jsonl file, one JSON object per non-empty line.
inline std::vector<Json> read_jsonl(const fs::path& p) {
  std::vector<Json> out;
  std::istringstream in(slurp(p));
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(Json::parse(line));
  return out;
}

/// Records keyed by their variant label.
inline std::map<std::string, Json> by_variant(const std::vector<Json>& rs) {
  std::map<std::string, Json> m;
  for (const auto& r : rs)
    m[r["variant"]["label"].get<std::string>()] = r;
  return m;
}

}  // namespace scanbench::test
