#include "scanbench/core/run_program.h"

#include <dirent.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

#include "scanbench/core/errors.h"

extern char** environ;

namespace scanbench::programs {

namespace fs = std::filesystem;

TempDir::TempDir(std::string_view stage) {
  std::string pattern =
      (fs::temp_directory_path() / fmt::format("scanbench-{}-XXXXXX", stage)).string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw Error(fmt::format("{}: cannot create a temporary directory {}: {}", stage, pattern,
                            std::strerror(errno)));
  }
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);  // best effort: a destructor must not throw
}

std::string log_tail(const fs::path& workdir, int lines) {
  for (const char* name : {"stderr.txt", "stdout.txt"}) {
    std::ifstream in(workdir / name);
    std::vector<std::string> kept;
    std::string line;
    while (std::getline(in, line)) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      kept.push_back(line);
      if (kept.size() > static_cast<std::size_t>(lines)) kept.erase(kept.begin());
    }
    if (kept.empty()) continue;
    std::string out;
    for (const auto& l : kept)
      out += (out.empty() ? "" : " | ") + l;
    return out;
  }
  return "";
}

namespace {

// kB value of a field ("VmHWM") of a /proc/<pid>/status file, or -1 when unavailable (not Linux,
// or the process has exited and released its memory).
long proc_status_kb(const std::string& path, const std::string& field) {
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::atol(line.c_str() + field.size() + 1);
  }
  return -1;
}

// The programs run_program is waiting for, in every thread of this process (reap_orphans keeps
// them).
std::mutex g_running_mutex;
std::set<pid_t>& running_programs() {
  static std::set<pid_t> s;
  return s;
}

struct RunningProgram {
  explicit RunningProgram(pid_t p) : pid(p) {
    std::lock_guard<std::mutex> g(g_running_mutex);
    running_programs().insert(pid);
  }
  ~RunningProgram() {
    std::lock_guard<std::mutex> g(g_running_mutex);
    running_programs().erase(pid);
  }
  pid_t pid;
};

// The children of this process, from /proc/<pid>/stat's parent field (the fourth, after the
// command name in parentheses, which may itself hold spaces and parentheses).
std::vector<pid_t> children_of_self() {
  std::vector<pid_t> out;
  const pid_t self = ::getpid();
  DIR* d = ::opendir("/proc");
  if (!d) return out;
  while (const dirent* e = ::readdir(d)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (pid <= 0 || *end != 0) continue;
    std::ifstream f(fmt::format("/proc/{}/stat", pid));
    std::string stat;
    std::getline(f, stat);
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    char state = 0;
    long ppid = 0;
    if (std::sscanf(stat.c_str() + close + 1, " %c %ld", &state, &ppid) == 2 && ppid == self) {
      out.push_back(static_cast<pid_t>(pid));
    }
  }
  ::closedir(d);
  return out;
}

// After a program ended: in a subreaper, its orphans are now children of this process.
// Elsewhere (a test binary calling run_program) nothing is reparented here, and this process's
// other children are not ours to end.
void end_orphans_of(pid_t program) {
  int is_subreaper = 0;
  if (::prctl(PR_GET_CHILD_SUBREAPER, &is_subreaper, 0, 0, 0) == 0 && is_subreaper) {
    reap_orphans({program});
  }
}

std::string with_log(std::string message, const fs::path& workdir) {
  const std::string tail = log_tail(workdir);
  return tail.empty() ? message + " (no output on stderr or stdout)" : message + ": " + tail;
}

}  // namespace

