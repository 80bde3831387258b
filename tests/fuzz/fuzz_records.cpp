// libFuzzer target for the record readers of a results folder (harness/src/results/records.cpp,
// Job::from_json): the first byte picks what the rest is, written into a scratch results folder
// the way the harness finds it, then read by the same functions `table`, `merge` and a job's
// child call:
//   0  jobs/<id>.json, a job record        -> load_records (through jobs/)
//   1  runs.jsonl, the merged records      -> load_records (a folder of merged records only)
//   2  a job spec's "job" (tmp/<id>.spec.json) -> parse_json_text + Job::from_json
// and every record read is asked for its values (record_value, record_samples) and written as CSV
// (records_csv). A reader may only return or throw a scanbench::Error (the CLI's exit 2); any
// other exception (a nlohmann type_error from an unchecked get<>), crash, deep recursion, leak or
// sanitizer report is a bug.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/records.h"

namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, std::string_view bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void use(const std::vector<scanbench::Json>& records) {
  for (const scanbench::Json& r : records) {
    for (const char* q : {"time.total", "time.cpu", "peak_rss_mb", "sizes.points", "chamfer"}) {
      (void)scanbench::harness::record_value(r, q);
      (void)scanbench::harness::record_samples(r, q);
    }
  }
  (void)scanbench::harness::records_csv(records);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  static const fs::path dir =
      fs::temp_directory_path() / ("scanbench-fuzz-records-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  try {
    switch (data[0] % 3) {
      case 0:
        write(dir / "jobs" / "0123456789abcdef.json", text);
        use(scanbench::harness::load_records(dir));
        break;
      case 1:
        write(dir / "runs.jsonl", text);
        use(scanbench::harness::load_records(dir));
        break;
      default:
        (void)scanbench::harness::Job::from_json(
            scanbench::parse_json_text(text, "tmp/0123456789abcdef.spec.json"));
        break;
    }
  } catch (const scanbench::Error&) {
    // The expected outcome for a damaged record.
  }
  return 0;
}
