#pragma once
// One writer per results folder (SQLite's habit: one writer, checked reads).
//
// Every command that writes into a results folder DIR (`run`, `merge`, `report`, `nightly`,
// `claims`, `history add`, the Slurm submission and its merge job) holds an exclusive lock on
// DIR/.lock (flock(2), so the kernel drops it when the holder dies: a killed run leaves no stale
// lock). The file says who holds it: "pid 1234 on host node7: scanbench run (since
// 2026-12-06T01:02:03Z)". A second writer is refused with that line (or waits up to a
// given time). Within one process the lock is re-entrant: `nightly` holds DIR's lock and its
// report, merge and history steps take it again at no cost.
//
// Slurm array tasks take no lock: each writes only the files named by its own job ids
// (jobs/<id>.json, logs/<id>.log, outputs/<id>*, tmp/<id>.*) and the scan cache, whose entries
// are written atomically under content-derived names. The submission holds the lock while it
// prepares the folder; a new submission or a local run is refused while an earlier submission's
// jobs are still in the queue (slurm.h); the merge job takes the lock, waiting for a reader-writer
// such as `report` to finish.
#include <filesystem>
#include <memory>
#include <string>

#include "scanbench/core/errors.h"

namespace scanbench::harness {

/// Another process holds the folder's lock. Message: "DIR: in use by pid N on host H:
/// scanbench run (since T); one writer per results folder".
class FolderBusyError : public Error {
 public:
  using Error::Error;
};

class FolderLock {
 public:
  /// Takes DIR's lock for `command` (e.g. "scanbench run"), creating DIR first when `create`.
  /// Waits up to `wait_s` seconds for another holder (0: refuse at once). Throws FolderBusyError
  /// naming the holder's pid, host and command, or IoError when DIR is not a folder or DIR/.lock
  /// cannot be created (the reason from errno) or is a symbolic link.
  static FolderLock acquire(const std::filesystem::path& dir, const std::string& command,
                            double wait_s = 0, bool create = false);

  FolderLock(FolderLock&&) noexcept;
  FolderLock& operator=(FolderLock&&) noexcept;
  ~FolderLock();

  /// The holder line written into DIR/.lock for this process.
  const std::string& holder() const;

  struct State;  ///< shared by the re-entrant holders of one folder in this process

 private:
  explicit FolderLock(std::shared_ptr<State> s);
  std::shared_ptr<State> state_;
};

/// The line in DIR/.lock: who holds or last held the folder ("" when none).
std::string folder_lock_holder(const std::filesystem::path& dir);

}  // namespace scanbench::harness
