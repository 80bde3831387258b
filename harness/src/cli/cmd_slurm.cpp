// scanbench status DIR [--json]
// scanbench merge DIR [--submission SUB]
// scanbench slurm-task DIR SUB             (hidden: one array task of a Slurm submission)
#include <fmt/format.h>

#include "cli/commands.h"
#include "scanbench/harness/exec/slurm.h"
#include "scanbench/harness/results/finish.h"
#include "scanbench/harness/results/folder_lock.h"

namespace scanbench::harness {

int merge_and_finish(const std::filesystem::path& dir, const std::string& submission) {
  // The Slurm merge job may start while a reader-writer (`report`) holds the folder: it waits.
  const FolderLock lock = FolderLock::acquire(dir, "scanbench merge", 600);
  const MergedFolder m = merge_folder(dir, submission);
  FinishOptions fo;
  fo.report = true;
  const FinishedRun f = finish_run(dir, fo);
  fmt::print("merged {} records: {}/runs.jsonl, runs.csv{}, {}\n", f.records.size(), dir.string(),
             f.records.empty() ? "" : ", tables.md", f.report.filename().string());
  fmt::print("{}", render_missing(m));
  std::fflush(stdout);
  return static_cast<int>(m.missing.size());
}

void add_status_command(Cli& cli) {
  struct Args {
    std::string dir;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "status",
      "Jobs of a results folder: done, failed (with reasons) from the records; running and "
      "pending from squeue for Slurm submissions");
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_flag("--json", a->json, "Print JSON (counts and every job) instead of text");
  sub->callback([&cli, a] {
    cli.action = [a] {
      const FolderStatus s = folder_status(a->dir);
      if (a->json) {
        fmt::print("{}\n", status_json(s).dump(1));
      } else {
        fmt::print("{}", render_status(s));
      }
      return 0;
    };
  });
}

void add_merge_command(Cli& cli) {
  struct Args {
    std::string dir, submission;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "merge",
      "Merge a results folder's records into runs.jsonl, runs.csv, tables.md and index.html "
      "(the Slurm merge job runs it); exit 1 when jobs have no record");
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_option("--submission", a->submission,
                  "Slurm submission (DIR/slurm/<SUB>): record its jobs that started but left no "
                  "record, and list only its jobs without one");
  sub->callback([&cli, a] {
    cli.action = [a] { return merge_and_finish(a->dir, a->submission) > 0 ? 1 : 0; };
  });
}

void add_slurm_task_command(Cli& cli) {
  struct Args {
    std::string dir, submission;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "slurm-task", "Run array task $SLURM_ARRAY_TASK_ID of a submission (internal)");
  sub->group("");  // hidden
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_option("submission", a->submission, "Submission number (DIR/slurm/<SUB>)")->required();
  sub->callback([&cli, a] { cli.action = [a] { return run_slurm_task(a->dir, a->submission); }; });
}

}  // namespace scanbench::harness
