#pragma once
// Running an external program as one step (reconstruct.poisson, external, the photogrammetric
// scanner's COLMAP; in core so that every module runs programs the same way): in a private
// temporary directory, with a timeout, its stdout and stderr captured to files there, and every way
// it can fail turned into one error naming the step: not found, a non-zero exit code, a signal, the
// timeout, and also exit code 0 with no or empty output (COLMAP's poisson_mesher exits 0 when its
// input is missing or unreadable; see poisson.h).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/run_context.h"

namespace scanbench::programs {

/// A fresh private directory (mode 0700) under the system temp directory, removed with its
/// contents on destruction. Throws Error when it cannot be created.
class TempDir {
 public:
  explicit TempDir(std::string_view stage);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Runs argv[0] (looked up in PATH) with argv[1..] in `workdir`, stdin from /dev/null, stdout and
/// stderr to workdir/stdout.txt and workdir/stderr.txt, in its own process group. Waits at most
/// timeout_s seconds, then kills the group. Honours ctx cancellation (the group is killed first).
/// Throws Error("<stage>: ...") when the program cannot start, exits non-zero, dies from a signal
/// or times out; the message ends with the last lines of its stderr (or stdout).
/// On Linux, the program's own peak RSS goes to ctx.note_program_peak_rss_kb. The kernel's
/// ru_maxrss of the child (wait4) is not that peak alone: execve folds the high-water mark of the
/// memory the child had before exec into it, and a posix_spawn child shares the caller's memory
/// until exec, so ru_maxrss is at least this process's peak RSS at the spawn. So: ru_maxrss when
/// it exceeds this process's VmHWM read after the spawn (then it is the program's own peak,
/// exactly); else the program stayed below that, and its peak is the largest VmHWM of
/// /proc/<pid>/status sampled while it ran (the wait loop's polls, every 1 to 50 ms).
void run_program(const std::vector<std::string>& argv, const std::filesystem::path& workdir,
                 double timeout_s, std::string_view stage, RunContext& ctx);

/// Throws Error("<stage>: <program> exited 0 but wrote no/an empty <what> <path>: <log tail>")
/// unless `path` is a non-empty regular file.
void require_output(const std::filesystem::path& path, const std::filesystem::path& workdir,
                    std::string_view program, std::string_view what, std::string_view stage);

/// Makes this process a child subreaper (Linux prctl PR_SET_CHILD_SUBREAPER): a process orphaned
/// below it (a daemon an external program started with setsid, outside the program's group)
/// becomes its child rather than init's, so that reap_orphans can end it. `scanbench` sets it in
/// every command; a job's child process and the runner thus own every process their steps start.
void become_subreaper();

/// Kills (SIGKILL) and reaps every child of this process that is neither a running run_program
/// program nor in `keep`, and the children they leave, until none is left; returns how many. In
/// a subreaper these are the orphans of finished programs and jobs. Called by run_program after
/// its program ends, by the runner after each job, and by a job's child at its end.
int reap_orphans(const std::vector<int>& keep = {});

/// The last `lines` non-empty lines of workdir's stderr.txt, else of its stdout.txt ("" if none).
std::string log_tail(const std::filesystem::path& workdir, int lines = 5);

}  // namespace scanbench::programs
