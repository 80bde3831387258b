#include "scanbench/harness/results/folder_lock.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <mutex>
#include <thread>

#include "scanbench/harness/results/records.h"  // utc_now

namespace scanbench::harness {

namespace fs = std::filesystem;

struct FolderLock::State {
  fs::path key;  ///< the folder's canonical path
  int fd = -1;
  std::string holder;
  ~State() {
    if (fd >= 0) ::close(fd);  // releases the flock
  }
};

namespace {

// The locks this process holds, by canonical folder: a second acquire in the same process shares
// the first (flock locks of two open file descriptions would refuse each other).
std::mutex g_mutex;
std::map<fs::path, std::weak_ptr<FolderLock::State>>& held() {
  static std::map<fs::path, std::weak_ptr<FolderLock::State>> m;
  return m;
}

std::string this_host() {
  char host[256] = {};
  if (::gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  return host[0] ? host : "?";
}

std::string read_holder(int fd) {
  char buf[512] = {};
  const ssize_t n = ::pread(fd, buf, sizeof(buf) - 1, 0);
  std::string s = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
  while (!s.empty() && (s.back() == '\n' || s.back() == ' '))
    s.pop_back();
  return s;
}

std::string io_reason(const fs::path& p, const char* what) {
  return fmt::format("{}: {}: {}", p.string(), what, std::strerror(errno));
}

}  // namespace

FolderLock::FolderLock(std::shared_ptr<State> s) : state_(std::move(s)) {}
FolderLock::FolderLock(FolderLock&&) noexcept = default;
FolderLock& FolderLock::operator=(FolderLock&&) noexcept = default;
FolderLock::~FolderLock() {
  if (!state_) return;
  std::lock_guard<std::mutex> g(g_mutex);
  const fs::path key = state_->key;
  state_.reset();
  auto it = held().find(key);
  if (it != held().end() && it->second.expired()) held().erase(it);
}

const std::string& FolderLock::holder() const {
  return state_->holder;
}

FolderLock FolderLock::acquire(const fs::path& dir, const std::string& command, double wait_s,
                               bool create) {
  std::error_code ec;
  if (create) {
    fs::create_directories(dir, ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the folder: {}", dir.string(), ec.message()));
    }
  }
  // The folder itself may be a link the user made (a results disk mounted elsewhere); its
  // entries are checked for links (here and in the runner).
  if (!fs::is_directory(dir)) throw IoError(fmt::format("{}: not a results folder", dir.string()));
  const fs::path key = fs::canonical(dir);
  std::lock_guard<std::mutex> g(g_mutex);
  if (auto it = held().find(key); it != held().end()) {
    if (auto s = it->second.lock()) return FolderLock(s);
  }
  const fs::path file = dir / ".lock";
  const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) {
    if (errno == ELOOP) {
      throw IoError(
          fmt::format("{}: is a symbolic link; scanbench opens no file of a results "
                      "folder through a link it did not make",
                      file.string()));
    }
    throw IoError(io_reason(file, "cannot open the folder's lock"));
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno != EWOULDBLOCK && errno != EINTR) {
      const std::string msg = io_reason(file, "cannot lock");
      ::close(fd);
      throw IoError(msg);
    }
    if (std::chrono::steady_clock::now() >= deadline) {
      const std::string who = read_holder(fd);
      ::close(fd);
      throw FolderBusyError(fmt::format(
          "{}: in use by {}; one writer per results folder (wait for it, or choose another "
          "folder with -o)",
          dir.string(), who.empty() ? "another process" : who));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  auto s = std::make_shared<State>();
  s->key = key;
  s->fd = fd;
  s->holder =
      fmt::format("pid {} on host {}: {} (since {})", ::getpid(), this_host(), command, utc_now());
  const std::string line = s->holder + "\n";
  // The holder line is information for the refused writer; failing to write it (a full disk)
  // does not stop the holder, whose lock is the flock itself.
  if (::ftruncate(fd, 0) == 0) {
    [[maybe_unused]] const ssize_t n = ::pwrite(fd, line.data(), line.size(), 0);
  }
  held()[key] = s;
  return FolderLock(s);
}

std::string folder_lock_holder(const fs::path& dir) {
  const int fd = ::open((dir / ".lock").c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return "";
  std::string s = read_holder(fd);
  ::close(fd);
  return s;
}

}  // namespace scanbench::harness
