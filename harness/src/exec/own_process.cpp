#include "exec/own_process.h"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/json_text.h"
#include "scanbench/core/run_program.h"
#include "scanbench/harness/exec/chain.h"

namespace scanbench::harness {

// Why a step needs its own process. CGAL 5.5's advancing-front mesher breaks ties between
// candidate facets by handle address, and the scale-space reconstruction's alpha-shape mesher
// (force_manifold) walks std::maps keyed by vertex and union-find handles: which facets survive
// follows heap addresses, so the same call gives another mesh after other work (other thread
// counts, other steps) has shaped the heap. No sort of the output can undo that (the set of facets
// differs, not only its order); a fresh process gives the mesher the same heap every time.

std::optional<std::string> own_process_exe() {
  if (const char* e = std::getenv("SCANBENCH_EXE"); e != nullptr && *e != '\0') return e;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec && self.filename() == "scanbench") return self.string();
  return std::nullopt;
}

StageData run_in_own_process(const std::string& exe,
                             const algorithms::AlgorithmRegistry::Entry& entry, const Json& params,
                             const StageData& input, RunContext& ctx) {
  const auto& io = entry.fn.io;
  if (io.produces != DataKinds(io.primary)) {
    throw Error(entry.name + ": an own-process step must produce its primary kind only");
  }
  const programs::TempDir dir(entry.name);
  std::vector<std::string> argv = {exe, "algo", entry.name};
  for (const auto& [kind, path] : write_stage_data(input, io.consumes, [&](DataKind k) {
         return dir.path() / ("in." + std::string(kind_suffix(k)) + ".ply");
       })) {
    argv.push_back("-i");
    argv.push_back(path.string());
  }
  const std::filesystem::path out = dir.path() / "out.ply";
  const std::filesystem::path timings = dir.path() / "timings.json";
  argv.insert(argv.end(), {"-o", out.string(), "--seed", std::to_string(ctx.seed()), "--threads",
                           std::to_string(ctx.threads()), "--timings", timings.string()});
  for (const auto& [key, value] : params.items()) {
    argv.push_back("--set");
    argv.push_back(key + "=" + (value.is_string() ? value.get<std::string>() : value.dump()));
  }
  // A week: the job's own timeout (the runner kills the job's process group) is the real bound.
  programs::run_program(argv, dir.path(), 7 * 86400.0, entry.name, ctx);
  programs::require_output(out, dir.path(), "scanbench algo", kind_name(io.primary), entry.name);
  StageData produced = read_stage_file(out);
  if (!produced.kinds().has(io.primary)) {
    throw Error(entry.name + ": scanbench algo produced no " + std::string(kind_name(io.primary)));
  }
  const Json record = parse_json_file(timings, "timings of scanbench algo");
  const Json phases = record.is_object() ? record.value("phases", Json()) : Json();
  if (!phases.is_object()) throw IoError(timings.string() + ": expected an object \"phases\"");
  for (const auto& [phase, seconds] : phases.items()) {
    if (!seconds.is_number()) {
      throw IoError(timings.string() + ": /phases/" + phase + ": expected a number of seconds");
    }
    ctx.add_phase_time(phase, seconds.get<double>());
  }
  return StageData::carry(std::move(produced), input, io.produces);
}

}  // namespace scanbench::harness
