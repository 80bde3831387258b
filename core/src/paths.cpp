#include "scanbench/core/paths.h"

#include <cstdlib>

#ifndef SCANBENCH_SOURCE_ROOT
#error "SCANBENCH_SOURCE_ROOT must be defined by the build"
#endif

namespace scanbench {

namespace {
std::filesystem::path from_env(const char* name, const std::filesystem::path& fallback) {
  const char* v = std::getenv(name);
  return (v != nullptr && *v != '\0') ? std::filesystem::path(v) : fallback;
}
}  // namespace

std::filesystem::path project_root() {
  return from_env("SCANBENCH_ROOT", SCANBENCH_SOURCE_ROOT);
}
std::filesystem::path config_root() {
  return project_root() / "configs";
}
std::filesystem::path data_root() {
  return from_env("SCANBENCH_DATA", project_root() / "data");
}

}  // namespace scanbench
