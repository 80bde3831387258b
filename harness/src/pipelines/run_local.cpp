#include "scanbench/harness/pipelines/run_local.h"

#include "scanbench/core/files.h"
#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/exec/slurm.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/tuning.h"

namespace scanbench::harness {

RunSummary run_local(Experiment e, const RunOptions& o) {
  // Held across the tuning and the run (re-entrant: run_experiment takes it again).
  const FolderLock lock = FolderLock::acquire(o.out, o.command, 0, true);
  refuse_if_submission_queued(o.out);
  if (e.raw.contains("protocol")) {
    const std::filesystem::path file = e.file;
    const Protocol p =
        resolve_protocol(e.raw, parse_protocol(e.raw["protocol"], file.string() + ": /protocol"),
                         o.out, local_records_runner(o.jobs, o.resume, o.quiet, o.exe));
    e = parse_experiment(protocol_config(e.raw, p, false), file.string());
    e.file = file;
    write_json_file(o.out / "protocol.json", protocol_json(p));
  }
  return run_experiment(e, o);
}

}  // namespace scanbench::harness
