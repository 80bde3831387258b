#include "scanbench/core/files.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <system_error>

namespace scanbench {

namespace fs = std::filesystem;

namespace {

std::atomic<unsigned long> temp_counter{0};

/// Closes a descriptor on every path out of a writer.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  /// close(2)'s own result: on NFS and some FUSE file systems a deferred write error shows here.
  int close() {
    const int r = ::close(fd_);
    fd_ = -1;
    return r;
  }

 private:
  int fd_;
};

/// Removes the temp unless the rename committed it.
class TempGuard {
 public:
  explicit TempGuard(fs::path tmp) : tmp_(std::move(tmp)) {}
  TempGuard(const TempGuard&) = delete;
  TempGuard& operator=(const TempGuard&) = delete;
  ~TempGuard() {
    if (!committed_) ::unlink(tmp_.c_str());
  }
  void commit() { committed_ = true; }

 private:
  fs::path tmp_;
  bool committed_ = false;
};

/// A new temp name beside `path`, unique per process and per call. The final name is cut to 200
/// bytes in it so that a name that fits NAME_MAX (255) keeps a temp that fits too.
fs::path temp_beside(const fs::path& path) {
  std::string name = path.filename().string();
  if (name.size() > 200) name.resize(200);
  return path.parent_path() /
         fmt::format(".{}.tmp.{}.{}", name, ::getpid(), temp_counter.fetch_add(1) + 1);
}

/// Creates the temp: never an existing file, never through a link planted at its name.
int create_temp(const fs::path& tmp, const fs::path& path) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw io_error(path, "cannot write", errno);
  return fd;
}

/// Renames the finished temp over `path` and makes the rename durable.
void commit(const fs::path& tmp, const fs::path& path) {
  if (::rename(tmp.c_str(), path.c_str()) != 0) throw io_error(path, "cannot write", errno);
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  Fd d(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  // A folder that cannot be opened for reading (mode 0300) or a file system without directory
  // fsync (EINVAL) still holds the renamed file; only a real IO error is reported.
  if (d.get() >= 0 && ::fsync(d.get()) != 0 && errno != EINVAL) {
    throw io_error(dir, "cannot sync the folder", errno);
  }
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  if (from.empty()) return s;
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
  return s;
}

}  // namespace

IoError io_error(const fs::path& path, std::string_view what, int err) {
  // std::generic_category's message is strerror's text, and thread-safe.
  return IoError(
      fmt::format("{}: {}: {}", path.string(), what, std::generic_category().message(err)));
}

bool is_temp_name(std::string_view name) {
  if (name.size() < 2 || name[0] != '.') return false;
  const std::size_t at = name.rfind(".tmp.");
  if (at == std::string_view::npos || at == 0) return false;
  const std::string_view tail = name.substr(at + 5);
  if (tail.empty()) return false;
  for (const char c : tail) {
    if ((c < '0' || c > '9') && c != '.') return false;
  }
  return true;
}

void write_file_atomic(const fs::path& path, std::string_view text) {
  const fs::path tmp = temp_beside(path);
  Fd fd(create_temp(tmp, path));
  TempGuard guard(tmp);
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd.get(), text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw io_error(path, "cannot write", errno);
    if (n == 0) throw io_error(path, "cannot write", EIO);
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd.get()) != 0) throw io_error(path, "cannot write", errno);
  if (fd.close() != 0) throw io_error(path, "cannot write", errno);
  commit(tmp, path);
  guard.commit();
}

void write_via_temp(const fs::path& path, const std::function<void(const fs::path& tmp)>& write) {
  const fs::path tmp = temp_beside(path);
  Fd(create_temp(tmp, path)).close();
  TempGuard guard(tmp);
  try {
    write(tmp);
  } catch (const IoError& e) {
    throw IoError(replace_all(e.what(), tmp.string(), path.string()));
  }
  Fd fd(::open(tmp.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() < 0) throw io_error(path, "cannot write: the writer left no file", errno);
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) throw io_error(path, "cannot write", errno);
  if (!S_ISREG(st.st_mode) || st.st_size == 0) {
    throw IoError(fmt::format("{}: cannot write: the writer left {}", path.string(),
                              S_ISREG(st.st_mode) ? "an empty file" : "no regular file"));
  }
  if (::fsync(fd.get()) != 0) throw io_error(path, "cannot write", errno);
  if (fd.close() != 0) throw io_error(path, "cannot write", errno);
  commit(tmp, path);
  guard.commit();
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