void run_program(const std::vector<std::string>& argv, const fs::path& workdir, double timeout_s,
                 std::string_view stage, RunContext& ctx) {
  if (argv.empty() || argv[0].empty()) throw Error(fmt::format("{}: empty command", stage));
  const std::string program = argv[0];
  std::vector<char*> args;
  for (const auto& a : argv)
    args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  // posix_spawn rather than fork: the caller is multi-threaded (TBB).
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string out = (workdir / "stdout.txt").string();
  const std::string err = (workdir / "stderr.txt").string();
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addchdir_np(&actions, workdir.c_str());
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, program.c_str(), &actions, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    throw Error(fmt::format("{}: cannot run '{}': {}", stage, program, std::strerror(rc)));
  }
  const RunningProgram registered(pid);
  // posix_spawn returns once the child has exec'ed: our peak now bounds the memory the child's
  // ru_maxrss inherited (see run_program.h).
  const long own_hwm_kb = proc_status_kb("/proc/self/status", "VmHWM");
  const std::string child_status = fmt::format("/proc/{}/status", pid);
  long sampled_kb = -1;
  struct rusage usage {};

  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  auto kill_group = [&] {
    ::kill(-pid, SIGKILL);
    while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
    }
    end_orphans_of(pid);
  };
  for (auto pause = std::chrono::milliseconds(1);;
       pause = std::min(pause * 2, std::chrono::milliseconds(50))) {
    sampled_kb = std::max(sampled_kb, proc_status_kb(child_status, "VmHWM"));
    const pid_t w = ::wait4(pid, &status, WNOHANG, &usage);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      throw Error(
          fmt::format("{}: waiting for '{}' failed: {}", stage, program, std::strerror(errno)));
    }
    if (Clock::now() > deadline) {
      kill_group();
      throw Error(
          with_log(fmt::format("{}: '{}' timed out after {} s (killed)", stage, program, timeout_s),
                   workdir));
    }
    try {
      ctx.check_cancelled(stage);
    } catch (...) {
      kill_group();
      throw;
    }
    std::this_thread::sleep_for(pause);
  }
  // The program's children may outlive it: those in its group, and (in a subreaper, see
  // become_subreaper) those it orphaned outside the group, such as a daemon started with setsid.
  ::kill(-pid, SIGKILL);
  end_orphans_of(pid);
  const long maxrss_kb = usage.ru_maxrss;  // kB on Linux
  ctx.note_program_peak_rss_kb(own_hwm_kb >= 0 && maxrss_kb > own_hwm_kb ? maxrss_kb : sampled_kb);
  if (WIFSIGNALED(status)) {
    throw Error(with_log(fmt::format("{}: '{}' was killed by signal {} ({})", stage, program,
                                     WTERMSIG(status), strsignal(WTERMSIG(status))),
                         workdir));
  }
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code != 0) {
    throw Error(
        with_log(fmt::format("{}: '{}' exited with code {}", stage, program, code), workdir));
  }
}

void become_subreaper() {
  ::prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0);
}

int reap_orphans(const std::vector<int>& keep) {
  int reaped = 0;
  // Each pass ends the current orphans; their own children are reparented here and end in the
  // next pass. A bound on the passes: a fork bomb must not keep this loop alive.
  for (int pass = 0; pass < 64; ++pass) {
    std::set<pid_t> kept(keep.begin(), keep.end());
    {
      std::lock_guard<std::mutex> g(g_running_mutex);
      kept.insert(running_programs().begin(), running_programs().end());
    }
    std::vector<pid_t> orphans;
    for (pid_t pid : children_of_self())
      if (!kept.count(pid)) orphans.push_back(pid);
    if (orphans.empty()) break;
    for (pid_t pid : orphans)
      ::kill(pid, SIGKILL);
    for (pid_t pid : orphans) {
      while (::waitpid(pid, nullptr, 0) < 0 && errno == EINTR) {
      }
      ++reaped;
    }
  }
  return reaped;
}

void require_output(const fs::path& path, const fs::path& workdir, std::string_view program,
                    std::string_view what, std::string_view stage) {
  std::error_code ec;
  const bool exists = fs::is_regular_file(path, ec);
  const auto size = exists ? fs::file_size(path, ec) : 0;
  if (!exists || size == 0) {
    throw Error(
        with_log(fmt::format("{}: '{}' exited with code 0 but wrote {} {} {}", stage, program,
                             exists ? "an empty" : "no", what, path.filename().string()),
                 workdir));
  }
}

}  // namespace scanbench::programs
