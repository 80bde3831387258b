#include "scanbench/core/files.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include "scanbench/core/errors.h"

namespace scanbench {

namespace fs = std::filesystem;

void write_file_atomic(const fs::path& path, const std::string& text) {
  const fs::path tmp =
      path.parent_path() / fmt::format(".{}.tmp.{}", path.filename().string(), ::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError(fmt::format("{}: cannot write", tmp.string()));
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n <= 0) {
      ::close(fd);
      throw IoError(fmt::format("{}: write failed", tmp.string()));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    throw IoError(fmt::format("{}: write failed", tmp.string()));
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw IoError(fmt::format("{}: rename failed: {}", path.string(), ec.message()));
}

void write_json_file(const fs::path& path, const Json& j, int indent) {
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the folder: {}", path.parent_path().string(),
                                ec.message()));
    }
  }
  write_file_atomic(path, j.dump(indent) + "\n");
}

}  // namespace scanbench
