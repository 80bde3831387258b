#pragma once
// Version and the git commit the binary was built from (stamped at build time).
namespace scanbench {
const char* version_string();
const char* git_commit();
}  // namespace scanbench
