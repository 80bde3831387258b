// A fresh private folder per call for tests that write files. ctest runs every test of every
// executable as its own process, several at once (and two checkouts may test on one machine), so
// a fixed name under /tmp is shared by concurrent tests: one deletes what another still reads.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>

namespace scanbench::test {

/// A new folder under the system temp dir, named scanbench-TAG-XXXXXX (mkdtemp: unique, 0700).
inline std::filesystem::path fresh_temp_dir(const std::string& tag) {
  std::string tmpl =
      (std::filesystem::temp_directory_path() / ("scanbench-" + tag + "-XXXXXX")).string();
  if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed for " + tmpl);
  return tmpl;
}

/// Removes the folder at scope exit.
struct TempDir {
  explicit TempDir(const std::string& tag) : path(fresh_temp_dir(tag)) {}
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::filesystem::path operator/(const std::string& name) const { return path / name; }
  std::filesystem::path path;
};

}  // namespace scanbench::test
