#include "scanbench/harness/cli.h"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <string_view>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/run_program.h"
#include "scanbench/core/simd.h"
#include "scanbench/core/version.h"
#include "scanbench/harness/plugins.h"

namespace scanbench::harness {

namespace {

/// An environment failure (a read-only folder, a file where a folder should be, a name too long)
/// as one line: the path, what failed and the reason, without the library's prefix.
std::string filesystem_line(const std::filesystem::filesystem_error& e) {
  std::string what = e.what();
  constexpr std::string_view prefix = "filesystem error: ";
  if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
  if (const auto at = what.find(" ["); at != std::string::npos) what.erase(at);
  return e.path1().empty() ? what : fmt::format("{}: {}", e.path1().string(), what);
}

}  // namespace

int run_cli(int argc, char** argv) {
  // Every process a step starts is this process's to end (run_program.h): orphans come here.
  programs::become_subreaper();
  Cli cli;
  // The SIMD path (SCANBENCH_ISA is checked here, once, for every command: an ISA this binary or
  // CPU lacks is a one-line error).
  std::string isa;
  try {
    isa = simd::describe();
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  }
  cli.app.set_version_flag("--version", fmt::format("scanbench {} (commit {})\nsimd: {}",
                                                    version_string(), git_commit(), isa));
  cli.app.require_subcommand(1);
  // Plugins (docs/plugins.md), loaded before any command runs: SCANBENCH_PLUGIN_PATH, then these.
  std::vector<std::string> plugin_files;
  cli.app
      .add_option("--plugin", plugin_files,
                  "Load a plugin (a shared library of algorithms and metrics, "
                  "scanbench/plugin.h) before the command; repeatable")
      ->type_name("FILE");

  // One explicit list of subcommands.
  add_list_command(cli);
  add_scan_command(cli);
  add_import_command(cli);
  add_algo_command(cli);
  add_bench_command(cli);
  add_eval_command(cli);
  add_run_command(cli);
  add_job_command(cli);
  add_table_command(cli);
  add_compare_command(cli);
  add_report_command(cli);
  add_nightly_command(cli);
  add_status_command(cli);
  add_merge_command(cli);
  add_slurm_task_command(cli);
  add_claims_command(cli);
  add_history_command(cli);

  try {
    cli.app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cli.app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    load_plugins_from_env();
    for (const auto& f : plugin_files)
      load_plugin(f, "--plugin");
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  }
  try {
    return cli.action ? cli.action() : 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // The environment, not scanbench: exit 2 like bad input (3 is for scanbench's own faults).
    std::fprintf(stderr, "scanbench: %s\n", filesystem_line(e).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "scanbench: internal error: %s\n", e.what());
    return 3;
  }
}

}  // namespace scanbench::harness
