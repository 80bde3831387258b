#include "scanbench/harness/results/finish.h"

#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/report.h"
#include "scanbench/harness/results/table.h"

namespace scanbench::harness {

FinishedRun finish_run(const std::filesystem::path& dir, const FinishOptions& o) {
  FinishedRun f;
  f.records = load_records(dir);
  if (!f.records.empty()) {
    TableSpec time;
    time.metric = "time.total";
    f.tables = render_table(build_table(f.records, TableSpec{}), "md") + "\n" +
               render_table(build_table(f.records, time), "md");
    write_file_atomic(dir / "tables.md", f.tables);
  }
  if (o.report) f.report = write_report(dir, {}, o.history_db);
  return f;
}

}  // namespace scanbench::harness
